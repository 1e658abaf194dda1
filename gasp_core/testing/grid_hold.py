"""The grid contact's hold near the stick limit (round 46, issue 67 item 3; docs/contact.md "Round 46: the grid
contact's hold near the limit"): :func:`hold_travel`, a block on a slope on ``contact = "grid"`` released, settled
first or damped, and :func:`slide_error`, its acceleration against Coulomb's where it slides. The scene is
:func:`gasp_core.testing.snow.slope_setup`'s (15 x 15 x 5 cm whatever ``n_grid``); ``benchmarks/grid_hold.py`` prints
the figures, ``tests/test_grid_hold.py`` checks them."""
from __future__ import annotations

import math

import numpy as np

SETTLE_S = 0.5
DAMPED_ETA = 200.0
HOLD_MU = 5.0


def block_material(name: str, eta: float = 0.0):
    """The block's :class:`~gasp_core.seam.setup.Material`: ``"snow"`` (the schema's defaults) or the jelly (E 1e5 Pa,
    nu 0.3, rho 1000 kg/m^3, ``model = "elastic"``) with ``viscosity`` ``eta`` Pa s (none at 0)."""
    from gasp_core.seam.setup import Material
    from .snow import SNOW
    if name == "snow":
        return SNOW
    kw = {"viscosity": eta} if eta else {}
    return Material("jelly", model="elastic", E=1.0e5, nu=0.3, rho=1000.0, **kw)


def hold_travel(engine: str, material: str, variant: str, n: int, theta: float, mu: float,
                factor: float = 1.0, options: dict | None = None, set_mu=None) -> float:
    """The block's centroid travel (mm, float; ``inf`` if it left the box) over 1 s from 0.1 s after the measured part
    starts. ``material``: ``"jelly"`` (E 1e5 Pa, nu 0.3, rho 1000 kg/m^3) or ``"snow"`` (the schema's defaults);
    ``variant``: ``"release"`` (put on the ground undeformed and let go, the tests' scene), ``"settled"`` (held
    ``SETTLE_S`` s on the ground's friction ``HOLD_MU``, then ``set_mu(engine_object, factor mu)`` called: the
    caller's way to write the built engine's ground friction; ``ValueError`` without it) or
    ``"damped"`` (``release`` with the jelly's ``viscosity`` ``DAMPED_ETA`` Pa s: a damping ratio about 0.4 of the
    block's first compression mode, ``eta omega / (2 E)``, ``omega = pi c_p / (2 h)`` = 365 rad/s); ``n`` the grid;
    ``theta`` degrees; ``mu`` the ground's friction. ``factor`` breaks the engine's friction on purpose (the
    checks' catch: the ground's friction ``factor mu``, in the scene, or through ``set_mu`` after the settle);
    ``options`` (dict) overrides the engine options (``contact`` ``"grid"``; e.g. ``cfl``, or ``contact =
    "particle"`` for the other contact)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from .snow import SLOPE_FPS, slope_setup
    mat = block_material(material, DAMPED_ETA if variant == "damped" else 0.0)
    if variant == "settled" and set_mu is None:
        raise ValueError("hold_travel: the settled variant needs set_mu")
    s = slope_setup(theta, HOLD_MU if variant == "settled" else factor * mu, n, mat,
                    {"contact": "grid", **(options or {})})
    e = build_engine(get_engine(engine), s)
    try:
        if variant == "settled":
            for _ in range(round(SETTLE_S * SLOPE_FPS)):
                e.step_frame()
            set_mu(e, factor * mu)
        c = []
        for _ in range(round(1.1 * SLOPE_FPS)):
            e.step_frame()
            c.append(e.positions().astype(np.float64).mean(axis=0))
    except EngineDivergence:
        return math.inf
    return 1000.0 * float(np.linalg.norm(c[-1] - c[round(0.1 * SLOPE_FPS) - 1]))


def slide_error(engine: str, material: str, n: int, theta: float, mu: float, damped: bool = False,
                factor: float = 1.0) -> float:
    """The released block's acceleration along the slope against Coulomb's ``g (sin theta - mu cos theta)``, as
    ``tests/test_elastic_slope.py`` measures it (twice the leading coefficient of a parabola fitted to the centroid's
    travel from 0.05 s to 0.3 s): the relative error (float, 0.01 = 1 %; ``inf`` if it left the box). ``damped``: the
    jelly with ``viscosity`` ``DAMPED_ETA`` Pa s; ``factor`` breaks the engine's friction on purpose (the checks' catch:
    the scene's ground friction ``factor mu``, Coulomb's acceleration still read at ``mu``)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from .snow import SLOPE_FPS, slope_setup
    s = slope_setup(theta, factor * mu, n, block_material(material, DAMPED_ETA if damped else 0.0), {"contact": "grid"})
    e = build_engine(get_engine(engine), s)
    c = [np.asarray(s.x, np.float64).mean(axis=0)]
    try:
        for _ in range(round(0.3 * SLOPE_FPS)):
            e.step_frame()
            c.append(e.positions().astype(np.float64).mean(axis=0))
    except EngineDivergence:
        return math.inf
    t = np.arange(len(c)) / SLOPE_FPS
    sel = t >= 0.05
    a = 2.0 * float(np.polyfit(t[sel], np.array(c)[sel, 0], 2)[0])
    r = math.radians(theta)
    return a / (9.81 * (math.sin(r) - mu * math.cos(r))) - 1.0


