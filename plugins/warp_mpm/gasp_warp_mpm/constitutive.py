"""Constitutive models (docs/mpm.md "Constitutive models"): the Kirchhoff stresses, the polar rotation and the
per-material return mapping, as Warp functions per scalar type (:mod:`gasp_warp_mpm.precision`).

Sources: taichi_elements (materials), Klar et al. 2016 (Drucker-Prager sand), Stomakhin et al. 2013 (snow),
Higham 1986 (polar decomposition), Rankine damage in a crack band (Bazant & Oh 1983; docs/fracture.md) for brittle.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

# Material codes and the columns of the per-body parameter table ``mat_par`` are gasp_core.mpm.materials'.
from gasp_core.mpm.cells import OPENING as CELL_OPENING
from gasp_core.mpm.materials import (BRITTLE, JELLY, METAL, NEO_HOOKEAN, P_ALPHA, P_DMU, P_FT, P_HARDENING, P_IK, P_K,
                                         P_CELLS, P_LAM, P_MU, P_SF, P_SOFTENING, P_THETA_C, P_THETA_S, P_YIELD, PLASTICINE,
                                         SAND, SNOW, VON_MISES_RADIUS)

from .precision import build_types


def polar_tol(Ft):
    """The Newton polar iteration stops when the l1 change of X is below this (about 30 ulp of 1)."""
    return Ft(4e-6) if Ft == wp.float32 else Ft(1e-13)


@functools.cache
def build_polar(Ft):
    """``polar_rotation(F, tol) -> (R, converged)``: the rotation of the polar decomposition, scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

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

    return polar_rotation


