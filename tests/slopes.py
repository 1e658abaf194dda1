"""What the slope, ramp and rolling tests share (issue 67): the MPM engines as parameters, Coulomb's closed form, the
two-sided check of a measured figure against it, and the rest-speed brake that stands for a broken engine."""
from __future__ import annotations

import math

import numpy as np
import pytest

from gasp_core.errors import EngineDivergence
from gasp_core.seam import build_engine, engines, get_engine

G = 9.81
INSTALLED = engines()
ENGINE_NAMES = ("taichi_mpm", "warp_mpm")


def engine_param(e, marks=()):
    """Engine ``e`` as a pytest parameter, skipped where it is not installed."""
    return pytest.param(e, marks=[pytest.mark.skipif(e not in INSTALLED or INSTALLED[e].unavailable_reason()
                                                     is not None, reason=f"{e} not installed"), *marks])


ENGINES = [engine_param(e) for e in ENGINE_NAMES]


def closed_form(theta: float, mu: float) -> float:
    """Coulomb's acceleration along a slope of ``theta`` degrees (m/s^2), 0 where the block sticks."""
    t = math.radians(theta)
    return max(G * (math.sin(t) - mu * math.cos(t)), 0.0)


def slides(theta: float, mu: float) -> bool:
    return math.tan(math.radians(theta)) > mu


def coulomb_problem(theta: float, mu: float, figure: float, tol: float, stick_mm: float, stick_t: float,
                    after: str = "") -> str | None:
    """None when ``figure`` meets Coulomb, else what is wrong (two-sided): where the block slides, its acceleration
    (m/s^2) within ``tol`` of :func:`closed_form`; where it sticks, its travel (mm) in ``stick_t`` s (``after`` a
    settle, said in the message) under ``stick_mm``."""
    if slides(theta, mu):
        a0 = closed_form(theta, mu)
        err = figure / a0 - 1.0
        if not abs(err) <= tol:
            return f"{theta} deg, mu {mu}: a = {figure:.4f} m/s^2 against {a0:.4f} ({100 * err:+.2f} %)"
        return None
    if not figure < stick_mm:
        return f"{theta} deg, mu {mu}: it moved {figure:.3f} mm in {stick_t:g} s{after} (sticks: under {stick_mm} mm)"
    return None


def centroids(engine: str, s, frames: int) -> np.ndarray | None:
    """The centroid of ``s``'s points per frame on ``engine`` (frame 0 the start), shape ``(frames + 1, 3)`` (m); None
    where the engine stops on a divergence (a body that left the box: no figure meets Coulomb)."""
    e = build_engine(get_engine(engine), s)
    out = [np.asarray(s.x, np.float64).mean(axis=0)]
    try:
        for _ in range(frames):
            e.step_frame()
            out.append(e.positions().astype(np.float64).mean(axis=0))
    except EngineDivergence:
        return None
    finally:
        e.close()
    return np.array(out)


def coulomb_figure(c: np.ndarray, theta: float, mu: float, fps: float, slide_from: float, along=(1.0, 0.0, 0.0),
                   settle: int = 0) -> float:
    """What :func:`coulomb_problem` reads from the centroids ``c`` (frames + 1, 3): where the block slides, its
    acceleration along the unit vector ``along`` (m/s^2; twice the leading coefficient of a parabola fitted to its
    travel from ``slide_from`` s); where it sticks, its travel (mm) from frame ``settle`` to the last."""
    if slides(theta, mu):
        t = np.arange(len(c)) / fps
        sel = t >= slide_from
        return 2.0 * float(np.polyfit(t[sel], (c[sel] - c[0]) @ np.asarray(along, float), 2)[0])
    return 1000.0 * float(np.linalg.norm(c[-1] - c[settle]))


def landing_end(c: np.ndarray, fps: float, settle: int, v_stop: float = 1e-3) -> int | None:
    """The first frame from ``settle`` on after which the centroids ``c`` (frames + 1, 3; m) move slower than
    ``v_stop`` m/s over a frame: where a block released unstressed on a slope has finished its landing (it sags into
    its own weight, and the tangential speed gained while its base's normal force builds is taken off by friction at
    ``g (mu cos - sin)``, longer as ``tan / mu`` nears 1); None where it never slows so far."""
    v = np.linalg.norm(np.diff(c, axis=0), axis=1) * fps
    return next((f for f in range(settle, len(v)) if v[f] < v_stop), None)


def rest_brake(c: np.ndarray, fps: float, v_rest: float = 0.1, horizontal: bool = True) -> np.ndarray:
    """The centroids ``c`` (frames, 3) of an engine that holds a body still whenever its speed after a frame (its
    horizontal speed, or its whole speed) is under ``v_rest`` m/s: a speed threshold where Coulomb's force balance
    should decide."""
    out = c.copy()
    v = np.diff(c, axis=0) * fps
    u = np.zeros(3)
    for i in range(1, len(c)):
        u = u + (v[i - 1] - (v[i - 2] if i > 1 else 0.0))   # the engine's own change of velocity this frame
        if np.linalg.norm(u[:2] if horizontal else u) < v_rest:
            u = np.zeros(3)
        out[i] = out[i - 1] + u / fps
    return out


def turn_deg(x0: np.ndarray, x: np.ndarray) -> float:
    """How far a body whose points moved from ``x0`` to ``x`` (n, 3; m) has turned about y, in degrees (negative:
    downhill, towards +x over the top): the rotation of the least-squares rigid fit (Kabsch) in the x-z plane."""
    a, b = x0 - x0.mean(axis=0), x - x.mean(axis=0)
    u, _, vt = np.linalg.svd(a[:, [0, 2]].T @ b[:, [0, 2]])
    r = vt.T @ u.T
    return math.degrees(math.atan2(r[1, 0], r[0, 0]))
