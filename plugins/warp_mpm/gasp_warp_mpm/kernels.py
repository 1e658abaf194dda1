"""Warp kernels of the MLS-MPM solver specified in ``docs/mpm.md``.

One set of kernels is built per scalar type (``wp.float32`` or ``wp.float64``) by
:func:`build_kernels`: the kernels are closures over the scalar, vector and matrix types, so the
same source serves both precisions (Warp compiles one instantiation per type). It assembles one
builder per concern, each cached per scalar type so that the functions they share are built once:
:func:`build_grid_funcs` (grid indexing, weights, collide), :func:`build_elastic_funcs`,
:func:`build_plastic_funcs` and :func:`build_stress_funcs` (stresses and return mappings),
:func:`build_extras` (colliders, forces, impulses), :func:`build_p2g`, :func:`build_grid_update`,
:func:`build_g2p`, :func:`build_g2p_passive` and :func:`build_checks`.

Grid layout: a flat array of ``n_grid**3`` nodes, node ``(i, j, k)`` at flat index
``(i * n_grid + j) * n_grid + k``. ``grid_mv`` holds ``(momentum, mass)`` per node as a 4-vector
(one accumulation per node and point in P2G); ``grid_vel`` holds the updated node velocity
read by G2P. The grid update clears ``grid_mv`` after reading it, so no separate clear pass is
needed (the spec's step 1 is folded into the previous substep's step 3).

Sources: Hu et al. 2018 (MLS-MPM, APIC, quadratic B-splines), taichi's mpm128 (``F`` advanced in
P2G), taichi_elements (materials, "separate" collider with Coulomb friction), Klar et al. 2016
(Drucker-Prager sand), Stomakhin et al. 2013 (snow).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools
import types

import warp as wp

# Material codes and the columns of the per-body parameter table ``mat_par`` are gasp_core.toolkit.materials'.
from gasp_core.toolkit.materials import (JELLY, METAL, NEO_HOOKEAN, P_ALPHA, P_ETA, P_HARDENING, P_K, P_LAM, P_MU, P_SOFTENING,
                                         P_THETA_C, P_THETA_S, P_YIELD, PLASTICINE, SAND, SNOW,
                                         VON_MISES_RADIUS)

# Warp compiles CPU code at -O2 by default; -O3 is several times faster on these kernels.
_OPTS = {"optimization_level": 3}


@functools.cache
def build_types(Ft):
    """``(vec3, vec4, mat33)``: Warp vector and matrix types of the scalar type ``Ft``."""
    return wp.types.vector(3, Ft), wp.types.vector(4, Ft), wp.types.matrix((3, 3), Ft)


@functools.cache
def build_grid_funcs(Ft):
    """``(in_grid, weights, collide)``: grid-stencil test, quadratic B-spline weights and the Coulomb
    collider, shared by the kernels of scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def in_grid(X: vec3, n_grid: int):
        # base = floor(X - 0.5) must lie in [0, n_grid - 3] on every axis; compared as floats so
        # that NaN and inf positions are out of the grid (never converted to an index).
        lim = Ft(n_grid - 3)
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        ok = b0 >= Ft(0.0) and b0 <= lim and b1 >= Ft(0.0) and b1 <= lim
        return ok and b2 >= Ft(0.0) and b2 <= lim

    @wp.func
    def weights(fx: vec3):
        # Quadratic B-spline weights, row r = weights of node offset r on each axis.
        t0 = vec3(Ft(1.5)) - fx
        t1 = fx - vec3(Ft(1.0))
        t2 = fx - vec3(Ft(0.5))
        w0 = Ft(0.5) * wp.cw_mul(t0, t0)
        w1 = vec3(Ft(0.75)) - wp.cw_mul(t1, t1)
        w2 = Ft(0.5) * wp.cw_mul(t2, t2)
        return wp.matrix_from_rows(w0, w1, w2)

    @wp.func
    def collide(v: vec3, n: vec3, mu_b: Ft):
        # taichi_elements' "separate" collider with Coulomb friction mu_b (docs/mpm.md step 3).
        vn = wp.dot(v, n)
        out = v
        if vn < Ft(0.0):
            vt = v - vn * n
            lt = wp.length(vt)
            if lt > Ft(1e-30):
                out = vt * wp.max(Ft(0.0), Ft(1.0) + mu_b * vn / lt)
            else:
                out = vec3(Ft(0.0))
        return out

    return in_grid, weights, collide