@functools.cache
def build_sym_eig(Ft):
    """``sym_eig(A) -> (V, lam)``: ``A = V diag(lam) V^T`` of a symmetric 3x3 matrix by cyclic Jacobi, scalar
    type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    # Jacobi stops when the squared off-diagonal norm is below this times the squared diagonal norm.
    EIG_TOL = Ft(1e-14) if Ft == wp.float32 else Ft(1e-30)

    def jacobi_rotation(p, q, r):
        # one Jacobi rotation annihilating A[p, q] of the symmetric A, accumulated into V (Golub & Van Loan,
        # "Matrix Computations", Sec. 8.5); (p, q, r) a permutation of the axes, fixed per function
        @wp.func
        def rotate(A_in: mat33, V_in: mat33):
            A = A_in
            V = V_in
            apq = A[p, q]
            if apq != Ft(0.0):
                theta = (A[q, q] - A[p, p]) / (Ft(2.0) * apq)
                t = Ft(1.0) / (wp.abs(theta) + wp.sqrt(theta * theta + Ft(1.0)))
                if theta < Ft(0.0):
                    t = -t
                c = Ft(1.0) / wp.sqrt(t * t + Ft(1.0))
                s = t * c
                A[p, p] = A[p, p] - t * apq
                A[q, q] = A[q, q] + t * apq
                A[p, q] = Ft(0.0)
                A[q, p] = Ft(0.0)
                arp = A[r, p]
                arq = A[r, q]
                A[r, p] = c * arp - s * arq
                A[p, r] = A[r, p]
                A[r, q] = s * arp + c * arq
                A[q, r] = A[r, q]
                for k in range(3):
                    vkp = V[k, p]
                    vkq = V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
            return A, V
        return rotate

    rot01, rot02, rot12 = jacobi_rotation(0, 1, 2), jacobi_rotation(0, 2, 1), jacobi_rotation(1, 2, 0)

    @wp.func
    def sym_eig(A_in: mat33):
        # A = V diag(lam) V^T of a symmetric A, V a rotation: cyclic Jacobi sweeps until the off-diagonal part
        # is below the working precision relative to the diagonal (at most 12 sweeps)
        A = A_in
        V = wp.identity(3, dtype=Ft)
        for sweep in range(12):
            off = A[0, 1] * A[0, 1] + A[0, 2] * A[0, 2] + A[1, 2] * A[1, 2]
            if off <= EIG_TOL * (A[0, 0] * A[0, 0] + A[1, 1] * A[1, 1] + A[2, 2] * A[2, 2]):
                break
            A, V = rot01(A, V)
            A, V = rot02(A, V)
            A, V = rot12(A, V)
        return V, vec3(A[0, 0], A[1, 1], A[2, 2])

    return sym_eig


@functools.cache
def build_decompositions(Ft):
    """``(polar_rotation, sym_eig, svd)`` of scalar type ``Ft``: the polar rotation, the symmetric eigenproblem
    and the SVD built on them (docs/mpm.md "Constitutive models"), written the same way in the Taichi plugin.

    ``svd(F)``: for ``det F > 0`` the polar ``F = R S`` (``polar_rotation``), ``S = V diag(sig) V^T`` by cyclic
    Jacobi (``sym_eig``), ``U = R V``; otherwise, or where the iteration does not converge, ``wp.svd3`` (Taichi:
    ``ti.svd``; both give U, V proper rotations with a reflection carried by the sign of a singular value).
    The singular values are not sorted: every use is an isotropic function of them."""
    vec3, vec4, mat33 = build_types(Ft)
    POLAR_TOL = polar_tol(Ft)
    polar_rotation = build_polar(Ft)
    sym_eig = build_sym_eig(Ft)

    @wp.func
    def svd(Fp: mat33):
        # F = U diag(sig) V^T, U and V rotations (see build_decompositions)
        R, ok = polar_rotation(Fp, POLAR_TOL)
        U = mat33()
        sig = vec3()
        V = mat33()
        if ok == 0:  # det F <= 0 (inverted) or no convergence
            wp.svd3(Fp, U, sig, V)
        else:
            S = wp.transpose(R) * Fp
            S = Ft(0.5) * (S + wp.transpose(S))
            V, sig = sym_eig(S)
            U = R * V
        return U, sig, V

    return polar_rotation, sym_eig, svd


@functools.cache
def build_elastic_funcs(Ft):
    """``(hencky_tau, corotated_tau, jelly_tau)``: Kirchhoff stresses of scalar type ``Ft`` (Hencky strain,
    fixed corotated from an SVD, fixed corotated with the polar rotation)."""
    vec3, vec4, mat33 = build_types(Ft)
    polar_rotation = build_polar(Ft)
    POLAR_TOL = polar_tol(Ft)

    @wp.func
    def hencky_tau(U: mat33, eps: vec3, mu: Ft, lam: Ft):
        # tau = U diag(2 mu eps + lam tr(eps)) U^T
        tr = eps[0] + eps[1] + eps[2]
        d = Ft(2.0) * mu * eps + vec3(lam * tr)
        return U * wp.diag(d) * wp.transpose(U)

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
    svd = build_decompositions(Ft)[2]

    @wp.func
    def hencky_return(F_trial: mat33, mu: Ft, lam: Ft, kind: int, b: int, p: int,
                      mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft), dt: Ft):
        # metal, plasticine (von Mises, Jp += plastic strain) and sand (Drucker-Prager) in Hencky strain:
        # returns (F after the return mapping, tau)
        Fp = F_trial
        U, sig, V = svd(Fp)
        eps = vec3(wp.log(wp.max(sig[0], Ft(1e-4))), wp.log(wp.max(sig[1], Ft(1e-4))),
                   wp.log(wp.max(sig[2], Ft(1e-4))))
        tr = eps[0] + eps[1] + eps[2]
        e = eps - vec3(tr / Ft(3.0))
        e_norm = wp.length(e)
        if kind == SAND:
            if tr >= Ft(0.0):
                eps = vec3(Ft(0.0))
            else:
                k = Ft(3.0) * lam + Ft(2.0) * mu
                alpha = mat_par[b, P_ALPHA]
                dg = e_norm + k / (Ft(2.0) * mu) * tr * alpha
                if mat_par[b, P_DMU] > Ft(0.0) and dg > Ft(0.0):   # mu(I): materials.mu_of_I (taichi's mu_i_alpha)
                    rate = wp.sqrt(Ft(2.0)) * dg / dt
                    alpha = alpha * (Ft(1.0) + mat_par[b, P_DMU] / (
                        Ft(1.0) + mat_par[b, P_IK] * wp.sqrt(-k / Ft(3.0) * tr) / rate))
                    dg = e_norm + k / (Ft(2.0) * mu) * tr * alpha
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
        U, sig, V = svd(F_trial)
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
def build_brittle_return(Ft):
    """``brittle_return``: the brittle damage and stress (docs/fracture.md) for the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    svd = build_decompositions(Ft)[2]

    @wp.func
    def band_sf(U: mat33, s: vec3, ft: Ft, sf: Ft, fx: vec3, band: int):
        # the point's own end of softening f_t + W (s_f - f_t), W its crack band weight along the direction of its
        # largest principal stress (gasp_core.mpm.materials.band_weight, band_softening_stress: its MLS gradient
        # weight on its own cell, so every point of a cracked cell breaks through at the same opening; round 33).
        # band 3: s_f of the band dx g, g = sum_a |n_a| the cell's projection on that normal (band_projection,
        # round 34), where it stays above f_t. The Taichi plugin's band_sf.
        im = 0
        if s[1] > s[im]:
            im = 1
        if s[2] > s[im]:
            im = 2
        W = Ft(0.0)
        g = Ft(0.0)
        for a in range(3):
            w = Ft(2.0) * fx[a] * (Ft(1.5) - fx[a]) * (Ft(1.5) - fx[a])
            W += U[a, im] * U[a, im] * wp.max(w, Ft(1.0) - w)
            g += wp.abs(U[a, im])
        sfb = sf
        if band >= 3 and sf / g > ft:
            sfb = sf / g
        return ft + W * (sfb - ft)

    @wp.func
    def brittle_return(F_trial: mat33, mu: Ft, lam: Ft, b: int, p: int, mat_par: wp.array2d(dtype=Ft),
                       Jp: wp.array(dtype=Ft), fx: vec3, band: int):
        # brittle (docs/fracture.md): undamaged Hencky principal stresses s_i = 2 mu eps_i + lam tr(eps); the
        # largest sets the crack band's linear-softening damage (Bazant & Oh 1983;
        # gasp_core.mpm.materials.brittle_damage), kept in Jp when larger (never heals); only the tensile
        # s_i > 0 are scaled by 1 - d. Returns (F unchanged, tau). The Taichi plugin's brittle_tau.
        U, sig, V = svd(F_trial)
        d = Jp[p]
        eps = vec3(wp.log(wp.max(sig[0], Ft(1e-4))), wp.log(wp.max(sig[1], Ft(1e-4))),
                   wp.log(wp.max(sig[2], Ft(1e-4))))
        s = Ft(2.0) * mu * eps + vec3(lam * (eps[0] + eps[1] + eps[2]))
        smax = wp.max(s[0], wp.max(s[1], s[2]))
        if d < Ft(0.0):   # a Grady cell's inside (initial_Jp -1): never damages (cells.py)
            return F_trial, U * wp.diag(s) * wp.transpose(U)
        ft = mat_par[b, P_FT]
        sf = mat_par[b, P_SF]
        if band != 0:   # round 33's crack band weight (a free point; held_return's band)
            sf = band_sf(U, s, ft, sf, fx, band)
        if smax > ft:
            dt = Ft(1.0)
            if smax < sf:
                dt = Ft(1.0) - ft * (sf - smax) / (smax * (sf - ft))
            d = wp.max(d, dt)
        Jp[p] = d
        if d >= Ft(1.0) and mat_par[b, P_CELLS] != Ft(0.0):   # broken in Grady's cells: its opening kept in F up to
            em = Ft(CELL_OPENING)   # a stretch of 2, its cell's width; the fields carry the contact beyond (cells.py)
            eps = vec3(wp.min(eps[0], em), wp.min(eps[1], em), wp.min(eps[2], em))
            F_trial = U * wp.diag(vec3(wp.exp(eps[0]), wp.exp(eps[1]), wp.exp(eps[2]))) * wp.transpose(V)
            s = Ft(2.0) * mu * eps + vec3(lam * (eps[0] + eps[1] + eps[2]))
        g = vec3(Ft(1.0))   # the factor on each principal stress: 1 - d in tension, 1 in compression
        if s[0] > Ft(0.0):
            g[0] = Ft(1.0) - d
        if s[1] > Ft(0.0):
            g[1] = Ft(1.0) - d
        if s[2] > Ft(0.0):
            g[2] = Ft(1.0) - d
        return F_trial, U * wp.diag(wp.cw_mul(g, s)) * wp.transpose(U)

    return brittle_return


