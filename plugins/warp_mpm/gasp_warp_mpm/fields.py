"""The two-field grid contact (``gasp_core.mpm.fields``, ``docs/contact.md`` "Sand that slides on what it touches",
issue 53 items 3 and 5) as Warp kernels: field A's bodies (``in_a``, ``field_bodies``: a mixed scene's flowing
bodies, or body 1 of two soft bodies) scatter their momentum and mass to ``grid_sv`` in P2G (``transfers.p2g``);
:func:`build_fields`' ``field_contact``, after P2G and before the grid update, turns them and the whole grid's into each field's velocity offset ``grid_dv``
(field A's at ``node``, B's at ``n_nodes + node``) and clears ``grid_sv``; G2P (``transfers.g2p``) adds a point's own
field's offset to the grid velocity.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import numpy as np
import warp as wp

from gasp_core.mpm.contact import flowing_bodies
from gasp_core.mpm import fields as core_fields, gap_touch as G
from gasp_core.mpm.fields import (MIN_FRACTION, MIN_GRADIENT, body_pair, field_bodies, field_friction, flow_touch,
                                  gap_levels, node_friction, touch_fraction, a_node_friction)
from gasp_core.mpm.face_share import face_share
from gasp_core.mpm.flow_reach import flow_levels
from gasp_core.mpm.shared_fields import shared_field_warning

from . import ENGINE
from .pair_touch import build_gap_curve, build_gap_touch, build_pair_funcs, build_pair_touch
from .precision import MODULE_OPTIONS, build_types
from .face import build_faced
from .field_nodes import (allocate_box, box_launches, build_field_clear, build_field_old, build_field_shared,
                          shared_threads, sweep_args)
from .rigid_pairs import allocate_pairs, build_node_slot, mat33d, slot_inputs, vec3d
from .grid_box import grid_box_launches, grid_sweep   # noqa: F401 (grid_sweep: the engine's, round 64)
from .touch import build_held


@functools.cache
def build_field_reads(Ft):
    """``(field_offset_base, field_node_v)``: G2P's reads of a point's field, scalar type ``Ft``. The first gives
    where the point's offsets start in ``grid_dv`` (0 for field A, ``n_nodes`` for B; -1 without two fields), the
    second a node's velocity plus that offset (the grid's alone at -1)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def field_offset_base(grid_dv: wp.array(dtype=vec3), in_a: wp.array(dtype=wp.int32), b: int, n_nodes: int):
        off = int(-1)
        if grid_dv.shape[0] > 1:
            off = n_nodes
            if in_a[b] != 0:
                off = 0
        return off

    @wp.func
    def field_node_v(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), off: int, node: int):
        gv = grid_v[node]
        if off >= 0:
            gv = gv + grid_dv[off + node]
        return gv

    return field_offset_base, field_node_v


