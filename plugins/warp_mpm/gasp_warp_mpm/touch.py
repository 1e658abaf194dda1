"""The ground's contact detected from the points (issue 67, rounds 35-36; docs/contact.md "Round 36: the touched layer
on both engines"), taichi_mpm's ``gasp_taichi_mpm.touch`` in Warp: with the grid contact, the node layer just above a
ground's plane takes the ground's Coulomb rule in the columns where a point of the body touches the plane: a point of
a body that does not flow when its lowest extent (its height less half its own spacing) lies within ``touch_margin``
of that half spacing (round 47, docs/contact.md "Round 47: the touch test tied to the point's extent"), a point of a
flowing body (sand, snow, liquid) when its height is under ``touch_delta`` cells (round 36's rule). Round 48
(docs/contact.md "Round 48: a dashpot above the held layers"): in a column a body that does not flow touches, the
node layer above the held ones takes a dashpot on its normal velocity (:func:`build_dashpot`). Round 49
(docs/contact.md "Round 49: the touched layer shares the column's Coulomb bound"): in such a column the touched layer
takes no normal stop (its normal motion is the body's, with the dashpot) and only the Coulomb bound its column's held
layers left unused (:func:`build_share`). Round 50 (docs/contact.md "Round 50: the dashpot's push in the column's
Coulomb bound"): the dashpot's signed push, times ``mu``, a credit of the column kept across substeps that the touched
node's friction may spend (``touch_credit``, :func:`build_share`). Round 51 (docs/contact.md "Round 51: the landing's
friction"): ``touch_bound``, the whole column's friction under one bound (``gasp_warp_mpm.share``).

After P2G (and the viscous step), before the two-field contact and the grid update: :func:`build_touch`'s
``touch_clear`` (a node-column kernel) zeroes ``ground_touch``, then ``touch_mark`` (a points kernel, atomic max)
marks the 3 x 3 stencil columns of every near point. :func:`build_touch`'s ``ground_reach`` is the grounds' node
test that ``grid.build_boundary_rules`` and ``fields.build_fields`` read; :func:`build_held`'s ``held_node`` the
test of a node both fields move with the mean at (a ground's node layers or the walls'), which the two-field
contact (``fields.build_fields``) and the friction given to field B (``grid.build_field_friction``) share.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import numpy as np
import warp as wp

from gasp_core.mpm.contact import DAMPING, FLOWING, TOUCH_BOUNDS, TOUCH_PULLS, touch_dashpot_speed

from .body_bound import POOL, build_body_bound
from .precision import MODULE_OPTIONS, build_types
from .share import SLOTS, build_share



class GroundTouch:
    """The engine's switch (a mixin of :class:`gasp_warp_mpm.engine.WarpMPMEngine`; taichi_mpm's
    ``GridUpdate.touch_contact``, the same defaults)."""

    #: True: the node layer above a ground's top layer takes its rule in the touched columns (the grid contact's rule
    #: only: ``"grid"`` and the grid contact's reach of ``"mixed"``); False: the node layers ``k <= ground[g][0]``
    #: alone, the rule before (the catch of ``tests/test_ground_touch.py``). Read when the engine is built.
    touch_contact = True
    #: Round 58 (docs/contact.md "Round 58: the sand's base slips at Coulomb's bound"): True: a column a flowing
    #: body's point touches is marked 2 as a column of a body that does not flow (its touched layer takes no normal
    #: stop and the Coulomb bound of its column's held layers, round 49-53's rule); False: round 36's full Coulomb
    #: rule on the touched layer's own velocity (the rule before). taichi_mpm's ``GroundTouch.flow_share``.
    flow_share = False
    #: Cells: a point of a flowing body (sand, snow, liquid) touches the plane when its height above it is under
    #: ``touch_delta dx`` (round 36's rule, kept for them: docs/contact.md "Round 47").
    touch_delta = 0.25
    #: Round 47: a point of a body that does not flow touches the plane when its lowest extent (its height less
    #: ``h``, half its own spacing, ``p_vol^(1/3) / 2``) lies under ``touch_margin h`` above it (or below it). At 1
    #: the test sits halfway between a fill's lowest row (its extent on the plane) and its next row (``2 h`` up), as
    #: far from both as it can be, so no rounding of the fill decides it (round 46: the fixed 0.25 dx was the lowest
    #: row's own height, a knife-edge).
    touch_margin = 1.0
    #: Round 48 (docs/contact.md "Round 48: a dashpot above the held layers"): the damping ratio of the dashpot on
    #: the normal velocity of the node layer just above the held ones (``ground[q][0] + 2``) in the columns a point
    #: of a body that does not flow touches (``gasp_core.mpm.contact.touch_dashpot_speed``; the particle contact's
    #: ``DAMPING``); 0 turns it off (the rule before, the catch of ``tests/test_grid_hold.py``). Read when built.
    touch_damping = DAMPING
    #: Round 49 (docs/contact.md "Round 49: the touched layer shares the column's Coulomb bound"): True: in a column
    #: marked 2 the touched layer's normal motion is the body's (no stop), and its tangential motion takes what the
    #: held layers' Coulomb bound left unused (:func:`build_share`); False: round 47-48's full Coulomb rule there
    #: (the catch of ``tests/test_sag_family.py``). Read when the engine is built.
    touch_share = True
    #: Round 50 (docs/contact.md "Round 50: the dashpot's push in the column's Coulomb bound"): True, with
    #: ``touch_share``: the dashpot's signed normal impulse on the touched node and the one above, times ``mu``, is a
    #: credit of the column kept across substeps, which the touched node's friction may spend where positive
    #: (:func:`build_share`); False: round 49's rule (the dashpot's push gives no friction). Read when built.
    touch_credit = True
    #: Round 51 (docs/contact.md "Round 51: the landing's friction"): the column's Coulomb bound
    #: (``gasp_core.mpm.contact.TOUCH_BOUNDS``): ``"debt"`` the whole column's friction under its stops and the
    #: dashpots' signed push, a pull's debt kept until paid; ``"credit"`` round 50's rule (the catch of
    #: ``tests/test_landed_slide.py``; ``touch_credit`` is read only there); round 52 ``"body"`` (the default since
    #: round 52) the debt's balance per body and ground (``gasp_warp_mpm.body_bound``). Read when built.
    touch_bound = "body"
    #: Round 53 (docs/contact.md "Round 53: a pull's debt refunded at once"): under ``"body"``, the answer to the two
    #: dashpots' pull (``TOUCH_PULLS``): ``"refund"`` (the default) the pool's debt returned at once along the slip
    #: (``body_bound``); ``"both"`` round 52's (a pull as a push, its debt paid by later stops); ``"contact"`` a
    #: column's pull at most its net push since its contact began (``touch_credits``); ``"none"`` no pull. Read when
    #: built.
    touch_pull = "refund"

    def bound_mode(self) -> int:
        """Round 51: the kernels' ``mode`` (``TOUCH_BOUNDS``); 0 without ``touch_share``."""
        return TOUCH_BOUNDS[self.touch_bound] if self.touch_share else 0

    def column_dashpot(self) -> bool:
        """Whether the two dashpots act in ``touch_share`` (round 50's credit or a round 51 bound), not the grid
        update."""
        return bool(self.touch_share and (self.touch_credit or self.bound_mode() > 0))

    def allocate_touch(self, Ft, contact: str) -> None:
        """``touch_on`` (the switch, a ground, and ``contact`` ``"grid"`` or ``"mixed"``), ``ground_touch`` (int32,
        ``n_grounds * n_grid**2``: ground ``q``'s column ``(i, j)`` at ``(q n_grid + i) n_grid + j``, 2 where a point of
        a body that does not flow touches, else 1 where a flowing one does; one unused entry when off),
        ``touch_speed`` (the dashpot's speed, m/s, float: ``touch_dashpot_speed``, 0.0 when off), ``ground_z`` (the
        grounds' heights, m, scalar type ``Ft``) and ``touch_solid`` (int32, per body: 1 where it does not flow, the
        extent test; 0 for sand, snow and liquid, round 36's height test)."""
        heights = [float(b.height) for b in self.setup.boundaries if b.kind == "ground"]
        rubs = any(b.friction > 0 for b in self.setup.boundaries if b.kind == "ground")   # ground_reach: mu > 0 only
        self.touch_on = bool(self.touch_contact and rubs and contact in ("grid", "mixed"))
        n = len(heights) * self.n_grid ** 2 if self.touch_on else 1
        self.ground_touch = wp.zeros(n, dtype=wp.int32, device=self.device)
        self.touch_speed = touch_dashpot_speed(self.setup, self.touch_damping) if self.touch_on else 0.0   # m/s
        # round 49: the held layers' unused Coulomb bound and the touched node's mass (round 50: and the node above's),
        # SLOTS a column (build_share)
        shared = self.touch_on and self.touch_share
        self.touch_slots = wp.zeros(SLOTS * n if shared else 1, dtype=Ft, device=self.device)
        # round 50: each column's credit, mu times the dashpot's net push less the friction it gave (kg m/s)
        self.touch_credits = wp.zeros(n if shared else 1, dtype=Ft, device=self.device)
        # round 52 ("body", body_bound.py): each column's body, and a pool a ground and body
        pooled = shared and self.bound_mode() == TOUCH_BOUNDS["body"]
        self.n_pool_bodies = max(1, len(self.setup.materials))
        self.touch_body = wp.zeros(n if pooled else 1, dtype=wp.int32, device=self.device)
        self.touch_pool = wp.zeros(POOL * max(1, len(heights)) * self.n_pool_bodies if pooled else 1, dtype=Ft,
                                   device=self.device)
        self.ground_z = wp.array(np.array(heights or [0.0], dtype=self._np_dtype), dtype=Ft, device=self.device)
        # 1 a body that does not flow; round 58 (flow_share): 2 a flowing body whose columns are marked 2 too
        self.touch_solid = wp.array(np.array([1 if m.name not in FLOWING else 2 if self.flow_share else 0
                                              for m in self.setup.materials] or [0],
                                             dtype=np.int32), dtype=wp.int32, device=self.device)

    def share_launches(self, Ft) -> list:
        """Round 49: the recorded :func:`build_share` ``touch_share`` (after the grid update); none when
        ``touch_on`` is False or ``touch_share`` is off."""
        if self.touch_slots.shape[0] == 1:   # touch_on and touch_share
            return []
        credit = Ft(self.touch_speed * self.dt / self.dx if self.column_dashpot() else 0.0)   # the dashpot here
        if self.touch_body.shape[0] > 1:   # round 52: the body's pool (body_bound.py)
            gather, settle, apply = build_body_bound(Ft)
            n, d, ng, nb = self.ground_touch.shape[0], self.device, self.n_grid, self.n_pool_bodies
            cols = [self.grid_v, self.touch_slots, self.ground, self.ground_touch, self.touch_body, ng]
            pull = TOUCH_PULLS[self.touch_pull]
            return [wp.launch(gather, dim=n, device=d, record_cmd=True,
                              inputs=cols + [credit, self.touch_pool, nb, self.touch_credits, pull]),
                    wp.launch(settle, dim=self.touch_pool.shape[0] // POOL, device=d, record_cmd=True,
                              inputs=[self.touch_pool, pull]),
                    wp.launch(apply, dim=n, device=d, record_cmd=True, inputs=cols + [self.touch_pool, nb])]
        return [wp.launch(build_share(Ft)[1], dim=self.ground_touch.shape[0], device=self.device, record_cmd=True,
                          inputs=[self.grid_v, self.touch_slots, self.ground, self.ground_touch, self.n_grid, credit,
                                  self.touch_credits, self.bound_mode()])]

    def touch_launches(self, Ft) -> list:
        """The recorded clear and mark (after P2G, before the two-field contact and the grid update); none when
        ``touch_on`` is False."""
        if not self.touch_on:
            return []
        clear, mark, _ = build_touch(Ft)
        ng, d = self.n_grid, self.device
        lo = self.k.vec3(*[float(c) for c in self.setup.domain_lo])
        return [wp.launch(clear, dim=self.ground_touch.shape[0], device=d, record_cmd=True,
                          inputs=[self.ground_touch, self.touch_body]),
                wp.launch(mark, dim=self.n_material, device=d, record_cmd=True, inputs=[
                    self.x, self.p_vol, self.body, self.flows, self.touch_solid, self.ground_z, self.ground_touch, lo,
                    Ft(self.inv_dx), Ft(self.touch_delta * self.dx), Ft(self.touch_margin), ng, self.touch_body])]


