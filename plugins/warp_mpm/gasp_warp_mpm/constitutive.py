"""Constitutive models (docs/mpm.md "Constitutive models"): the Kirchhoff stresses, the polar rotation and the
per-material return mapping, as Warp functions per scalar type (:mod:`gasp_warp_mpm.precision`).

Sources: taichi_elements (materials), Klar et al. 2016 (Drucker-Prager sand), Stomakhin et al. 2013 (snow),
Higham 1986 (polar decomposition).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

# Material codes and the columns of the per-body parameter table ``mat_par`` are gasp_core.toolkit.materials'.
from gasp_core.toolkit.materials import (JELLY, METAL, NEO_HOOKEAN, P_ALPHA, P_HARDENING, P_K, P_LAM, P_MU,
                                         P_SOFTENING, P_THETA_C, P_THETA_S, P_YIELD, PLASTICINE, SAND, SNOW,
                                         VON_MISES_RADIUS)

from .precision import build_types


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
def build_return_mapping(Ft):
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
