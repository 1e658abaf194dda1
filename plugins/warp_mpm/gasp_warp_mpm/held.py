"""The held boxes (docs/fracture.md, "The held region"): a ``fixed_region`` and a box impulse of ``mode = "set"``
while it acts. Their ghost nodes after the grid update (:func:`build_mirror`), the image gradient, the stress and the
damage of the points near their faces in P2G (:func:`build_image_flip`, :func:`build_held_return`); as Warp functions and kernels per scalar type (:mod:`gasp_warp_mpm.precision`).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.grid_tables import IM_A, IM_B, IMPULSE_ROW
from gasp_core.mpm.materials import BRITTLE, P_LAM, P_MU
from gasp_core.mpm import grid_tables
from gasp_core.mpm.points import CUT_REACH, HELD_STRAIN_CELLS, HELD_STRAINED, MIRROR_CELLS, cuts_held_faces

from .constitutive import build_return_mapping
from .forces import build_constrain, build_extras_struct
from .field_nodes import build_sweep
from .grid_box import grid_sweep
from .held_rule import HeldRule, build_held_tau, build_set_box_row, hold_set_faces_launches   # HeldRule: the engine's switch
from .mid_stress import build_mid_stress
from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_mirror(Ft):
    """``mirror_held``: the kernel of the held boxes' ghost nodes (docs/fracture.md, "The held region"; taichi_mpm's
    ``GridUpdate.mirror_held``): each box impulse of ``mode = "set"`` while it acts (held at its velocity), then each
    ``fixed_region`` (held at 0). A node inside a box within ``MIRROR_CELLS`` cells of its nearest face takes
    ``2 v_set - v(X')``, ``X'`` its mirror image across that face (``v`` linear along the face's normal; where one of
    the two nodes is the node itself, solved for it); a set box leaves ``v_set`` where a mirror node has no mass. A
    fixed region's node that ``mark_cut`` marked in ``grid_cut`` (its first ``n_grid^3``), where the face's last node
    on its line along the normal is not marked in the second (no intact free point reads it: the material beside the
    face broken through, so the face is free of traction), takes the velocity of the first node past the face along
    its normal, less its normal part into the box (a free-slip face the material cannot enter). Round 65: the kernel
    sweeps the grid update's box (``grid_box.py``'s module notes: why it reads the whole grid's values there), its
    last three inputs ``grid_box.grid_sweep``'s.

    It is long because its ``wp.func`` (a node's mirror image, solved where the image is the node itself, and the
    broken face's free slip) and the kernel over the boxes must be built together, from one scalar type."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    set_box_row = build_set_box_row(Ft)
    constrain = build_constrain(Ft)[0]
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    by_mass = int(grid_tables.MIRROR_BY_MASS)
    fixed_by_mass = int(grid_tables.FIXED_BY_MASS)   # a fixed region's image nodes too (round 40)

    @wp.func
    def image_share(v_set: vec3, grid_v: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft), j: int, node: int,
                    empty: int):
        v = grid_v[j]   # an image node by its mass over the ghost's (taichi_mpm's Forces.image_share)
        if (by_mass != 0 and empty != 0) or (fixed_by_mass != 0 and empty == 0):
            mi = grid_m[node]
            if mi > Ft(0.0):
                v = v_set + wp.min(Ft(1.0), grid_m[j] / mi) * (v - v_set)
        return v

    @wp.func
    def mirror_node(node: int, X: vec3, blo: vec3, bhi: vec3, v_set: vec3, grid_v: wp.array(dtype=vec3),
                    grid_m: wp.array(dtype=Ft), empty: int, lo: vec3, dx: Ft, n_grid: int, cut: int,
                    grid_cut: wp.array(dtype=wp.int32)):
        s = Ft(1e30)
        ax = int(0)
        side = Ft(1.0)
        for d in range(3):
            if X[d] - blo[d] < s:
                s = X[d] - blo[d]
                ax = d
                side = Ft(-1.0)
            if bhi[d] - X[d] < s:
                s = bhi[d] - X[d]
                ax = d
                side = Ft(1.0)
        v = v_set
        if s < Ft(MIRROR_CELLS) * dx:
            stride = int(1)
            if ax == 0:
                stride = n_grid * n_grid
            elif ax == 1:
                stride = n_grid
            me = (node / stride) % n_grid
            q = (X[ax] + Ft(2.0) * side * s - lo[ax]) / dx
            a = wp.min(wp.max(int(wp.floor(q)), 0), n_grid - 2)
            t = q - Ft(a)
            na = node + (a - me) * stride
            nb = na + stride
            va = image_share(v_set, grid_v, grid_m, na, node, empty)   # by its share of this node's material
            vb = image_share(v_set, grid_v, grid_m, nb, node, empty)
            if a == me:       # the lower node is this one (an upper face under dx/2 away)
                v = (Ft(2.0) * v_set - t * vb) / (Ft(2.0) - t)
            elif a + 1 == me:   # the upper node is this one (a lower face)
                v = (Ft(2.0) * v_set - (Ft(1.0) - t) * va) / (Ft(1.0) + t)
            else:
                v = Ft(2.0) * v_set - (Ft(1.0) - t) * va - t * vb
            if empty != 0:
                if grid_m[na] <= Ft(0.0) or grid_m[nb] <= Ft(0.0):
                    v = v_set
            if cut != 0:
                side_i = int(1)
                if side < Ft(0.0):
                    side_i = -1
                out = wp.min(wp.max(me + side_i * (int(wp.floor(s / dx + Ft(1e-6))) + 1), 0), n_grid - 1)
                last = wp.min(wp.max(out - side_i, 0), n_grid - 1)   # the face's last node on this line
                if grid_cut[n_grid * n_grid * n_grid + node + (last - me) * stride] == 0:
                    v = grid_v[node + (out - me) * stride]
                    if (v[ax] - v_set[ax]) * side < Ft(0.0):
                        v[ax] = v_set[ax]
        return v

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def mirror_held(grid_v: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft), lo: vec3, dx: Ft, n_grid: int,
                    fixed_lo: wp.array(dtype=vec3), fixed_hi: wp.array(dtype=vec3), has_extras: int, ex: Extras,
                    grid_cut: wp.array(dtype=wp.int32), box: wp.array(dtype=wp.int32), threads: int, along: int):
        n = box_units(box, along)   # round 65: the grid update's box (grid_box.py), not the whole grid
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    i = node / (n_grid * n_grid)
                    j = (node / n_grid) % n_grid
                    k = node % n_grid
                    X = lo + dx * vec3(Ft(i), Ft(j), Ft(k))
                    if has_extras != 0:
                        for qi in range(ex.n_imp):
                            c, b, dv, on = set_box_row(ex, qi)
                            if (on != 0 and X[0] >= c[0] and X[1] >= c[1] and X[2] >= c[2] and X[0] <= b[0]
                                    and X[1] <= b[1] and X[2] <= b[2]):
                                v_img = mirror_node(node, X, c, b, dv, grid_v, grid_m, 1, lo, dx, n_grid, 0, grid_cut)
                                grid_v[node] = constrain(ex, qi, grid_v[node], v_img)
                    cut = int(0)
                    if grid_cut.shape[0] > 2:
                        cut = grid_cut[node]
                    for rg in range(fixed_lo.shape[0]):
                        flo = fixed_lo[rg]
                        fhi = fixed_hi[rg]
                        if (X[0] >= flo[0] and X[0] <= fhi[0] and X[1] >= flo[1] and X[1] <= fhi[1]
                                and X[2] >= flo[2] and X[2] <= fhi[2]):
                            grid_v[node] = mirror_node(node, X, flo, fhi, vec3(Ft(0.0)), grid_v, grid_m, 0, lo, dx,
                                                       n_grid, cut, grid_cut)

    return mirror_held


