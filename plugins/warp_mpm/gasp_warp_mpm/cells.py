"""Grady's cells parted at their faces (``gasp_core.run.grady_cells``; ``docs/fracture.md`` "Round 102: Grady's cells
in the engines"), the engines' feature ``fracture_cells``; taichi_mpm's ``cells.py`` is the same steps.

Before each P2G, ``cell_ref`` gives every node its reference cell: the cell of its point of largest weight, by an
atomic max of a key packing the weight above the cell id (one thread a point, the same bits in any order). In P2G
(``transfers.p2g``) a split point whose cell is the node's reference scatters its momentum and mass to ``grid_cs``
as well (field A; field B is the rest of the node), and each field's largest damage to ``grid_cd``. ``cell_contact``
then turns them into each field's velocity offset ``grid_cdv`` (A's at the node, B's ``n_grid^3`` on): the fields
move as one unless each has a broken point (damage 1) there, and then meet in Coulomb contact when they approach (the
normal field B's mass gradient, as the two-field contact takes it) and part freely when they do not. G2P
(``transfers.g2p``) adds each node's offset of the point's field (:func:`build_cell_reads`). A cell's inside starts at
``Jp`` -1 and never damages, and a broken point of a body in cells keeps its tension-free stress (``P_CELLS``,
constitutive.py). One entry each without cells.

Round 103 (:data:`CELL_BOX`; ``docs/performance.md`` "Round 103: Grady's cells over the touched box"): the node passes
(the reference cells' clear before P2G, the contact and the clear after it) sweep the grid update's box
(``grid_box.grid_sweep``: the hull of the nodes P2G touched this substep and the last), launched after the box is
built, not the whole grid; the same bits (``tests/test_cell_box.py``: why the hull is enough).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import numpy as np
import warp as wp

from gasp_core.mpm.fields import MIN_FRACTION, MIN_GRADIENT
from gasp_core.mpm.cells import FACE_MU, KEY_SCALE
from gasp_core.seam import SceneError

from .field_nodes import build_sweep
from .grid_box import grid_sweep
from .precision import MODULE_OPTIONS, build_types
from .stencil import build_stencil

#: Round 103: the node passes (``cell_ref_clear``, ``cell_contact``, ``cell_clear``) sweep the grid update's box, not
#: the whole grid (module notes); False: the whole grid (round 102's, the catch of the tests).
CELL_BOX = True


@functools.cache
def build_cell_reads(Ft):
    """``(cell_of, cell_side, scatter_cells, cell_gather)``, the P2G and G2P parts for scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def node_offset(i: int, j: int, k: int):
        # the stencil node's (i, j, k) as a vector of Ft
        return vec3(Ft(float(i)), Ft(float(j)), Ft(float(k)))

    @wp.func
    def cell_of(c: int):
        # SimSetup.cells' cell (an inside's -2 - cell; -1 none)
        out = c
        if c <= -2:
            out = -2 - c
        return out

    @wp.func
    def cell_side(grid_ref: wp.array(dtype=wp.int32), c: int, node: int):
        # 0 where cell c is the node's reference cell (or c is none), else 1
        ref = grid_ref[node]
        side = int(0)
        if c >= 0 and ref >= 0 and ref % 256 != c:
            side = 1
        return side

    @wp.func
    def scatter_cells(grid_cs: wp.array(dtype=vec4), grid_cd: wp.array(dtype=Ft), grid_ref: wp.array(dtype=wp.int32),
                      c: int, d: Ft, idx0: int, n_grid: int, W: mat33, mom0: vec3, A: mat33, pm: Ft):
        # the point's share to its field at each node: A's momentum and mass, each field's largest damage
        nn = n_grid * n_grid
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    node = idx0 + i * nn + j * n_grid + k
                    side = cell_side(grid_ref, c, node)
                    if side == 0:
                        w = W[i, 0] * W[j, 1] * W[k, 2]
                        mv = mom0 + A * node_offset(i, j, k)
                        wp.atomic_add(grid_cs, node, vec4(w * mv[0], w * mv[1], w * mv[2], w * pm))
                    wp.atomic_max(grid_cd, side * nn * n_grid + node, d)

    @wp.func
    def cell_gather(grid_cdv: wp.array(dtype=vec3), grid_ref: wp.array(dtype=wp.int32), c: int, W: mat33, idx0: int,
                    n_grid: int):
        # sum w dv and sum w dv (i, j, k)^T of the point's field's offsets (G2P's v and B, stencil.build_gather);
        # zero for a point in no cell (c < 0)
        nn = n_grid * n_grid
        dv = vec3(Ft(0.0))
        B = mat33()
        if c < 0:
            return dv, B
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    node = idx0 + i * nn + j * n_grid + k
                    g = (W[i, 0] * W[j, 1] * W[k, 2]) * grid_cdv[cell_side(grid_ref, c, node) * nn * n_grid + node]
                    dv = dv + g
                    B = B + wp.outer(g, node_offset(i, j, k))
        return dv, B

    return cell_of, cell_side, scatter_cells, cell_gather


