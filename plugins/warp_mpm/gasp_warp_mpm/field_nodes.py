"""Round 63 (``docs/rigid.md`` "Round 63: the cost of rigid pairs"): the two-field contact's node kernels over the
nodes where both fields meet, not the whole grid. ``field_shared`` writes the offsets ``grid_dv`` to zero and lists
the inner nodes where both fields hold more than ``MIN_FRACTION`` of the node's mass (an atomic counter; on the CPU
the list is in node order); ``fields.field_contact`` then runs over that list only, ``shared_threads`` threads each a
run of it in the list's order (on the CPU, the order the whole-grid kernel visited them: the same sums, the same
bits). ``field_clear`` clears the fields' channels after the contact, and the list's count.

Before, ``field_contact`` ran one thread a node over the whole grid (96^3 = 884,736 nodes for the cup of
``examples/cup_drop.toml``) at about 17 ns a node on warp_mpm's CPU whatever the node held (its 45 arguments): on the
cup's 47 fragments 68 s of 247 (``benchmarks/rigid_pairs_cost.py --cup 20 --profile``).

Round 64 (``docs/performance.md`` "Round 64: the field passes over the touched box"; :data:`FIELD_BOX`): the passes
that still swept the whole grid every substep (``field_shared``, ``field_clear``, ``field_old`` with AFLIP, the
touch's ``gap_clear`` / ``flow_apply``, ``pair_touch.py``) sweep a box instead: the hull of the nodes P2G touched this
substep and the last (``eng.field_box``, 12 int32: this substep's lowest and highest node per axis, then the last
substep's). ``field_box_reset`` (one thread) moves this substep's box to the last's and empties it; ``field_box`` (a
thread a material point, after P2G) widens it to each point's 27 nodes with atomic min / max (the same box in any
order). No host reads it: a sweep is a fixed launch of :func:`sweep_threads` threads, each a run of
``ceil(box / threads)`` of the box's nodes, x-major as the grid (on the CPU each thread a contiguous run, the threads
in turn: the whole-grid kernel's node order, so ``field_shared``'s list and the contact's sums are the same, the same
bits; on CUDA thread ``t`` takes the box's nodes ``t, t + threads, ...``, neighbours in memory side by side).

Why the hull gives the whole-grid passes' values at every node: P2G writes ``grid_sv``, ``grid_vf``, A's
``grid_mv0`` only at its material points' stencils, all in this substep's box, and each writer of ``grid_dv``,
``grid_v0``'s offsets, ``flow_touch`` and ``flow_push`` writes only at nodes with mass (in this substep's box: the
contact and ``rc_mark`` at the listed nodes, ``flow_layer`` at a node of B's mass behind one, the grid update's
friction, the touch's marks at point stencils). So what is not zero before a substep lies in the last substep's box,
and zeroing the hull leaves zero everywhere the whole-grid pass would have, and writes the rest as it did; G2P reading
nodes beyond this substep's box (a point moved by round 62's push) reads the zeros it read before.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import numpy as np
import warp as wp

from gasp_core.mpm.fields import MIN_FRACTION

from .precision import MODULE_OPTIONS, build_types

#: Round 64: the field passes over the hull of the boxes P2G touched this substep and the last (module notes). False:
#: round 63's passes over the whole grid (the box fixed to the grid; the catch of the tests).
FIELD_BOX = True
#: ``field_contact``'s threads over the list of shared nodes, and the box sweeps' (each a run of ``ceil(n / threads)``
#: of them): few on the CPU, whose threads run in turn (each costs its argument block), enough for a GPU's cores on
#: CUDA.
THREADS_CPU = 1024
THREADS_CUDA = 65536


def shared_threads(eng) -> int:
    """``field_contact``'s launch size (:data:`THREADS_CPU` or :data:`THREADS_CUDA`, at most the nodes)."""
    return int(min(eng.n_grid ** 3, THREADS_CUDA if eng.device.is_cuda else THREADS_CPU))


def sweep_args(eng) -> list:
    """The last three inputs of a box sweep: ``eng.field_box``, the threads (:func:`shared_threads`) and ``along``
    (1 on the CPU: each thread a contiguous run; 0 on CUDA: strided)."""
    return [eng.field_box, shared_threads(eng), int(not eng.device.is_cuda)]


def allocate_box(eng) -> None:
    """``eng.field_box`` (12 int32, module notes): empty (lowest ``n_grid``, highest -1) with :data:`FIELD_BOX`, the
    whole grid (both boxes) without it."""
    ng = eng.n_grid
    whole = [0, 0, 0, ng - 1, ng - 1, ng - 1]
    box = whole * 2 if not FIELD_BOX else [ng] * 3 + [-1] * 3 + [ng] * 3 + [-1] * 3
    eng.field_box = wp.array(np.array(box, np.int32), dtype=wp.int32, device=eng.device)