@functools.cache
def build_mark_cut(Ft):
    """``clear_cut`` and ``mark_cut``: the fixed regions' broken faces (docs/fracture.md, "The held region";
    taichi_mpm's ``GridUpdate.mark_cut``; :func:`gasp_core.mpm.points.cuts_held_faces`). ``grid_cut`` (int32,
    ``2 n_grid^3``) cleared, then the 27 nodes of the stencil of a strained held point of a brittle body broken through
    (``Jp >= 1``: its own stress, its mirror image's, passed the full softening's) marked in its first ``n_grid^3``,
    of a free brittle point not broken through within ``CUT_REACH`` cells of a region in the second. Round 65:
    ``clear_cut(grid_cut, n_grid, box, threads, along)`` clears both halves over the grid update's box, which holds
    the last substep's marks (``grid_box.py``)."""
    vec3, vec4, mat33 = build_types(Ft)

    box_units, unit_first, unit_len, box_q = build_sweep(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def clear_cut(grid_cut: wp.array(dtype=wp.int32), n_grid: int, box: wp.array(dtype=wp.int32), threads: int,
                  along: int):
        n = box_units(box, along)   # round 65: both halves over the grid update's box (grid_box.py)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    grid_cut[node] = 0
                    grid_cut[n_grid * n_grid * n_grid + node] = 0

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def mark_cut(x: wp.array(dtype=vec3), fixed: wp.array(dtype=wp.int32), Jp: wp.array(dtype=Ft),
                 body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32), grid_cut: wp.array(dtype=wp.int32),
                 lo: vec3, inv_dx: Ft, dx: Ft, n_grid: int, fixed_lo: wp.array(dtype=vec3),
                 fixed_hi: wp.array(dtype=vec3)):
        p = wp.tid()
        if mat_kind[body[p]] != BRITTLE:
            return
        X = x[p]
        c = int(-1)
        if fixed[p] >= HELD_STRAINED and Jp[p] >= Ft(1.0):
            c = 0
        elif fixed[p] == 0 and Jp[p] < Ft(1.0):
            r = Ft(CUT_REACH) * dx
            for b in range(fixed_lo.shape[0]):
                flo = fixed_lo[b]
                fhi = fixed_hi[b]
                if (X[0] >= flo[0] - r and X[1] >= flo[1] - r and X[2] >= flo[2] - r and X[0] <= fhi[0] + r
                        and X[1] <= fhi[1] + r and X[2] <= fhi[2] + r):
                    c = 1
        if c < 0:
            return
        G = (X - lo) * inv_dx
        b0 = int(wp.floor(G[0] - Ft(0.5)))
        b1 = int(wp.floor(G[1] - Ft(0.5)))
        b2 = int(wp.floor(G[2] - Ft(0.5)))
        if wp.min(wp.min(b0, b1), b2) < 0 or wp.max(wp.max(b0, b1), b2) > n_grid - 3:
            return
        for q in range(27):
            grid_cut[c * n_grid * n_grid * n_grid + ((b0 + q / 9) * n_grid + b1 + (q / 3) % 3) * n_grid + b2
                     + q % 3] = 1

    return clear_cut, mark_cut


