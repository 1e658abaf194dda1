"""Round 51 (issue 67; docs/contact.md "Round 51: a rigid body on the grid contact"): a rigid body (hardwood, E 1e10
Pa, rho 700 kg/m^3, ``model = "rigid"``) on a ground under the engine option ``contact = "grid"``: the sink of a 7.5 cm
cube on a flat ground over 1.1 s, and the slides (30 deg, mu 0.3) and sticks (30 deg, mu 0.7) of a slab, a cube and a
disc on a slope (gravity turned by the slope's angle; the layout of the slide shapes of round 51: the body's front
4.3 dx from the box's low x face). Used by ``tests/test_rigid_grid_contact.py`` and
``benchmarks/rigid_grid_contact.py``."""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup

G = 9.81
SIDE, GROUND, FPS = 0.6, 0.05, 60
WOOD = Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0)
#: (kind, dims m): a 12 x 12 x 2 cm slab, a 7.5 cm cube, a disc of radius 6 cm and height 3 cm.
SHAPES = {"slab": ("box", (0.12, 0.12, 0.02)), "cube": ("box", (0.075, 0.075, 0.075)), "disc": ("disc", (0.06, 0.03))}


def points(shape: str, n_grid: int) -> tuple[np.ndarray, float]:
    """The body's points (m, shape (n, 3) float64) standing on the ground, its front 4.3 dx from the low x face,
    centred across (0.2 dx off), spacing dx / 2, and the volume per point (m^3). ``shape``: a key of :data:`SHAPES`."""
    dx = SIDE / n_grid
    kind, d = SHAPES[shape]
    e = np.array([2 * d[0], 2 * d[0], d[1]]) if kind == "disc" else np.asarray(d, float)
    lo = np.array([4.3 * dx, SIDE / 2 - e[1] / 2 + 0.2 * dx, GROUND])
    x, p_vol = box_points(lo, lo + e, dx / 2)
    if kind == "box":
        return x, p_vol
    c = lo + e / 2
    x = x[np.hypot(x[:, 0] - c[0], x[:, 1] - c[1]) <= d[0]]
    return x, math.pi * d[0] ** 2 * d[1] / len(x)


def setup(shape: str, n_grid: int, theta: float, mu: float):
    """A :class:`~gasp_core.seam.setup.SimSetup`: one rigid body on a ground tilted by ``theta`` degrees (gravity
    turned), friction ``mu``, ``contact = "grid"``, a 0.6 m box of ``n_grid`` cells, 60 frames/s."""
    x, p_vol = points(shape, n_grid)
    t = math.radians(theta)
    s = make_setup(x, p_vol, WOOD, gravity=(G * math.sin(t), 0.0, -G * math.cos(t)), lo=np.zeros(3),
                   hi=np.full(3, SIDE), n_grid=n_grid, frame_dt=1.0 / FPS,
                   boundaries=[Boundary("ground", height=GROUND, friction=mu)], options={"contact": "grid"})
    s.n_render = 0
    return s


def run(engine: str, s, seconds: float) -> list[np.ndarray]:
    """The points (m, shape (n, 3) float64) per frame, frame 0 the start, over ``seconds`` on engine ``engine``."""
    e = build_engine(get_engine(engine), s)
    out = [np.asarray(s.x, np.float64)]
    for _ in range(round(seconds * FPS)):
        e.step_frame()
        out.append(e.positions().astype(np.float64))
    return out


def sink(engine: str, n_grid: int) -> tuple[float, float, float]:
    """``(drop, low, skin)`` in cells: the cube's centroid drop over 1.1 s on a flat ground, its lowest point over the
    plane at the end, and the particle contact's skin (half a point spacing)."""
    s = setup("cube", n_grid, 0.0, 0.7)
    xs = run(engine, s, 1.1)
    return ((xs[0][:, 2].mean() - xs[-1][:, 2].mean()) / s.dx, (xs[-1][:, 2].min() - GROUND) / s.dx,
            0.5 * float(np.median(np.cbrt(s.p_vol))) / s.dx)


def slope_figure(engine: str, shape: str, n_grid: int, theta: float, mu: float) -> float:
    """A slide's acceleration (m/s^2, a parabola fit of the centroid from 0.05 s to 0.3 s) or a stick's travel (mm)
    in 1 s after a 0.1 s settle."""
    s = setup(shape, n_grid, theta, mu)
    slides = math.tan(math.radians(theta)) > mu
    c = np.array([x.mean(axis=0) for x in run(engine, s, 0.3 if slides else 1.1)])
    if slides:
        t = np.arange(len(c)) / FPS
        sel = t >= 0.05 - 1e-9
        return 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0])
    return 1000.0 * float(np.linalg.norm(c[-1] - c[round(0.1 * FPS)]))