@functools.cache
def build_return_mapping(Ft):
    """``return_mapping``: the per-material return mapping and Kirchhoff stress (docs/mpm.md) for the
    scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    jelly_tau = build_elastic_funcs(Ft)[2]
    hencky_return, snow_return = build_plastic_funcs(Ft)
    brittle_return = build_brittle_return(Ft)

    @wp.func
    def return_mapping(F_trial: mat33, p: int, body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32),
                       mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft), dt: Ft, fx: vec3, band: int):
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
            Fp, tau = hencky_return(Fp, mu, lam, kind, b, p, mat_par, Jp, dt)
        elif kind == SNOW:
            Fp, tau = snow_return(Fp, mu, lam, b, p, mat_par, Jp)
        elif kind == BRITTLE:
            if Jp[p] >= Ft(1.0) and mat_par[b, P_CELLS] == Ft(0.0):   # broken through: cohesionless sand
                # (docs/fracture.md); in Grady's cells (P_CELLS) it keeps its tension-free stress (cells.py)
                Fp, tau = hencky_return(Fp, mu, lam, SAND, b, p, mat_par, Jp, dt)
            else:
                Fp, tau = brittle_return(Fp, mu, lam, b, p, mat_par, Jp, fx, band)
        else:  # LIQUID
            J = wp.determinant(Fp)
            Fp = wp.identity(3, dtype=Ft) * wp.pow(J, Ft(1.0) / Ft(3.0))
            tau = wp.identity(3, dtype=Ft) * (mat_par[b, P_K] * J * (J - Ft(1.0)))
        return Fp, tau

    return return_mapping