@functools.cache
def build_touch(Ft):
    """``(touch_clear, touch_mark, ground_reach)`` of scalar type ``Ft``: the two kernels (module docstring) and
    ``ground_reach(k, gr, q, i, j, n_grid, ground_touch)``, whether ground ``q`` (``gr = ground[q]``, its top node
    layer ``gr[0]``) holds node ``(i, j, k)``: ``k <= gr[0]``, or (``ground_touch`` of more than one entry) the
    layer ``gr[0] + 1`` in a marked column."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def touch_clear(ground_touch: wp.array(dtype=wp.int32), touch_body: wp.array(dtype=wp.int32)):
        ground_touch[wp.tid()] = 0
        if touch_body.shape[0] > 1:   # round 52: the column's body (body_bound.py)
            touch_body[wp.tid()] = 0

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def touch_mark(x: wp.array(dtype=vec3), p_vol: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32),
                   flows: wp.array(dtype=wp.int32), solid: wp.array(dtype=wp.int32), ground_z: wp.array(dtype=Ft),
                   ground_touch: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, reach: Ft, margin: Ft, n_grid: int,
                   touch_body: wp.array(dtype=wp.int32)):
        # a point of a flowing body (flows: all with "grid", the flowing bodies with "mixed") in the grid (P2G's
        # stencil test) that touches ground q's plane marks its 3 x 3 stencil columns: a point of a body that does
        # not flow (solid) when its lowest extent (its height less h, half its spacing p_vol^(1/3) / 2) lies under
        # margin h above the plane (below it too), a point of sand, snow or liquid when its height is under reach
        p = wp.tid()
        if flows[body[p]] == 0:
            return
        xp = x[p]
        X = (xp - lo) * inv_dx
        lim = Ft(n_grid - 3)
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        if not (b0 >= Ft(0.0) and b0 <= lim and b1 >= Ft(0.0) and b1 <= lim and b2 >= Ft(0.0) and b2 <= lim):
            return
        is_solid = solid[body[p]] == 1
        mark = int(1)
        h = Ft(0.0)
        if is_solid:
            h = Ft(0.5) * wp.pow(p_vol[p], Ft(1.0 / 3.0))   # only the extent test reads it
            mark = int(2)   # round 48: the dashpot above the held layers acts in such columns (build_dashpot)
        if solid[body[p]] == 2:
            mark = int(2)   # round 58 (flow_share): a flowing body's column shares the bound, round 36's test
        for q in range(ground_z.shape[0]):
            z = xp[2] - ground_z[q]
            near = z < reach
            if is_solid:
                near = z - h < margin * h
            if near:
                for a in range(3):
                    for c in range(3):
                        wp.atomic_max(ground_touch, (q * n_grid + int(b0) + a) * n_grid + int(b1) + c, mark)
                        if mark == 2 and touch_body.shape[0] > 1:   # round 52: the column's body, the largest id
                            wp.atomic_max(touch_body, (q * n_grid + int(b0) + a) * n_grid + int(b1) + c, body[p])

    @wp.func
    def ground_reach(k: int, gr: vec3, q: int, i: int, j: int, n_grid: int, ground_touch: wp.array(dtype=wp.int32)):
        on = Ft(k) <= gr[0]   # node layer k at or below the ground's top layer (exact small integers)
        # the touched layer gives the base's shear its friction: none on a frictionless ground (gr[1] = 0), where
        # it would only raise the floor a layer (a liquid's dam break ran 39 % slow with it)
        if ground_touch.shape[0] > 1 and Ft(k) == gr[0] + Ft(1.0) and gr[1] > Ft(0.0):
            if ground_touch[(q * n_grid + i) * n_grid + j] != 0:
                on = True
        return on

    return touch_clear, touch_mark, ground_reach


@functools.cache
def build_dashpot(Ft):
    """Round 48 (``GroundTouch.touch_damping``; docs/contact.md "Round 48: a dashpot above the held layers"), scalar
    type ``Ft``: ``dashpot(vel, k, gr, q, i, j, n_grid, ground_touch, d, slots) -> vel`` (m/s): at node ``(i, j, k)``
    in the layer just above ground ``q``'s held ones (``k = gr[0] + 2``: the touched layer is ``gr[0] + 1``; round 49,
    with ``slots`` of more than one entry, :func:`build_share`, the touched layer too) of a column
    marked 2 (a point of a body that does not flow touches the plane, :func:`build_touch`), the normal (+z) velocity
    divided by ``1 + d`` (``d = s dt / dx``, ``s`` the engine's ``touch_speed``), both ways; ``vel`` elsewhere. No
    friction is taken from it: the held layers' Coulomb rule is unchanged. taichi_mpm's ``GroundTouch.dashpot``."""
    vec3 = build_types(Ft)[0]

    @wp.func
    def dashpot(vel: vec3, k: int, gr: vec3, q: int, i: int, j: int, n_grid: int,
                ground_touch: wp.array(dtype=wp.int32), d: Ft, slots: wp.array(dtype=Ft)):
        out = vel
        up = Ft(k) - gr[0]   # round 49: the touched layer (up 1) too where it shares the bound (slots: the switch)
        layer = up == Ft(2.0) or (up == Ft(1.0) and slots.shape[0] > 1)
        if d > Ft(0.0) and ground_touch.shape[0] > 1 and layer and gr[1] > Ft(0.0):
            if ground_touch[(q * n_grid + i) * n_grid + j] == 2:
                out = vec3(vel[0], vel[1], vel[2] / (Ft(1.0) + d))
        return out

    return dashpot


@functools.cache
def build_field_reach(Ft):
    """``field_reach(k, gr, q, i, j, n_grid, ground_touch, free)``, scalar type ``Ft``: whether ground ``q`` holds node
    ``(i, j, k)`` for the two-field contact (both fields move with the mean there): :func:`build_touch`'s
    ``ground_reach``, except (``free`` not 0, with the touched columns) the ground's top node layer in a column no
    flowing point touches (``gasp_core.mpm.fields.TOP_FREE``): there the fields keep their offsets."""
    vec3, vec4, mat33 = build_types(Ft)
    ground_reach = build_touch(Ft)[2]

    @wp.func
    def field_reach(k: int, gr: vec3, q: int, i: int, j: int, n_grid: int,
                    ground_touch: wp.array(dtype=wp.int32), free: int):
        on = ground_reach(k, gr, q, i, j, n_grid, ground_touch)
        if free != 0 and ground_touch.shape[0] > 1 and Ft(k) == gr[0]:
            if ground_touch[(q * n_grid + i) * n_grid + j] == 0:
                on = False
        return on

    return field_reach


@functools.cache
def build_held(Ft):
    """``held_node(i, j, k, ground, n_grid, ground_touch, free, p, p_lo, p_hi, walls) -> int``, scalar type ``Ft``: 1
    where node ``(i, j, k)`` is in a ground's node layers (:func:`build_field_reach`: ``ground_reach`` with the touched
    layer, less a ground's top layer in an untouched column where ``free`` is not 0) or, with ``walls`` non-zero, where
    the point ``p`` (vec3) lies below ``p_lo`` or above ``p_hi`` on an axis (the walls' reach: each caller gives ``p``
    and the bounds in its own units, node indices or metres); 0 elsewhere. The two-field contact leaves such a node's
    fields moving with the mean (``fields.build_fields``), and gives it none of the particle contact's friction
    (``grid.build_field_friction``)."""
    vec3 = build_types(Ft)[0]
    field_reach = build_field_reach(Ft)

    @wp.func
    def held_node(i: int, j: int, k: int, ground: wp.array(dtype=vec3), n_grid: int,
                  ground_touch: wp.array(dtype=wp.int32), free: int, p: vec3, p_lo: vec3, p_hi: vec3, walls: int):
        held = int(0)
        for q in range(ground.shape[0]):
            if field_reach(k, ground[q], q, i, j, n_grid, ground_touch, free):   # with the touched layer
                held = int(1)
        if walls != 0:
            for d in range(3):
                if p[d] < p_lo[d] or p[d] > p_hi[d]:
                    held = int(1)
        return held

    return held_node