@functools.cache
def build_elastic_funcs(Ft):
    """``(hencky_tau, corotated_tau, jelly_tau)``: Kirchhoff stresses of scalar type ``Ft`` (Hencky strain,
    fixed corotated from an SVD, fixed corotated with the polar rotation)."""
    vec3, vec4, mat33 = build_types(Ft)
    # Newton polar iteration stops when the l1 change of X is below this (about 30 ulp of 1).
    POLAR_TOL = Ft(4e-6) if Ft == wp.float32 else Ft(1e-13)

    @wp.func
    def hencky_tau(U: mat33, eps: vec3, mu: Ft, lam: Ft):
        # tau = U diag(2 mu eps + lam tr(eps)) U^T
        tr = eps[0] + eps[1] + eps[2]
        d = Ft(2.0) * mu * eps + vec3(lam * tr)
        return U * wp.diag(d) * wp.transpose(U)

    @wp.func
    def polar_rotation(Fp: mat33, tol: Ft):
        # R of F = R S (R = U V^T of the SVD when det F > 0) by Newton's iteration
        # X <- (g X + X^-T / g) / 2 with determinant scaling g = |det X|^(-1/3) on the first step
        # (Higham 1986). Returns (R, converged).
        X = Fp
        ok = int(0)
        for it in range(30):
            c0 = wp.cross(vec3(X[1, 0], X[1, 1], X[1, 2]), vec3(X[2, 0], X[2, 1], X[2, 2]))
            c1 = wp.cross(vec3(X[2, 0], X[2, 1], X[2, 2]), vec3(X[0, 0], X[0, 1], X[0, 2]))
            c2 = wp.cross(vec3(X[0, 0], X[0, 1], X[0, 2]), vec3(X[1, 0], X[1, 1], X[1, 2]))
            det = X[0, 0] * c0[0] + X[0, 1] * c0[1] + X[0, 2] * c0[2]
            if det <= Ft(0.0):
                break
            g = Ft(1.0)
            if it == 0:
                g = wp.pow(det, Ft(-1.0) / Ft(3.0))
            a = Ft(0.5) * g
            bb = Ft(0.5) / (g * det)
            Xn = a * X + bb * wp.matrix_from_rows(c0, c1, c2)
            D = Xn - X
            X = Xn
            err = (wp.abs(D[0, 0]) + wp.abs(D[0, 1]) + wp.abs(D[0, 2]) + wp.abs(D[1, 0]) + wp.abs(D[1, 1])
                   + wp.abs(D[1, 2]) + wp.abs(D[2, 0]) + wp.abs(D[2, 1]) + wp.abs(D[2, 2]))
            if err < tol:
                ok = 1
                break
        return X, ok

    @wp.func
    def corotated_tau(Fp: mat33, U: mat33, V: mat33, mu: Ft, lam: Ft):
        # tau = 2 mu (F - U V^T) F^T + lam J (J - 1) I, J = det F
        J = wp.determinant(Fp)
        R = U * wp.transpose(V)
        return Ft(2.0) * mu * (Fp - R) * wp.transpose(Fp) + wp.identity(3, dtype=Ft) * (lam * J * (J - Ft(1.0)))

    @wp.func
    def jelly_tau(Fp: mat33, mu: Ft, lam: Ft):
        # fixed corotated with R from the polar iteration; the SVD's U V^T where det F <= 0 or no convergence
        R, ok = polar_rotation(Fp, POLAR_TOL)
        if ok == 0:  # det F <= 0 (inverted) or no convergence: R = U V^T from the SVD
            U = mat33()
            sig = vec3()
            V = mat33()
            wp.svd3(Fp, U, sig, V)
            R = U * wp.transpose(V)
        J = wp.determinant(Fp)
        return Ft(2.0) * mu * (Fp - R) * wp.transpose(Fp) + wp.identity(3, dtype=Ft) * (lam * J * (J - Ft(1.0)))

    return hencky_tau, corotated_tau, jelly_tau


