"""Slides and sticks over a family of shapes (issue 67, round 51; docs/contact.md "Round 51: slides over a family of
shapes"): the bodies a neighbour would build for ``tests/test_rigid_slope.py`` and ``tests/test_elastic_slope.py``'s
checks, each resting on a face it cannot tip over from, measured as those tests measure.

The family (:data:`SHAPES`, metres at size 1; :data:`SIZES` scales every length): boxes of other proportions (a thin
wide slab, a cube, a bar along the slope and one across it), a flat disc (a cylinder, axis normal to the ground), a
hexagonal prism on its face, and the bundled donut lying flat (``examples/data/donut_mesh.ply``, the real capture's
closed mesh, 20.5 x 20.5 x 8.6 cm; at 0.7 and 1, :data:`SIZES_OF`; inside by trimesh's test). Points: a lattice at
half a cell (``dx / 2``, cell-centred in the body's bounding box,
:func:`gasp_core.testing.helpers.box_points`) kept where inside the shape, ``p_vol`` the shape's volume over the
points, as :func:`gasp_core.testing.helpers.sphere_points` fills a ball. The ground (height ``GROUND``, friction
``mu``) is a slope of ``theta`` by gravity tilted ``[g sin theta, 0, -g cos theta]`` in a 0.6 m box.

Tipping (a block on a face of extent ``w`` along the slope and height ``h``): it sticks without tipping while the
ground's resultant passes inside its base, ``h / w < 1 / tan theta``; sliding, the kinetic friction ``mu N`` at the
base moves the resultant forward by ``mu h / 2``, so ``h / w < 1 / mu``. :func:`tip_margin` gives
``(h / w) max(tan theta, mu)`` (under 1: it cannot tip); ``w`` is the disc's diameter and the prism's flat-to-flat
width (its narrowest).

:func:`measure` returns the tests' figure: where ``tan theta > mu`` the acceleration along the slope (m/s^2, twice
the leading coefficient of a parabola fitted to the centroid's x from ``SLIDE_FROM`` to ``SLIDE_T`` s), else the
centroid's travel (mm) over ``STICK_T`` s after a settle of ``SETTLE_T`` s (the body is put down undeformed)."""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

G = 9.81
SIDE = 0.6
GROUND = 0.05
FPS = 60
SLIDE_FROM = 0.05
SLIDE_T = 0.3
SETTLE_T = 0.1
STICK_T = 1.0
#: name -> (kind, lengths in metres at size 1): box (x along the slope, y across, z up); disc (radius, height);
#: hex (circumradius, height; a flat side faces down the slope).
SHAPES = {
    "slab": ("box", (0.12, 0.12, 0.02)),
    "cube": ("box", (0.075, 0.075, 0.075)),
    "bar_along": ("box", (0.18, 0.06, 0.04)),
    "bar_across": ("box", (0.06, 0.18, 0.04)),
    "disc": ("disc", (0.06, 0.03)),
    "hex": ("hex", (0.06, 0.03)),
    "donut": ("mesh", "examples/data/donut_mesh.ply"),
}
SIZES = (1.0, 1.5)
#: Sizes other than :data:`SIZES`: the bundled donut (20.5 x 20.5 x 8.6 cm, lying flat) at 0.7 and its own size.
SIZES_OF = {"donut": (0.7, 1.0)}
ROOT = Path(__file__).resolve().parents[2]


def sizes(shape: str) -> tuple:
    """The sizes the family takes ``shape`` at (scale factors on its lengths)."""
    return SIZES_OF.get(shape, SIZES)


@functools.cache
def _mesh(path: str):
    """The closed mesh at ``path`` (relative to the repository), moved so its bounding box starts at the origin."""
    import trimesh
    m = trimesh.load(ROOT / path, force="mesh")
    m.apply_translation(-m.bounds[0])
    return m
MATERIALS = ("rigid", "jelly")


def material(name: str):
    """``"rigid"``: hardwood (E 1e10 Pa, nu 0.3, rho 700 kg/m^3, ``model = "rigid"``, tests/test_rigid_slope.py's);
    ``"jelly"``: E 1e5 Pa, nu 0.3, rho 1000 kg/m^3, ``model = "elastic"`` (tests/test_elastic_slope.py's)."""
    from gasp_core.seam.setup import Material
    if name == "rigid":
        return Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0)
    return Material("jelly", model="elastic", E=1.0e5, nu=0.3, rho=1000.0)


