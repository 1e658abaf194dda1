"""Damping scenes: the free vibration of a bar, numerical and Kelvin-Voigt (issue 18).

``bar_viscous_decay``: a free-free bar (``nu = 0``, no gravity) set vibrating in its first longitudinal
mode, with the Kelvin-Voigt viscosity ``eta`` (:attr:`~gasp_core.seam.setup.Material.viscosity`). With
``nu = 0`` the bar is exactly one-dimensional (no lateral coupling, ``E = 2 mu``, P-wave modulus ``E``),
and the viscous stress ``2 eta D`` gives ``sigma_xx = E u_x + 2 eta u_xt``. The mode
``u = q(t) cos(k (x - x0))``, ``k = pi / L``, obeys

    ``q'' + 2 beta q' + omega0^2 q = 0``,  ``omega0 = k sqrt(E / rho)``,  ``beta = eta k^2 / rho``,

so it decays as ``exp(-beta t)`` at ``omega_d = sqrt(omega0^2 - beta^2)``: logarithmic decrement per period
``delta = 2 pi beta / omega_d`` (any elastic text with a Kelvin-Voigt solid, e.g. Graff, *Wave Motion in
Elastic Solids*, 1975, Sec. 8.1). The check fits ``A exp(-b t) cos(w t + phi)`` to the mode's velocity
amplitude and compares ``2 pi b / w`` with ``delta``, two-sided. :func:`bar_mode_decay` is also what
``benchmarks/bench_dissipation.py`` uses to measure the numerical decay (``eta = 0``).
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, make_setup
from gasp_core.testing.kit import Requires, Scene, Trace

__all__ = ["SCENES_DAMPING", "bar_mode_setup", "bar_mode_decay", "kelvin_voigt_decrement"]

BAR_NGRID = 32
BAR_L = 0.5                              # m, 16 dx at n_grid 32
BAR_SIDE = 2.0 / BAR_NGRID               # 2 x 2 dx section (nu = 0: any section is one-dimensional)
BAR_V0 = 0.05                            # m/s mode velocity amplitude: strain 0.5 %
BAR_E, BAR_RHO = 1e5, 1000.0             # c = 10 m/s, first mode 10 Hz
#: Viscosity of the check: damping ratio beta / omega0 = 0.2 (delta = 1.28 per period), large against the
#: transfers' own decrement (measured on MPM at n_grid 32, cfl 0.4: see docs/dissipation.md).
BAR_ETA = 0.2 * math.sqrt(BAR_E / BAR_RHO) * BAR_RHO * BAR_L / math.pi
BAR_FRAME_DT = 0.005
BAR_T = 0.3
#: Relative error on the log decrement (two-sided): 3x the honest error (issue 28). Measured +0.53 % on the
#: MLS-MPM engines at n_grid 32, cfl 0.4 (their own, numerical, decrement of this mode is 0.0025 per period,
#: 0.2 % of the physical one; docs/dissipation.md); a viscosity 5 % off moves it 5.2 %.
DECAY_TOL = 0.016


def kelvin_voigt_decrement(E: float, rho: float, eta: float, L: float) -> tuple[float, float, float]:
    """First longitudinal mode of a free-free Kelvin-Voigt bar (``nu = 0``).

    Returns
    -------
    beta : float
        Amplitude decay rate ``eta (pi / L)^2 / rho``, 1/s.
    omega_d : float
        Damped angular frequency, rad/s (NaN when overdamped).
    delta : float
        Logarithmic decrement per period ``2 pi beta / omega_d``.
    """
    k = math.pi / L
    w0 = k * math.sqrt(E / rho)
    beta = eta * k * k / rho
    wd = math.sqrt(w0 * w0 - beta * beta) if beta < w0 else float("nan")
    return beta, wd, 2.0 * math.pi * beta / wd


def bar_mode_setup(eta: float = BAR_ETA, n_grid: int = BAR_NGRID, frame_dt: float = BAR_FRAME_DT,
                   options: dict | None = None) -> SimSetup:
    """The bar of ``bar_viscous_decay`` (first mode, ``v_x = V0 cos(pi (x - x0) / L)``) at any grid."""
    dx = 1.0 / n_grid
    side = max(BAR_SIDE, 2.0 * dx)
    x0 = 0.5 - BAR_L / 2
    x, p_vol = box_points((x0, 0.5 - side / 2, 0.5 - side / 2), (x0 + BAR_L, 0.5 + side / 2, 0.5 + side / 2), dx / 2)
    v = np.zeros_like(x)
    v[:, 0] = BAR_V0 * np.cos(math.pi * (x[:, 0] - x0) / BAR_L)
    mat = Material("jelly", E=BAR_E, nu=0.0, rho=BAR_RHO, viscosity=eta)
    return make_setup(x, p_vol, mat, v=v, gravity=(0.0, 0.0, 0.0), n_grid=n_grid, frame_dt=frame_dt,
                      options=options)


def bar_mode_decay(tr: Trace) -> dict[str, float]:
    """Fit ``A exp(-b t) cos(w t + phi)`` to the first mode's velocity amplitude of a bar run.

    The amplitude is the mass-weighted projection of ``v_x`` on the mode shape at the initial positions.

    Returns
    -------
    dict
        ``beta`` (1/s), ``omega`` (rad/s), ``delta`` (log decrement per period ``2 pi b / w``), ``rms``
        (residual over the initial amplitude), ``ke_left`` (the kinetic energy's last peak over the first).
    """
    from scipy.optimize import curve_fit
    X = tr.x[0, :, 0]
    s = (X.max() - X.min()) / max(1, len(np.unique(np.round(X, 9))) - 1)   # lattice spacing along the bar
    x0, L = X.min() - s / 2, X.max() - X.min() + s                         # cell-centred: half a spacing each end
    phi = np.cos(math.pi * (X - x0) / L)
    m = tr.p_mass
    q = tr.v[:, :, 0] @ (m * phi) / float(m @ (phi * phi))
    t = tr.t
    w_guess = math.pi / L * math.sqrt(tr.setup.materials[0].E / tr.setup.materials[0].rho)

    def model(t, a, b, w, p):
        return a * np.exp(-b * t) * np.cos(w * t + p)

    try:
        (a, b, w, p), _ = curve_fit(model, t, q, p0=(q[0], 1.0, w_guess, 0.0), maxfev=20000)
    except RuntimeError:
        return {"beta": float("nan"), "omega": float("nan"), "delta": float("nan"), "rms": float("nan"), "ke_left": float("nan")}
    rms = float(np.sqrt(np.mean((model(t, a, b, w, p) - q) ** 2)) / abs(q[0]))
    ke = 0.5 * (tr.v ** 2).sum(axis=2) @ m
    peaks = [i for i in range(1, len(ke) - 1) if ke[i] >= ke[i - 1] and ke[i] >= ke[i + 1]]
    ke_left = float(ke[peaks[-1]] / ke[0]) if peaks else float("nan")
    return {"beta": float(b), "omega": abs(float(w)), "delta": 2 * math.pi * float(b) / abs(float(w)), "rms": rms,
            "ke_left": ke_left}


def _build(info: EngineInfo) -> SimSetup:
    return bar_mode_setup()


def _eval(info: EngineInfo, tr: Trace) -> list[Check]:
    mat = tr.setup.materials[0]
    beta, wd, delta = kelvin_voigt_decrement(mat.E, mat.rho, mat.viscosity, BAR_L)
    fit = bar_mode_decay(tr)
    rel = fit["delta"] / delta - 1.0
    ok = bool(np.isfinite(rel) and abs(rel) <= DECAY_TOL and fit["rms"] < 0.1)
    return [Check("kelvin_voigt_decrement", ok,
                  f"log decrement per period of the first mode {fit['delta']:.4f} vs Kelvin-Voigt {delta:.4f} "
                  f"(eta {mat.viscosity:.4g} Pa s; decay rate {fit['beta']:.3f} vs {beta:.3f} 1/s, omega "
                  f"{fit['omega']:.2f} vs {wd:.2f} rad/s; fit residual {fit['rms']:.3f} of the amplitude; "
                  f"signed {rel:+.4f}, tolerance {DECAY_TOL:.0%})",
                  {"value": abs(rel), "limit": DECAY_TOL, "signed": rel, "measured": fit["delta"], "expected": delta,
                   "beta": fit["beta"], "omega": fit["omega"], "rms": fit["rms"]})]


SCENES_DAMPING: list[Scene] = [
    Scene("bar_viscous_decay", f"free-free bar (L {BAR_L} m = 16 dx, nu 0, no gravity, eta {BAR_ETA:.0f} Pa s) "
          f"vibrating in its first longitudinal mode: log decrement 2 pi beta / omega_d, beta = eta k^2 / rho, "
          f"within {DECAY_TOL:.0%}",
          Requires(frozenset({"jelly"}), features=frozenset({"viscosity"})), _build, round(BAR_T / BAR_FRAME_DT),
          _eval),
]