@functools.cache
def build_sweep(Ft):
    """``(box_units, unit_first, unit_len, box_q)``: a box sweep's units over the hull of ``box``'s two boxes (0 if
    both are empty): with ``along`` (the CPU) its rows along z (``unit_first`` the grid index of row ``q``'s first
    node, x-major as the grid; ``unit_len`` the hull's z extent), else its nodes (``q``-th, x-major, one each); and
    the ``r``-th of thread ``t``'s units (``run = ceil(n / threads)``: ``t run + r`` along, ``t + r threads``
    strided; at least ``n`` where the thread has none left)."""

    @wp.func
    def box_lo(box: wp.array(dtype=wp.int32), d: int):
        return wp.min(box[d], box[6 + d])

    @wp.func
    def box_ext(box: wp.array(dtype=wp.int32), d: int):
        return wp.max(wp.max(box[3 + d], box[9 + d]) - box_lo(box, d) + 1, 0)

    @wp.func
    def box_units(box: wp.array(dtype=wp.int32), along: int):
        n = box_ext(box, 0) * box_ext(box, 1)
        if along == 0:
            n = n * box_ext(box, 2)
        return n

    @wp.func
    def unit_first(box: wp.array(dtype=wp.int32), q: int, n_grid: int, along: int):
        e1 = box_ext(box, 1)
        e2 = box_ext(box, 2)
        row = q
        k = box_lo(box, 2)
        if along == 0:
            row = q / e2
            k = k + q % e2
        return ((box_lo(box, 0) + row / e1) * n_grid + box_lo(box, 1) + row % e1) * n_grid + k

    @wp.func
    def unit_len(box: wp.array(dtype=wp.int32), along: int):
        n = int(1)
        if along != 0:
            n = box_ext(box, 2)
        return n

    @wp.func
    def box_q(t: int, r: int, run: int, threads: int, along: int):
        q = t + r * threads
        if along != 0:
            q = t * run + r
        return q

    return box_units, unit_first, unit_len, box_q


@functools.cache
def build_field_box(Ft):
    """``(box_reset, field_box)``: ``box_reset(box, n_grid)`` (one thread) this substep's box to the last's, and
    empty; ``field_box(x, box, lo, inv_dx, n_grid)`` (a thread a material point) this substep's box widened to the
    point's 27 nodes (``floor(X - 0.5)`` to 2 more, ``X = (x - lo) / dx``; a point out of the grid, which P2G skips,
    none), atomic min / max read first (few atomics on a GPU)."""
    from .stencil import build_stencil   # here: stencil imports fields, which imports this module
    vec3 = build_types(Ft)[0]
    in_grid = build_stencil(Ft)[0]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def box_reset(box: wp.array(dtype=wp.int32), n_grid: int):
        for d in range(6):
            box[6 + d] = box[d]
        for d in range(3):
            box[d] = n_grid
            box[3 + d] = -1

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_box(x: wp.array(dtype=vec3), box: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int):
        X = (x[wp.tid()] - lo) * inv_dx
        if in_grid(X, n_grid):
            for d in range(3):
                b = int(wp.floor(X[d] - Ft(0.5)))
                if b < box[d]:
                    wp.atomic_min(box, d, b)
                if b + 2 > box[3 + d]:
                    wp.atomic_max(box, 3 + d, b + 2)

    return box_reset, field_box


def box_launches(eng, Ft) -> list:
    """The recorded ``box_reset`` and ``field_box`` (first of the field passes, after P2G); none without
    :data:`FIELD_BOX` (the box then the whole grid, :func:`allocate_box`)."""
    if not FIELD_BOX:
        return []
    box_reset, field_box = build_field_box(Ft)
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    return [wp.launch(box_reset, dim=1, device=eng.device, record_cmd=True, inputs=[eng.field_box, eng.n_grid]),
            wp.launch(field_box, dim=eng.n_material, device=eng.device, record_cmd=True, inputs=[
                eng.x, eng.field_box, lo, Ft(eng.inv_dx), eng.n_grid])]


