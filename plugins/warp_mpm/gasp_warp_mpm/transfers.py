"""Transfers between points and grid (docs/mpm.md steps 2, 4 and 5): the stencil, P2G, G2P and the passive
points' G2P, as Warp kernels per scalar type (:mod:`gasp_warp_mpm.precision`).

Grid layout: a flat array of ``n_grid**3`` nodes, node ``(i, j, k)`` at flat index
``(i * n_grid + j) * n_grid + k``. ``grid_mv`` holds ``(momentum, mass)`` per node as a 4-vector
(one accumulation per node and point in P2G); ``grid_v`` holds the updated node velocity
read by G2P.

Sources: Hu et al. 2018 (MLS-MPM, APIC, quadratic B-splines), taichi's mpm128 (``F`` advanced in P2G).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm import grid_tables
from gasp_core.mpm.materials import BRITTLE, P_ETA

from .balance import build_mark
from .cells import build_cell_reads
from .contact import build_collider_contact, build_passive_hold
from .fields import build_aflip_gather, build_field_reads
from .forces import build_extras_struct
from .held_rule import build_held_g2p
from .precision import MODULE_OPTIONS, build_types
from .spanned import build_spanned_inverse
from .stencil import build_gather, build_scatter_vec, build_stencil
from .held import build_held_return
from .trapezoid import trapezoid_return


@functools.cache
def build_scatter(Ft):
    """``(scatter, scatter_wind, scatter_scalar)``: a point's momentum and mass, its windward area, and a scalar
    (the viscous volume), added to its 27 nodes (P2G), scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def scatter(grid_mv: wp.array(dtype=vec4), idx0: int, n_grid: int, W: mat33, mom0: vec3, A: mat33, pm: Ft):
        # grid_v += w (p_mass v + affine dpos), grid_m += w p_mass over the 27 nodes from flat index idx0;
        # affine dpos = A ((i, j, k) - fx) is added a column of A per node step
        a0 = vec3(A[0, 0], A[1, 0], A[2, 0])
        a1 = vec3(A[0, 1], A[1, 1], A[2, 1])
        a2 = vec3(A[0, 2], A[1, 2], A[2, 2])
        nn = n_grid * n_grid
        mi = mom0
        for i in range(3):
            mj = mi
            for j in range(3):
                wij = W[i, 0] * W[j, 1]
                mk = mj
                row = idx0 + i * nn + j * n_grid
                for k in range(3):
                    w = wij * W[k, 2]
                    wm = w * mk
                    grid_mv[row + k] += vec4(wm[0], wm[1], wm[2], w * pm)
                    mk = mk + a2
                mj = mj + a1
            mi = mi + a0

    @wp.func
    def scatter_wind(grid_g: wp.array(dtype=vec3), idx0: int, n_grid: int, W: mat33, fx: vec3, sv: Ft):
        # grid_g += p_vol grad N_ip (m^2; the gradient of the volume fraction times dx^3), sv = p_vol inv_dx
        # d N / d x_node per axis (cells): rows of node offsets 0, 1, 2
        dW = wp.matrix_from_rows(vec3(Ft(1.5)) - fx, Ft(2.0) * (fx - vec3(Ft(1.0))), vec3(Ft(0.5)) - fx)
        nn = n_grid * n_grid
        for i in range(3):
            for j in range(3):
                row = idx0 + i * nn + j * n_grid
                for k in range(3):
                    grid_g[row + k] += sv * vec3(dW[i, 0] * W[j, 1] * W[k, 2], W[i, 0] * dW[j, 1] * W[k, 2],
                                                 W[i, 0] * W[j, 1] * dW[k, 2])

    @wp.func
    def scatter_scalar(grid_s: wp.array(dtype=Ft), idx0: int, n_grid: int, W: mat33, value: Ft):
        # grid_s += w value over the 27 nodes from flat index idx0
        nn = n_grid * n_grid
        for i in range(3):
            for j in range(3):
                row = idx0 + i * nn + j * n_grid
                for k in range(3):
                    grid_s[row + k] += W[i, 0] * W[j, 1] * W[k, 2] * value

    return scatter, scatter_wind, scatter_scalar