@functools.cache
def build_plastic_funcs(Ft):
    """``(hencky_return, snow_return)``: return mappings and stresses of the plastic materials (metal,
    plasticine, sand; snow) for the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    hencky_tau, corotated_tau, _ = build_elastic_funcs(Ft)

    @wp.func
    def hencky_return(F_trial: mat33, mu: Ft, lam: Ft, kind: int, b: int, p: int,
                      mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft)):
        # metal, plasticine (von Mises, Jp += plastic strain) and sand (Drucker-Prager) in Hencky strain:
        # returns (F after the return mapping, tau)
        Fp = F_trial
        U = mat33()
        sig = vec3()
        V = mat33()
        wp.svd3(Fp, U, sig, V)
        eps = vec3(wp.log(wp.max(sig[0], Ft(1e-4))), wp.log(wp.max(sig[1], Ft(1e-4))),
                   wp.log(wp.max(sig[2], Ft(1e-4))))
        tr = eps[0] + eps[1] + eps[2]
        e = eps - vec3(tr / Ft(3.0))
        e_norm = wp.length(e)
        if kind == SAND:
            if tr >= Ft(0.0):
                eps = vec3(Ft(0.0))
            else:
                dg = e_norm + (Ft(3.0) * lam + Ft(2.0) * mu) / (Ft(2.0) * mu) * tr * mat_par[b, P_ALPHA]
                if dg > Ft(0.0):
                    eps = eps - (dg / e_norm) * e
            Fp = U * wp.diag(vec3(wp.exp(eps[0]), wp.exp(eps[1]), wp.exp(eps[2]))) * wp.transpose(V)
        else:
            ys = mat_par[b, P_YIELD]
            jp = Jp[p]
            if kind == PLASTICINE:
                ys = ys * wp.max(Ft(0.0), Ft(1.0) - mat_par[b, P_SOFTENING] * jp)
            dg = e_norm - Ft(VON_MISES_RADIUS) * ys / (Ft(2.0) * mu)   # ||dev tau|| <= sqrt(2/3) Y
            if dg > Ft(0.0):
                eps = eps - (dg / e_norm) * e
                Fp = U * wp.diag(vec3(wp.exp(eps[0]), wp.exp(eps[1]), wp.exp(eps[2]))) * wp.transpose(V)
            if kind == PLASTICINE:
                Jp[p] = jp + wp.max(dg, Ft(0.0))
        return Fp, hencky_tau(U, eps, mu, lam)

    @wp.func
    def snow_return(F_trial: mat33, mu: Ft, lam: Ft, b: int, p: int, mat_par: wp.array2d(dtype=Ft),
                    Jp: wp.array(dtype=Ft)):
        # singular values clamped to [1 - theta_c, 1 + theta_s], hardening exp(xi (1 - Jp)):
        # returns (F after the return mapping, tau)
        U = mat33()
        sig = vec3()
        V = mat33()
        wp.svd3(F_trial, U, sig, V)
        jp = Jp[p]
        h = wp.exp(mat_par[b, P_HARDENING] * (Ft(1.0) - jp))
        s_lo = Ft(1.0) - mat_par[b, P_THETA_C]
        s_hi = Ft(1.0) + mat_par[b, P_THETA_S]
        sc = vec3(wp.clamp(sig[0], s_lo, s_hi), wp.clamp(sig[1], s_lo, s_hi), wp.clamp(sig[2], s_lo, s_hi))
        Jp[p] = jp * (sig[0] * sig[1] * sig[2]) / (sc[0] * sc[1] * sc[2])
        Fp = U * wp.diag(sc) * wp.transpose(V)
        return Fp, corotated_tau(Fp, U, V, mu * h, lam * h)

    return hencky_return, snow_return


@functools.cache
def build_stress_funcs(Ft):
    """``return_mapping``: the per-material return mapping and Kirchhoff stress (docs/mpm.md) for the
    scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    jelly_tau = build_elastic_funcs(Ft)[2]
    hencky_return, snow_return = build_plastic_funcs(Ft)

    @wp.func
    def return_mapping(F_trial: mat33, p: int, body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32),
                       mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft)):
        # return mapping and Kirchhoff stress of point p (docs/mpm.md table): (F, tau); writes Jp[p]
        Fp = F_trial
        b = body[p]
        kind = mat_kind[b]
        mu = mat_par[b, P_MU]
        lam = mat_par[b, P_LAM]
        tau = mat33()
        if kind == JELLY:
            tau = jelly_tau(Fp, mu, lam)
        elif kind == NEO_HOOKEAN:
            J = wp.determinant(Fp)
            tau = mu * (Fp * wp.transpose(Fp) - wp.identity(3, dtype=Ft)) + wp.identity(3, dtype=Ft) * (
                lam * wp.log(wp.max(J, Ft(1e-6))))
        elif kind == METAL or kind == PLASTICINE or kind == SAND:
            Fp, tau = hencky_return(Fp, mu, lam, kind, b, p, mat_par, Jp)
        elif kind == SNOW:
            Fp, tau = snow_return(Fp, mu, lam, b, p, mat_par, Jp)
        else:  # LIQUID
            J = wp.determinant(Fp)
            Fp = wp.identity(3, dtype=Ft) * wp.pow(J, Ft(1.0) / Ft(3.0))
            tau = wp.identity(3, dtype=Ft) * (mat_par[b, P_K] * J * (J - Ft(1.0)))
        return Fp, tau

    return return_mapping


