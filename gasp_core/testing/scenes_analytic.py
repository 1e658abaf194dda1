"""Conformance scenes with closed-form answers and two-sided tolerances (issue 17, "What to build" 2).

Every check here is two-sided: it fails an engine that is too stiff as well as one too soft, too
dissipative as well as one that gains energy. Each tolerance is stated beside its scene with the
errors measured on the installed engines (the two MLS-MPM engines, identical to
4 digits; the flex (tetrahedral) engine), so that ``conformance_tests/RESULTS.md`` reads measured error against
tolerance.

- ``bounce_hertz``: an elastic ball dropped on a frictionless ground; restitution in a band from
  the numerics and the contact duration against Hertz (Johnson 1985, *Contact Mechanics*, Sec. 11.4);
- ``self_weight_sag``: a column standing on a frictionless ground shortens by
  ``rho g H^2 / (2 E)`` (uniaxial stress, laterally free);
- ``bar_wave``: a thin bar hit at one end; the compression front runs at ``c = sqrt(E / rho)``;
- ``granular_collapse``: a sand column of aspect ratio a = 0.5 collapses; runout and final height
  against the scaling laws of Lube, Huppert, Sparks & Hallworth (2004) and Lajeunesse et al. (2004).

All use SI units, z up, and points at ``dx / 2`` (8 per cell).
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check, GRAVITY, make_setup, sphere_points
from gasp_core.testing.kit import Requires, Scene, Trace

__all__ = ["SCENES_ANALYTIC", "hertz_contact", "HERTZ_FORCE_FRAC", "timoshenko_cantilever"]


def _band(name: str, value: float, lo: float, hi: float, what: str, **figures) -> Check:
    """A two-sided :class:`Check`: passes when ``lo <= value <= hi`` (and finite)."""
    ok = bool(np.isfinite(value) and lo <= value <= hi)
    return Check(name, ok, f"{what} = {value:.4g} (band [{lo:.4g}, {hi:.4g}])",
                 {"value": float(value), "lo": float(lo), "hi": float(hi), **{k: float(v) for k, v in figures.items()}})


def timoshenko_cantilever(E: float, nu: float, rho: float, L: float, h: float, g: float = GRAVITY,
                          n_el: int = 200) -> tuple[float, float]:
    """Static tip deflection under self-weight and first bending frequency of a clamped-free bar of
    square section ``h x h``, Timoshenko beam theory (shear deformation and rotary inertia).

    Finite elements with linear ``w``, ``theta`` and one-point shear integration (free of shear
    locking, converged to < 0.1 % at 200 elements), shear coefficient ``kappa = 10 (1 + nu) /
    (12 + 11 nu)`` for a rectangle (Cowper 1966, J. Appl. Mech. 33:335). At ``h / L -> 0`` it gives
    Euler-Bernoulli: ``q L^4 / (8 E I)`` and ``f1 = 1.8751^2 / (2 pi) sqrt(E I / (rho A L^4))``.

    Returns
    -------
    deflection : float
        Tip deflection, m.
    f1 : float
        First bending frequency, Hz.
    """
    A, I = h * h, h ** 4 / 12.0
    Gs = E / (2.0 * (1.0 + nu))
    kappa = 10.0 * (1.0 + nu) / (12.0 + 11.0 * nu)
    le = L / n_el
    n = 2 * (n_el + 1)                                   # dofs (w_i, theta_i)
    K = np.zeros((n, n))
    M = np.zeros((n, n))
    kb = E * I / le * np.array([[0, 0, 0, 0], [0, 1, 0, -1], [0, 0, 0, 0], [0, -1, 0, 1]], float)
    b = np.array([-1.0 / le, -0.5, 1.0 / le, -0.5])     # shear strain w' - theta at the midpoint
    ks = kappa * Gs * A * le * np.outer(b, b)
    mw = rho * A * le / 6.0 * np.array([[2, 0, 1, 0], [0, 0, 0, 0], [1, 0, 2, 0], [0, 0, 0, 0]], float)
    mt = rho * I * le / 6.0 * np.array([[0, 0, 0, 0], [0, 2, 0, 1], [0, 0, 0, 0], [0, 1, 0, 2]], float)
    f = np.zeros(n)
    for e in range(n_el):
        d = slice(2 * e, 2 * e + 4)
        K[d, d] += kb + ks
        M[d, d] += mw + mt
        f[2 * e] += 0.5 * rho * g * A * le
        f[2 * e + 2] += 0.5 * rho * g * A * le
    free = slice(2, n)                                   # node 0 clamped
    Kf, Mf = K[free, free], M[free, free]
    w = np.linalg.solve(Kf, f[free])
    Lc = np.linalg.cholesky(Mf)
    Li = np.linalg.inv(Lc)
    lam = np.linalg.eigvalsh(Li @ Kf @ Li.T)
    return float(w[-2]), float(math.sqrt(lam[0]) / (2 * math.pi))


# --------------------------------------------------------------------------------------------
# Bounce: restitution and Hertz contact duration
# --------------------------------------------------------------------------------------------
BOUNCE_NGRID = 32
BOUNCE_R = 0.12                       # ball radius, m (3.84 dx)
BOUNCE_DROP = 0.14                    # gap between the ball and the ground at rest, m
BOUNCE_MAT = Material("jelly", E=2e5, nu=0.3, rho=1000.0)
BOUNCE_FPS = 240.0                    # ~16 frames per contact: the force profile is sampled finely
#: Share of the peak ground force above which the ball counts as in contact (both in the run and in
#: the Hertz reference, so that the two durations are measured alike).
HERTZ_FORCE_FRAC = 0.05
#: Restitution band. An elastic ball rebounds with e = 1 (Hertz + gravity is conservative); an
#: explicit MPM loses some energy in the grid transfers, and more the smaller its substep: measured
#: on the two MLS-MPM engines at n_grid 32, e = 0.853 (cfl 0.1), 0.909 (0.2), 0.939 (0.4, the default),
#: 0.958 (0.8 and 1.0); 0.885 at n_grid 16. The band admits that numerical dissipation, and no energy
#: gain beyond 2 %; a perfectly inelastic engine (e = 0) or one at half the energy (e = 0.71) fails.
RESTITUTION_BAND = (0.80, 1.02)
#: Contact duration, relative to Hertz. Measured (MPM, n_grid 32, R = 3.8 dx): +8.7 % at the default
#: cfl 0.4, +7.3 % (cfl 0.8) to +11.1 % (cfl 0.1); +43 % at n_grid 16 (R = 1.9 dx). The grid spreads
#: the contact over about one cell, which lengthens it; the error falls with dx. 0.15 is the
#: honest bound at this resolution (it cannot see a 5 % bias; the restitution band does the work of
#: catching a wrong bounce, this one a contact far too stiff or too soft: Hertz t_c goes as E^-2/5,
#: so 0.15 is E off by a factor 1.4).
HERTZ_TOL = 0.15


def hertz_contact(m: float, R: float, E_star: float, v: float, g: float = GRAVITY,
                  frac: float = HERTZ_FORCE_FRAC, n: int = 20000) -> dict[str, float]:
    """Hertz impact of an elastic sphere on a rigid plane, with gravity during the contact.

    Integrates ``m d'' = m g - k d^(3/2)``, ``k = (4/3) E* sqrt(R)``, from ``d = 0``, ``d' = v``
    until the sphere leaves (Johnson 1985, *Contact Mechanics*, Eq. 11.24 without gravity gives
    ``t_c = 2.87 (m^2 / (R E*^2 v))^(1/5)``).

    Parameters
    ----------
    m : float
        Mass, kg.
    R : float
        Radius, m.
    E_star : float
        Contact modulus ``E / (1 - nu^2)`` for a rigid plane, Pa.
    v : float
        Impact speed, m/s (> 0).
    frac : float
        Share of the peak force that bounds the "above threshold" duration.

    Returns
    -------
    dict
        ``t_formula`` (2.87 ..., s), ``t_contact`` (with gravity, s), ``t_above`` (time with force above
        ``frac`` of its peak, s), ``restitution`` (1 up to the integration error), ``F_max`` (N).
    """
    k = 4.0 / 3.0 * E_star * math.sqrt(R)
    t_formula = 2.87 * (m * m / (R * E_star * E_star * v)) ** 0.2
    dt = 2.0 * t_formula / n
    d, u, t = 0.0, v, 0.0
    ts, fs = [], []
    while d >= 0.0 or t == 0.0:  # velocity Verlet on the overlap d
        f = k * max(d, 0.0) ** 1.5
        u_half = u + 0.5 * dt * (g - f / m)
        d += dt * u_half
        f = k * max(d, 0.0) ** 1.5
        u = u_half + 0.5 * dt * (g - f / m)
        t += dt
        ts.append(t)
        fs.append(f)
    ts_a, fs_a = np.array(ts), np.array(fs)
    above = ts_a[fs_a > frac * fs_a.max()]
    return {"t_formula": t_formula, "t_contact": t, "t_above": float(above[-1] - above[0]),
            "restitution": -u / v, "F_max": float(fs_a.max())}


def _build_bounce(info: EngineInfo) -> SimSetup:
    dx = 1.0 / BOUNCE_NGRID
    ground = 3 * dx
    x, p_vol = sphere_points((0.5, 0.5, ground + BOUNCE_R + BOUNCE_DROP), BOUNCE_R, dx / 2)
    return make_setup(x, p_vol, BOUNCE_MAT, n_grid=BOUNCE_NGRID, frame_dt=1.0 / BOUNCE_FPS,
                  boundaries=[Boundary("ground", height=ground, friction=0.0)])


def _bounce_frames() -> int:
    v = math.sqrt(2 * GRAVITY * BOUNCE_DROP)
    return int(math.ceil((v / GRAVITY + 0.12 + 0.6 * v / GRAVITY) * BOUNCE_FPS))  # fall, contact, part of the rise


def ground_force(tr: Trace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertical ground force on the body averaged over each frame, from the momentum balance.

    Returns
    -------
    t_mid : ndarray, shape (n_frames,)
        Mid-frame times, s.
    F : ndarray, shape (n_frames,)
        ``M (dv_z / dt + g)``, N (zero in free flight).
    vz : ndarray, shape (n_frames + 1,)
        Mass-weighted mean vertical velocity per frame, m/s.
    """
    m = tr.p_mass
    M = m.sum()
    vz = np.einsum("i,fi->f", m, tr.v[:, :, 2]) / M
    T = tr.setup.frame_dt
    g = -float(tr.setup.gravity[2])
    return 0.5 * (tr.t[1:] + tr.t[:-1]), M * (np.diff(vz) / T + g), vz