@functools.cache
def build_cell_clears(Ft):
    """``(cell_ref_clear, cell_clear)``: box sweeps (``field_nodes.build_sweep``) that set ``grid_ref`` to -1 (before
    P2G) and the fields' sums ``grid_cs``, ``grid_cd`` to zero (after the contact)."""
    vec3, vec4, mat33 = build_types(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cell_ref_clear(grid_ref: wp.array(dtype=wp.int32), n_grid: int, box: wp.array(dtype=wp.int32), threads: int,
                       along: int):
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    grid_ref[node] = -1

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cell_clear(grid_cs: wp.array(dtype=vec4), grid_cd: wp.array(dtype=Ft), n_grid: int,
                   box: wp.array(dtype=wp.int32), threads: int, along: int):
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    grid_cs[node] = vec4(Ft(0.0))
                    grid_cd[node] = Ft(0.0)
                    grid_cd[n_grid * n_grid * n_grid + node] = Ft(0.0)

    return cell_ref_clear, cell_clear


@functools.cache
def build_contact_node(Ft):
    """``contact_node(grid_mv, grid_cs, grid_cd, grid_cdv, n_grid, node)``: both fields' velocity offsets at ``node``
    (module notes: one motion unless each field has a broken point there; then Coulomb when they approach along field
    B's mass gradient, free when they part)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def mass_b(grid_mv: wp.array(dtype=vec4), grid_cs: wp.array(dtype=vec4), node: int):
        return grid_mv[node][3] - grid_cs[node][3]

    @wp.func
    def contact_node(grid_mv: wp.array(dtype=vec4), grid_cs: wp.array(dtype=vec4), grid_cd: wp.array(dtype=Ft),
                     grid_cdv: wp.array(dtype=vec3), n_grid: int, node: int):
        nodes = n_grid * n_grid * n_grid
        I = wp.vec3i(node // (n_grid * n_grid), (node // n_grid) % n_grid, node % n_grid)
        g = grid_mv[node]
        m = g[3]
        cs = grid_cs[node]
        m_a = cs[3]
        m_b = m - m_a
        da = vec3(Ft(0.0))
        db = vec3(Ft(0.0))
        inner = I[0] > 0 and I[1] > 0 and I[2] > 0 and I[0] < n_grid - 1 and I[1] < n_grid - 1 and I[2] < n_grid - 1
        broken = grid_cd[node] >= Ft(1.0) and grid_cd[nodes + node] >= Ft(1.0)
        if inner and broken and m_a > Ft(MIN_FRACTION) * m and m_b > Ft(MIN_FRACTION) * m:
            nn = n_grid * n_grid
            gb = vec3(mass_b(grid_mv, grid_cs, node + nn) - mass_b(grid_mv, grid_cs, node - nn),
                      mass_b(grid_mv, grid_cs, node + n_grid) - mass_b(grid_mv, grid_cs, node - n_grid),
                      mass_b(grid_mv, grid_cs, node + 1) - mass_b(grid_mv, grid_cs, node - 1))
            if wp.length(gb) > Ft(MIN_GRADIENT) * m:
                n = wp.normalize(gb)   # field A's outward normal
                v_a = vec3(cs[0], cs[1], cs[2]) / m_a
                v_b = vec3(g[0] - cs[0], g[1] - cs[1], g[2] - cs[2]) / m_b
                vcm = vec3(g[0], g[1], g[2]) / m
                new_a = v_a   # parting: free
                new_b = v_b
                if wp.dot(v_a - v_b, n) > Ft(0.0):   # approaching: Coulomb
                    u = v_a - vcm
                    un = wp.dot(u, n)
                    ut = u - un * n
                    lt = wp.length(ut)
                    scale = wp.max(Ft(0.0), Ft(1.0) - Ft(FACE_MU) * wp.max(un, Ft(0.0)) / wp.max(lt, Ft(1e-30)))
                    new_a = vcm + scale * ut
                    new_b = vcm - (m_a / m_b) * scale * ut
                da = new_a - vcm
                db = new_b - vcm
        grid_cdv[node] = da
        grid_cdv[nodes + node] = db

    return contact_node


@functools.cache
def build_cell_kernels(Ft):
    """``(cell_ref_clear, cell_clear, cell_ref, cell_contact)`` for scalar type ``Ft`` (module notes); the node passes
    sweep a box (``field_nodes.build_sweep``: ``box``, ``threads``, ``along``)."""
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    cell_of = build_cell_reads(Ft)[0]
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)
    contact_node = build_contact_node(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cell_ref(x: wp.array(dtype=vec3), p_mass: wp.array(dtype=Ft), p_cell: wp.array(dtype=wp.int32),
                 grid_ref: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, n_grid: int):
        p = wp.tid()
        c = cell_of(p_cell[p])
        X = (x[p] - lo) * inv_dx
        if c < 0 or p_mass[p] <= Ft(0.0) or not in_grid(X, n_grid):
            return
        b = vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
        W = weights(X - b)
        idx0 = (int(b[0]) * n_grid + int(b[1])) * n_grid + int(b[2])
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    key = int(W[i, 0] * W[j, 1] * W[k, 2] * Ft(KEY_SCALE)) * 256 + c
                    wp.atomic_max(grid_ref, idx0 + (i * n_grid + j) * n_grid + k, key)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def cell_contact(grid_mv: wp.array(dtype=vec4), grid_cs: wp.array(dtype=vec4), grid_cd: wp.array(dtype=Ft),
                     grid_cdv: wp.array(dtype=vec3), n_grid: int, box: wp.array(dtype=wp.int32), threads: int,
                     along: int):
        n = box_units(box, along)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    contact_node(grid_mv, grid_cs, grid_cd, grid_cdv, n_grid, node)

    return (*build_cell_clears(Ft), cell_ref, cell_contact)


def allocate_cells(eng, Ft) -> None:
    """``eng.p_cell`` (per point, ``SimSetup.cells`` in the engine's order), ``grid_ref``, ``grid_cs``, ``grid_cd``
    and ``grid_cdv`` (module notes); one entry each without cells (``eng.cells_on`` False).

    Raises
    ------
    ValueError
        With the two-field contact between bodies (a scene of one body only: ``gasp_core.run.grady_cells``).
    """
    cells = eng.setup.cells
    eng.cells_on = cells is not None
    if eng.cells_on and eng.fields:
        raise SceneError("SimSetup.cells: Grady's cells need a scene of one body (no two-field contact)")
    k, d = eng.k, eng.device
    n = eng.n_grid ** 3 if eng.cells_on else 1
    buf = np.asarray(cells, np.int32)[eng._order] if eng.cells_on else np.full(1, -1, np.int32)
    eng.p_cell = wp.array(buf, dtype=wp.int32, device=d)
    eng.grid_ref = wp.full(n, -1, dtype=wp.int32, device=d)
    eng.grid_cs = wp.zeros(n, dtype=k.vec4, device=d)
    eng.grid_cd = wp.zeros(2 * n if eng.cells_on else 1, dtype=Ft, device=d)
    eng.grid_cdv = wp.zeros(2 * n if eng.cells_on else 1, dtype=k.vec3, device=d)


def follow_order(eng) -> None:
    """``eng.p_cell`` in ``eng._order`` again (after a restored state's order, ``engine.restore_extras``)."""
    if eng.cells_on:
        eng.p_cell.assign(np.asarray(eng.setup.cells, np.int32)[eng._order])


def cell_arrays(eng, which: str) -> list:
    """The cells' inputs of ``transfers.p2g`` (``which`` "p2g") or ``transfers.g2p`` ("g2p")."""
    if which == "p2g":
        return [eng.p_cell, eng.grid_ref, eng.grid_cs, eng.grid_cd]
    return [eng.p_cell, eng.grid_ref, eng.grid_cdv]


def cell_launches(eng, Ft) -> tuple[list, list]:
    """``(before, after)``: the recorded launches before each P2G (the reference cells) and after it (the contact,
    the clear); none without cells."""
    if not eng.cells_on:
        return [], []
    ref_clear, clear, ref, contact = build_cell_kernels(Ft)
    d, ng = eng.device, eng.n_grid
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    sweep = cell_sweep(eng)
    before = [wp.launch(ref_clear, dim=sweep[1], device=d, record_cmd=True, inputs=[eng.grid_ref, ng, *sweep]),
              wp.launch(ref, dim=eng.n_material, device=d, record_cmd=True, inputs=[
                  eng.x, eng.p_mass, eng.p_cell, eng.grid_ref, lo, Ft(eng.inv_dx), ng])]
    after = [wp.launch(contact, dim=sweep[1], device=d, record_cmd=True, inputs=[
                 eng.grid_mv, eng.grid_cs, eng.grid_cd, eng.grid_cdv, ng, *sweep]),
             wp.launch(clear, dim=sweep[1], device=d, record_cmd=True, inputs=[eng.grid_cs, eng.grid_cd, ng, *sweep])]
    return before, after


def cell_sweep(eng) -> list:
    """The node passes' last three inputs (``field_nodes.build_sweep``): with :data:`CELL_BOX` the grid update's box
    (``grid_box.grid_sweep``: the hull of the nodes P2G touched this substep and the last), else the whole grid."""
    sweep = grid_sweep(eng)
    if not CELL_BOX:
        ng = eng.n_grid
        sweep[0] = wp.array(np.array([0, 0, 0, ng - 1, ng - 1, ng - 1] * 2, np.int32), dtype=wp.int32,
                            device=eng.device)
    return sweep
