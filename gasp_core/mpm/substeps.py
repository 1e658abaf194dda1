"""Time step of a grid (MPM) engine: the stable substep, whole substeps per frame and the passive points' schedule.

``docs/mpm.md``, "Time step": ``dt = cfl dx / (c_p + v_max)`` (:func:`mpm_stable_dt`; the engine option
``cfl_rule``, default ``"sum"`` since round 54; ``"max"``: ``cfl dx / max(c_p, v_max)``, :data:`CFL_RULES`; a brittle
body's wave speed
at its impact, :func:`impact_wave_speed`; a viscous material lowers it, :func:`viscous_dt`), rounded to
whole substeps per frame (:func:`substeps_for`), bounded by :data:`MAX_SUBSTEPS`
(:func:`substeps_from_options`); :func:`passive_schedule` says at which substeps passive points move.
"""
from __future__ import annotations

import math
import sys
from typing import Any, Iterable, Mapping

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.seam.options import Option
from gasp_core.seam.setup import Material

#: The grid engines' default Courant number (engine option ``cfl``): ``dt = cfl dx / (c_p + v_max)``
#: (:data:`CFL_RULES`).
CFL = 0.4

#: The speeds the automatic substep divides by (engine option ``cfl_rule``): ``"sum"`` (the engines' default since
#: round 54), ``dt = cfl dx / (c_p + v_max)``, Courant's condition on the wave and the material speed together (a
#: brittle body's :func:`impact_wave_speed` already adds ``v_max``); ``"max"``, ``dt = cfl dx / max(c_p, v_max)`` (the
#: default until round 53). Measured (docs/fracture.md "Round 53: the jelly donut's elastic gain at cfl 0.8" and
#: "Round 54: cfl_rule sum is the default"; ``benchmarks/cfl_gain_probe.py``): the jelly donut thrown at 4.43 m/s,
#: n_grid 48, cfl 0.8, gains 8.7 % of its energy in the explicit elastic step with "max" (its points cross cells at
#: ``(c_p + |v|) dt / dx`` = 1.10 from the first substep), 2.75 % with "sum" at 1.63x the substeps (the README quick
#: start: 1.07x). "sum" is the default as the best step rule measured, though the gain stays over 1 % at cfl 0.8.
#: :data:`CFL_RULE` is every function's default here, so a caller of :func:`mpm_stable_dt` gets the engines' step.
CFL_RULES = ("max", "sum")

#: The default of ``cfl_rule`` (the engine option and :func:`mpm_stable_dt`, :func:`mpm_substeps`): ``"sum"``.
CFL_RULE = "sum"


def p_wave_speed(m: Material) -> float:
    """Dilatational (P-wave) speed of ``m``, m/s (:attr:`gasp_core.seam.setup.Material.p_wave_speed`)."""
    return m.p_wave_speed


def impact_wave_speed(m: Material, v_max: float) -> float:
    """The speed (m/s) the step rule takes for ``m`` when its bodies may land at up to ``v_max`` (m/s).

    ``c_p`` for every material but ``brittle``. A brittle body is Hencky-elastic in compression (its damage softens
    only tension), which stiffens as it is crushed: along a principal axis of log strain ``e < 0`` the Kirchhoff
    stress is ``M e``, so a plane wave runs at ``c_p sqrt(1 - e)`` in space (``rho_0 c_L^2 = dP/dlambda``, ``P = M
    ln(lambda) / lambda``, ``c = lambda c_L``). A landing at ``v`` compresses it to ``e = -v / c_p`` (the plane-wave
    impact stress ``rho c_p v`` over ``M``), and its points still move at up to ``v`` across the grid, so the
    information crosses a cell at ``c_p sqrt(1 + v / c_p) + v`` (Courant's condition on the wave and the material
    speed together; Belytschko, Liu & Moran 2000, Sec. 6.3). Measured (issue 66, ``docs/fracture.md``, "The brittle
    README donut"): the README donut at the brittle defaults (``c_p`` 11.6 m/s) landing at 4.43 m/s, ``cfl`` 0.8
    with ``max(c_p, v_max)``: ``(c_p + |v|) dt / dx`` 1.11 before it touched, a point crushed to 2 % of its length
    two substeps after, every point out of the grid at frame 1; at the step of this speed (22.1 m/s) it lands and
    crumbles. The other materials keep ``c_p`` (jelly's corotated pressure softens as it is crushed, and their
    frames are unchanged).
    """
    c = p_wave_speed(m)
    if m.name != "brittle" or c <= 0.0:
        return c
    v = max(float(v_max), 0.0)
    return c * math.sqrt(1.0 + v / c) + v