@functools.cache
def build_p2g(Ft):
    """The P2G kernel ``p2g`` of scalar type ``Ft``: return mapping, stress, scatter. It is long because P2G is one
    pass per point: the stress, the contacts' and the two fields' scatters.

    F by C, return mapping, stress (docs/mpm.md), the scatter (wind: grid_g; flip: the APIC momentum alone to
    grid_mv0, gasp_core.mpm.transfer); particle contact (planes: grounds, walls; colc: colliders): the normal impulses
    join the momentum, their friction budget to grid_fb (walls or colliders: its normal to grid_fn, supports'
    velocity to grid_fv; gasp_warp_mpm.contact); the contact per body: flowing bodies' (flows[b]) mass to grid_mf;
    two-field contact (gasp_warp_mpm.fields): field A's (in_a[b]) momentum and mass to grid_sv, each field's volume
    to grid_vf (A's at the node, B's n_grid^3 further); B's per-node friction (body_mu,
    gasp_core.mpm.fields.node_friction): B's w m mu 2 n_grid^3 further; A's several angles (a_node_friction): A's w
    m tan(phi) 3 n_grid^3 further, B's unnamed w m 4 further; Grady's cells (p_cell: cells.py) their field's
    momentum and mass to grid_cs, each field's damage to grid_cd."""
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    scatter, scatter_wind, scatter_scalar = build_scatter(Ft)
    point_contact = build_collider_contact(Ft)[1]
    mark_nodes = build_mark(Ft)
    Extras = build_extras_struct(Ft)
    scatter_vec, trap_return = build_scatter_vec(Ft), trapezoid_return(Ft, build_held_return(Ft))
    cell_of, _side, scatter_cells, _gather = build_cell_reads(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def p2g(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), F: wp.array(dtype=mat33),
        C: wp.array(dtype=mat33), Jp: wp.array(dtype=Ft), p_mass: wp.array(dtype=Ft),
        p_vol: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32),
        mat_kind: wp.array(dtype=wp.int32), mat_par: wp.array2d(dtype=Ft),
        grid_mv: wp.array(dtype=vec4), n_out: wp.array(dtype=wp.int32),
        lo: vec3, inv_dx: Ft, dx: Ft, dt: Ft, n_grid: int, grid_g: wp.array(dtype=vec3), has_wind: int,
        grid_mv0: wp.array(dtype=vec4), flip: int,
        p_contact: wp.array(dtype=vec3), planes: wp.array(dtype=vec3), plane_n: wp.array(dtype=vec3),
        grid_fb: wp.array(dtype=Ft),
        grid_eta: wp.array(dtype=Ft), shift: wp.array2d(dtype=wp.float64), grid_fbody: wp.array(dtype=wp.int32),
        ex: Extras, colc: int, n_sup: int, grid_fn: wp.array(dtype=vec3), grid_fv: wp.array(dtype=vec3),
        grid_mf: wp.array(dtype=Ft), flows: wp.array(dtype=wp.int32), grid_sv: wp.array(dtype=vec4),
        grid_vf: wp.array(dtype=Ft), in_a: wp.array(dtype=wp.int32), fixed: wp.array(dtype=wp.int32), rule: int,
        p_pic: wp.array(dtype=wp.int32), body_mu: wp.array(dtype=Ft), C_prev: wp.array(dtype=mat33),
        C_guess: wp.array(dtype=mat33), p_cell: wp.array(dtype=wp.int32), grid_ref: wp.array(dtype=wp.int32),
        grid_cs: wp.array(dtype=vec4), grid_cd: wp.array(dtype=Ft),
    ):
        # the steps in build_p2g's notes
        p = wp.tid()
        X = (x[p] - lo) * inv_dx
        if not in_grid(X, n_grid):
            wp.atomic_add(n_out, 0, 1)
            return
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        fx = X - vec3(b0, b1, b2)
        W = weights(fx)
        F_new, tau = trap_return(C[p], F[p], dt, p, fixed[p], x[p], dx, ex, body, mat_kind, mat_par, Jp, rule, fx,
                                 C_prev, C_guess)   # (I + dt C) F, the return mapping, the stress (trapezoid.py)
        F[p] = F_new
        eta = mat_par[body[p], P_ETA]
        pm = p_mass[p]
        # the affine momentum's mass: none for a point of A touching B (p_pic: one 0 without the marks; PIC_AT_B)
        pc = pm * Ft(1 - p_pic[wp.min(p, p_pic.shape[0] - 1)])
        affine = (-dt * p_vol[p] * Ft(4.0) * inv_dx * inv_dx) * tau + pc * C[p]
        A = dx * affine  # affine dpos = A ((i, j, k) - fx)
        mom0 = pm * v[p] - A * fx
        idx0 = (int(b0) * n_grid + int(b1)) * n_grid + int(b2)
        if planes.shape[0] > 0 or colc != 0:
            imp, bud, fn, fv, sup = point_contact(planes, plane_n, p_contact[p], x[p], v[p], dt, colc, ex, body[p], pm)
            mom0 = mom0 + imp
            if sup >= 0 and shift.shape[0] > 0:   # the nodes' support, for the contact's balance (balance.py)
                mark_nodes(grid_fbody, idx0, n_grid, W, imp, body[p] * n_sup + sup)
            if bud > Ft(0.0):
                scatter_scalar(grid_fb, idx0, n_grid, W, bud)   # the friction budget
                if grid_fn.shape[0] > 1:   # its normal and the supports' velocity, budget-weighted (walls, colliders)
                    scatter_vec(grid_fn, idx0, n_grid, W, fn)
                    scatter_vec(grid_fv, idx0, n_grid, W, fv)
        scatter(grid_mv, idx0, n_grid, W, mom0, A, pm)
        if grid_cs.shape[0] > 1:   # Grady's cells: the point's field at each node (cells.py)
            scatter_cells(grid_cs, grid_cd, grid_ref, cell_of(p_cell[p]), wp.max(Jp[p], Ft(0.0)), idx0, n_grid, W,
                          mom0, A, pm)
        if grid_mf.shape[0] > 1:
            if flows[body[p]] != 0:
                scatter_scalar(grid_mf, idx0, n_grid, W, pm)
        if grid_sv.shape[0] > 1:   # field A's momentum and mass; the volume into its field's (B's n_grid^3 on)
            if in_a[body[p]] != 0:
                scatter(grid_sv, idx0, n_grid, W, mom0, A, pm)
            scatter_scalar(grid_vf, idx0 + (1 - in_a[body[p]]) * n_grid * n_grid * n_grid, n_grid, W, p_vol[p])
            if body_mu.shape[0] > 1:   # its field's friction channel (B's third part, A's fourth; -1: none)
                mu_p = body_mu[body[p]]
                if mu_p >= Ft(0.0):
                    scatter_scalar(grid_vf, idx0 + (2 + in_a[body[p]]) * n_grid * n_grid * n_grid, n_grid, W,
                                   pm * mu_p)
                elif mu_p < Ft(-1.5):   # B's unnamed body beside named ones (UNNAMED): its mass, the fifth part
                    scatter_scalar(grid_vf, idx0 + 4 * n_grid * n_grid * n_grid, n_grid, W, pm)
        if flip != 0:
            A0 = (dx * pc) * C[p]
            scatter(grid_mv0, idx0, n_grid, W, pm * v[p] - A0 * fx, A0, pm)
            if grid_mv0.shape[0] > n_grid * n_grid * n_grid and in_a[body[p]] != 0:   # round 59: field A's own too
                scatter(grid_mv0, idx0 + n_grid * n_grid * n_grid, n_grid, W, pm * v[p] - A0 * fx, A0, pm)
        if has_wind != 0:
            scatter_wind(grid_g, idx0, n_grid, W, fx, p_vol[p] * inv_dx)
        if eta > Ft(0.0):  # Kelvin-Voigt, implicit on the grid: the point's J V eta (gasp_warp_mpm.viscosity)
            scatter_scalar(grid_eta, idx0, n_grid, W, eta * wp.determinant(F_new) * p_vol[p])

    return p2g