def _eval_bounce(info: EngineInfo, tr: Trace) -> list[Check]:
    tm, F, vz = ground_force(tr)
    M = float(tr.p_mass.sum())
    Fmax = float(F.max())
    thr = HERTZ_FORCE_FRAC * Fmax
    idx = np.nonzero(F > thr)[0]
    fail = lambda why: [Check("rebound", False, why, {"F_max_over_Mg": Fmax / (M * GRAVITY)})]  # noqa: E731
    if Fmax < 0.5 * M * GRAVITY or len(idx) == 0:
        return fail(f"the ball never pressed on the ground (peak force {Fmax / (M * GRAVITY):.2f} M g)")
    i0, i1 = int(idx[0]), int(idx[-1])
    if i0 < 3:
        return fail("the ground force starts in the first frames: no free fall before the impact")
    if i1 + 4 >= len(F):
        return fail(f"the ball is still on the ground at the end of the run (ground force {F[-1] / (M * GRAVITY):.2f} "
                    f"M g in the last frame): no rebound")
    # threshold crossings, linearly interpolated between frame midpoints
    t_s = tm[i0 - 1] + (thr - F[i0 - 1]) / (F[i0] - F[i0 - 1]) * (tm[i0] - tm[i0 - 1])
    t_e = tm[i1] + (F[i1] - thr) / (F[i1] - F[i1 + 1]) * (tm[i1 + 1] - tm[i1])
    t = tr.t
    before = np.polyfit(t[1:i0], vz[1:i0], 1)            # free fall, frames fully before the contact
    after = np.polyfit(t[i1 + 2:], vz[i1 + 2:], 1)       # free flight after it
    v_in = -float(np.polyval(before, t_s))
    v_out = float(np.polyval(after, t_e))
    e = v_out / v_in
    mat = tr.setup.materials[0]
    R = BOUNCE_R
    hz = hertz_contact(M, R, mat.E / (1 - mat.nu ** 2), v_in)
    dur = t_e - t_s
    rel = dur / hz["t_above"] - 1.0
    return [_band("restitution", e, *RESTITUTION_BAND,
                  f"v_out / v_in at the contact's ends (v_in {v_in:.3f}, v_out {v_out:.3f} m/s; elastic: 1)",
                  v_in=v_in, v_out=v_out),
            check("hertz_duration", abs(rel), HERTZ_TOL,
                   f"|t_above / t_above_Hertz - 1| with t_above the time the ground force exceeds "
                   f"{HERTZ_FORCE_FRAC:.0%} of its peak (measured {dur * 1e3:.2f} ms, Hertz {hz['t_above'] * 1e3:.2f} ms; "
                   f"whole contact 2.87(m^2/(R E*^2 v))^(1/5) = {hz['t_formula'] * 1e3:.2f} ms, "
                   f"{hz['t_contact'] * 1e3:.2f} ms with gravity; signed error {rel:+.3f}; "
                   f"peak force {Fmax / (M * GRAVITY):.2f} M g vs Hertz {hz['F_max'] / (M * GRAVITY):.2f})",
                   measured=dur, expected=hz["t_above"], signed=rel)]


