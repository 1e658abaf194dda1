"""The optional MPM toolkit: what every grid (MPM) engine of GASP shares, and nothing the seam needs.

Engines opt in by importing it; :mod:`gasp_core.engine` never does. It holds the declared options
of a grid engine (:data:`MPM_OPTIONS`), the stable time step and substeps (``docs/mpm.md``,
"Time step"), so that with the same scene every MPM engine runs the same ``dt`` and
``n_substeps``.
"""
from __future__ import annotations

import math
from typing import Iterable

import numpy as np

from .engine import Option
from .setup import Material


def p_wave_speed(m: Material) -> float:
    """Dilatational (P-wave) speed ``sqrt((lam + 2 mu) / rho)``, m/s.

    For ``liquid`` the shear modulus is not used: ``sqrt(lam' / rho)`` with the bulk modulus
    ``K = E / (3 (1 - 2 nu))``.
    """
    if m.name == "liquid":
        K = m.E / (3.0 * (1.0 - 2.0 * m.nu))
        return math.sqrt(K / m.rho)
    if m.name == "snow":  # hardening can stiffen the material up to exp(xi * theta_c) (Jp < 1)
        h = math.exp(m.hardening * m.theta_c)
        return math.sqrt(h * (m.lam + 2.0 * m.mu) / m.rho)
    return math.sqrt((m.lam + 2.0 * m.mu) / m.rho)


def mpm_stable_dt(materials: Iterable[Material], dx: float, gravity, height: float,
                  v0_max: float = 0.0, cfl: float = 0.4) -> float:
    """Largest substep that satisfies the elastic-wave and particle CFL limits.

    ``dt = cfl * dx / max(c_p, v_max)`` where ``c_p`` is the fastest P-wave speed over the
    materials and ``v_max = v0_max + sqrt(2 |g| height)`` bounds the speed a falling body reaches
    in the domain.

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
    Fang et al. 2018 / taichi_elements use ``dt <= C dx / c_p`` with ``C`` about 0.3-0.5 for
    explicit MLS-MPM with quadratic B-splines.
    """
    c = max(p_wave_speed(m) for m in materials)
    g = float(np.linalg.norm(gravity))
    v_max = v0_max + math.sqrt(2.0 * g * max(height, 0.0))
    return cfl * dx / max(c, v_max, 1e-12)


def mpm_substeps(setup, dt: float | None = None, n_substeps: int | None = None,
                 cfl: float = 0.4) -> tuple[int, float]:
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
                               cfl=float(cfl))
    return substeps_for(setup.frame_dt, dt_max)


def substeps_for(frame_dt: float, dt_max: float) -> tuple[int, float]:
    """Whole substeps per frame: ``n_substeps = ceil(frame_dt / dt_max)``, ``dt = frame_dt / n_substeps``."""
    n = max(1, math.ceil(frame_dt / dt_max - 1e-9))
    return n, frame_dt / n


#: The options every MPM engine of this project takes (``docs/mpm.md``); engines add their own.
MPM_OPTIONS = (
    Option("device", "cpu", "where to run: 'cpu' or 'cuda' ('cuda:N' picks a GPU)", kind="str",
           pattern=r"cpu|cuda(:\d+)?"),
    Option("precision", "f32", "floating-point precision of the solver", kind="str", choices=("f32", "f64")),
    Option("dt", None, "substep length, s (default: from cfl)", kind="number", lo=0.0, lo_open=True),
    Option("n_substeps", None, "substeps per frame (default: from cfl); not with dt", kind="int", lo=1),
    Option("cfl", 0.4, "Courant number of the automatic substep: dt = cfl dx / max(c_p, v_max)",
           kind="number", lo=0.0, hi=1.0, lo_open=True),
)


def check_time_options(options, engine: str) -> None:
    """Refuse ``dt`` and ``n_substeps`` given together (each is checked alone by its :class:`Option`).

    Raises
    ------
    SceneError
    """
    from .errors import SceneError
    if options.get("dt") is not None and options.get("n_substeps") is not None:
        raise SceneError(f"engine '{engine}': give option dt or option n_substeps, not both")