@functools.cache
def build_aflip_gather(Ft):
    """``aflip_gather(grid_v0, W, idx0, nn, n_grid, off)``: AFLIP's ``v_PIC(old)`` at a point (``sum w grid_v0``); with
    the two fields' old offsets (``grid_v0`` of 3 n_grid^3 entries, :func:`build_field_old`, round 59) plus its
    field's (``off`` from ``field_offset_base``: 0 field A, n_grid^3 field B, -1 none)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def aflip_gather(grid_v0: wp.array(dtype=vec3), W: mat33, idx0: int, nn: int, n_grid: int, off: int):
        old_v = vec3(Ft(0.0))
        n_nodes = nn * n_grid
        own = off >= 0 and grid_v0.shape[0] > n_nodes
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    node = idx0 + i * nn + j * n_grid + k
                    g0 = grid_v0[node]
                    if own:
                        g0 = g0 + grid_v0[n_nodes + off + node]
                    old_v = old_v + (W[i, 0] * W[j, 1] * W[k, 2]) * g0
        return old_v

    return aflip_gather


@functools.cache
def build_b_normal(Ft):
    """``b_normal(grid_mv, grid_sv, ground, node, n_grid, mirror)``, scalar type ``Ft``: ``grad m_B`` at an inner node
    by central differences (the ``1 / (2 dx)`` cancels in the direction), field B's surface normal, into B (kg, not
    normalised); ``m_B`` the whole grid's mass less A's, with ``mirror`` (int, not 0) seen at or below a ground's top
    node layer ``ground[r][0]`` plus its mirror image above that layer (``gasp_core.mpm.fields.ground_mirror``: the
    ground is B's support, not a surface of B)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def mass_b(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), ground: wp.array(dtype=vec3), node: int,
               n_grid: int, mirror: int):
        out = grid_mv[node][3] - grid_sv[node][3]
        if mirror != 0:
            k = node % n_grid
            for r in range(ground.shape[0]):
                top = int(ground[r][0])
                if k <= top and 2 * top - k < n_grid:
                    j = node + 2 * (top - k)
                    out = out + grid_mv[j][3] - grid_sv[j][3]
        return out

    @wp.func
    def b_normal(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), ground: wp.array(dtype=vec3),
                 node: int, n_grid: int, mirror: int):
        nn = n_grid * n_grid
        return vec3(mass_b(grid_mv, grid_sv, ground, node + nn, n_grid, mirror)
                    - mass_b(grid_mv, grid_sv, ground, node - nn, n_grid, mirror),
                    mass_b(grid_mv, grid_sv, ground, node + n_grid, n_grid, mirror)
                    - mass_b(grid_mv, grid_sv, ground, node - n_grid, n_grid, mirror),
                    mass_b(grid_mv, grid_sv, ground, node + 1, n_grid, mirror)
                    - mass_b(grid_mv, grid_sv, ground, node - 1, n_grid, mirror))

    return b_normal


@functools.cache
def build_node_pair(Ft):
    """``node_pair``: the A-B pair's Coulomb coefficient at a node, scalar type ``Ft``: ``mu`` (the scalar) where
    ``mu_on`` is 0, else ``combine_friction(tan_A, mu_B)``: ``tan_A`` A's one ``own``, or (bit 2, round 43) its
    mass-weighted mean from ``grid_vf``'s fourth part clamped to ``a_lo, a_hi``; ``mu_B`` (bit 1, round 42) B's
    mass-weighted mean from the third part clamped to ``mu_lo, mu_hi`` (bit 4, round 44: B's unnamed bodies' mass,
    the fifth part, taken at ``tan_A``: ``(S_mu + tan_A S_u) / m_B``), else B's one ``b_mu``, else ``tan_A``
    (``b_mu`` negative: B names none)."""

    @wp.func
    def node_pair(grid_vf: wp.array(dtype=Ft), node: int, n_nodes: int, m_a: Ft, m_b: Ft, mu: Ft, mu_on: int,
                  own: Ft, mu_lo: Ft, mu_hi: Ft, a_lo: Ft, a_hi: Ft, b_mu: Ft):
        mu_n = mu
        if mu_on != 0:
            t_a = own
            if mu_on >= 2:   # A's sands' angles, mass-weighted (grid_vf's fourth part)
                t_a = wp.clamp(grid_vf[3 * n_nodes + node] / m_a, a_lo, a_hi)
            mu_bn = t_a
            if mu_on % 2 != 0:   # B's bodies' frictions, mass-weighted (grid_vf's third part)
                s_b = grid_vf[2 * n_nodes + node]
                if mu_on >= 4:   # B's unnamed bodies at A's own (fifth part: their w m; round 44)
                    s_b = s_b + t_a * grid_vf[4 * n_nodes + node]
                mu_bn = wp.clamp(s_b / m_b, mu_lo, mu_hi)
            elif b_mu >= Ft(0.0):
                mu_bn = b_mu
            mu_n = wp.min(wp.sqrt(t_a * mu_bn), Ft(10.0))
        return mu_n

    return node_pair