# --------------------------------------------------------------------------------------------
# Self-weight sag of a column
# --------------------------------------------------------------------------------------------
SAG_NGRID = 32
SAG_SIDE, SAG_H = 0.125, 0.25          # square column 4 x 4 x 8 dx, m
SAG_MAT = Material("jelly", E=1.2e5, nu=0.3, rho=1000.0)   # rho g H / E = 2 % strain at the base
SAG_FRAME_DT = 0.01
SAG_T = 0.6                            # ~6.6 periods of the first axial mode (quarter wave, ~11 Hz)
#: Relative error on the shortening (two-sided). Measured +1.7 % on the two MLS-MPM engines (n_grid 32),
#: +8.1 % on the flex (tetrahedral) engine (declared known failure). 5 % as the issue asks (3x the MPM error); E 10 %
#: off moves the sag by 11 %.
SAG_TOL = 0.05


def sag_shortening(z_b: float, z_t: float, H: float, rho: float, E: float, g: float = GRAVITY) -> float:
    """Shortening (m) between heights ``z_b < z_t`` (above the base) of a column of height ``H``
    under its own weight in uniaxial stress: ``sigma_zz = rho g (H - z)``, so
    ``delta = rho g ((H - z_b)^2 - (H - z_t)^2) / (2 E)``; ``rho g H^2 / (2 E)`` from base to top.

    Exact in linear elasticity for a column on a frictionless base with free sides (the lateral
    stresses vanish, so it does not depend on ``nu``); a base that holds the column laterally
    confines it there and shortens it less (fully confined: by ``(1 + nu)(1 - 2 nu) / (1 - nu)``,
    0.74 at ``nu = 0.3``).
    """
    return rho * g * ((H - z_b) ** 2 - (H - z_t) ** 2) / (2.0 * E)


