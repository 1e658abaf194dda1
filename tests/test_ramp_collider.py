"""Issue 67 item 1 on a ``[[collider]]``: a rigid block on a ramp given as a closed mesh, gravity straight down, slides
and sticks as Coulomb says, on both MPM engines.

The ramp: a box 1.0 x 0.6 x 0.1 m built from geometry (its 12 triangles, tilted ``theta`` about y:
:func:`ramp_triangles`) and turned into a collider by ``gasp_core.colliders.sdf.collider_from_triangles``, the route
a ``[[collider]] mesh = ...`` takes (trimesh's exact signed distance), with friction ``mu``. The block:
``tests/test_rigid_slope.py``'s hardwood block (E 1e10 Pa, rho 700, ``material.model = "rigid"``; 6 x 6 x 2 cells
of fill at n_grid 24 in a 0.6 m box) set on the ramp's top face, gravity ``[0, 0, -g]``. Known answers (Coulomb, a
block on its face):

* ``tan theta > mu``: ``a = g (sin theta - mu cos theta)`` down the ramp: twice the leading coefficient of a parabola
  fitted to the centroid's travel along the ramp over ``SLIDE_T`` s from ``SLIDE_FROM`` s. Tolerance ``TOL`` = 5 %,
  two-sided (the issue's); both engines read within 0.01 %.
* ``tan theta < mu``: it sticks: its centroid moves less than ``STICK_MM`` = 1 mm in ``STICK_T`` = 1 s.

The default tier runs a slide (30 deg, mu 0.2) and a stick (15 deg, mu 0.4) on each engine; the issue's 3 x 3 grid
(15, 30, 45 degrees x mu 0.2, 0.4, 0.6) is slow. ``test_the_checks_catch_broken_engines`` fails engines broken on
purpose: one that ignores ``mu`` (the collider's friction 0.4 whatever the scene says), one that never sticks (the
friction halved), one that brakes at a rest speed (the block held while slower than 0.1 m/s) and figures 6 % off.
``test_a_ball_rolls_or_slips_on_the_mesh_ramp``: ``tests/test_rolling.py``'s ball on the 20 degree ramp.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest

from gasp_core.colliders.sdf import SDF_SPACING, collider_from_triangles
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import box_points, make_setup
from slopes import ENGINES, centroids, closed_form, coulomb_figure, coulomb_problem, rest_brake, slides

pytest.importorskip("trimesh", reason="mesh colliders need trimesh (the [mesh] extra)")

N_GRID = 24
SIDE = 0.6
DX = SIDE / N_GRID
FPS = 60
#: The block's bottom centre at the start, on the ramp's top face (m).
START = np.array([0.2, 0.3, 0.42])
RAMP_HALF = (0.5, 0.3, 0.05)
SLIDE_T = 0.3
SLIDE_FROM = 0.05
TOL = 0.05
STICK_T = 1.0
STICK_MM = 1.0
THETAS = (15, 30, 45)
MUS = (0.2, 0.4, 0.6)
DEFAULT_CASES = ((30, 0.2), (15, 0.4))
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
_FACES = np.array([(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
                   (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)])


def ramp_frame(theta: float) -> tuple[np.ndarray, np.ndarray]:
    """The ramp's outward normal and its downhill direction (unit vectors, world frame)."""
    t = math.radians(theta)
    return np.array([math.sin(t), 0.0, math.cos(t)]), np.array([math.cos(t), 0.0, -math.sin(t)])


def ramp_triangles(theta: float) -> np.ndarray:
    """The ramp's closed mesh: a box of half sides ``RAMP_HALF`` (downhill, across, normal) whose top face passes
    through ``START`` tilted ``theta`` degrees, shape (12, 3, 3), m."""
    n, s = ramp_frame(theta)
    b = _CORNERS * np.asarray(RAMP_HALF)
    centre = START + 0.3 * s - RAMP_HALF[2] * n
    world = centre + b[:, :1] * s + b[:, 1:2] * np.array([0.0, 1.0, 0.0]) + b[:, 2:] * n
    return world[_FACES]


@functools.lru_cache(maxsize=None)
def ramp_collider(theta: float):
    """The ramp's collider (its signed distance field from the mesh, once per ``theta``: trimesh takes about 1 s)."""
    return collider_from_triangles(ramp_triangles(theta), SDF_SPACING * DX, name="ramp", friction=0.0)


def ramp_setup(theta: float, mu: float):
    """The block on the ramp of friction ``mu``, gravity straight down."""
    n, s = ramp_frame(theta)
    col = dataclasses.replace(ramp_collider(theta), friction=mu)
    side = np.array([6 * DX, 6 * DX, 2 * DX])
    local, p_vol = box_points(-side * np.array([0.5, 0.5, 0.0]), side * np.array([0.5, 0.5, 1.0]), DX / 2)
    x = START + local[:, :1] * s + local[:, 1:2] * np.array([0.0, 1.0, 0.0]) + local[:, 2:] * n
    st = make_setup(x, p_vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                    hi=np.full(3, SIDE), n_grid=N_GRID, frame_dt=1.0 / FPS)
    st.n_render = 0   # a fill: its surface half a spacing beyond its outer points, on the ramp
    st.colliders = [col]
    return st


