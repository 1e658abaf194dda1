"""Issue 67 items 1 and 3: a rigid block on a slope slides and sticks as Coulomb says, on both MPM engines.

The scene: a hardwood block (E 1e10 Pa, rho 700: ``material.model = "rigid"``, the route ``auto`` takes for it) of
6 x 6 x 2 cells of fill (15 x 15 x 5 cm at n_grid 24 in a 0.6 m box) set down on a flat ground of friction ``mu``,
gravity tilted by ``theta`` (``[g sin theta, 0, -g cos theta]``: the ground is a slope of ``theta``). Known answers
(Coulomb, a block on its face):

* ``tan theta > mu``: it slides with ``a = g (sin theta - mu cos theta)`` along the slope. Measured as twice the
  leading coefficient of a parabola fitted to its centroid's travel over ``SLIDE_T`` s from 0.05 s (the contact's
  first substeps excluded). Tolerance ``SLIDE_TOL`` = 2.5 %, two-sided: the issue asks 5 %; both engines read within
  0.01 % on all six sliding cases, and an engine biased by 5 % must fail.
* ``tan theta < mu``: it sticks: its centroid moves less than ``STICK_MM`` = 1 mm in ``STICK_T`` = 1 s (both engines:
  0.15-0.18 mm, almost all of it the contact's settling into the ground in the first frame; 0.02-0.12 mm along the
  slope).

Before issue 67 the block stuck at 30 degrees and mu 0.3 (a = -0.0003 m/s^2 against 2.357): the nodes' friction, made
Coulomb's on the body by the contact's balance, and the slide brake on the body as one each took the budget
``mu J``: twice the friction (``gasp_core.mpm.rigid_friction.coulomb_friction``, ``docs/rigid.md`` "Slopes").

The default tier runs two cases on each engine (a slide, a stick); the full 3 x 3 grid (15, 30, 45 degrees x mu 0.2,
0.4, 0.6) on both engines is slow. ``test_the_checks_catch_broken_engines`` runs the checks on engines broken on
purpose: the issue's (the node budget restored: the friction taken twice), one that ignores ``mu`` (the ground's
friction 0.4 whatever the scene says), one that never sticks (the friction halved: the 15 degree block at mu 0.4
slides), one that brakes at a rest speed (its motion held while the centroid is slower than 0.1 m/s) and one whose
acceleration is 5 % high.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup
from slopes import (ENGINES, G, centroids, closed_form, coulomb_figure, coulomb_problem, rest_brake,  # noqa: F401
                    slides)

N_GRID = 24
SIDE = 0.6
DX = SIDE / N_GRID
GROUND = 0.05
FPS = 60
SLIDE_T = 0.3
SLIDE_FROM = 0.05
SLIDE_TOL = 0.025
STICK_T = 1.0
STICK_MM = 1.0
#: The issue's grid.
THETAS = (15, 30, 45)
MUS = (0.2, 0.4, 0.6)
DEFAULT_CASES = ((30, 0.2), (15, 0.4))


def block_setup(theta: float, mu: float):
    """The block of the module docstring on a ground of friction ``mu``, gravity tilted ``theta`` degrees."""
    side = np.array([6 * DX, 6 * DX, 2 * DX])
    lo = np.array([4.3 * DX, SIDE / 2 - side[1] / 2 + 0.2 * DX, GROUND])
    x, p_vol = box_points(lo, lo + side, DX / 2)
    t = math.radians(theta)
    s = make_setup(x, p_vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0),
                   gravity=(G * math.sin(t), 0.0, -G * math.cos(t)), lo=np.zeros(3), hi=np.full(3, SIDE),
                   n_grid=N_GRID, frame_dt=1.0 / FPS, boundaries=[Boundary("ground", height=GROUND, friction=mu)])
    s.n_render = 0   # a fill: its surface half a spacing beyond its outer points
    return s


def measure(engine: str, theta: float, mu: float, spoil=None, output=None) -> float:
    """The measured figure: the acceleration along the slope (m/s^2) where it slides, the centroid's travel (mm) in
    ``STICK_T`` where it sticks. ``spoil(setup)`` and ``output(centroids)`` break the engine on purpose."""
    s = block_setup(theta, mu)
    if spoil is not None:
        spoil(s)
    c = centroids(engine, s, round((SLIDE_T if slides(theta, mu) else STICK_T) * FPS))
    if c is None:   # it slid out of the box
        return math.inf
    return coulomb_figure(c if output is None else output(c), theta, mu, FPS, SLIDE_FROM)


def check(theta: float, mu: float, figure: float) -> str | None:
    """None when the figure meets Coulomb, else what is wrong (two-sided)."""
    return coulomb_problem(theta, mu, figure, SLIDE_TOL, STICK_MM, STICK_T)


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("theta,mu", DEFAULT_CASES)
def test_rigid_block_on_a_slope(engine, theta, mu):
    problem = check(theta, mu, measure(engine, theta, mu))
    assert problem is None, f"{engine}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("theta", THETAS)
@pytest.mark.parametrize("mu", MUS)
def test_rigid_block_on_a_slope_grid(engine, theta, mu):
    problem = check(theta, mu, measure(engine, theta, mu))
    assert problem is None, f"{engine}: {problem}"


def _friction(factor=None, value=None):
    def spoil(s):
        s.boundaries = [Boundary("ground", height=b.height, friction=value if value is not None else b.friction * factor)
                        for b in s.boundaries]
    return spoil


def _rest_brake(c: np.ndarray, v_rest: float = 0.1) -> np.ndarray:
    """A broken engine braking to rest under ``v_rest`` m/s (the block gains 0.053 m/s a frame at 30 degrees and
    mu 0.2, so it never moves): :func:`slopes.rest_brake`."""
    return rest_brake(c, FPS, v_rest)


def _double_budget(monkeypatch, engine):
    """The engine of the issue: a rigid body's points give the nodes their friction budget again, on top of the
    friction on the body as one (the budget taken twice)."""
    if engine == "taichi_mpm":
        import taichi as ti
        from gasp_taichi_mpm.rigid import Rigid

        @ti.func
        def node_budget(self, p, budget):
            return budget
        monkeypatch.setattr(Rigid, "node_budget", node_budget)
        return True
    return False


@pytest.mark.parametrize("engine", ENGINES)
def test_the_checks_catch_broken_engines(engine, monkeypatch):
    # the real engine passes both default cases (test_rigid_block_on_a_slope); each broken one fails one of them
    slide, stick = DEFAULT_CASES
    caught = {
        "ignores mu (0.4 always)": check(*slide, measure(engine, *slide, spoil=_friction(value=0.4))),
        "never sticks (friction halved)": check(*stick, measure(engine, *stick, spoil=_friction(factor=0.5))),
        "brakes at a rest speed (0.1 m/s)": check(*slide, measure(engine, *slide, output=_rest_brake)),
        "5 % high": check(*slide, 1.05 * closed_form(*slide)),
        "5 % low": check(*slide, 0.95 * closed_form(*slide)),
    }
    if _double_budget(monkeypatch, engine):
        caught["the friction taken twice (issue 67)"] = check(*slide, measure(engine, *slide))
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the checks miss {missed}"


def test_coulomb_friction_reference():
    """``gasp_core.mpm.rigid_friction.coulomb_friction``: a block on its face (a wide patch) that needs less than ``mu J``
    is stopped at its contact point without a spin; one that needs more keeps ``u - mu J / M``; a ball on a point
    (no patch) takes the impulse through its effective mass at the contact, ``M / (1 + M R^2 / I)``, and spins up:
    ``omega R = v`` after a stopping impulse."""
    from gasp_core.mpm.rigid_friction import coulomb_friction
    M, n, c = 2.0, np.array([0.0, 0.0, 1.0]), np.zeros(3)
    I_block = np.diag([0.01, 0.01, 0.02])
    S_face = np.diag([0.05 ** 2 / 3, 0.05 ** 2 / 3, 0.0])   # a 10 cm face
    x_f = np.array([0.0, 0.0, -0.02])
    J = M * 9.81 * 0.01
    V, w = coulomb_friction([0.02, 0.0, 0.0], np.zeros(3), I_block, M, c, n, x_f, np.zeros(3), 0.5 * J, J, S_face)
    assert np.allclose(V, 0.0, atol=1e-12) and np.allclose(w, 0.0, atol=1e-12)   # sticks, no spin
    V, w = coulomb_friction([0.5, 0.0, 0.0], np.zeros(3), I_block, M, c, n, x_f, np.zeros(3), 0.5 * J, J, S_face)
    assert V[0] == pytest.approx(0.5 - 0.5 * J / M) and np.allclose(w, 0.0, atol=1e-12)   # slides, kinetic
    # a moving support: the same block at the support's speed needs no friction
    V, w = coulomb_friction([0.5, 0.0, 0.0], np.zeros(3), I_block, M, c, n, x_f, [0.5, 0.0, 0.0], 0.5 * J, J, S_face)
    assert np.allclose(V, [0.5, 0.0, 0.0])
    R = 0.05
    I_ball = np.eye(3) * 0.4 * M * R * R
    V, w = coulomb_friction([0.01, 0.0, 0.0], np.zeros(3), I_ball, M, c, n, [0.0, 0.0, -R], np.zeros(3), 10.0, J,
                            np.zeros((3, 3)))
    assert V[0] == pytest.approx(0.01 * 5.0 / 7.0) and w[1] * R == pytest.approx(V[0])   # rolls: omega R = v