@functools.cache
def build_image_flip(Ft):
    """``(held_axis, image_flip, set_box_at)`` (docs/fracture.md, "The held region"). ``held_axis(code, X, dx, ex)``:
    the normal axis of the face that a point near it takes its image gradient across: a held point's (``code =
    HELD_STRAINED + a``, :func:`gasp_core.mpm.points.held_codes`), or a point's within ``HELD_STRAIN_CELLS`` cells
    inside the nearest face of a box impulse of ``mode = "set"`` acting now; else -1.
    ``image_flip(a)``: the diagonal matrix ``D`` that negates every column but ``a``. P2G advances such a point's ``F``
    by ``C D``, the velocity gradient at its mirror image across the face (the ghost field is ``2 v_set - v(X')``, so
    ``C = -grad v(X') R``), and scatters its stress as ``tau D``, the force that update pairs with.
    ``set_box_at(X, ex)``: the index of the box impulse of ``mode = "set"`` acting now that holds ``X``, else -1."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)

    set_box_row = build_set_box_row(Ft)

    @wp.func
    def set_box_at(X: vec3, ex: Extras):
        hit = int(-1)
        for q in range(ex.n_imp):
            c, b, dv, on = set_box_row(ex, q)
            if (on != 0 and X[0] >= c[0] and X[1] >= c[1] and X[2] >= c[2] and X[0] <= b[0] and X[1] <= b[1]
                    and X[2] <= b[2]):
                hit = q
        return hit

    @wp.func
    def held_axis(code: int, X: vec3, dx: Ft, ex: Extras):
        a = int(-1)
        if code >= HELD_STRAINED:
            a = code - HELD_STRAINED
        if code == 0 and ex.n_imp > 0:
            q = set_box_at(X, ex)
            if q >= 0:
                r = q * IMPULSE_ROW
                near = Ft(HELD_STRAIN_CELLS) * dx
                for d in range(3):
                    s = wp.min(X[d] - ex.imps[r + IM_A + d], ex.imps[r + IM_B + d] - X[d])
                    if s < near:
                        near = s
                        a = d
        return a

    @wp.func
    def image_flip(a: int):
        flip = vec3(Ft(-1.0))
        flip[a] = Ft(1.0)
        return wp.diag(flip)

    return held_axis, image_flip, set_box_at


@functools.cache
def build_held_return(Ft):
    """``held_return(C, F, dt, p, code, X, dx, ex, body, mat_kind, mat_par, Jp, rule, fx)``: P2G's ``F`` update and
    return mapping (``(F, tau)``, :func:`gasp_warp_mpm.constitutive.build_return_mapping`) with the held boxes' rule
    (:func:`build_image_flip`): near a held box's face ``F`` advances by ``C D``, ``tau D`` is scattered, and a
    brittle point keeps its damage (its stress is its mirror image's: the material a box holds does not break);
    elsewhere ``(I + dt C) F``. With ``rule`` 1 (the brittle held rule, :mod:`gasp_warp_mpm.held_rule`) a brittle
    point near a set box's face scatters the stress of its held damage (not softened on the way; a fixed region's
    held points keep the stress of their strain, :mod:`gasp_warp_mpm.held_rule`). With ``rule``'s bit 1 a free brittle
    point's softening range is scaled by its crack band weight at its stencil offset ``fx``, with bit 2 too its band
    is the cell's projection on its crack's normal (``constitutive``'s ``band_sf``: ``band`` 1 and 3)."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    held_axis, image_flip, set_box_at = build_image_flip(Ft)
    along_matrix = build_constrain(Ft)[1]
    return_mapping = build_return_mapping(Ft)
    held_tau = build_held_tau(Ft)
    mid_tau = build_mid_stress(Ft)

    @wp.func
    def held_return(Cp: mat33, Fp: mat33, dt: Ft, p: int, code: int, X: vec3, dx: Ft, ex: Extras,
                    body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32),
                    mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft), rule: int, fx: vec3):
        a = held_axis(code, X, dx, ex)
        band = 0   # the crack band weight (rule's bits 1, 2) for a free point only: a held one's stress is its image's
        if rule % 8 >= 2 and a < 0 and code == 0:
            band = (rule % 8) // 2
        d_held = Jp[p]
        brittle = mat_kind[body[p]] == BRITTLE
        Cf = Cp
        q = int(-1)   # a set box's point: its box (constrain = "along": the mirror's rows along its pull alone)
        if a >= 0:
            if code == 0:
                q = set_box_at(X, ex)
            Cf = along_matrix(ex, q, Cp, Cp * image_flip(a))
        F_new, tau = return_mapping((wp.identity(3, dtype=Ft) + dt * Cf) * Fp, p, body, mat_kind, mat_par, Jp,
                                    dt, fx, band)
        if a >= 0 and brittle and Jp[p] < Ft(1.0):   # broken through: stays so
            Jp[p] = d_held
            if rule % 2 != 0 and code == 0:   # a set box's: not softened on the way, its stress at its held damage
                tau = held_tau(F_new, mat_par[body[p], P_MU], mat_par[body[p], P_LAM], d_held)
        if a >= 0:
            tau = along_matrix(ex, q, tau, tau * image_flip(a))
        elif rule >= 8:   # the midpoint stress (mid_stress.py, MID_BIT)
            tau = mid_tau(Cp, F_new, tau, dt, p, body, mat_kind, mat_par, Jp, fx)
        return F_new, tau

    return held_return