@functools.cache
def build_extras_struct(Ft):
    """``Extras``: the struct of colliders, forces and impulses (:func:`gasp_core.toolkit.grid_tables.grid_tables`,
    ``frame_table``) of scalar type ``Ft``."""

    @wp.struct
    class Extras:
        # gasp_core.toolkit.grid_tables.grid_tables / frame_table (docs/colliders.md)
        sdf: wp.array(dtype=Ft)
        grad: wp.array(dtype=Ft)
        meta: wp.array(dtype=Ft)
        forces: wp.array(dtype=Ft)
        modes: wp.array(dtype=Ft)
        imps: wp.array(dtype=Ft)
        tab: wp.array(dtype=Ft)
        step: wp.array(dtype=wp.int32)
        n_col: int
        n_force: int
        n_imp: int
        width: int
    return Extras


@functools.cache
def build_force_funcs(Ft):
    """``(apply_forces, apply_impulses)``: forces and impulses on a grid node's velocity, scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)

    @wp.func
    def apply_forces(v_in: vec3, X: vec3, dt: Ft, m: Ft, gsurf: vec3, t: Ft, ex: Extras):
        # Wind (docs/colliders.md): quadratic drag on the windward surface, F = 1/2 rho_air C_d A |w| w,
        # w = u - v, A = max(0, gsurf . w / |w|) (gsurf = sum_p p_vol grad N_ip, m^2: the node's share
        # of the area the body shows the relative wind); applied implicitly in the drag rate
        # k = 1/2 rho_air C_d A |w| / m: v += w dt k / (1 + dt k), so it never overshoots the wind.
        # Point forces: acceleration "strength" along centre - X, linear in r inside the radius, constant
        # (or falling as 1/r^2) outside.
        v = v_in
        for f in range(ex.n_force):
            r = f * 12
            a = vec3(Ft(0.0))
            if ex.forces[r] == Ft(0.0):
                u = vec3(ex.forces[r + 1], ex.forces[r + 2], ex.forces[r + 3])
                m0 = int(ex.forces[r + 10])
                for mm in range(m0, m0 + int(ex.forces[r + 11])):
                    q = mm * 8
                    kv = vec3(ex.modes[q], ex.modes[q + 1], ex.modes[q + 2])
                    A = vec3(ex.modes[q + 3], ex.modes[q + 4], ex.modes[q + 5])
                    u = u + A * wp.sin(wp.dot(kv, X) + ex.modes[q + 7] * t + ex.modes[q + 6])
                wrel = u - v
                wn = wp.length(wrel)
                if wn > Ft(0.0):
                    area = wp.max(Ft(0.0), wp.dot(gsurf, wrel) / wn)
                    kdt = dt * ex.forces[r + 4] * area * wn / m
                    v = v + (kdt / (Ft(1.0) + kdt)) * wrel
            else:
                d = vec3(ex.forces[r + 1], ex.forces[r + 2], ex.forces[r + 3]) - X
                rr = wp.length(d)
                strength = ex.forces[r + 7]
                radius = ex.forces[r + 8]
                mag = strength * rr / radius
                if rr >= radius:
                    mag = strength
                    if ex.forces[r + 9] == Ft(1.0):
                        mag = strength * (radius / rr) * (radius / rr)
                if rr > Ft(0.0):
                    a = d * (mag / rr)
            v = v + dt * a
        return v

    @wp.func
    def apply_impulses(v_in: vec3, X: vec3, base: int, ex: Extras):
        # impulses over a box or a sphere, weighted by the substep's time-table entry: add dv, or set v = dv
        v = v_in
        for q in range(ex.n_imp):
            r = q * 11
            c = vec3(ex.imps[r + 1], ex.imps[r + 2], ex.imps[r + 3])
            b = vec3(ex.imps[r + 4], ex.imps[r + 5], ex.imps[r + 6])
            inside = False
            if ex.imps[r] == Ft(0.0):
                inside = (X[0] >= c[0] and X[1] >= c[1] and X[2] >= c[2] and X[0] <= b[0] and X[1] <= b[1]
                          and X[2] <= b[2])
            else:
                inside = wp.length(X - c) <= b[0]
            w = ex.tab[base + 1 + 18 * ex.n_col + q]
            if inside and w > Ft(0.0):
                dv = vec3(ex.imps[r + 8], ex.imps[r + 9], ex.imps[r + 10])
                if ex.imps[r + 7] == Ft(0.0):
                    v = v + w * dv
                else:
                    v = dv
        return v

    return apply_forces, apply_impulses


@functools.cache
def build_collider_func(Ft):
    """``apply_colliders``: the colliders' signed distances on a grid node's velocity, scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    collide = build_grid_funcs(Ft)[2]
    Extras = build_extras_struct(Ft)

    @wp.func
    def apply_colliders(v_in: vec3, X: vec3, base: int, ex: Extras):
        # each collider: trilinear signed distance and gradient in its frame (pose and velocity from the
        # substep's time-table row); inside (phi <= 0) collide relative to the collider's velocity
        v = v_in
        for cc in range(ex.n_col):
            r = cc * 9
            p0 = base + 1 + 18 * cc
            R = mat33(ex.tab[p0 + 0], ex.tab[p0 + 1], ex.tab[p0 + 2],
                      ex.tab[p0 + 3], ex.tab[p0 + 4], ex.tab[p0 + 5],
                      ex.tab[p0 + 6], ex.tab[p0 + 7], ex.tab[p0 + 8])
            T = vec3(ex.tab[p0 + 9], ex.tab[p0 + 10], ex.tab[p0 + 11])
            h = ex.meta[r + 3]
            org = vec3(ex.meta[r], ex.meta[r + 1], ex.meta[r + 2])
            nx = int(ex.meta[r + 4])
            ny = int(ex.meta[r + 5])
            nz = int(ex.meta[r + 6])
            off = int(ex.meta[r + 7])
            u = (wp.transpose(R) * (X - T) - org) / h
            if (u[0] >= Ft(0.0) and u[1] >= Ft(0.0) and u[2] >= Ft(0.0) and u[0] <= Ft(nx - 1)
                    and u[1] <= Ft(ny - 1) and u[2] <= Ft(nz - 1)):
                i0 = wp.min(int(wp.floor(u[0])), nx - 2)
                j0 = wp.min(int(wp.floor(u[1])), ny - 2)
                k0 = wp.min(int(wp.floor(u[2])), nz - 2)
                fx = u - vec3(Ft(i0), Ft(j0), Ft(k0))
                phi = Ft(0.0)
                gr = vec3(Ft(0.0))
                for di in range(2):
                    for dj in range(2):
                        for dk in range(2):
                            wx = Ft(1.0) - fx[0]
                            if di == 1:
                                wx = fx[0]
                            wy = Ft(1.0) - fx[1]
                            if dj == 1:
                                wy = fx[1]
                            wz = Ft(1.0) - fx[2]
                            if dk == 1:
                                wz = fx[2]
                            wgt = wx * wy * wz
                            idx = off + ((i0 + di) * ny + (j0 + dj)) * nz + (k0 + dk)
                            phi = phi + wgt * ex.sdf[idx]
                            gr = gr + wgt * vec3(ex.grad[3 * idx], ex.grad[3 * idx + 1], ex.grad[3 * idx + 2])
                gl = wp.length(gr)
                if phi <= Ft(0.0) and gl > Ft(0.0):
                    n = R * (gr / gl)
                    vl = vec3(ex.tab[p0 + 12], ex.tab[p0 + 13], ex.tab[p0 + 14])
                    om = vec3(ex.tab[p0 + 15], ex.tab[p0 + 16], ex.tab[p0 + 17])
                    vc = vl + wp.cross(om, X - T)
                    v = vc + collide(v - vc, n, ex.meta[r + 8])
        return v

    return apply_colliders