def _build_sag(info: EngineInfo) -> SimSetup:
    dx = 1.0 / SAG_NGRID
    ground = 3 * dx
    c = 0.5
    x, p_vol = box_points((c - SAG_SIDE / 2, c - SAG_SIDE / 2, ground), (c + SAG_SIDE / 2, c + SAG_SIDE / 2,
                                                                      ground + SAG_H), dx / 2)
    return make_setup(x, p_vol, SAG_MAT, n_grid=SAG_NGRID, frame_dt=SAG_FRAME_DT,
                  boundaries=[Boundary("ground", height=ground, friction=0.0)])


def _fit_mean(t: np.ndarray, y: np.ndarray, f_lo: float, f_hi: float) -> tuple[float, float]:
    """``(a, f)`` of the least-squares fit ``a + b cos(2 pi f t) + c sin(2 pi f t)``, f searched on a
    log grid in ``[f_lo, f_hi]``: the level a signal oscillates about, and its frequency (Hz)."""
    best = (np.inf, float("nan"), float("nan"))
    for f in np.exp(np.linspace(math.log(f_lo), math.log(f_hi), 1500)):
        A = np.stack([np.ones_like(t), np.cos(2 * math.pi * f * t), np.sin(2 * math.pi * f * t)], axis=1)
        coef = np.linalg.lstsq(A, y, rcond=None)[0]
        r = float(np.sum((A @ coef - y) ** 2))
        if r < best[0]:
            best = (r, float(coef[0]), float(f))
    return best[1], best[2]