@functools.cache
def build_fields(Ft):
    """``field_contact``: the node kernel of the two-field contact, scalar type ``Ft``; its ``mirror`` (int): B's mass
    at a ground's node layers seen with its mirror image for the normal (``gasp_core.mpm.fields.GROUND_MIRROR``); its
    ``free`` (int): a ground's top layer in an untouched column takes the contact (``TOP_FREE``, touch.py); its
    ``mu_on`` (int): bit 1 B's per-node friction (round 42, ``grid_vf``'s third part, ``own`` A's one ``tan(phi)``),
    bit 2 A's (round 43, ``grid_vf``'s fourth part, clamped to ``a_lo, a_hi``; B's one ``b_mu`` without bit 1, A's
    own where it is negative); 0: the scalar ``mu``. It is long because the node kernel's branches (round 62's pair
    slot among them) are one closure."""
    vec3, vec4, mat33 = build_types(Ft)
    held_node = build_held(Ft)
    b_normal = build_b_normal(Ft)
    coulomb, flow_layer = build_pair_funcs(Ft)
    node_pair = build_node_pair(Ft)
    node_slot = build_node_slot(Ft)
    faced, a_face = build_faced(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_contact(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), grid_dv: wp.array(dtype=vec3),
                      n_grid: int, mu: Ft, ground: wp.array(dtype=vec3), grid_vf: wp.array(dtype=Ft), cell: Ft,
                      wall_lo: Ft, wall_hi: vec3, touch_frac: Ft, pair: int, lo: vec3, dx: Ft,
                      pair_acc: wp.array(dtype=wp.float64), ground_touch: wp.array(dtype=wp.int32),
                      flow_touch: wp.array(dtype=wp.int32), flow_push: wp.array(dtype=vec3), mirror: int,
                      free: int, own: Ft, mu_lo: Ft, mu_hi: Ft, mu_on: int, a_lo: Ft, a_hi: Ft, b_mu: Ft,
                      in_a: wp.array(dtype=wp.int32), rigid: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d),
                      rot: wp.array(dtype=mat33d), box: wp.array(dtype=vec3d), nb: int, pad: wp.float64,
                      slots: wp.array(dtype=wp.int32), n_on: wp.array(dtype=wp.int32),
                      seen: wp.array(dtype=wp.int32), shared: wp.array(dtype=wp.int32),
                      n_shared: wp.array(dtype=wp.int32), threads: int, face: Ft):
        nn = n_grid * n_grid
        n_nodes = nn * n_grid
        n_on_grid = n_shared[0]   # round 63: the inner nodes where both fields have mass (field_nodes.field_shared)
        run = (n_on_grid + threads - 1) / threads   # a thread's run of them, in the list's order
        for q in range(wp.tid() * run, wp.min(wp.tid() * run + run, n_on_grid)):
            node = shared[q]
            i = node / nn
            j = (node / n_grid) % n_grid
            k = node % n_grid
            g = grid_mv[node]
            m = g[3]
            m_a = grid_sv[node][3]
            m_b = m - m_a
            dva = vec3(Ft(0.0))
            dvb = vec3(Ft(0.0))
            # in a ground's node layers or the walls' (the grid rule's reach): both move with the mean (touch.py)
            held = held_node(i, j, k, ground, n_grid, ground_touch, free, vec3(Ft(i), Ft(j), Ft(k)), vec3(wall_lo),
                             wall_hi, 1)
            mb_eff = Ft(0.0)   # > 0: A against B's mass here and behind (pair_touch.py)
            if held == 0:
                touch = (grid_vf[node] + grid_vf[n_nodes + node]) >= touch_frac * cell   # the bodies meet here
                flow = flow_push.shape[0] > 1   # the flowing body's touch (pair_touch.py): its layer behind
                if flow_touch.shape[0] > 1:   # its points mark the nodes, or round 60's touch by geometry's (gap_touch)
                    touch = flow_touch[node] != 0
                pa = grid_sv[node]
                v_b = vec3(g[0] - pa[0], g[1] - pa[1], g[2] - pa[2]) / m_b
                u = vec3(pa[0], pa[1], pa[2]) / m_a - v_b
                n = b_normal(grid_mv, grid_sv, ground, node, n_grid, mirror)
                ln = wp.length(n)
                u2 = u
                # several frictions in a field: the pair's per node (node_friction, a_node_friction)
                mu_n = node_pair(grid_vf, node, n_nodes, m_a, m_b, mu, mu_on, own, mu_lo, mu_hi, a_lo, a_hi, b_mu)
                if ln > Ft(MIN_GRADIENT) * m:
                    nh = n / ln
                    un = wp.dot(u, nh)
                    xn = lo + dx * vec3(Ft(i), Ft(j), Ft(k))
                    slot = pair   # 1: two rigid bodies; round 62 (pair 2): the pair of rigid bodies here, 0 none
                    if pair > 1 and touch:
                        slot = node_slot(xn, in_a, rigid, centre, rot, box, nb, pad)
                    if slot != 0 and pair != 0 and touch:   # rigid bodies: where they touch, for their contact as one
                        wr = wp.float64(m_a * m_b / m)
                        for ax in range(3):
                            wp.atomic_add(pair_acc, 7 * (slot - 1) + 1 + ax, wr * wp.float64(xn[ax]))
                            wp.atomic_add(pair_acc, 7 * (slot - 1) + 4 + ax, wr * wp.float64(nh[ax]))
                        wp.atomic_add(pair_acc, 7 * (slot - 1), wr)
                        if pair > 1 and wp.atomic_add(seen, slot - 1, 1) == 0:   # round 63: listed the first time
                            slots[wp.atomic_add(n_on, 0, 1)] = slot - 1
                    elif un > Ft(0.0) and touch and faced(grid_sv, node, n_grid, n, m_b, face):   # approaching, B's face
                        u2 = u - coulomb(u, nh, mu_n)
                        if flow and m_b < m_a:   # A's side: B's node behind it takes the reaction with this one's B
                            qm = flow_layer(grid_mv, grid_sv, flow_push, node, nh, nn, n_grid, pa, v_b, m_b, mu_n, u2)
                            u2 = vec3(qm[0], qm[1], qm[2])
                            mb_eff = qm[3]
                else:
                    if not a_face(grid_sv, node, n_grid, m, face):   # round 96: A's face in B's middle keeps them
                        u2 = vec3(Ft(0.0))   # no normal: the fields move as one
                dva = (m_b / m) * u2
                dvb = -(m_a / m) * u2
                if mb_eff > Ft(0.0):   # A against B's mass at both nodes, moving as one
                    dva = (m_b / m) * u - (mb_eff / (m_a + mb_eff)) * (u - u2)
                    dvb = -(m_a / m) * u + (m_a / (m_a + mb_eff)) * (u - u2)
            grid_dv[node] = dva
            grid_dv[n_nodes + node] = dvb

    return field_contact, build_field_clear(Ft)