def extents(shape: str, size: float = 1.0) -> np.ndarray:
    """The bounding box's sides (m, shape (3,): along the slope, across, up)."""
    kind, d = SHAPES[shape]
    if kind == "mesh":
        return np.asarray(_mesh(d).extents, float) * size
    d = np.asarray(d, float) * size
    if kind == "box":
        return d
    if kind == "disc":
        return np.array([2 * d[0], 2 * d[0], d[1]])
    return np.array([math.sqrt(3.0) * d[0], 2 * d[0], d[1]])   # hex: flat-to-flat along x, vertex to vertex along y


def tip_margin(shape: str, theta: float, mu: float, size: float = 1.0) -> float:
    """``(h / w) max(tan theta, mu)`` (module docstring): under 1 the body cannot tip over its front edge."""
    e = extents(shape, size)
    return float(e[2] / e[0] * max(math.tan(math.radians(theta)), mu))


def shape_points(shape: str, size: float, n_grid: int) -> tuple[np.ndarray, float]:
    """The body's points (m, shape (n, 3) float64) standing on the ground, its front at ``4.3 dx`` from the box's low x
    face and centred across (0.2 dx off), and the volume per point (m^3): the shape's volume over n."""
    from gasp_core.testing.helpers import box_points
    dx = SIDE / n_grid
    kind, d = SHAPES[shape]
    e = extents(shape, size)
    lo = np.array([4.3 * dx, SIDE / 2 - e[1] / 2 + 0.2 * dx, GROUND])
    x, p_vol = box_points(lo, lo + e, dx / 2)
    if kind == "box":
        return x, p_vol
    if kind == "mesh":   # trimesh's inside test on the mesh scaled by size, its box on lo
        m = _mesh(d)
        x = x[m.contains((x - lo) / size)]
        return x, float(m.volume) * size ** 3 / len(x)
    d = np.asarray(d, float) * size
    c = lo + e / 2
    r = x[:, :2] - c[:2]
    if kind == "disc":
        keep = np.hypot(r[:, 0], r[:, 1]) <= d[0]
        vol = math.pi * d[0] ** 2 * d[1]
    else:   # a regular hexagon: its three pairs of flat sides, normals at 0, 60 and 120 degrees, at the apothem
        a = d[0] * math.sqrt(3.0) / 2.0   # apothem
        keep = np.ones(len(x), bool)
        for ang in (0.0, math.pi / 3, 2 * math.pi / 3):
            keep &= np.abs(r[:, 0] * math.cos(ang) + r[:, 1] * math.sin(ang)) <= a
        vol = 1.5 * math.sqrt(3.0) * d[0] ** 2 * d[1]
    x = x[keep]
    return x, vol / len(x)


def slides(theta: float, mu: float) -> bool:
    return math.tan(math.radians(theta)) > mu


def closed_form(theta: float, mu: float) -> float:
    """Coulomb's acceleration along a slope of ``theta`` degrees (m/s^2), 0 where the body sticks."""
    t = math.radians(theta)
    return max(G * (math.sin(t) - mu * math.cos(t)), 0.0)


def shape_setup(shape: str, size: float, mat: str, contact: str, n_grid: int, theta: float, mu: float):
    """The :class:`~gasp_core.seam.setup.SimSetup` of one case (module docstring); ``contact``: the engine option
    ``"particle"`` or ``"grid"``."""
    from gasp_core.seam.setup import Boundary
    from gasp_core.testing.helpers import make_setup
    x, p_vol = shape_points(shape, size, n_grid)
    t = math.radians(theta)
    s = make_setup(x, p_vol, material(mat), gravity=(G * math.sin(t), 0.0, -G * math.cos(t)), lo=np.zeros(3),
                   hi=np.full(3, SIDE), n_grid=n_grid, frame_dt=1.0 / FPS,
                   boundaries=[Boundary("ground", height=GROUND, friction=mu)], options={"contact": contact})
    s.n_render = 0   # a fill: its surface half a spacing beyond its outer points
    return s


def friction_spoil(factor: float = 1.0, value: float | None = None):
    """A broken engine's setup change: the ground's friction ``value`` whatever the scene says, or ``factor`` times."""
    from gasp_core.seam.setup import Boundary

    def spoil(s):
        s.boundaries = [Boundary("ground", height=b.height,
                                 friction=value if value is not None else b.friction * factor) for b in s.boundaries]
    return spoil