LAND_GAP_DX = 0.0
LAND_FIT = (0.2, 0.45)


def landed_trace(engine: str, n: int, theta: float, mu: float, v_land: float, factor: float = 1.0,
                 frames: int | None = None, eta: float = 0.0) -> tuple:
    """Round 50 (docs/contact.md "Round 50: a slide after a landing"): the jelly block of :func:`slide_error` lifted
    ``LAND_GAP_DX`` cells off the slope's plane and thrown at it, normal velocity ``-v_land`` m/s (``v_land`` >= 0),
    on the grid contact. Returns ``(t, c)``: ``t`` the frame times (s, float64, ``(F + 1,)``, 0 the throw), ``c`` the
    centroid (m, float64, ``(F + 1, 3)``); ``None`` if the engine diverged. ``frames`` defaults to
    ``LAND_FIT[1]`` s; ``factor`` the catch's friction (the scene's ``factor mu``)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from .snow import SLOPE_FPS, slope_setup
    s = slope_setup(theta, factor * mu, n, block_material("jelly", eta), {"contact": "grid"})
    s.x = s.x + np.array([0.0, 0.0, LAND_GAP_DX * float(s.domain_hi[2] - s.domain_lo[2]) / n])
    s.v = np.tile(np.array([0.0, 0.0, -float(v_land)]), (len(s.x), 1))
    e = build_engine(get_engine(engine), s)
    c = [np.asarray(s.x, np.float64).mean(axis=0)]
    try:
        for _ in range(frames or round(LAND_FIT[1] * SLOPE_FPS)):
            e.step_frame()
            c.append(e.positions().astype(np.float64).mean(axis=0))
    except EngineDivergence:
        return None
    return np.arange(len(c)) / SLOPE_FPS, np.array(c)


def landed_slide_error(engine: str, n: int, theta: float, mu: float, v_land: float, factor: float = 1.0) -> float:
    """:func:`landed_trace`'s block after its landing: the acceleration along the slope (twice the leading
    coefficient of a parabola fitted to the centroid's x over ``LAND_FIT`` s) against Coulomb's ``g (sin theta - mu
    cos theta)``, the relative error (float, 0.01 = 1 %; ``inf`` if it diverged)."""
    tr = landed_trace(engine, n, theta, mu, v_land, factor)
    if tr is None:
        return math.inf
    t, c = tr
    sel = (t >= LAND_FIT[0] - 1e-9) & (t <= LAND_FIT[1] + 1e-9)
    a = 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0])
    r = math.radians(theta)
    return a / (9.81 * (math.sin(r) - mu * math.cos(r))) - 1.0


#: Round 52: the along-slope speed (m/s) of :func:`landing_error`'s throw, enough that its base slides through the
#: landing's frame on every slope of the family (it loses at most ``mu`` (1 + g cos theta / 60) < 1.2 m/s there).
LAND_ALONG = 1.6


def landing_error(engine: str, n: int, theta: float, mu: float, v_land: float, v_along: float = LAND_ALONG) -> float:
    """Round 52 (docs/contact.md "Round 52: one balance carried with the body"): Coulomb's impulse law over a
    landing on a slope: :func:`landed_trace`'s block thrown at the plane at ``-v_land`` m/s and along +x (down the
    slope) at ``v_along`` m/s; over the landing's frame (frame 0 to 1, ``T`` = 1 / ``SLOPE_FPS``) the friction
    impulse per unit mass ``-(dV_x - g_x T)`` over ``mu`` times the normal one ``dV_z + g_z T`` (``V`` the mass
    centre's velocity, ``g_x`` = g sin theta, ``g_z`` = g cos theta), less 1 (float, 0.01 = 1 %; ``inf`` if it
    diverged). The base slides forward throughout, so Coulomb's law makes it 0 whatever the block's ringing."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from .snow import SLOPE_FPS, slope_setup
    s = slope_setup(theta, mu, n, block_material("jelly"), {"contact": "grid"})
    s.v = np.tile(np.array([float(v_along), 0.0, -float(v_land)]), (len(s.x), 1))
    e = build_engine(get_engine(engine), s)
    try:
        e.step_frame()
        v1 = np.asarray(e.velocities(), np.float64)
    except EngineDivergence:
        return math.inf
    m = np.asarray(s.p_mass, np.float64)
    dv = (m @ v1) / m.sum() - np.array([v_along, 0.0, -v_land])
    r, g, t = math.radians(theta), 9.81, 1.0 / SLOPE_FPS
    return float(-(dv[0] - g * math.sin(r) * t) / (mu * (dv[2] + g * math.cos(r) * t)) - 1.0)


__all__ = ["DAMPED_ETA", "LAND_ALONG", "landing_error", "HOLD_MU", "SETTLE_S", "LAND_FIT", "LAND_GAP_DX",
           "block_material", "hold_travel", "landed_slide_error", "landed_trace", "slide_error"]