def allocate_fields(eng, Ft, contact: str) -> None:
    """The contact chosen per body (``contact`` the scene's): ``eng.flows`` (per body, 1 where it flows) and
    ``grid_mf`` (the flowing bodies' mass per node in a mixed scene); the two-field contact's ``in_a`` (per body, 1 in
    field A), ``pair`` (1 for two rigid bodies, whose touching nodes sum into ``pair_acc``: sum m_red, sum m_red x,
    sum m_red n; ``rigid_friction.build_rigid_pair``), ``grid_sv`` (field A's momentum and mass per node),
    ``grid_vf`` (each field's volume) and ``grid_dv``
    (the two offsets per node), one unused entry each without it (``eng.fields`` says which), and its friction
    ``eng.field_mu`` and touch threshold ``eng.field_touch``; where field B's bodies bring several frictions
    (``eng.node_mu``, ``gasp_core.mpm.fields.node_friction``), ``eng.body_mu`` (per body) and a third part of
    ``grid_vf`` (B's ``w m mu`` per node: the pair's friction per node in ``field_contact``), else one entry; where
    field A's sands bring several angles (``eng.a_mu``, ``a_node_friction``) a fourth part (A's ``w m tan(phi)``),
    ``body_mu`` then A's ``tan(phi)`` too (-1: a body whose field has no channel, it scatters none); where B's
    unnamed bodies take A's own (``UNNAMED`` in ``body_mu``, ``b_unnamed_mix``, round 44) a fifth (their ``w m``); the
    grounds' touched columns (``GroundTouch.allocate_touch``, touch.py)."""
    from gasp_core.mpm.rigid import step_view
    k, d = eng.k, eng.device
    view = step_view(eng.setup)
    eng.flows = wp.array(flowing_bodies(view, contact).astype(np.int32), dtype=wp.int32, device=d)
    in_a = field_bodies(view)
    # rounds 81-82 (gasp_core.mpm.rigid_a.rigid_node_rule): beside a rigid field the grid update's friction goes to
    # the soft field alone, decided per node: P2G scatters the rigid bodies' mass (eng.mf_bodies) to grid_mf,
    # field_shared writes A's mass back signed (field_nodes.rigid_side_mass)
    from gasp_core.mpm.rigid import rigid_mask
    from gasp_core.mpm.rigid_a import rigid_node_rule
    eng.rigid_rule = rigid_node_rule(view) if in_a is not None and contact != "mixed" else 0
    eng.rigid_a = eng.rigid_rule != 0
    eng.grid_mf = wp.zeros(eng.n_grid ** 3 if contact == "mixed" or eng.rigid_a else 1, dtype=Ft, device=d)
    shared_field_warning(view, ENGINE)   # solids glued where they touch (gasp_core.mpm.fields)
    eng.fields = in_a is not None
    eng.in_a = wp.array((in_a if eng.fields else np.zeros(1, bool)).astype(np.int32), dtype=wp.int32, device=d)
    eng.field_mu = field_friction(view) if eng.fields else 0.0
    eng.field_touch = touch_fraction(view) if eng.fields else 0.0
    allocate_pairs(eng, view)   # rigid pairs: two (rigid.py) or among three or more (round 62, rigid_pairs.py)
    n = eng.n_grid ** 3 if eng.fields else 1
    eng.grid_sv = wp.zeros(n, dtype=k.vec4, device=d)
    eng.shared_nodes = wp.zeros(n, dtype=wp.int32, device=d)   # round 63: the nodes both fields meet at (field_nodes)
    eng.n_shared = wp.zeros(1, dtype=wp.int32, device=d)
    allocate_box(eng)   # round 64: the field passes' box (field_nodes.py)
    eng.grid_dv = wp.zeros(2 * n if eng.fields else 1, dtype=k.vec3, device=d)
    # B's bodies' several frictions (gasp_core.mpm.fields.node_friction): a third part of grid_vf, B's w m mu per node
    eng.node_mu = node_friction(view) if eng.fields else None
    eng.a_mu = a_node_friction(view) if eng.fields else None   # round 43: A's several angles, a fourth part
    # round 44: B's unnamed bodies beside named ones with A per node (core_fields.b_unnamed_mix), a fifth part
    unnamed = eng.node_mu is not None and bool((np.asarray(eng.node_mu[1]) == core_fields.UNNAMED).any())
    eng.mu_on = int(eng.node_mu is not None) + 2 * int(eng.a_mu is not None) + 4 * int(unnamed)
    parts = 5 if eng.mu_on >= 4 else 4 if eng.mu_on >= 2 else 3 if eng.mu_on else 2
    eng.grid_vf = wp.zeros(parts * n if eng.fields else 1, dtype=Ft, device=d)
    eng.body_mu = wp.array(body_channel(in_a, eng.node_mu, eng.a_mu) if eng.mu_on else np.zeros(1), dtype=Ft,
                           device=d)
    # round 59: with AFLIP, field A's APIC momentum n_grid^3 further in grid_mv0, the fields' old offsets in grid_v0
    # (build_field_old; gasp_core.mpm.fields.FIELD_OLD_VELOCITY)
    eng.field_flip = bool(eng.fields and eng.flip > 0 and core_fields.FIELD_OLD_VELOCITY)
    if eng.field_flip:
        eng.grid_mv0 = wp.zeros(2 * n, dtype=k.vec4, device=d)
        eng.grid_v0 = wp.zeros(3 * n, dtype=k.vec3, device=d)
    # the grid update gives the particle contact's friction to field B alone (grid.build_field_friction)
    on = eng.fields and ((contact == "mixed" and core_fields.B_FRICTION) or eng.rigid_a)
    eng.dv_friction = eng.grid_dv if on else wp.zeros(1, dtype=k.vec3, device=d)
    # round 42: a ground's top layer free in untouched columns, the friction on B's own velocity (grid.py); round 81:
    # bit 4 (8) alone where field A is rigid: grid_mf is A's mass for the friction only (the friction on the mean)
    eng.field_rule = core_fields.field_rule() if eng.fields and contact == "mixed" else 8 if eng.rigid_a else 0
    eng.mf_bodies = (wp.array(np.asarray(rigid_mask(view.materials)).astype(np.int32), dtype=wp.int32, device=d)
                     if eng.rigid_a else eng.flows)   # whose mass P2G scatters to grid_mf
    eng.flow_touch_on = bool(eng.fields and flow_touch(view))   # the flowing body's touch (pair_touch.py)
    # round 75: its level per body, the point's surface at B's (gasp_core.mpm.flow_reach.flow_levels)
    eng.flow_level = wp.array(flow_levels(view) if eng.flow_touch_on else np.zeros(1), dtype=Ft, device=d)
    levels = gap_levels(view, bool(core_fields.GAP_TOUCH) and body_pair(view)) if eng.fields else None   # round 60
    eng.gap_touch_on = levels is not None
    eng.gap_curve = bool(eng.gap_touch_on and G.CURVATURE)   # round 61: the level reads the curvature
    eng.gap_level = wp.array(levels if eng.gap_touch_on else np.zeros(1), dtype=Ft, device=d)
    eng.flow_touch = wp.zeros(n if eng.flow_touch_on or eng.gap_touch_on else 1, dtype=wp.int32, device=d)
    eng.flow_push = wp.zeros(n if eng.flow_touch_on else 1, dtype=k.vec3, device=d)
    # field A's points without their affine momentum where they meet B (transfers.p2g, gasp_core PIC_AT_B)
    eng.p_pic = wp.zeros(eng.n_material if eng.flow_touch_on and core_fields.PIC_AT_B else 1, dtype=wp.int32, device=d)
    eng.allocate_touch(Ft, contact)   # the grounds' touched columns (touch.py)
    from .cells import allocate_cells   # here: cells.py reads stencil.py, which reads this module
    allocate_cells(eng, Ft)   # Grady's cells