@functools.cache
def build_field_shared(Ft):
    """``field_shared(grid_mv, grid_sv, grid_dv, n_grid, shared, n_shared, grid_mf, rigid_rule, box, threads, along)``:
    at each node of
    the box sweep (module notes) the offsets (``grid_dv``: field A's at ``node``, B's at ``n_grid^3 + node``) to zero,
    and the node appended to ``shared`` (its count ``n_shared[0]``) where it is inner and both fields hold more than
    ``MIN_FRACTION`` of its mass (``grid_mv``'s fourth entry, A's ``grid_sv``'s), as ``fields.field_contact`` asks;
    with ``rigid_rule`` (round 82, ``gasp_core.mpm.rigid_a.rigid_node_rule``) the node's rigid mass in ``grid_mf``
    rewritten as A's mass, signed by the side that takes the friction (``rigid_side_mass``)."""
    vec3, vec4, mat33 = build_types(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.func
    def rigid_side_mass(r: Ft, m: Ft, m_a: Ft, rule: int):
        # round 82 (gasp_core.mpm.rigid_a.rigid_node_rule): r the node's rigid mass (P2G); A's mass m_a where A holds
        # all of it and B none (rule bit 1: the friction to B alone), -m_a where B holds all and A none (bit 2: to A
        # alone), else 0 (both fields take it); taichi_mpm's Fields.rigid_side_mass
        out = Ft(0.0)
        m_b = m - m_a
        tol = Ft(1e-5) * m
        if r > Ft(0.0) and m_a > Ft(0.0) and m_b > Ft(0.0):
            if rule % 2 != 0 and (wp.abs(r - m) <= tol or wp.abs(r - m_a) <= tol):
                out = m_a
            elif (rule / 2) % 2 != 0 and wp.abs(r - m_b) <= tol:
                out = -m_a
        return out

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_shared(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), grid_dv: wp.array(dtype=vec3),
                     n_grid: int, shared: wp.array(dtype=wp.int32), n_shared: wp.array(dtype=wp.int32),
                     grid_mf: wp.array(dtype=Ft), rigid_rule: int, box: wp.array(dtype=wp.int32), threads: int,
                     along: int):
        nn = n_grid * n_grid
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    grid_dv[node] = vec3(Ft(0.0))
                    grid_dv[nn * n_grid + node] = vec3(Ft(0.0))
                    m = grid_mv[node][3]
                    m_a = grid_sv[node][3]
                    m_b = m - m_a
                    if rigid_rule != 0:
                        grid_mf[node] = rigid_side_mass(grid_mf[node], m, m_a, rigid_rule)
                    if m_a > Ft(MIN_FRACTION) * m and m_b > Ft(MIN_FRACTION) * m:
                        i = node / nn
                        j = (node / n_grid) % n_grid
                        k = node % n_grid
                        if i > 0 and j > 0 and k > 0 and i < n_grid - 1 and j < n_grid - 1 and k < n_grid - 1:
                            shared[wp.atomic_add(n_shared, 0, 1)] = node

    return field_shared


@functools.cache
def build_field_clear(Ft):
    """``field_clear(grid_sv, grid_vf, n_shared, n_grid, box, threads, along)``: at each node of the box sweep
    ``grid_sv`` and the fields' ``grid_vf`` channels (both fields' volume, and the friction channels, its third to
    fifth parts where there are) back to zero for the next P2G; thread 0 resets the shared nodes' count. (Written
    only where not zero already, it took twice as long on the cup: 22.7 s against 11.7, round 63.)"""
    vec3, vec4, mat33 = build_types(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_clear(grid_sv: wp.array(dtype=vec4), grid_vf: wp.array(dtype=Ft), n_shared: wp.array(dtype=wp.int32),
                    n_grid: int, box: wp.array(dtype=wp.int32), threads: int, along: int):
        if wp.tid() == 0:
            n_shared[0] = 0
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    grid_sv[node] = vec4(Ft(0.0))
                    for part in range(grid_vf.shape[0] / grid_sv.shape[0]):
                        grid_vf[part * grid_sv.shape[0] + node] = Ft(0.0)

    return field_clear


@functools.cache
def build_field_old(Ft):
    """``field_old(grid_mv0, grid_v0, n_grid, box, threads, along)``: round 59 (docs/contact.md "Round 59: AFLIP's
    old velocity per field", ``gasp_core.mpm.fields.FIELD_OLD_VELOCITY``), with AFLIP, at each node of the box sweep
    the offsets of AFLIP's old velocity: field A's own APIC velocity less the mean's at ``n_grid^3 + node`` of
    ``grid_v0``, B's at ``2 n_grid^3 + node`` (``m_B / m u0``, ``-m_A / m u0``, ``u0 = v0_A - v0_B``; ``grid_mv0``
    the whole grid's APIC momentum and mass, A's ``n_grid^3`` further), where both fields have more than
    ``MIN_FRACTION`` of the node's mass at an inner node, else zero; clears A's part of ``grid_mv0`` (the grid update
    clears the whole grid's). (In ``fields.py`` until round 64.)"""
    vec3, vec4, mat33 = build_types(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_old(grid_mv0: wp.array(dtype=vec4), grid_v0: wp.array(dtype=vec3), n_grid: int,
                  box: wp.array(dtype=wp.int32), threads: int, along: int):
        nn = n_grid * n_grid
        n_nodes = nn * n_grid
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    i = node / nn
                    j = (node / n_grid) % n_grid
                    k = node % n_grid
                    g = grid_mv0[node]
                    pa = grid_mv0[n_nodes + node]
                    m = g[3]
                    m_a = pa[3]
                    m_b = m - m_a
                    dva = vec3(Ft(0.0))
                    dvb = vec3(Ft(0.0))
                    inner = i > 0 and j > 0 and k > 0 and i < n_grid - 1 and j < n_grid - 1 and k < n_grid - 1
                    if inner and m_a > Ft(MIN_FRACTION) * m and m_b > Ft(MIN_FRACTION) * m:
                        u0 = vec3(pa[0], pa[1], pa[2]) / m_a - vec3(g[0] - pa[0], g[1] - pa[1], g[2] - pa[2]) / m_b
                        dva = (m_b / m) * u0
                        dvb = -(m_a / m) * u0
                    grid_v0[n_nodes + node] = dva
                    grid_v0[2 * n_nodes + node] = dvb
                    grid_mv0[n_nodes + node] = vec4(Ft(0.0))

    return field_old