def centroid_trace(engine: str, s, seconds: float) -> np.ndarray:
    """The centroid per frame (frame 0 the start; m, shape (frames + 1, 3) float64); ``inf`` rows from a divergence
    on (it slid out of the box)."""
    from gasp_core.errors import EngineDivergence
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    e = build_engine(get_engine(engine), s)
    n = round(seconds * FPS)
    out = np.full((n + 1, 3), np.inf)
    out[0] = np.asarray(s.x, np.float64).mean(axis=0)
    try:
        for i in range(n):
            e.step_frame()
            out[i + 1] = e.positions().astype(np.float64).mean(axis=0)
    except EngineDivergence:
        pass
    return out


def figure(c: np.ndarray, theta: float, mu: float) -> float:
    """The measured figure of a centroid trace ``c`` (module docstring); ``inf`` if it diverged."""
    if not np.all(np.isfinite(c)):
        return math.inf
    if slides(theta, mu):
        t = np.arange(len(c)) / FPS
        sel = t >= SLIDE_FROM - 1e-9
        return 2.0 * float(np.polyfit(t[sel], c[sel, 0], 2)[0])
    return 1000.0 * float(np.linalg.norm(c[-1] - c[round(SETTLE_T * FPS)]))


def measure(engine: str, shape: str, size: float, mat: str, contact: str, n_grid: int, theta: float, mu: float,
            spoil=None, output=None) -> float:
    """:func:`figure` of one case; ``spoil(setup)`` and ``output(centroids)`` break the engine on purpose."""
    s = shape_setup(shape, size, mat, contact, n_grid, theta, mu)
    if spoil is not None:
        spoil(s)
    c = centroid_trace(engine, s, SLIDE_T if slides(theta, mu) else SETTLE_T + STICK_T)
    if output is not None:
        c = output(c)
    return figure(c, theta, mu)


def problem(theta: float, mu: float, fig: float, tol: float, stick_mm: float = 1.0) -> str | None:
    """None when ``fig`` meets Coulomb (two-sided: the slide's acceleration within ``tol`` of :func:`closed_form`,
    the stick's travel under ``stick_mm`` mm in ``STICK_T`` s after the settle), else what is wrong."""
    if slides(theta, mu):
        a0 = closed_form(theta, mu)
        err = fig / a0 - 1.0
        return None if abs(err) <= tol else f"a = {fig:.4f} m/s^2 against {a0:.4f} ({100 * err:+.2f} %)"
    return None if fig < stick_mm else f"moved {fig:.3f} mm in {STICK_T:g} s after the settle (sticks: < {stick_mm})"


def landing_error(engine: str, shape: str, size: float, n_grid: int, theta: float = 30.0, mu: float = 0.4,
                  v_land: float = 1.0, v_along: float = 1.6) -> float:
    """Round 52 (docs/contact.md "Round 52: one balance carried with the body", the review's family): the jelly body
    ``shape`` at ``size`` on the grid contact, thrown at the slope's plane at ``-v_land`` m/s and along +x (down the
    slope) at ``v_along`` m/s; over the landing's frame (``T`` = 1 / :data:`FPS`) the friction impulse per unit mass
    ``-(dV_x - g sin theta T)`` over ``mu`` times the normal one ``dV_z + g cos theta T`` (``V`` the mass centre's
    velocity), less 1 (float, 0.01 = 1 %): Coulomb's impulse law, 0 while the base slides forward
    (``gasp_core.testing.grid_hold.landing_error`` on the grid-hold block)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    s = shape_setup(shape, size, "jelly", "grid", n_grid, theta, mu)
    s.v = np.tile(np.array([float(v_along), 0.0, -float(v_land)]), (len(s.x), 1))
    e = build_engine(get_engine(engine), s)
    e.step_frame()
    v1 = np.asarray(e.velocities(), np.float64)
    m = np.asarray(s.p_mass, np.float64)
    dv = (m @ v1) / m.sum() - np.array([v_along, 0.0, -v_land])
    r, t = math.radians(theta), 1.0 / FPS
    return float(-(dv[0] - G * math.sin(r) * t) / (mu * (dv[2] + G * math.cos(r) * t)) - 1.0)