def mpm_stable_dt(materials: Iterable[Material], dx: float, gravity, height: float,
                  v0_max: float = 0.0, cfl: float = CFL, implicit_viscosity: bool = False,
                  rule: str = CFL_RULE) -> float:
    """Largest substep that satisfies the elastic-wave, particle CFL and viscous limits.

    ``dt = cfl * dx / (c_p + v_max)`` (``rule`` ``"sum"``, :data:`CFL_RULE`; ``"max"``: ``cfl dx / max(c_p,
    v_max)``; a brittle material's speed unchanged, :data:`CFL_RULES`) where ``c_p`` is the fastest P-wave speed
    over the materials (a brittle one's :func:`impact_wave_speed`) and ``v_max = v0_max + sqrt(2 |g| height)`` bounds the
    speed a falling body reaches in the domain; a material with viscosity caps it at ``cfl * viscous_dt``
    (:func:`viscous_dt`,
    about ``cfl rho dx^2 / (4 eta)`` when the viscosity dominates) unless the engine integrates the
    viscosity implicitly (``implicit_viscosity``: backward Euler, stable at any step; ``docs/dissipation.md``).

    Parameters
    ----------
    materials : iterable of Material
    dx : float
        Grid spacing, metres.
    gravity : array-like, shape (3,)
        m/s^2.
    height : float
        Vertical extent of the domain, metres.
    v0_max : float
        Largest initial speed, m/s.
    cfl : float
        Courant number in (0, 1].

    Returns
    -------
    float
        Seconds.

    Notes
    -----
    Fang et al. 2018 and the MLS-MPM reference code (Hu et al. 2018) use ``dt <= C dx / c_p`` with ``C`` about 0.3-0.5 for
    explicit MLS-MPM with quadratic B-splines.
    """
    materials = list(materials)
    g = float(np.linalg.norm(gravity))
    v_max = v0_max + math.sqrt(2.0 * g * max(height, 0.0))
    if rule not in CFL_RULES:
        raise SceneError(f"cfl_rule {rule!r}: expected one of {CFL_RULES}")
    add = v_max if rule == "sum" else 0.0
    c = max(impact_wave_speed(m, v_max) + (add if m.name != "brittle" else 0.0) for m in materials)
    caps = [] if implicit_viscosity else [viscous_dt(m, dx) for m in materials if m.viscosity > 0]
    return cfl * min([dx / max(c, v_max, 1e-12)] + caps)


def viscous_dt(m: Material, dx: float) -> float:
    """Stable explicit step of a Kelvin-Voigt material (:attr:`Material.viscosity` ``eta`` > 0), seconds, before ``cfl``.

    The grid's fastest mode, ``omega = 2 c / dx`` (``c`` the P-wave speed), is a damped oscillator with the
    damping ratio ``xi = omega tau / 2``, ``tau = 2 eta / (rho c^2)`` (longitudinal viscous over elastic
    modulus, bulk viscosity ``2 eta / 3``). Symplectic Euler on it is stable for
    ``dt <= (2 / omega) (sqrt(1 + xi^2) - xi)`` (Belytschko, Liu & Moran, *Nonlinear Finite Elements*, 2000,
    Sec. 6.3): ``dx / c`` without viscosity, tending to ``rho dx^2 / (4 eta)`` (the diffusion limit) when
    the viscosity dominates.
    """
    c = max(p_wave_speed(m), 1e-12)
    xi = 2.0 * m.viscosity / (m.rho * c * dx)
    return dx / c * (math.sqrt(1.0 + xi * xi) - xi)