def body_channel(in_a, node_mu, a_mu) -> np.ndarray:
    """Per body what its points scatter, weighted by ``w m``, to its field's friction channel (``grid_vf``'s third
    part for B, fourth for A): B's ``friction`` (``node_mu[1]``; ``UNNAMED``, -2: its ``w m`` to the fifth part),
    A's ``tan(phi)`` (``a_mu[0]``), -1 for a body whose field has no channel (it scatters none). Shape (n_bodies,),
    float64."""
    out = np.full(len(in_a), -1.0)
    if node_mu is not None:
        out[~np.asarray(in_a, bool)] = np.asarray(node_mu[1])[~np.asarray(in_a, bool)]
    if a_mu is not None:
        out[np.asarray(in_a, bool)] = np.asarray(a_mu[0])[np.asarray(in_a, bool)]
    return out


def field_launches(eng, Ft) -> list:
    """The recorded launches of the contact and the clear (after P2G, before the grid update); none without it."""
    from .cells import cell_launches   # here: cells.py reads stencil.py, which reads this module
    if not eng.fields:   # round 64's grid box (grid_box.py), then Grady's cells' contact and clear over it (cells.py)
        return grid_box_launches(eng, Ft) + cell_launches(eng, Ft)[1]
    contact, clear = build_fields(Ft)
    ng, d = eng.n_grid, eng.device
    # the walls' grid rule reaches node indices below wall_in and above (hi - lo) / dx - wall_in (grid.py)
    walls = eng.wall_mu.shape[0] > 0
    wall_lo = eng.wall_in if walls else -1.0
    side = (np.asarray(eng.setup.domain_hi, float) - np.asarray(eng.setup.domain_lo, float)) / eng.dx
    wall_hi = side - eng.wall_in if walls else np.full(3, 1e30)
    mark, apply = build_pair_touch(Ft)
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    flow = [wp.launch(mark, dim=eng.n_material, device=d, record_cmd=True, inputs=[
        eng.x, eng.body, eng.in_a, eng.grid_vf, eng.flow_touch, lo, Ft(eng.inv_dx), Ft(eng.dx ** 3),
        eng.flow_level, ng, eng.p_pic])] if eng.flow_touch_on else []
    sweep = sweep_args(eng)   # round 64: the passes over the field box (field_nodes.py), not the whole grid
    after = [wp.launch(apply, dim=sweep[1], device=d, record_cmd=True, inputs=[
        eng.grid_mv, eng.grid_sv, eng.grid_dv, eng.flow_push, eng.flow_touch, ng, *sweep])] if eng.flow_touch_on else []
    if eng.gap_touch_on:   # round 60: the touch by geometry (pair_touch.build_gap_touch)
        gmark, gclear = build_gap_touch(Ft)
        curve = [ng, G.TABLE_N, Ft(G.TABLE_STEP), Ft(G.SIGMA2)] if eng.gap_curve else [ng]   # round 61
        flow = [wp.launch(build_gap_curve(Ft) if eng.gap_curve else gmark, dim=eng.n_material, device=d,
                          record_cmd=True, inputs=[eng.x, eng.body, eng.in_a, eng.grid_vf, eng.flow_touch, lo,
                                                   Ft(eng.inv_dx), Ft(eng.dx ** 3), eng.gap_level, *curve])]
        after = [wp.launch(gclear, dim=sweep[1], device=d, record_cmd=True, inputs=[eng.flow_touch, ng, *sweep])]
    old = [wp.launch(build_field_old(Ft), dim=sweep[1], device=d, record_cmd=True, inputs=[
        eng.grid_mv0, eng.grid_v0, ng, *sweep])] if eng.field_flip else []   # round 59: AFLIP's old velocity per field
    shared = [wp.launch(build_field_shared(Ft), dim=sweep[1], device=d, record_cmd=True, inputs=[
        eng.grid_mv, eng.grid_sv, eng.grid_dv, ng, eng.shared_nodes, eng.n_shared, eng.grid_mf, eng.rigid_rule,
        *sweep])]   # round 63; round 82: grid_mf per node (rigid_node_rule)
    flow = box_launches(eng, Ft) + grid_box_launches(eng, Ft) + flow   # round 64: the boxes first (field_nodes.py)
    return flow + old + shared + [wp.launch(contact, dim=shared_threads(eng), device=d, record_cmd=True, inputs=[
                eng.grid_mv, eng.grid_sv, eng.grid_dv, ng, Ft(eng.field_mu), eng.ground, eng.grid_vf,
                Ft(eng.dx ** 3), Ft(wall_lo), eng.k.vec3(*[float(c) for c in wall_hi]), Ft(eng.field_touch), eng.pair,
                eng.k.vec3(*[float(c) for c in eng.setup.domain_lo]), Ft(eng.dx), eng.pair_acc, eng.ground_touch,
                eng.flow_touch, eng.flow_push, int(bool(core_fields.GROUND_MIRROR)), eng.field_rule % 2,
                *([Ft(a) for a in (eng.node_mu[0], eng.node_mu[2], eng.node_mu[3])] if eng.node_mu else [Ft(0.0)] * 3),
                eng.mu_on, *([Ft(a) for a in eng.a_mu[1:]] if eng.a_mu else [Ft(0.0)] * 3), eng.in_a,
                *slot_inputs(eng), eng.shared_nodes, eng.n_shared, shared_threads(eng), Ft(face_share(eng.setup))])
            ] + after + [
            wp.launch(clear, dim=sweep[1], device=d, record_cmd=True, inputs=[
                eng.grid_sv, eng.grid_vf, eng.n_shared, ng, *sweep])]

