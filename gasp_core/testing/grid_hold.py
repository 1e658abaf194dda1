"""The grid contact's hold near the stick limit (round 46, issue 67 item 3; docs/contact.md "Round 46: the grid
contact's hold near the limit"): :func:`hold_travel`, a block on a slope on ``contact = "grid"`` released, settled
first or damped, and :func:`ring`, the ground's loads on a block released with its base held. The scene is
:func:`gasp_core.testing.snow.slope_setup`'s (15 x 15 x 5 cm whatever ``n_grid``); ``benchmarks/grid_hold.py`` prints
the figures, ``tests/test_grid_hold.py`` checks them."""
from __future__ import annotations

import math

import numpy as np

SETTLE_S = 0.5
DAMPED_ETA = 200.0
HOLD_MU = 5.0


def _material(name: str, eta: float = 0.0):
    from gasp_core.seam.setup import Material
    from .snow import SNOW
    if name == "snow":
        return SNOW
    kw = {"viscosity": eta} if eta else {}
    return Material("jelly", model="elastic", E=1.0e5, nu=0.3, rho=1000.0, **kw)


def set_ground_mu(e, mu: float) -> None:
    """Write ground 0's friction into a built engine between frames (warp_mpm's ``ground`` table, taichi_mpm's
    ``ground_fric`` field)."""
    if hasattr(e, "ground") and hasattr(e.ground, "numpy"):
        g = e.ground.numpy()
        g[:, 1] = mu
        e.ground.assign(g)
    else:
        e.solver.ground_fric[0] = mu


def hold_travel(engine: str, material: str, variant: str, n: int, theta: float, mu: float,
                factor: float = 1.0, options: dict | None = None) -> float:
    """The block's centroid travel (mm, float; ``inf`` if it left the box) over 1 s from 0.1 s after the measured part
    starts. ``material``: ``"jelly"`` (E 1e5 Pa, nu 0.3, rho 1000 kg/m^3) or ``"snow"`` (the schema's defaults);
    ``variant``: ``"release"`` (put on the ground undeformed and let go, the tests' scene), ``"settled"`` (held
    ``SETTLE_S`` s on the ground's friction ``HOLD_MU``, then the ground's friction set to ``factor mu``) or
    ``"damped"`` (``release`` with the jelly's ``viscosity`` ``DAMPED_ETA`` Pa s: a damping ratio about 0.4 of the
    block's first compression mode, ``eta omega / (2 E)``, ``omega = pi c_p / (2 h)`` = 365 rad/s); ``n`` the grid;
    ``theta`` degrees; ``mu`` the ground's friction. ``factor`` breaks the engine's friction on purpose (the
    checks' catch: the engine's ground friction ``factor mu``, set after the settle or before the first frame);
    ``options`` (dict) overrides the engine options (``contact`` ``"grid"``; e.g. ``cfl``, or ``contact =
    "particle"`` for the other contact)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam import build_engine, get_engine
    from .snow import SLOPE_FPS, slope_setup
    mat = _material(material, DAMPED_ETA if variant == "damped" else 0.0)
    s = slope_setup(theta, HOLD_MU if variant == "settled" else mu, n, mat, {"contact": "grid", **(options or {})})
    e = build_engine(get_engine(engine), s)
    if factor != 1.0 and variant != "settled":
        set_ground_mu(e, factor * mu)
    try:
        if variant == "settled":
            for _ in range(round(SETTLE_S * SLOPE_FPS)):
                e.step_frame()
            set_ground_mu(e, factor * mu)
        c = []
        for _ in range(round(1.1 * SLOPE_FPS)):
            e.step_frame()
            c.append(e.positions().astype(np.float64).mean(axis=0))
    except EngineDivergence:
        return math.inf
    return 1000.0 * float(np.linalg.norm(c[-1] - c[round(0.1 * SLOPE_FPS) - 1]))


def ring(engine: str, n: int, theta: float) -> str:
    """The ground's loads on the jelly block released on friction ``HOLD_MU`` (its base held), read from the block's
    mean velocity each substep over the first 0.12 s (warp_mpm only: it steps single substeps through its
    ``_substeps``): a markdown line with the normal load over ``M g cos theta`` (2 ms means, min and max) and the
    share of the time where the tangential load over the normal exceeds ``tan theta / 0.96``."""
    from gasp_core.seam import build_engine, get_engine
    from .snow import slope_setup
    s = slope_setup(theta, HOLD_MU, n, _material("jelly"), {"contact": "grid"})
    e = build_engine(get_engine(engine), s)
    t, g, dt = math.radians(theta), 9.81, e.dt
    v0, nn, tt = e.velocities().astype(np.float64).mean(0), [], []
    for _ in range(int(0.12 / dt)):
        ns, e.n_substeps = e.n_substeps, 1
        e._substeps()
        e.n_substeps = ns
        v = e.velocities().astype(np.float64).mean(0)
        a, v0 = (v - v0) / dt, v
        nn.append((a[2] + g * math.cos(t)) / (g * math.cos(t)))
        tt.append((g * math.sin(t) - a[0]) / (g * math.cos(t)))
    w = max(1, int(0.002 / dt))
    mean = lambda a: np.convolve(np.asarray(a), np.ones(w) / w, mode="valid")   # noqa: E731
    nm, tm = mean(nn), mean(tt)
    over = float(np.mean(tm / np.maximum(nm, 1e-9) > math.tan(t) / 0.96))
    return (f"| ring | {engine} | n{n} | {theta:g} deg | normal load / M g cos: {nm.min():.3f} .. {nm.max():.3f} | "
            f"tangential / normal over tan theta / 0.96: {100 * over:.0f} % of 0.12 s | dt {dt:.3g} s |")




def slide_error(engine: str, material: str, n: int, theta: float, mu: float) -> float:
    """The released block's acceleration along the slope against Coulomb's ``g (sin theta - mu cos theta)``, as
    ``tests/test_elastic_slope.py`` measures it (twice the leading coefficient of a parabola fitted to the centroid's
    travel from 0.05 s to 0.3 s): the relative error (float, 0.01 = 1 %; ``inf`` if it left the box)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam import build_engine, get_engine
    from .snow import SLOPE_FPS, slope_setup
    s = slope_setup(theta, mu, n, _material(material), {"contact": "grid"})
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


__all__ = ["DAMPED_ETA", "HOLD_MU", "SETTLE_S", "hold_travel", "ring", "set_ground_mu", "slide_error"]
