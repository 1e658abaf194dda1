"""Conformance scenes of elastic bodies with known answers: resting contact, bounce energy, momentum,
spinning, determinism, rotation/translation invariance (free fall: :mod:`.scenes_freefall`).

Each scene is a :class:`~gasp_core.testing.kit.Scene` in :data:`SCENES_BASIC`. All use the domain
``[0, 1]^3``; points sit at ``dx/2`` spacing (8 per cell, as usual for MPM). Materials are soft enough
that the elastic time step stays large (few substeps) and stiff enough that the shape barely changes
where a check assumes a rigid body. Tolerances are given with their reasons beside each scene.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check, GRAVITY, make_setup, sphere_points
from gasp_core.testing.kit import Requires, run_trace, Scene, Trace

def _kabsch_angle_z(a: np.ndarray, b: np.ndarray) -> float:
    """Rotation angle about z (rad) of the best rigid fit mapping centred ``a`` onto centred ``b``."""
    a = a - a.mean(axis=0)
    b = b - b.mean(axis=0)
    h = a.T @ b
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return math.atan2(r[1, 0], r[0, 0])



# --- resting on the ground ------------------------------------------------------------------
GROUND_H = 0.1875  # 3 dx at n_grid 16 in [0, 1]^3: clear of the grid engines' 3 dx boundary band


def _build_resting(info: EngineInfo) -> SimSetup:
    dx = 1.0 / 16
    x, p_vol = box_points((0.375, 0.375, GROUND_H), (0.625, 0.625, GROUND_H + 0.25), dx / 2)
    x[:, 2] += 0.5 * dx  # dropped from half a cell: a small impact to settle from
    return make_setup(x, p_vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0),
                      boundaries=[Boundary("ground", height=GROUND_H, friction=0.5)], frame_dt=1 / 30)


def _eval_resting(info: EngineInfo, tr: Trace) -> list[Check]:
    dx = tr.setup.dx
    ke = tr.kinetic()
    m = tr.p_mass.sum()
    e_drop = m * GRAVITY * 0.5 * dx  # energy of the half-cell drop, J
    late = float(ke[-5:].mean())
    checks = [check("settles", late / e_drop, 0.05,
                    "mean kinetic energy of the last 5 frames / (M g drop height)", peak_ke=ke.max(),
                    late_ke=late, e_drop=e_drop)]
    below = float(GROUND_H - tr.x[:, :, 2].min())
    checks.append(check("ground_penetration", below / dx, 1.0,
                        "deepest point below the ground over all frames, in dx"))
    c = tr.centroid()
    drift = float(np.hypot(*(c[:, :2] - c[0, :2]).T).max())
    checks.append(check("horizontal_drift", drift / dx, 0.05, "max horizontal centroid drift, in dx"))
    return checks


# --- bounce (energy) ------------------------------------------------------------------------
BOUNCE_TOL = 0.02  # of the impact energy M g h


def _build_bounce(info: EngineInfo) -> SimSetup:
    dx = 1.0 / 16
    x, p_vol = sphere_points((0.5, 0.5, 0.45), 0.12, dx / 2)
    return make_setup(x, p_vol, Material("jelly", E=2e5, nu=0.3, rho=1000.0),
                      boundaries=[Boundary("ground", height=GROUND_H, friction=0.0)], frame_dt=1 / 60)


def _eval_bounce(info: EngineInfo, tr: Trace) -> list[Check]:
    e = tr.kinetic() + tr.potential()
    m = tr.p_mass.sum()
    scale = m * GRAVITY * float(tr.x[0, :, 2].min() - GROUND_H)  # energy released by the fall to contact
    rise = float((e - e[0]).max())
    k = int(np.argmax(e - e[0]))
    return [check("energy_never_increases", rise / scale, BOUNCE_TOL,
                  f"max over frames of (E_kin + E_pot - E0) / (M g h) (at frame {k})",
                  scale=scale, e0=e[0], e_end=e[-1]),
            check("bounced", -float(tr.v[:, :, 2].mean(axis=1).max()), 0.0,
                  "-(largest mean upward velocity) (must be <= 0: the body hit the ground and rebounded "
                  "or stopped)", " m/s")]


# --- momentum in free flight ----------------------------------------------------------------
MOMENTUM_TOL = 5e-3


def _build_momentum(info: EngineInfo) -> SimSetup:
    dx = 1.0 / 16
    x, p_vol = box_points((0.25, 0.375, 0.375), (0.5, 0.625, 0.625), dx / 2)
    rng = np.random.default_rng(7)
    v = np.array([0.5, 0.25, -0.2]) + rng.uniform(-0.3, 0.3, size=x.shape)
    return make_setup(x, p_vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0), v=v, gravity=(0, 0, 0))


def _eval_momentum(info: EngineInfo, tr: Trace) -> list[Check]:
    p = tr.momentum()
    p0 = np.linalg.norm(p[0])
    err = float(np.linalg.norm(p - p[0], axis=1).max() / p0)
    c = tr.centroid()
    m = tr.p_mass.sum()
    pred = c[0] + np.outer(tr.t, p[0] / m)
    cerr = float(np.linalg.norm(c - pred, axis=1).max() / np.linalg.norm(pred[-1] - c[0]))
    return [check("momentum_constant", err, MOMENTUM_TOL, "max |P(t) - P0| / |P0|"),
            check("centroid_uniform_motion", cerr, MOMENTUM_TOL,
                  "max |c(t) - c0 - P0 t / M| / |P0 t_end / M|")]


# --- spinning body --------------------------------------------------------------------------
OMEGA = math.pi  # rad/s about z
SPIN_DIST_TOL = 0.03
SPIN_L_TOL = 0.02


def _build_spinning(info: EngineInfo) -> SimSetup:
    dx = 1.0 / 16
    x, p_vol = box_points((0.35, 0.35, 0.4), (0.65, 0.65, 0.6), dx / 2)
    c = x.mean(axis=0)
    v = np.cross(np.array([0.0, 0.0, OMEGA]), x - c)
    # the rigid rotation's velocity gradient, so APIC starts with the points' own spin; given only to
    # engines that declare the feature "initial_C" (the core refuses it to the others)
    W = np.array([[0.0, -OMEGA, 0.0], [OMEGA, 0.0, 0.0], [0.0, 0.0, 0.0]])
    C = np.broadcast_to(W, (len(x), 3, 3)).copy() if "initial_C" in info.capabilities.features else None
    return make_setup(x, p_vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0), v=v, gravity=(0, 0, 0), C=C)


def _pairs(n: int, x0: np.ndarray, min_dist: float, k: int = 400) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    i, j = rng.integers(0, n, size=(2, 4 * k))
    keep = np.linalg.norm(x0[i] - x0[j], axis=1) > min_dist
    return i[keep][:k], j[keep][:k]


def _eval_spinning(info: EngineInfo, tr: Trace) -> list[Check]:
    x0 = tr.x[0]
    i, j = _pairs(len(x0), x0, 2 * tr.setup.dx)
    d0 = np.linalg.norm(x0[i] - x0[j], axis=1)
    d = np.linalg.norm(tr.x[:, i] - tr.x[:, j], axis=2)
    dist_err = float(np.abs(d / d0 - 1).max())
    m = tr.p_mass
    c = tr.centroid()
    lz = np.einsum("i,fi->f", m, np.cross(tr.x - c[:, None, :], tr.v)[:, :, 2])
    # From frame 1 on: APIC/MLS-MPM keeps part of the angular momentum in the affine matrix C
    # (the points' own spin), which the scene initialises through SimSetup.C; an engine that
    # ignores it loses that part in the first transfer (L_z(1) / L_z(0) is reported), and
    # sum m x cross v is constant from then on.
    l_err = float(np.abs(lz[1:] / lz[1] - 1).max())
    angle = _kabsch_angle_z(x0, tr.x[-1])
    expected = OMEGA * tr.t[-1]
    ang_err = abs(angle - expected) / expected
    return [check("distances_preserved", dist_err, SPIN_DIST_TOL,
                  "max relative change of point-pair distances (pairs > 2 dx apart)"),
            check("angular_momentum", l_err, SPIN_L_TOL,
                  f"max |L_z(t) / L_z(frame 1) - 1| (L_z(frame 1) / L_z(0) = {lz[1] / lz[0]:.4f})"),
            check("rotation_angle", ang_err, 0.05,
                  f"|rigid-fit angle - omega t| / (omega t) (angle {math.degrees(angle):.2f} deg, "
                  f"expected {math.degrees(expected):.2f} deg)")]


# --- determinism ----------------------------------------------------------------------------

def _build_determinism(info: EngineInfo) -> SimSetup:
    dx = 1.0 / 16
    x, p_vol = box_points((0.35, 0.4, 0.3), (0.6, 0.6, 0.45), dx / 2)
    c = x.mean(axis=0)
    v = np.array([0.4, 0.0, 0.0]) + np.cross([0.0, 2.0, 1.0], x - c)
    return make_setup(x, p_vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0), v=v,
                      boundaries=[Boundary("ground", height=GROUND_H, friction=0.5)])


def _eval_determinism(info: EngineInfo, tr: Trace) -> list[Check]:
    # the option values the engine names as making a run repeat bit for bit (e.g. one thread)
    s = tr.setup.replace(options={**tr.setup.options, **info.deterministic_options})
    a = run_trace(info, s, 10)
    b = run_trace(info, s, 10)
    diff = float(np.abs(a.x - b.x).max())
    moved = float(np.abs(a.x[-1] - a.x[0]).max())
    return [Check("bit_identical", bool(np.array_equal(a.x, b.x) and np.array_equal(a.v, b.v)),
                  f"max |x_run1 - x_run2| = {diff:.3g} m over 10 frames (options {s.options}; "
                  f"points moved up to {moved:.3f} m)", {"max_diff": diff})]


# --- rotation and translation invariance ----------------------------------------------------
#: A grid engine whose lattice is anchored at domain_lo maps onto itself under this rotation and
#: shift, so it should agree to rounding; 0.25 dx leaves room for engines whose discretisation is
#: not symmetric under a 90 deg turn (a Kuhn tetrahedral lattice, a grid anchored elsewhere).
INV_TOL_DX = 0.25
INV_SHIFT = np.array([0.37, -0.21, 0.13])


def _build_invariance(info: EngineInfo) -> SimSetup:
    dx = 1.0 / 16
    x, p_vol = box_points((0.2, 0.3, 0.25), (0.5, 0.45, 0.35), dx / 2)
    c = x.mean(axis=0)
    v = np.array([0.6, 0.3, 0.0]) + np.cross([1.5, 0.0, 0.5], x - c)
    return make_setup(x, p_vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0), v=v,
                      boundaries=[Boundary("ground", height=GROUND_H, friction=0.2)])


def _rot_z90(p: np.ndarray, centre: np.ndarray) -> np.ndarray:
    q = p - centre
    return np.stack([-q[..., 1], q[..., 0], q[..., 2]], axis=-1) + centre


def transformed(setup: SimSetup) -> SimSetup:
    """``setup`` rotated by 90 deg about the vertical axis through the domain centre, then shifted
    by :data:`INV_SHIFT` (points, velocities, domain, ground height and fixed regions)."""
    centre = 0.5 * (setup.domain_lo + setup.domain_hi)
    x = _rot_z90(setup.x, centre) + INV_SHIFT
    v = _rot_z90(setup.v, np.zeros(3))
    lo = _rot_z90(setup.domain_lo, centre) + INV_SHIFT
    hi = _rot_z90(setup.domain_hi, centre) + INV_SHIFT
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    bounds = []
    for b in setup.boundaries:
        if b.kind == "ground":
            b = dataclasses.replace(b, height=b.height + INV_SHIFT[2])
        elif b.kind == "fixed_region":
            a = _rot_z90(np.array(b.lo), centre) + INV_SHIFT
            c = _rot_z90(np.array(b.hi), centre) + INV_SHIFT
            b = dataclasses.replace(b, lo=tuple(np.minimum(a, c)), hi=tuple(np.maximum(a, c)))
        bounds.append(b)
    return setup.replace(x=x, v=v, domain_lo=lo, domain_hi=hi, boundaries=bounds,
                         gravity=_rot_z90(setup.gravity, np.zeros(3)))


def _eval_invariance(info: EngineInfo, tr: Trace) -> list[Check]:
    s2 = transformed(tr.setup)
    b = run_trace(info, s2, len(tr.t) - 1)
    centre = 0.5 * (tr.setup.domain_lo + tr.setup.domain_hi)
    expect = _rot_z90(tr.x, centre) + INV_SHIFT
    err = np.linalg.norm(b.x - expect, axis=2)
    dx = tr.setup.dx
    moved = float(np.linalg.norm(tr.x[-1] - tr.x[0], axis=1).max())
    return [check("rotated_translated_matches", float(err.max()) / dx, INV_TOL_DX,
                  f"max |x_B - (R x_A + t)| over all frames, in dx (mean {err.mean() / dx:.3g} dx; "
                  f"points moved up to {moved / dx:.1f} dx)")]




SCENES_BASIC: list[Scene] = [
    Scene("resting", "elastic cube dropped half a cell onto the ground: settles, no point below the "
          "ground by more than dx, no horizontal drift beyond 0.05 dx",
          Requires(frozenset({"jelly"}), frozenset({"ground"})), _build_resting, 18, _eval_resting),
    Scene("bounce", f"elastic ball dropped on a frictionless ground: kinetic + potential energy never "
          f"rises above its initial value by more than {BOUNCE_TOL:.0%} of M g h",
          Requires(frozenset({"jelly"}), frozenset({"ground"})), _build_bounce, 36, _eval_bounce),
    Scene("momentum", f"elastic cube in free flight (no gravity) with random internal velocities: "
          f"total momentum constant within {MOMENTUM_TOL:.1%}",
          Requires(frozenset({"jelly"})), _build_momentum, 9, _eval_momentum),
    Scene("spinning", f"elastic block spinning at pi rad/s about z (no gravity) for 0.5 s: pair "
          f"distances within {SPIN_DIST_TOL:.0%}, L_z within {SPIN_L_TOL:.0%}, angle within 5% "
          f"(SimSetup.C given to engines with the feature 'initial_C')",
          Requires(frozenset({"jelly"})), _build_spinning, 15, _eval_spinning),
    Scene("determinism", "same run twice with EngineInfo.deterministic_options: bit-identical positions "
          "and velocities", Requires(frozenset({"jelly"}), frozenset({"ground"}), deterministic=True),
          _build_determinism, 1, _eval_determinism),
    Scene("invariance", f"scene rotated 90 deg about z and translated: result transforms "
          f"accordingly within {INV_TOL_DX} dx", Requires(frozenset({"jelly"}), frozenset({"ground"})),
          _build_invariance, 15, _eval_invariance),
]
