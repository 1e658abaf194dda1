"""The touched column's Coulomb bound of the grid contact (issue 67; split from ``gasp_warp_mpm.touch`` in round
51): round 49's share of the held layers' unused bound with the touched layer (docs/contact.md "Round 49: the touched
layer shares the column's Coulomb bound"), round 50's credit of the two touch dashpots' push ("Round 50: the dashpot's
push in the column's Coulomb bound") and round 51's bounds on the whole column ("Round 51: the landing's friction",
``gasp_core.mpm.contact.TOUCH_BOUNDS``). taichi_mpm's ``GroundTouch.touch_keep`` / ``share_bound`` /
``column_bound``.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from .precision import MODULE_OPTIONS, build_types

#: Round 50: a column's slots (:func:`build_share`): the held layers' unused bound (3), the touched node's mass, the
#: mass of the node above it (the dashpot's, with ``touch_credit``); round 51: the held layers' masses (3).
SLOTS = 8



@functools.cache
def build_damp_node(Ft):
    """Round 50: ``damp_node(grid_v, node, m, d, room) -> jn``, scalar type ``Ft``: node ``node``'s normal (+z)
    velocity (m/s) divided by ``1 + d``; returns the dashpot's normal impulse ``jn`` (kg m/s, + up; 0 where the mass
    ``m``, kg, is 0); round 53: its pull (a negative ``jn``) at most ``room`` (kg m/s; 1e30 for none).
    taichi_mpm's ``GroundTouch.damp_node``."""
    vec3 = build_types(Ft)[0]

    @wp.func
    def damp_node(grid_v: wp.array(dtype=vec3), node: int, m: Ft, d: Ft, room: Ft):
        jn = Ft(0.0)
        if m > Ft(0.0):
            v = grid_v[node]
            jn = wp.max(m * (v[2] / (Ft(1.0) + d) - v[2]), -wp.max(room, Ft(0.0)))
            grid_v[node] = vec3(v[0], v[1], v[2] + jn / m)
        return jn

    return damp_node


@functools.cache
def build_column_bound(Ft):
    """Round 51 (``GroundTouch.touch_bound``, ``mode`` > 0; docs/contact.md "Round 51: the landing's friction"), scalar
    type ``Ft``: ``column_bound(grid_v, slots, col, node, r, mode) -> r`` in :func:`build_share`'s ``touch_share``, at
    column ``col`` whose touched node is ``node`` (the held layers' nodes ``node - 3 .. node - 1``): the column's
    friction in the substep (kg m/s) at most ``avail``, the held layers' stops (slots 0-2, ``mu m max(0, -v_z)``) plus
    ``r`` (``mu`` times the two dashpots' signed push; "debt" / "episode" the carried balance too); given to the held
    nodes first (each at most its own stop's: their velocity's tangential part cut), the rest to the touched node
    (mass slot 3; held masses slots 5-7). Returns the balance to carry: "debt" (1) ``min(max(r, 0), avail - given)``,
    "episode" (3) ``avail - given``, else 0. taichi_mpm's ``GroundTouch.column_bound``."""
    vec3 = build_types(Ft)[0]

    @wp.func
    def column_bound(grid_v: wp.array(dtype=vec3), slots: wp.array(dtype=Ft), col: int, node: int, r: Ft, mode: int):
        m = slots[col * SLOTS + 3]
        avail = r
        want = Ft(0.0)
        for c in range(3):
            avail = avail + slots[col * SLOTS + c]
            mc = slots[col * SLOTS + 5 + c]
            if mc > Ft(0.0) and node - 3 + c >= 0:
                v = grid_v[node - 3 + c]
                want = want + wp.min(mc * wp.sqrt(v[0] * v[0] + v[1] * v[1]), slots[col * SLOTS + c])
        v = grid_v[node]
        lt = wp.sqrt(v[0] * v[0] + v[1] * v[1])
        give = wp.min(want + m * lt, wp.max(avail, Ft(0.0)))
        fh = Ft(1.0)
        if give < want:
            fh = give / want
        for c in range(3):
            mc = slots[col * SLOTS + 5 + c]
            if mc > Ft(0.0) and node - 3 + c >= 0:
                u = grid_v[node - 3 + c]
                lu = wp.sqrt(u[0] * u[0] + u[1] * u[1])
                if lu > Ft(1e-30):
                    s = wp.max(Ft(0.0), Ft(1.0) - fh * wp.min(mc * lu, slots[col * SLOTS + c]) / (mc * lu))
                    grid_v[node - 3 + c] = vec3(u[0] * s, u[1] * s, u[2])
        if m > Ft(0.0) and lt > Ft(1e-30) and give > want:
            s = wp.max(Ft(0.0), Ft(1.0) - (give - want) / (m * lt))
            grid_v[node] = vec3(v[0] * s, v[1] * s, v[2])
        out = Ft(0.0)
        if mode == 1:
            out = wp.min(wp.max(r, Ft(0.0)), avail - give)   # a debt kept until paid, a credit not beyond the push
        if mode == 3:
            out = avail - give
        return out

    return column_bound