def count_set_boxes(setup) -> int:
    """Box impulses of ``mode = "set"`` in ``setup`` (their nodes are held: :func:`build_mirror`)."""
    return sum(1 for i in (getattr(setup, "impulses", None) or []) if i.shape == "box" and i.mode == "set")


def held_boxes(setup) -> bool:
    """Whether ``setup`` holds a box (a ``fixed_region`` or a set box impulse): its grid keeps the node mass."""
    return any(b.kind == "fixed_region" for b in setup.boundaries) or count_set_boxes(setup) > 0


def mirror_launches(eng, Ft, has_extras: int, ex) -> list:
    """The recorded launches after the grid update, where the setup has a ``fixed_region`` or a set box impulse (else
    none): the broken faces' marks (:func:`build_mark_cut`), the set boxes' face nodes under the brittle held rule
    (:func:`gasp_warp_mpm.held_rule.hold_set_faces_launches`), then :func:`build_mirror`'s kernel."""
    if not held_boxes(eng.setup):
        return []
    k = eng.k
    lo_v = k.vec3(*[float(c) for c in eng.setup.domain_lo])
    cut = cuts_held_faces(eng.mat_kind.numpy(), eng.fixed_lo.shape[0])   # the regions' broken faces
    eng.grid_cut = wp.zeros(2 * eng.n_grid ** 3 if cut else 2, dtype=wp.int32, device=eng.device)
    clear_cut, mark_cut = build_mark_cut(Ft)
    sweep = grid_sweep(eng)   # round 65: the held passes over the grid update's box (grid_box.py)
    marks = [wp.launch(clear_cut, dim=sweep[1], device=eng.device, record_cmd=True, inputs=[
                 eng.grid_cut, eng.n_grid, *sweep]),
             wp.launch(mark_cut, dim=eng.n_material, device=eng.device, record_cmd=True, inputs=[
                 eng.x, eng.fixed, eng.Jp, eng.body, eng.mat_kind, eng.grid_cut, lo_v, Ft(eng.inv_dx), Ft(eng.dx),
                 eng.n_grid, eng.fixed_lo, eng.fixed_hi])] if cut else []
    marks += hold_set_faces_launches(eng, Ft, ex)   # a brittle body's set box: its faces' free nodes (held_rule.py)
    return marks + [wp.launch(build_mirror(Ft), dim=sweep[1], device=eng.device, record_cmd=True, inputs=[
        eng.grid_v, eng.grid_m, lo_v, Ft(eng.dx), eng.n_grid, eng.fixed_lo, eng.fixed_hi, has_extras, ex,
        eng.grid_cut, *sweep])]