@functools.cache
def build_g2p(Ft):
    """``g2p``: the G2P kernel of scalar type ``Ft`` for material points (with the position update)."""
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    field_offset_base, field_node_v = build_field_reads(Ft)
    aflip_gather = build_aflip_gather(Ft)
    Extras, gather, held_g2p = build_extras_struct(Ft), build_gather(Ft), build_held_g2p(Ft)
    cell_of, _side, _scatter, cell_gather = build_cell_reads(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def g2p(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
        fixed: wp.array(dtype=wp.int32), grid_v: wp.array(dtype=vec3),
        lo: vec3, inv_dx: Ft, dt: Ft, n_grid: int, grid_v0: wp.array(dtype=vec3), alpha: Ft,
        grid_dv: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
        ex: Extras, mat_kind: wp.array(dtype=wp.int32), fixed_lo: wp.array(dtype=vec3), fixed_hi: wp.array(dtype=vec3),
        dx: Ft, rule: int, grid_m: wp.array(dtype=Ft), p_cell: wp.array(dtype=wp.int32),
        grid_ref: wp.array(dtype=wp.int32), grid_cdv: wp.array(dtype=vec3),
    ):
        # with the two-field contact (gasp_warp_mpm.fields) each node's velocity plus the point's field's offset; with
        # rule a brittle point near a held box's face takes its mirror image's gradient
        p = wp.tid()
        if fixed[p] == 1:   # held; near its region's face (2) its C, so its F, follows the grid (docs/fracture.md)
            v[p] = vec3(Ft(0.0))
            C[p] = mat33()
            return
        xp = x[p]
        X = (xp - lo) * inv_dx
        if not in_grid(X, n_grid):
            return  # counted in P2G; the frame raises EngineDivergence
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        fx = X - vec3(b0, b1, b2)
        W = weights(fx)
        nn = n_grid * n_grid
        idx0 = (int(b0) * n_grid + int(b1)) * n_grid + int(b2)
        off = field_offset_base(grid_dv, in_a, body[p], n_grid * nn)   # -1 without two fields (fields.py)
        new_v, B = gather(grid_v, grid_dv, off, W, idx0, n_grid)   # sum w g, sum w g (i, j, k)^T
        if grid_cdv.shape[0] > 1:   # Grady's cells: each node's offset of the point's field (cells.py)
            dv, dB = cell_gather(grid_cdv, grid_ref, cell_of(p_cell[p]), W, idx0, n_grid)
            new_v = new_v + dv
            B = B + dB
        # C = 4 inv_dx^2 sum w g ((i, j, k) - fx)^T dx = 4 inv_dx (B - new_v fx^T)
        Cn = (Ft(4.0) * inv_dx) * (B - wp.outer(new_v, fx))
        if rule % 2 != 0 and mat_kind[body[p]] == BRITTLE:   # the brittle held rule (held_rule.py)
            Cn = held_g2p(Cn, fixed[p], xp, ex, fixed_lo, fixed_hi, grid_v, grid_dv, grid_m, off, lo, inv_dx, dx,
                          n_grid)
        C[p] = Cn
        if fixed[p] != 0:
            v[p] = vec3(Ft(0.0))
            return
        if alpha > Ft(0.0):  # AFLIP: v_PIC(new) + alpha (v_p - v_PIC(old)) (gasp_core.mpm.transfer)
            v[p] = new_v + alpha * (v[p] - aflip_gather(grid_v0, W, idx0, nn, n_grid, off))   # its field's (fields.py)
        else:
            v[p] = new_v
        x[p] = xp + dt * new_v

    return g2p


#: With ``grid_tables.PASSIVE_SPANNED`` off (round 38's spanned gather, the rule, overrides these): the passive gather
#: by the B-spline weight alone, renormalised over the nodes with mass (False), or weighted by the nodes' mass (True:
#: measured in round 37 and not adopted, docs/fracture.md "Round 37"), its mean read at the
#: weights' centroid or, with PASSIVE_AT_POINT, the weighted fit read at the point. Read when the kernel is built:
#: a change needs :func:`build_g2p_passive`'s and ``kernels.build_kernels``' caches cleared.
PASSIVE_BY_MASS = False
PASSIVE_AT_POINT = True


@functools.cache
def build_g2p_passive(Ft):
    """``g2p_passive``: the G2P kernel of scalar type ``Ft`` for passive points, each reading its body's velocity field
    (the two-field contact's offset, ``fields.build_field_reads``). It is long because the kernel is one closure of
    the scalar type: the gather over the nodes with mass, the least-squares ``C`` and the affine advance.

    Passive points (rows ``first..``): velocity ``v`` and affine velocity gradient ``C`` from the grid (no F, no P2G).
    Only nodes with mass count, weights renormalised over them: a surface point outside the material would otherwise
    be held back by the empty nodes' zero velocity. With ``grid_tables.PASSIVE_SPANNED`` (the rule, round 38) each node
    counts by its weight times its mass: the mean at the weights' centroid (``grid_tables.PASSIVE_MEAN_AT``, round 39:
    moved towards the material's centroid along the unspanned directions) plus the weighted least-squares gradient
    along the directions the material spans (:func:`build_spanned_inverse`), read at the point, ``C`` that gradient;
    off, by the weight alone, ``C`` the weighted fit (:data:`PASSIVE_BY_MASS`: round 37's variants). The
    point then advances over the ``m`` substeps since its last gather through the affine field
    ``v(y, k) = v_prev + (k/m)(v_new - v_prev) + (C_prev + (k/m)(C_new - C_prev)) y``,
    ``y += dt v(y, k)``, ``k = 1..m`` (``gasp_core.mpm.substeps.passive_schedule``), so it turns with the material.
    A point with no node of mass in its stencil (stranded) falls freely: ``v_new = v_prev + m dt g``; on the floor it
    slides with the floor's Coulomb friction ``mu_floor`` (``gasp_core.mpm.points.hold_passive``)."""
    spanned = bool(grid_tables.PASSIVE_SPANNED)   # round 38: by mass, the gradient along the spanned directions
    by_mass, at_point = bool(PASSIVE_BY_MASS) or spanned, bool(PASSIVE_AT_POINT) or spanned
    mean_at = grid_tables.passive_mean_at() if spanned else "weights"   # round 39: where the mean is read
    material, unspanned = mean_at == "material", mean_at == "unspanned"
    spanned_inverse = build_spanned_inverse(Ft)
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    hold_passive = build_passive_hold(Ft)
    field_offset_base, field_node_v = build_field_reads(Ft)

    @wp.func
    def passive_fit(new_v: vec3, rbar: vec3, Svr: mat33, Srr: mat33, wsum: Ft, mv: vec3, mr: vec3, msum: Ft,
                    span_mass: Ft, inv_dx: Ft):
        # the sums over the nodes with mass (weights N m or N, wsum > 0; by mass alone, msum) -> v at the point and C
        Cn = mat33()
        new_v = new_v / wsum
        rbar = rbar / wsum
        # centred moments per unit weight (divided by wsum: a point at a crack may see only a far corner node,
        # wsum ~ 1e-12, whose unscaled moments' determinant underflows f32 and made C non-finite); a tiny
        # ridge (1e-4 of a full stencil's second moment / 4) where the nodes with mass are planar
        Svr = Svr / wsum - wp.outer(new_v, rbar)
        Srr = Srr / wsum - wp.outer(rbar, rbar)
        Ps = mat33()   # the projector on the spanned directions, M^+ M
        if wp.static(spanned):
            Minv = spanned_inverse(Srr, wsum, span_mass)
            Cn = inv_dx * (Svr * Minv)
            Ps = Minv * Srr
        else:
            Cn = inv_dx * (Svr * wp.inverse(Srr + wp.identity(3, dtype=Ft) * Ft(2.5e-5)))
        if wp.static(material):   # the mean at the material's centroid (grid_tables.PASSIVE_MEAN_AT)
            new_v = mv / msum
            rbar = mr / msum
        if wp.static(unspanned):   # round 38's, plus what it misses there by the unspanned share (ditto)
            d = mr / msum - rbar
            du = d - Ps * d
            f = wp.dot(du, du) / wp.max(wp.dot(d, d), Ft(1e-30))
            new_v = new_v + f * (mv / msum - new_v - Cn * (d / inv_dx))
        if wp.static(by_mass and at_point):   # the fit read at the point (the builder's docstring)
            new_v = new_v - Cn * (rbar / inv_dx)
        return new_v, Cn

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def g2p_passive(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33), fixed: wp.array(dtype=wp.int32),
        grid_v: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft), flags: wp.array(dtype=wp.int32),
        lo: vec3, inv_dx: Ft, dt: Ft, m: int, n_grid: int, first: int, hold_lo: vec3, hold_hi: vec3, gravity: vec3,
        grid_dv: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32), mu_floor: Ft,
        span_mass: Ft,
    ):
        # Passive points (rows first..): v and C from the grid, then the affine advance (the builder's docstring)
        p = first + wp.tid()
        if fixed[p] != 0:
            v[p] = vec3(Ft(0.0))
            C[p] = mat33()
            return
        xp = x[p]
        X = (xp - lo) * inv_dx
        if not in_grid(X, n_grid):
            # out of the grid: it drops out where it is, uncounted here (flags[0] is the material points' count, the
            # blow-up verdict's; gasp_core.mpm.points.blow_up_rows), counted by the core (run.json left_domain)
            return
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        fx = X - vec3(b0, b1, b2)
        W = weights(fx)
        nn = n_grid * n_grid
        idx0 = (int(b0) * n_grid + int(b1)) * n_grid + int(b2)
        off = field_offset_base(grid_dv, in_a, body[p], n_grid * nn)   # its body's field: passive sand slides too
        new_v = vec3(Ft(0.0))
        wsum = Ft(0.0)
        rbar = vec3(Ft(0.0))
        steps = vec3(Ft(0.0), Ft(1.0), Ft(2.0))
        Svr = mat33()
        Srr = mat33()
        msum = Ft(0.0)   # the nodes by their mass alone: the material's centroid (round 39)
        mv = vec3(Ft(0.0))
        mr = vec3(Ft(0.0))
        for i in range(3):
            for j in range(3):
                row = idx0 + i * nn + j * n_grid
                for k in range(3):
                    if grid_m[row + k] > Ft(0.0):
                        w = W[i, 0] * W[j, 1] * W[k, 2]
                        if wp.static(by_mass):
                            w = w * grid_m[row + k]   # the node's say: its share of the material at the point
                        # node - point, cells; the steps read from `steps`, since in Warp 1.19 casting an unrolled
                        # loop's index, Ft(i) with Ft float64, retypes the index for the rest of the loop
                        r = vec3(steps[i], steps[j], steps[k]) - fx
                        gv = field_node_v(grid_v, grid_dv, off, row + k)
                        new_v = new_v + w * gv
                        wsum = wsum + w
                        rbar = rbar + w * r
                        Svr = Svr + w * wp.outer(gv, r)
                        Srr = Srr + w * wp.outer(r, r)
                        msum = msum + grid_m[row + k]   # by mass alone (read where PASSIVE_MEAN_AT says)
                        mv = mv + grid_m[row + k] * gv
                        mr = mr + grid_m[row + k] * r
        Cn = mat33()
        stranded = int(1)
        if wsum > Ft(0.0):
            stranded = int(0)
            new_v, Cn = passive_fit(new_v, rbar, Svr, Srr, wsum, mv, mr, wp.max(msum, Ft(1e-30)), span_mass, inv_dx)
        else:   # stranded, no material in its stencil: it falls freely until material or a boundary takes it
            new_v = v[p] + Ft(m) * dt * gravity
        vp = v[p]
        Cp = C[p]
        y = vec3(Ft(0.0))
        for kk in range(m):
            t = Ft(kk + 1) / Ft(m)
            y = y + dt * (vp + t * (new_v - vp) + (Cp + t * (Cn - Cp)) * y)
        # then held in the box the boundaries leave it, [hold_lo, hold_hi] (gasp_core.mpm.points.passive_bounds)
        xn, vn = hold_passive(xp + y, new_v + Cn * y, hold_lo, hold_hi, stranded, mu_floor)
        x[p] = xn
        v[p] = vn
        C[p] = Cn

    return g2p_passive