def _eval_sag(info: EngineInfo, tr: Trace) -> list[Check]:
    z0 = tr.x[0, :, 2]
    top = z0 > z0.max() - 1e-9
    bot = z0 < z0.min() + 1e-9
    length = tr.x[:, top, 2].mean(axis=1) - tr.x[:, bot, 2].mean(axis=1)   # bottom to top point layer
    short = length[0] - length
    mat = tr.setup.materials[0]
    ground = 3.0 / SAG_NGRID
    zb, zt = float(z0[bot].mean() - ground), float(z0[top].mean() - ground)
    expected = sag_shortening(zb, zt, SAG_H, mat.rho, mat.E)
    c_bar = math.sqrt(mat.E / mat.rho)
    f_ref = c_bar / (4 * SAG_H)
    level, f = _fit_mean(tr.t[1:], short[1:], 0.5 * f_ref, 2.0 * f_ref)
    rel = (level - expected) / expected
    return [check("sag", abs(rel), SAG_TOL,
                   f"|shortening - rho g (H^2 - ...)/(2E)| / expected, bottom to top point layer, level the "
                   f"axial oscillation is about (measured {level * 1e3:.4f} mm, expected {expected * 1e3:.4f} mm; "
                   f"rho g H^2/(2E) = {sag_shortening(0, SAG_H, SAG_H, mat.rho, mat.E) * 1e3:.4f} mm; oscillation "
                   f"{f:.1f} Hz, quarter wave c/(4H) {f_ref:.1f} Hz; signed {rel:+.4f})",
                   measured=level, expected=expected, signed=rel)]


# --------------------------------------------------------------------------------------------
# Bar wave speed
# --------------------------------------------------------------------------------------------
WAVE_NGRID = 32
WAVE_MAT = Material("jelly", E=1e5, nu=0.3, rho=1000.0)    # c = sqrt(E / rho) = 10 m/s
WAVE_V0 = 0.2                           # m/s: strain v0 / (2 c) = 1 %
WAVE_X = (0.05, 0.95)                   # bar ends, m
WAVE_SPLIT = 0.35                       # [0.05, 0.35] moves at v0, [0.35, 0.95] rests
WAVE_STATIONS = (0.45, 0.75)            # where the front's arrival is timed, m
WAVE_SIDE = 2.0 / WAVE_NGRID            # section 2 x 2 dx: width / path = 0.2, long-wave limit
WAVE_FRAME_DT = 1e-3
WAVE_T = 0.055
#: Relative error on c (two-sided). Measured +0.43 % on the two MLS-MPM engines (+0.78 % at cfl 0.1,
#: +0.12 % at nu = 0), -6.2 % on the flex (tetrahedral) engine (declared known failure). 1.5 %, about 3x the MPM error (the issue
#: asks for 3 %): E 10 % off moves c by 5 %.
WAVE_TOL = 0.015


def _build_wave(info: EngineInfo) -> SimSetup:
    dx = 1.0 / WAVE_NGRID
    h = WAVE_SIDE / 2
    x, p_vol = box_points((WAVE_X[0], 0.5 - h, 0.5 - h), (WAVE_X[1], 0.5 + h, 0.5 + h), dx / 2)
    v = np.zeros_like(x)
    v[x[:, 0] < WAVE_SPLIT, 0] = WAVE_V0
    # a domain 4 dx wider than the unit cube on each x face (same dx, same node alignment): the bar's ends
    # then lie 5.6 dx inside, clear of the 3 dx wall band of grid engines (an engine may refuse points there)
    pad = 4 * dx
    return make_setup(x, p_vol, WAVE_MAT, v=v, gravity=(0.0, 0.0, 0.0), lo=(-pad, 0.0, 0.0), hi=(1.0 + pad, 1.0, 1.0),
                      n_grid=WAVE_NGRID + 8, frame_dt=WAVE_FRAME_DT)


def _front_speed(tr: Trace) -> float:
    """Speed (m/s) of the step front between the two stations, timed where the resting part's velocity
    reaches half the step (v0 / 4); NaN when the front does not reach a station."""
    dx = tr.setup.dx
    x0 = tr.x[0, :, 0]
    times = []
    for xs in WAVE_STATIONS:
        u = tr.v[:, np.abs(x0 - xs) < 0.3 * dx, 0].mean(axis=1)
        k = np.nonzero(u > 0.25 * WAVE_V0)[0]
        if len(k) == 0 or k[0] == 0:
            return float("nan")
        i = int(k[0])
        times.append(tr.t[i - 1] + (0.25 * WAVE_V0 - u[i - 1]) / (u[i] - u[i - 1]) * (tr.t[i] - tr.t[i - 1]))
    return (WAVE_STATIONS[1] - WAVE_STATIONS[0]) / (times[1] - times[0])