def mpm_substeps(setup, dt: float | None = None, n_substeps: int | None = None,
                 cfl: float = CFL, implicit_viscosity: bool = False, rule: str = CFL_RULE) -> tuple[int, float]:
    """Substeps per frame and substep length for a grid engine (``docs/mpm.md``, "Time step").

    Parameters
    ----------
    setup : SimSetup
    dt : float, optional
        Requested substep, seconds (engine option ``dt``).
    n_substeps : int, optional
        Requested substeps per frame (engine option ``n_substeps``).
    cfl : float
        Courant number for :func:`mpm_stable_dt` when neither is given.
    implicit_viscosity : bool
        The engine integrates viscosity implicitly: no viscous cap (:func:`mpm_stable_dt`).
    rule : str
        ``"sum"`` (the default) or ``"max"`` (:data:`CFL_RULES`, engine option ``cfl_rule``).

    Returns
    -------
    n_substeps : int
    dt : float
        Seconds, ``setup.frame_dt / n_substeps``.
    """
    if dt is not None:
        dt_max = float(dt)
    elif n_substeps is not None:
        dt_max = setup.frame_dt / int(n_substeps)
    else:
        v0 = float(np.max(np.linalg.norm(setup.v, axis=1))) if len(setup.v) else 0.0
        dt_max = mpm_stable_dt(setup.materials, setup.dx, setup.gravity,
                               height=float(setup.domain_hi[2] - setup.domain_lo[2]), v0_max=v0,
                               cfl=float(cfl), implicit_viscosity=implicit_viscosity, rule=rule)
    return substeps_for(setup.frame_dt, dt_max)


def substeps_for(frame_dt: float, dt_max: float) -> tuple[int, float]:
    """Whole substeps per frame: ``n_substeps = ceil(frame_dt / dt_max)``, ``dt = frame_dt / n_substeps``; a
    ``dt_max`` so small that the ratio overflows (``dt = 1e-320``) counts as ``sys.maxsize`` substeps, which
    ``max_substeps`` then refuses (issue 68)."""
    ratio = frame_dt / dt_max
    n = max(1, math.ceil(ratio - 1e-9)) if math.isfinite(ratio) else sys.maxsize
    return n, frame_dt / n



#: Default bound on substeps per frame (engine option ``max_substeps``): the README donut needs 121.
MAX_SUBSTEPS = 20_000


def substeps_from_options(setup, options: Mapping[str, Any], engine: str = "",
                          implicit_viscosity: bool = False) -> tuple[int, float]:
    """:func:`mpm_substeps` with the engine options ``dt``, ``n_substeps``, ``cfl``, ``cfl_rule`` and ``max_substeps``
    (``implicit_viscosity``: the engine's viscosity needs no step cap).

    Raises
    ------
    SceneError
        More substeps per frame than ``max_substeps`` (default :data:`MAX_SUBSTEPS`): the message
        gives the count, what drives it (the stiffest material's wave speed, the fall speed or
        ``frame_dt``) and how to raise the bound, instead of a run that never finishes a frame.
    """
    n, dt = mpm_substeps(setup, options.get("dt"), options.get("n_substeps"), options.get("cfl", CFL),
                         implicit_viscosity, options.get("cfl_rule") or CFL_RULE)
    bound = options.get("max_substeps") or MAX_SUBSTEPS
    if n > bound:
        c = max(p_wave_speed(m) for m in setup.materials)
        raise SceneError(
            f"engine '{engine}': {n:.3g} substeps per frame (dt = {dt:.3g} s for frame_dt = {setup.frame_dt:g} s; "
            f"fastest wave {c:.3g} m/s, dx = {setup.dx:.3g} m) exceeds max_substeps = {bound}: lower E, the viscosity, frame_dt, "
            f"the speeds or n_grid, or raise the engine option max_substeps")
    return n, dt