@functools.cache
def build_keep(Ft):
    """Round 49 (docs/contact.md "Round 49: the touched layer shares the column's Coulomb bound"), scalar type
    ``Ft``: ``(touch_keep, shares)``, the grid update's side of :func:`build_share`.

    ``shares(k, gr, q, i, j, n_grid, ground_touch, slots, mode) -> int``: 1 at the touched layer (``k = gr[0] + 1``)
    of a column marked 2 (a point of a body that does not flow touches ground ``q``'s plane) on a ground with friction,
    with ``slots`` of more than one entry (the switch on); there the grid rule (``grid.build_boundary_rules``) leaves
    the node alone. Round 51 (``mode`` > 0, ``GroundTouch.bound_mode``): 2 at the held layers ``gr[0] - 2 .. gr[0]``
    of such a column, where the grid rule stops the normal motion only (their friction is :func:`touch_share`'s).
    ``touch_keep(slots, v, m, i, j, k, ground, n_grid, ground_touch, mode)`` (in the grid update at a node with mass,
    ``v`` its velocity before the rule, m/s, ``m`` its mass, kg): for the held layers ``gr[0] - 2 .. gr[0]`` of a
    column, the Coulomb bound the ground's stop gives and its node does not spend, ``m max(0, mu max(0, -v_z) -
    |v_xy|)`` (kg m/s; round 51, ``mode`` > 0: the whole bound ``mu m max(0, -v_z)``, and the mass at slot ``k - gr[0]
    + 7``), at slot ``k - gr[0] + 2``; for the touched layer its mass at slot 3, round 50 the node above's at slot 4
    (``slots``: :data:`SLOTS` a column, ``Ft``)."""
    vec3 = build_types(Ft)[0]

    @wp.func
    def shares(k: int, gr: vec3, q: int, i: int, j: int, n_grid: int, ground_touch: wp.array(dtype=wp.int32),
               slots: wp.array(dtype=Ft), mode: int):
        # 1: the touched node (no rule); round 51 (mode > 0): 2 at the held layers gr[0] - 2 .. gr[0] (the stop only)
        out = int(0)
        up = Ft(k) - gr[0]
        held = mode > 0 and up <= Ft(0.0) and up >= Ft(-2.0)
        if slots.shape[0] > 1 and gr[1] > Ft(0.0) and (up == Ft(1.0) or held):
            if ground_touch[(q * n_grid + i) * n_grid + j] == 2:
                out = int(1)
                if up < Ft(1.0):
                    out = int(2)
        return out

    @wp.func
    def touch_keep(slots: wp.array(dtype=Ft), v: vec3, m: Ft, i: int, j: int, k: int, ground: wp.array(dtype=vec3),
                   n_grid: int, ground_touch: wp.array(dtype=wp.int32), mode: int):
        if slots.shape[0] > 1:
            for q in range(ground.shape[0]):
                gr = ground[q]
                d = k - int(gr[0])
                if d >= -2 and d <= 2:
                    val = m   # the touched node's mass (d 1), round 50: the node above's (d 2)
                    base = ((q * n_grid + i) * n_grid + j) * SLOTS
                    if d < 1:
                        lt = wp.sqrt(v[0] * v[0] + v[1] * v[1])
                        val = m * wp.max(Ft(0.0), gr[1] * wp.max(Ft(0.0), -v[2]) - lt)
                        if mode > 0:   # round 51: the stop's whole bound, and the mass (the friction is deferred)
                            val = m * gr[1] * wp.max(Ft(0.0), -v[2])
                            slots[base + d + 7] = m
                    slots[base + d + 2] = val

    return touch_keep, shares