@functools.cache
def build_extras(Ft):
    """``(Extras, extras, tick)``: the struct of colliders, forces and impulses, the function applying them
    at a grid node and the kernel advancing the time table's substep, for the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    apply_forces, apply_impulses = build_force_funcs(Ft)
    apply_colliders = build_collider_func(Ft)

    @wp.func
    def extras(v_in: vec3, X: vec3, dt: Ft, m: Ft, gsurf: vec3, ex: Extras):
        # Forces, impulses, then colliders at a node (the same order as taichi_mpm's _extras).
        base = ex.step[0] * ex.width
        t = ex.tab[base]
        v = apply_forces(v_in, X, dt, m, gsurf, t, ex)
        v = apply_impulses(v, X, base, ex)
        return apply_colliders(v, X, base, ex)

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def tick(step: wp.array(dtype=wp.int32)):
        step[0] = step[0] + 1

    return Extras, extras, tick


@functools.cache
def build_p2g(Ft):
    """The P2G kernel ``p2g`` of scalar type ``Ft``: return mapping, stress, scatter."""
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights, _ = build_grid_funcs(Ft)
    return_mapping = build_stress_funcs(Ft)

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

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def p2g(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), F: wp.array(dtype=mat33),
        C: wp.array(dtype=mat33), Jp: wp.array(dtype=Ft), p_mass: wp.array(dtype=Ft),
        p_vol: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32),
        mat_kind: wp.array(dtype=wp.int32), mat_par: wp.array2d(dtype=Ft),
        grid_mv: wp.array(dtype=vec4), n_out: wp.array(dtype=wp.int32),
        lo: vec3, inv_dx: Ft, dx: Ft, dt: Ft, n_grid: int, grid_g: wp.array(dtype=vec3), has_wind: int,
        grid_mv0: wp.array(dtype=vec4), flip: int,
    ):
        # F advanced by C, return mapping and stress (docs/mpm.md), then the scatter (and, with wind, grid_g;
        # with flip, the APIC momentum alone into grid_mv0: gasp_core.toolkit.transfer)
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
        Cp = C[p]
        F_new, tau = return_mapping((wp.identity(3, dtype=Ft) + dt * Cp) * F[p], p, body, mat_kind, mat_par, Jp)
        F[p] = F_new
        eta = mat_par[body[p], P_ETA]
        if eta > Ft(0.0):  # Kelvin-Voigt: J 2 eta sym(grad v), C = grad v (docs/dissipation.md)
            tau = tau + (eta * wp.determinant(F_new)) * (Cp + wp.transpose(Cp))
        pm = p_mass[p]
        affine = (-dt * p_vol[p] * Ft(4.0) * inv_dx * inv_dx) * tau + pm * Cp
        A = dx * affine  # affine dpos = A ((i, j, k) - fx)
        mom0 = pm * v[p] - A * fx
        idx0 = (int(b0) * n_grid + int(b1)) * n_grid + int(b2)
        scatter(grid_mv, idx0, n_grid, W, mom0, A, pm)
        if flip != 0:
            A0 = (dx * pm) * Cp
            scatter(grid_mv0, idx0, n_grid, W, pm * v[p] - A0 * fx, A0, pm)
        if has_wind != 0:
            scatter_wind(grid_g, idx0, n_grid, W, fx, p_vol[p] * inv_dx)

    return p2g


@functools.cache
def build_grid_update(Ft):
    """The grid-update kernel ``grid_update`` of scalar type ``Ft``: node velocity, gravity, extras,
    boundaries."""
    vec3, vec4, mat33 = build_types(Ft)
    collide = build_grid_funcs(Ft)[2]
    Extras, extras, _ = build_extras(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def grid_update(
        grid_mv: wp.array(dtype=vec4), grid_vel: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft),
        gravity: vec3, lo: vec3, hi: vec3, dx: Ft, dt: Ft, n_grid: int,
        wall_mu: wp.array(dtype=Ft), ground: wp.array(dtype=vec3),
        fixed_lo: wp.array(dtype=vec3), fixed_hi: wp.array(dtype=vec3),
        has_extras: int, ex: Extras, grid_g: wp.array(dtype=vec3), has_wind: int,
        grid_mv0: wp.array(dtype=vec4), grid_v0: wp.array(dtype=vec3), flip: int,
    ):
        # ground[g] = (top node layer k_max as a float, friction, unused); grid_m (node mass, for
        # passive points) has one entry per node when the setup has passive points, else one unused entry
        node = wp.tid()
        g = grid_mv[node]
        m = g[3]
        if grid_m.shape[0] > 1:
            grid_m[node] = m
        out = vec3(Ft(0.0))
        if m > Ft(0.0):
            vel = vec3(g[0], g[1], g[2]) / m + dt * gravity
            i = node / (n_grid * n_grid)
            j = (node / n_grid) % n_grid
            k = node % n_grid
            X = lo + dx * vec3(Ft(i), Ft(j), Ft(k))
            if has_extras != 0:
                gsurf = vec3(Ft(0.0))
                if has_wind != 0:
                    gsurf = grid_g[node]
                vel = extras(vel, X, dt, m, gsurf, ex)
            for w in range(wall_mu.shape[0]):
                mu_b = wall_mu[w]
                for d in range(3):
                    if X[d] < lo[d] + Ft(3.0) * dx:
                        n = vec3(Ft(0.0))
                        n[d] = Ft(1.0)
                        vel = collide(vel, n, mu_b)
                    if X[d] > hi[d] - Ft(3.0) * dx:
                        n = vec3(Ft(0.0))
                        n[d] = Ft(-1.0)
                        vel = collide(vel, n, mu_b)
            for q in range(ground.shape[0]):
                gr = ground[q]
                if Ft(k) <= gr[0]:  # node layer k at or below the ground's top layer (exact small integers)
                    vel = collide(vel, vec3(Ft(0.0), Ft(0.0), Ft(1.0)), gr[1])
            for r in range(fixed_lo.shape[0]):
                flo = fixed_lo[r]
                fhi = fixed_hi[r]
                if (X[0] >= flo[0] and X[0] <= fhi[0] and X[1] >= flo[1] and X[1] <= fhi[1]
                        and X[2] >= flo[2] and X[2] <= fhi[2]):
                    vel = vec3(Ft(0.0))
            out = vel
        grid_vel[node] = out
        grid_mv[node] = vec4(Ft(0.0))
        if flip != 0:  # the APIC velocity before forces (gasp_core.toolkit.transfer)
            g0 = grid_mv0[node]
            grid_v0[node] = vec3(Ft(0.0))
            if m > Ft(0.0):
                grid_v0[node] = vec3(g0[0], g0[1], g0[2]) / m
            grid_mv0[node] = vec4(Ft(0.0))
        if has_wind != 0:
            grid_g[node] = vec3(Ft(0.0))

    return grid_update


@functools.cache
def build_g2p(Ft):
    """``g2p``: the G2P kernel of scalar type ``Ft`` for material points (with the position update)."""
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights, _ = build_grid_funcs(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def g2p(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
        fixed: wp.array(dtype=wp.int32), grid_vel: wp.array(dtype=vec3),
        lo: vec3, inv_dx: Ft, dt: Ft, n_grid: int, grid_v0: wp.array(dtype=vec3), alpha: Ft,
    ):
        p = wp.tid()
        if fixed[p] != 0:
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
        # new_v = sum w g;  B = sum w g (i, j, k)^T  accumulated as sums over node planes.
        new_v = vec3(Ft(0.0))
        si1 = vec3(Ft(0.0))
        si2 = vec3(Ft(0.0))
        sj1 = vec3(Ft(0.0))
        sj2 = vec3(Ft(0.0))
        sk1 = vec3(Ft(0.0))
        sk2 = vec3(Ft(0.0))
        for i in range(3):
            vi = vec3(Ft(0.0))
            for j in range(3):
                wij = W[i, 0] * W[j, 1]
                row = idx0 + i * nn + j * n_grid
                vj = vec3(Ft(0.0))
                for k in range(3):
                    wg = (wij * W[k, 2]) * grid_vel[row + k]
                    vj = vj + wg
                    if k == 1:
                        sk1 = sk1 + wg
                    if k == 2:
                        sk2 = sk2 + wg
                vi = vi + vj
                if j == 1:
                    sj1 = sj1 + vj
                if j == 2:
                    sj2 = sj2 + vj
            new_v = new_v + vi
            if i == 1:
                si1 = si1 + vi
            if i == 2:
                si2 = si2 + vi
        c0 = si1 + Ft(2.0) * si2
        c1 = sj1 + Ft(2.0) * sj2
        c2 = sk1 + Ft(2.0) * sk2
        B = wp.matrix_from_cols(c0, c1, c2)
        # C = 4 inv_dx^2 sum w g ((i, j, k) - fx)^T dx = 4 inv_dx (B - new_v fx^T)
        C[p] = (Ft(4.0) * inv_dx) * (B - wp.outer(new_v, fx))
        if alpha > Ft(0.0):  # AFLIP: v_PIC(new) + alpha (v_p - v_PIC(old)) (gasp_core.toolkit.transfer)
            old_v = vec3(Ft(0.0))
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        old_v = old_v + (W[i, 0] * W[j, 1] * W[k, 2]) * grid_v0[idx0 + i * nn + j * n_grid + k]
            v[p] = new_v + alpha * (v[p] - old_v)
        else:
            v[p] = new_v
        x[p] = xp + dt * new_v

    return g2p


@functools.cache
def build_g2p_passive(Ft):
    """``g2p_passive``: the G2P kernel of scalar type ``Ft`` for passive points."""
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights, _ = build_grid_funcs(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def g2p_passive(
        x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33), fixed: wp.array(dtype=wp.int32),
        grid_vel: wp.array(dtype=vec3), grid_m: wp.array(dtype=Ft), flags: wp.array(dtype=wp.int32),
        lo: vec3, inv_dx: Ft, dt: Ft, m: int, n_grid: int, first: int,
    ):
        # Passive points (rows first..): velocity v and affine velocity gradient C from the grid
        # (no F, no P2G). Only nodes with mass count, weights renormalised over them: a surface point
        # outside the material would otherwise be held back by the empty nodes' zero velocity; C is
        # the weighted least-squares fit of the node velocities (APIC's C on a full stencil). The
        # point then advances over the m substeps since its last gather through the affine field
        # v(y, k) = v_prev + (k/m)(v_new - v_prev) + (C_prev + (k/m)(C_new - C_prev)) y,
        # y += dt v(y, k), k = 1..m (gasp_core.toolkit.substeps.passive_schedule), so it turns with the material.
        p = first + wp.tid()
        if fixed[p] != 0:
            v[p] = vec3(Ft(0.0))
            C[p] = mat33()
            return
        xp = x[p]
        X = (xp - lo) * inv_dx
        if not in_grid(X, n_grid):
            wp.atomic_add(flags, 0, 1)
            return
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        fx = X - vec3(b0, b1, b2)
        W = weights(fx)
        nn = n_grid * n_grid
        idx0 = (int(b0) * n_grid + int(b1)) * n_grid + int(b2)
        new_v = vec3(Ft(0.0))
        wsum = Ft(0.0)
        rbar = vec3(Ft(0.0))
        Svr = mat33()
        Srr = mat33()
        for i in range(3):
            for j in range(3):
                row = idx0 + i * nn + j * n_grid
                for k in range(3):
                    if grid_m[row + k] > Ft(0.0):
                        w = W[i, 0] * W[j, 1] * W[k, 2]
                        r = vec3(Ft(i), Ft(j), Ft(k)) - fx          # node - point, cells
                        gv = grid_vel[row + k]
                        new_v = new_v + w * gv
                        wsum = wsum + w
                        rbar = rbar + w * r
                        Svr = Svr + w * wp.outer(gv, r)
                        Srr = Srr + w * wp.outer(r, r)
        Cn = mat33()
        if wsum > Ft(0.0):
            new_v = new_v / wsum
            rbar = rbar / wsum
            # centred moments; a tiny ridge (1e-4 of a full stencil's wsum / 4) where the nodes with mass are planar
            Svr = Svr - wsum * wp.outer(new_v, rbar)
            Srr = Srr - wsum * wp.outer(rbar, rbar) + wp.identity(3, dtype=Ft) * (Ft(2.5e-5) * wsum)
            Cn = inv_dx * (Svr * wp.inverse(Srr))
        vp = v[p]
        Cp = C[p]
        y = vec3(Ft(0.0))
        for kk in range(m):
            t = Ft(kk + 1) / Ft(m)
            y = y + dt * (vp + t * (new_v - vp) + (Cp + t * (Cn - Cp)) * y)
        x[p] = xp + y
        v[p] = new_v + Cn * y
        C[p] = Cn

    return g2p_passive



@functools.cache
def build_checks(Ft):
    """``(check, svd)``: the finite-state kernel and ``wp.svd3`` on the CPU (for the tests), scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def check(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), flags: wp.array(dtype=wp.int32)):
        # flags[1] counts points whose x or v is not finite.
        p = wp.tid()
        xp = x[p]
        vp = v[p]
        ok = wp.isfinite(xp[0]) and wp.isfinite(xp[1]) and wp.isfinite(xp[2])
        ok = ok and wp.isfinite(vp[0]) and wp.isfinite(vp[1]) and wp.isfinite(vp[2])
        if not ok:
            wp.atomic_add(flags, 1, 1)

    @wp.kernel(enable_backward=False, module="unique", module_options=_OPTS)
    def svd_kernel(A: wp.array(dtype=mat33), U: wp.array(dtype=mat33), sig: wp.array(dtype=vec3),
                   V: wp.array(dtype=mat33)):
        i = wp.tid()
        u = mat33()
        s = vec3()
        w = mat33()
        wp.svd3(A[i], u, s, w)
        U[i] = u
        sig[i] = s
        V[i] = w

    def svd(A):
        """``wp.svd3`` of each matrix of ``A`` (shape (n, 3, 3)) on the CPU: (U, sig, V) as ndarrays."""
        import numpy as np
        n = len(A)
        a = wp.array(np.asarray(A, dtype=np.float32 if Ft == wp.float32 else np.float64), dtype=mat33, device="cpu")
        U = wp.zeros(n, dtype=mat33, device="cpu")
        sig = wp.zeros(n, dtype=vec3, device="cpu")
        V = wp.zeros(n, dtype=mat33, device="cpu")
        wp.launch(svd_kernel, dim=n, inputs=[a, U, sig, V], device="cpu")
        return U.numpy(), sig.numpy(), V.numpy()

    return check, svd


@functools.cache
def build_kernels(Ft):
    """The solver's kernels for the scalar type ``Ft`` (``wp.float32`` or ``wp.float64``).

    Returns
    -------
    types.SimpleNamespace
        ``vec3, vec4, mat33`` (types), ``Extras`` (struct) and the kernels ``p2g, grid_update, g2p,
        g2p_passive, check, tick``, and ``svd`` (a function).
    """
    vec3, vec4, mat33 = build_types(Ft)
    Extras, _, tick = build_extras(Ft)
    g2p, g2p_passive = build_g2p(Ft), build_g2p_passive(Ft)
    check, svd = build_checks(Ft)
    return types.SimpleNamespace(vec3=vec3, vec4=vec4, mat33=mat33, p2g=build_p2g(Ft), Extras=Extras, tick=tick,
                                 grid_update=build_grid_update(Ft), g2p=g2p, g2p_passive=g2p_passive, check=check,
                                 svd=svd)

