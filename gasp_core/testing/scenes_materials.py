"""Conformance scenes of materials against published answers: cantilever vs Euler-Bernoulli (clamp on
and off a grid node), dam break vs Martin & Moyce (1952). (The sand column collapse against
Lube et al. 2005 is in :mod:`gasp_core.testing.scenes_granular`.)

Each scene is a :class:`~gasp_core.testing.kit.Scene` in :data:`SCENES_MATERIALS`.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check, GRAVITY, make_setup, wall_margin
from gasp_core.testing.kit import Requires, Scene, Trace

# --- cantilever (Euler-Bernoulli) -----------------------------------------------------------
CANT_L, CANT_H = 0.5, 0.1  # free length, side of the square section (m)
CANT_X0 = 6 / 32  # clamp face on a grid node at n_grid 32 (m)
CANT_X0_OFFGRID = 6.6 / 32  # clamp face 0.6 dx past a node: the answer must not change
CANT_E, CANT_RHO = 4.6e6, 1000.0
CANT_TOL = 0.10   # time-averaged deflection vs Timoshenko (measured +5.1 %, see _eval_cantilever)
CANT_FREQ_TOL = 0.05  # first frequency vs Timoshenko (measured -3.3 %)


def cantilever_deflection(E: float = CANT_E, rho: float = CANT_RHO, L: float = CANT_L,
                          h: float = CANT_H, g: float = GRAVITY) -> float:
    """Static tip deflection of a clamped square bar under its weight, m.

    ``delta = q L^4 / (8 E I)`` with ``q = rho g h^2`` and ``I = h^4 / 12``, i.e.
    ``1.5 rho g L^4 / (E h^2)`` (Euler-Bernoulli, uniformly loaded cantilever).
    """
    return 1.5 * rho * g * L ** 4 / (E * h ** 2)


def _cantilever_builder(x0: float, n_grid: int = 32) -> Callable[[EngineInfo], SimSetup]:
    def build(info: EngineInfo) -> SimSetup:
        dx = 1.0 / n_grid
        lo = (x0 - 0.1, 0.5 - CANT_H / 2, 0.55)
        hi = (x0 + CANT_L, 0.5 + CANT_H / 2, 0.55 + CANT_H)
        x, p_vol = box_points(lo, hi, dx / 2)
        clamp = Boundary("fixed_region", lo=(0.0, 0.0, 0.0), hi=(x0, 1.0, 1.0))
        return make_setup(x, p_vol, Material("jelly", E=CANT_E, nu=0.0, rho=CANT_RHO), n_grid=n_grid,
                      boundaries=[clamp], frame_dt=0.02)
    return build


def _first_frequency(t: np.ndarray, w: np.ndarray, f_ref: float) -> float:
    """Frequency (Hz) of the least-squares fit ``a + b cos(2 pi f t) + c sin(2 pi f t)`` to ``w(t)``,
    searched over ``[0.5, 2] f_ref`` on a 0.05 % grid."""
    best, f_best = np.inf, float("nan")
    for f in f_ref * np.exp(np.linspace(math.log(0.5), math.log(2.0), 2800)):
        A = np.stack([np.ones_like(t), np.cos(2 * math.pi * f * t), np.sin(2 * math.pi * f * t)], axis=1)
        r = float(np.sum((A @ np.linalg.lstsq(A, w, rcond=None)[0] - w) ** 2))
        if r < best:
            best, f_best = r, float(f)
    return f_best


def _eval_cantilever(info: EngineInfo, tr: Trace) -> list[Check]:
    """Against Timoshenko beam theory (:func:`~gasp_core.testing.scenes_analytic.timoshenko_cantilever`;
    at L / h = 5 it is Euler-Bernoulli + 3.2 % deflection, - 2.5 % frequency).

    First frequency within CANT_FREQ_TOL = 5 %: measured -3.3 % on the two MLS-MPM engines at n_grid 32
    (-2.4 % at n_grid 40), from a sinusoid fit over the run's ~4 periods. Time-averaged tip deflection
    within CANT_TOL = 10 %: measured +5.1 % (+4.0 % at n_grid 40); the section is 3.2 cells thick, the
    clamp acts on whole grid nodes, and the time average over a non-integer number of periods keeps up
    to ~2 % of the oscillation."""
    from gasp_core.testing.scenes_analytic import timoshenko_cantilever
    x0 = tr.x[0]
    tip = x0[:, 0] > x0[:, 0].max() - 1e-9
    w = tr.x[:, tip, 2].mean(axis=1) - x0[tip, 2].mean()
    # Gravity switches on at t = 0: the bar oscillates about its static shape; the time average
    # over several periods (first mode ~4.3 Hz, run 1 s) is the static deflection.
    mean_defl = float(-w[1:].mean())
    expected, f_ref = timoshenko_cantilever(CANT_E, 0.0, CANT_RHO, CANT_L, CANT_H)
    rel = (mean_defl - expected) / expected
    f1 = _first_frequency(tr.t, w, f_ref)
    frel = (f1 - f_ref) / f_ref
    return [check("first_frequency", abs(frel), CANT_FREQ_TOL,
                   f"|f1 - f1_Timoshenko| / f1_Timoshenko (measured {f1:.3f} Hz, Timoshenko {f_ref:.3f} Hz, "
                   f"Euler-Bernoulli {1.8751 ** 2 / (2 * math.pi) * math.sqrt(CANT_E * CANT_H ** 2 / (12 * CANT_RHO * CANT_L ** 4)):.3f} Hz; "
                   f"signed {frel:+.3f})", measured=f1, expected=f_ref, signed=frel),
            check("tip_deflection", abs(rel), CANT_TOL,
                   f"|time-averaged tip deflection - Timoshenko| / Timoshenko "
                   f"(measured {mean_defl * 1e3:.2f} mm, Timoshenko {expected * 1e3:.2f} mm, Euler-Bernoulli "
                   f"{cantilever_deflection() * 1e3:.2f} mm, largest {-w.min() * 1e3:.2f} mm; signed {rel:+.3f})",
                   measured=mean_defl, expected=expected, signed=rel)]


# --- dam break (Martin & Moyce 1952) --------------------------------------------------------
#: Martin & Moyce (1952), Phil. Trans. R. Soc. A 244:312-324, square column (n^2 = 1,
#: a = 2.25 in), front Z = x/a vs T = t sqrt(2 g / a), as tabulated by Koshizuka & Oka (1996),
#: Nucl. Sci. Eng. 123:421-434 (a subset of the points).
MARTIN_MOYCE_T = np.array([0.84, 1.19, 1.63, 1.98, 2.32])
MARTIN_MOYCE_Z = np.array([1.22, 1.44, 1.89, 2.33, 2.78])
DAM_A = 0.15
#: max |Z_sim - Z_MM| / Z_MM over the five points: measured 0.105 on the two MLS-MPM engines (0.096 on
#: an earlier run), 0.100 on a third MPM, at n_grid 32; the largest error is at the last points (the
#: front lags as the layer thins to a cell or two). 0.15 passes that honest error and fails it with a
#: 5 % bias on top (0.105 + 0.05), where 0.25 (before issue 17) let a 14 % bias through.
DAM_TOL = 0.15


def _build_dam(info: EngineInfo) -> SimSetup:
    n_grid = 32
    length = 1.2
    dx = length / n_grid
    m = wall_margin(info, dx)
    depth = 0.1
    z0 = 3 * dx
    # symmetric column of width 2a and height a: the symmetry plane x = 0.6 acts as the dam wall
    x, p_vol = box_points((0.6 - DAM_A, m, z0), (0.6 + DAM_A, m + depth, z0 + DAM_A), dx / 2)
    K = 4e5  # bulk modulus, Pa: sound speed 20 m/s, ten times the front speed sqrt(2 g a)
    nu = 0.3
    E = 3 * K * (1 - 2 * nu)
    return make_setup(x, p_vol, Material("liquid", E=E, nu=nu, rho=1000.0), hi=(length, 2 * m + depth, 0.5),
                      n_grid=n_grid, frame_dt=0.01,
                      boundaries=[Boundary("ground", height=z0, friction=0.0), Boundary("walls", friction=0.0)])


def _eval_dam(info: EngineInfo, tr: Trace) -> list[Check]:
    T = tr.t * math.sqrt(2 * GRAVITY / DAM_A)
    # front: farthest point from the symmetry plane on each side, averaged
    right = tr.x[:, :, 0].max(axis=1) - 0.6
    left = 0.6 - tr.x[:, :, 0].min(axis=1)
    front = 0.5 * (right + left)
    Z = 1.0 + (front - front[0]) / DAM_A  # the outermost points start spacing/2 inside the column
    Zs = np.interp(MARTIN_MOYCE_T, T, Z)
    rel = np.abs(Zs - MARTIN_MOYCE_Z) / MARTIN_MOYCE_Z
    pts = ", ".join(f"T={a:.2f}: Z={b:.2f} vs {c:.2f}" for a, b, c in zip(MARTIN_MOYCE_T, Zs, MARTIN_MOYCE_Z))
    return [check("front_vs_martin_moyce", float(rel.max()), DAM_TOL,
                  f"max |Z_sim - Z_MM| / Z_MM ({pts})")]




SCENES_MATERIALS: list[Scene] = [
    Scene("cantilever", f"clamped square bar (L 0.5 m, h 0.1 m) under gravity: first frequency "
          f"within {CANT_FREQ_TOL:.0%} and time-averaged tip deflection within {CANT_TOL:.0%} of Timoshenko beam theory",
          Requires(frozenset({"jelly"}), frozenset({"fixed_region"})), _cantilever_builder(CANT_X0),
          50, _eval_cantilever),
    Scene("cantilever_offgrid", "the cantilever with its clamp face 0.6 dx past a grid node: same "
          f"Timoshenko tolerances ({CANT_FREQ_TOL:.0%} frequency, {CANT_TOL:.0%} deflection)",
          Requires(frozenset({"jelly"}), frozenset({"fixed_region"})),
          _cantilever_builder(CANT_X0_OFFGRID), 50, _eval_cantilever),
    Scene("dam_break", f"liquid square column collapse: front Z(T) vs Martin & Moyce 1952 within "
          f"{DAM_TOL:.0%}", Requires(frozenset({"liquid"}), frozenset({"ground", "walls"})),
          _build_dam, 25, _eval_dam),
]