@functools.cache
def build_share(Ft):
    """Round 49 (``GroundTouch.touch_share``; docs/contact.md "Round 49: the touched layer shares the column's Coulomb
    bound"), scalar type ``Ft``: ``(touch_keep, touch_share, shares)``.

    ``touch_keep`` and ``shares``: :func:`build_keep`.
    The kernel ``touch_share(grid_v, slots, ground, ground_touch, n_grid, credit, res, mode)`` (a column a thread,
    after the grid update): the touched node of a column marked 2 has its tangential velocity cut by the column's
    unused bound over its mass (to 0 at most); its normal velocity is left as the body moved it. Round 50 (``credit =
    s dt / dx`` not 0): first the dashpot on the touched node and the one above (their normal velocity divided by ``1
    + credit``), its signed normal impulse times ``mu`` added to the column's credit ``res`` (kg m/s, kept across
    substeps, 0 in a column not marked 2); the cut may then spend the credit where positive, and what it spends beyond
    the held layers' bound is taken from it. Round 51 (``mode`` > 0): the whole column's friction instead, by
    ``column_bound`` (``gasp_core.mpm.contact.TOUCH_BOUNDS``: the held nodes first, each at most its own stop's, then
    the touched node, all at most the held layers' stops plus ``res`` and the push; "debt" carries a negative
    balance until paid). It clears every column's slots."""
    vec3 = build_types(Ft)[0]
    damp_node, column_bound = build_damp_node(Ft), build_column_bound(Ft)
    touch_keep, shares = build_keep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def touch_share(grid_v: wp.array(dtype=vec3), slots: wp.array(dtype=Ft), ground: wp.array(dtype=vec3),
                    ground_touch: wp.array(dtype=wp.int32), n_grid: int, credit: Ft, res: wp.array(dtype=Ft),
                    mode: int):
        col = wp.tid()
        q = col / (n_grid * n_grid)
        i = (col / n_grid) % n_grid
        j = col % n_grid
        gr = ground[q]
        kt = int(gr[0]) + 1
        if ground_touch[col] == 2 and gr[1] > Ft(0.0) and kt >= 0 and kt < n_grid:
            m = slots[col * SLOTS + 3]
            node = (i * n_grid + j) * n_grid + kt
            r = res[col]
            if mode == 2:
                r = Ft(0.0)
            if credit > Ft(0.0):
                # round 50: the dashpot on the touched node and the one above (both ways), its signed normal impulse
                # times mu added to the column's credit, kept across substeps; the friction may spend what is positive
                r = r + gr[1] * damp_node(grid_v, node, m, credit, Ft(1e30))
                if kt + 1 < n_grid:
                    r = r + gr[1] * damp_node(grid_v, node + 1, slots[col * SLOTS + 4], credit, Ft(1e30))
            if mode > 0:
                r = column_bound(grid_v, slots, col, node, r, mode)
            else:
                v = grid_v[node]
                lt = wp.sqrt(v[0] * v[0] + v[1] * v[1])
                if m > Ft(0.0) and lt > Ft(1e-30):
                    held = slots[col * SLOTS] + slots[col * SLOTS + 1] + slots[col * SLOTS + 2]
                    s = wp.max(Ft(0.0), Ft(1.0) - (held + wp.max(r, Ft(0.0))) / (m * lt))
                    grid_v[node] = vec3(v[0] * s, v[1] * s, v[2])
                    r = r - wp.max(Ft(0.0), m * lt * (Ft(1.0) - s) - held)   # what it spent beyond the held layers'
            res[col] = r
        else:
            res[col] = Ft(0.0)
        for c in range(SLOTS):   # cleared for the next substep (a node of no mass writes none)
            slots[col * SLOTS + c] = Ft(0.0)

    return touch_keep, touch_share, shares