def measure(engine: str, theta: float, mu: float, spoil=None, output=None) -> float:
    """The acceleration down the ramp (m/s^2) where it slides, the centroid's travel (mm) in ``STICK_T`` where it
    sticks. ``spoil(setup)`` and ``output(centroids)`` break the engine on purpose."""
    s = ramp_setup(theta, mu)
    if spoil is not None:
        spoil(s)
    c = centroids(engine, s, round((SLIDE_T if slides(theta, mu) else STICK_T) * FPS))
    if c is None:   # it left the box
        return math.inf
    return coulomb_figure(c if output is None else output(c), theta, mu, FPS, SLIDE_FROM, ramp_frame(theta)[1])


def check(theta: float, mu: float, figure: float) -> str | None:
    """None when the figure meets Coulomb, else what is wrong (two-sided)."""
    return coulomb_problem(theta, mu, figure, TOL, STICK_MM, STICK_T)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("theta,mu", DEFAULT_CASES)
def test_rigid_block_on_a_mesh_ramp(engine, theta, mu):
    problem = check(theta, mu, measure(engine, theta, mu))
    assert problem is None, f"{engine}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("theta", THETAS)
@pytest.mark.parametrize("mu", MUS)
def test_rigid_block_on_a_mesh_ramp_grid(engine, theta, mu):
    problem = check(theta, mu, measure(engine, theta, mu))
    assert problem is None, f"{engine}: {problem}"


def _friction(factor=None, value=None):
    def spoil(s):
        s.colliders = [dataclasses.replace(c, friction=value if value is not None else c.friction * factor)
                       for c in s.colliders]
    return spoil


def _rest_brake(c: np.ndarray, v_rest: float = 0.1) -> np.ndarray:
    """A broken engine holding a body still under ``v_rest`` m/s, its whole speed (the block gains 0.053 m/s a frame
    at 30 degrees and mu 0.2): :func:`slopes.rest_brake`."""
    return rest_brake(c, FPS, v_rest, horizontal=False)


@pytest.mark.parametrize("engine", ENGINES)
def test_the_checks_catch_broken_engines(engine):
    # the real engine passes both default cases (test_rigid_block_on_a_mesh_ramp); each broken one fails one of them
    slide, stick = DEFAULT_CASES
    caught = {
        "ignores mu (0.4 always)": check(*slide, measure(engine, *slide, spoil=_friction(value=0.4))),
        "never sticks (friction halved)": check(*stick, measure(engine, *stick, spoil=_friction(factor=0.5))),
        "brakes at a rest speed (0.1 m/s)": check(*slide, measure(engine, *slide, output=_rest_brake)),
        "6 % high": check(*slide, 1.06 * closed_form(*slide)),
        "6 % low": check(*slide, 0.94 * closed_form(*slide)),
    }
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the checks miss {missed}"


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape,mu", (("ball", 0.5), ("ball", 0.05)))
def test_a_ball_rolls_or_slips_on_the_mesh_ramp(engine, shape, mu):
    """``tests/test_rolling.py``'s ball (and its checks: ``(5/7) g sin theta`` and ``omega R = v`` rolling, ``g (sin -
    mu cos)`` and the spin-up slipping, 5 % two-sided) on the 20 degree mesh ramp, gravity straight down, in a 0.8 m
    box at n_grid 32 (the same cell): the rolling law on a collider as on the ground."""
    import test_rolling as rl
    from gasp_core.testing.helpers import make_setup as setup_of
    n, s = ramp_frame(rl.THETA)
    x, vol, n_shell = rl.body_points(shape, np.zeros(3))
    x = START + 0.15 * s + rl.R * n + x[:, :1] * s + x[:, 1:2] * np.array([0.0, 1.0, 0.0]) + x[:, 2:] * n
    st = setup_of(x, vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                  hi=np.full(3, 0.8), n_grid=32, frame_dt=1.0 / FPS)
    st.n_render = n_shell
    st.colliders = [dataclasses.replace(ramp_collider(rl.THETA), friction=mu)]
    c, v, w = rl.trace(engine, st)
    t = np.arange(len(c)) / FPS
    sel = t >= rl.FIT_FROM
    fig = {"a": 2.0 * float(np.polyfit(t[sel], (c[sel] - c[0]) @ s, 2)[0]), "wR": float(w[-1, 1]) * rl.R,
           "v": float(v[-1] @ s)}
    problem = rl.check(shape, mu, fig)
    assert problem is None, f"{engine}: {problem}"