#: Option of the grid engines with the feature ``passive_points`` (:func:`passive_schedule`).
#: Largest ``passive_every``: measured on the README donut at ``draft`` (``benchmarks/passive_every_drift.py``,
#: ``benchmarks/results/passive_every_drift.md``, 12 frames, 121 substeps a frame), the passive points stay
#: within 0.23 dx of where a gather every substep puts them up to 16 (0.14 dx at 16), leave the body by 4.1 dx at 32
#: and go non-finite at 64 (frame 3): the affine field extrapolated over many substeps detaches them (issue 41: 128
#: let the Gaussians drift 940 mm from a body that moved 52 mm).
MAX_PASSIVE_EVERY = 16

PASSIVE_EVERY = Option(
    "passive_every", 1, "move passive points every this many substeps, through the grid's affine velocity field "
    "(velocity and gradient gathered at the point, linear in time between updates; 1: every substep, plain G2P; "
    f"at most {MAX_PASSIVE_EVERY}: beyond it the surface leaves the body, benchmarks/passive_every_drift.py)",
    kind="int", lo=1, hi=MAX_PASSIVE_EVERY)


def passive_schedule(n_substeps: int, every: int, dt: float) -> list[tuple[int, float, float]]:
    """When a frame moves its passive points, and with which weights.

    A passive point is carried by the grid velocity: with an update after every substep ``s``,
    ``x += dt v_s`` (``v_s`` gathered at the point after the grid update of substep ``s``). Gathering
    only every ``m`` substeps, the velocity between two gathers ``v_prev`` (substep ``s - m``, the
    point's stored ``v``) and ``v_now`` (substep ``s``) is taken linear in the substep, which sums to

        ``x += a v_prev + b v_now``,  ``a = dt (m - 1) / 2``,  ``b = dt (m + 1) / 2``

    (``m = 1`` is the plain update: ``a = 0``, ``b = dt``). That alone moves the point in a straight
    line between gathers, so on a spinning body it drifts outward (``exp(pi omega (m - 1) dt) - 1`` a
    turn: 5.7 % at ``m = 4`` in the ``passive_spin`` scene). The engines therefore also gather the
    affine velocity gradient ``C`` (weighted least-squares over the nodes with mass; APIC's ``C`` on a
    full stencil) and advance through the affine field, linear in time as ``v``,

        ``y += dt (v_prev + (k/m)(v_now - v_prev) + (C_prev + (k/m)(C_now - C_prev)) y)``, ``k = 1..m``,

    then store ``v = v_now + C_now y`` (the field at the new position) and ``C = C_now``. With ``C = 0``
    this is the sum above; on the spinning sphere the mean radius after one turn is off by 0.0006 %
    at ``m = 4`` and 0.006 % at ``m = 8`` (0.0014 % at ``m = 1``). The error is second order in ``m dt`` where the grid velocity changes
    smoothly, and nothing crosses a frame: the last substep of every frame updates, so frames are
    written and saved states resumed with every point in place.

    Parameters
    ----------
    n_substeps : int
        Substeps per frame (>= 1).
    every : int
        ``m``, the engine option ``passive_every`` (>= 1); cut to ``n_substeps``.
    dt : float
        Substep length, s.

    Returns
    -------
    list of (int, float, float)
        ``(s, a, b)`` per update: after the grid update of substep ``s`` (0-based), move by
        ``a v_prev + b v_now`` (metres per m/s) when ``C = 0``; the interval is ``m = (a + b) / dt``
        substeps. At most two distinct ``(a, b)`` pairs occur.
    """
    every = max(1, min(int(every), int(n_substeps)))
    out, last = [], -1
    for s in range(n_substeps):
        if (s + 1) % every == 0 or s == n_substeps - 1:
            m = s - last
            out.append((s, dt * (m - 1) / 2.0, dt * (m + 1) / 2.0))
            last = s
    return out