def _eval_wave(info: EngineInfo, tr: Trace) -> list[Check]:
    """c from the momentum the compression front carries into the resting part.

    Across the front, momentum balance (Rankine-Hugoniot) gives ``[sigma] = rho c [v]``; the front
    lifts the resting part to ``v0 / 2`` at the stress ``rho c v0 / 2``, so that part's momentum grows
    as ``P(t) = (M / L) c (v0 / 2) t`` until the front reaches its far end. The slope of ``P(t)`` (fitted
    over 5-50 ms) gives c at long wavelengths, where a thin bar's c is ``sqrt(E / rho)``.

    The front's own arrival (half its height, or a pulse's peak) travels at the group velocity of the
    discretisation, which the grid's dispersion lowers: measured -6.1 % on MPM at n_grid 32 (-5.6 % at
    nu = 0, -3.0 % at n_grid 64 with a smooth pulse), -6.4 % on the flex (tetrahedral) engine. It is reported, not checked.
    """
    x0 = tr.x[0, :, 0]
    right = x0 > WAVE_SPLIT
    m = tr.p_mass
    P = tr.v[:, right, 0] @ m[right]
    m_line = float(m.sum()) / (WAVE_X[1] - WAVE_X[0])
    sel = (tr.t > 0.005) & (tr.t < 0.05)
    c = 2.0 * float(np.polyfit(tr.t[sel], P[sel], 1)[0]) / (m_line * WAVE_V0)
    mat = tr.setup.materials[0]
    c0 = math.sqrt(mat.E / mat.rho)
    lam_2mu = mat.E * (1 - mat.nu) / ((1 + mat.nu) * (1 - 2 * mat.nu))
    rel = (c - c0) / c0
    cf = _front_speed(tr)
    return [check("wave_speed", abs(rel), WAVE_TOL,
                   f"|c - sqrt(E/rho)| / sqrt(E/rho), c = 2 (dP/dt) / ((M/L) v0) from the momentum the front "
                   f"carries into the resting part (c {c:.3f} m/s, sqrt(E/rho) {c0:.3f} m/s, P wave "
                   f"{math.sqrt(lam_2mu / mat.rho):.3f} m/s; signed {rel:+.4f}; the front's half-height arrival "
                   f"between x = {WAVE_STATIONS[0]} and {WAVE_STATIONS[1]} m runs at {cf:.3f} m/s, the group velocity "
                   f"of the discretisation)", measured=c, expected=c0, signed=rel, front_speed=cf)]


SCENES_ANALYTIC: list[Scene] = [
    Scene("bounce_hertz", f"elastic ball (R {BOUNCE_R} m = 3.8 dx, E 2e5 Pa) dropped {BOUNCE_DROP} m on a "
          f"frictionless ground: restitution in [{RESTITUTION_BAND[0]}, {RESTITUTION_BAND[1]}] and the contact "
          f"duration within {HERTZ_TOL:.0%} of Hertz",
          Requires(frozenset({"jelly"}), frozenset({"ground"})), _build_bounce, _bounce_frames(), _eval_bounce),
    Scene("self_weight_sag", f"column {SAG_SIDE} x {SAG_SIDE} x {SAG_H} m (nu 0.3) standing on a frictionless "
          f"ground, sides free: shortening rho g H^2 / (2E) (uniaxial stress) within {SAG_TOL:.0%}",
          Requires(frozenset({"jelly"}), frozenset({"ground"})), _build_sag, round(SAG_T / SAG_FRAME_DT), _eval_sag),
    Scene("bar_wave", f"thin bar (2 x 2 dx, nu 0.3, no gravity), one part set moving into the rest: the "
          f"compression front runs at sqrt(E/rho) within {WAVE_TOL:.0%}",
          Requires(frozenset({"jelly"})), _build_wave, round(WAVE_T / WAVE_FRAME_DT), _eval_wave),
]
