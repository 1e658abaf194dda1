"""Soft bodies resting on the grid contact sag as the static estimates say (round 49, issue 67; docs/contact.md "Round
49: the touched layer shares the column's Coulomb bound"): :func:`sag_ratio` for the family of
``tests/test_sag_family.py`` and ``benchmarks/sag_family.py``.

Each body is put on the ground at rest (its lowest points' extent on the plane), undeformed, with no damping, on
``contact = "grid"`` (ground friction 0.5), and its centre of mass's mean drop over ``N_FRAMES`` frames at ``FPS``
(0.6 s: about 3 periods of the sag's oscillation ``2 pi sqrt(delta / g)``, over which the mean drop is ``delta``) is
compared with the static estimate; the grid contact's offset off the ground (a fraction of a cell, independent of
``E``) is removed by subtracting the same run with ``10 E`` (as the plugin test ``test_sag.py``):
``ratio = (drop(E) - drop(10 E)) / (delta(E) - delta(10 E))``.

Shapes and estimates (``rho`` 300 kg/m^3, ``g`` 9.81 m/s^2, ``E* = E / (1 - nu^2)``):

* ``"ball"``, radius ``R`` = 6 cm, E 8000 Pa, nu 0.3: Hertz's sphere on a plane under its weight ``P = rho g 4/3 pi
  R^3``, approach ``(9 P^2 / (16 E*^2 R))^(1/3)`` (Johnson, "Contact Mechanics", 1985, Sec. 4.2; contact radius about
  0.4 R here), plus its vertical fibres' own shortening (a fibre of height ``H`` free to bulge, stress ``rho g (H -
  z)``: its centre of mass drops ``rho g H^2 / (3 E)``; over the ball, mass-weighted, ``4 rho g R^2 / (5 E)``).
* ``"block"``, 15 x 15 x 10 cm, E 3000 Pa, **nu 0**: a column under its own weight with no lateral strain at all (nu 0:
  neither the base's friction nor the bulge matters), exact in small strain: ``rho g H^2 / (3 E)``.
* ``"donut"``: the plugin test ``test_sag.py``'s README donut (Hertz line contact plus fibres), any engine.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

RHO, G, FPS, N_FRAMES = 300.0, 9.81, 30.0, 18
SIDE, GROUND, MU = 0.6, 0.05, 0.5
BALL_R, BALL_E, BLOCK, BLOCK_E, DONUT_E = 0.15, 20000.0, (0.15, 0.15, 0.10), 3000.0, 1500.0
ROOT = Path(__file__).resolve().parents[2]


def ball_sag(E: float, nu: float = 0.3, R: float = BALL_R) -> float:
    """The resting ball's centre-of-mass drop, m (float): Hertz's approach plus the fibres' shortening."""
    P = RHO * G * 4.0 / 3.0 * math.pi * R ** 3
    E_star = E / (1.0 - nu ** 2)
    return (9.0 * P ** 2 / (16.0 * E_star ** 2 * R)) ** (1.0 / 3.0) + 4.0 * RHO * G * R ** 2 / (5.0 * E)


def block_sag(E: float, H: float = BLOCK[2]) -> float:
    """The resting block's centre-of-mass drop with nu 0, m (float): ``rho g H^2 / (3 E)``."""
    return RHO * G * H ** 2 / (3.0 * E)


def donut_sag(E: float, a: float, nu: float = 0.3) -> float:
    """The resting donut's centre-of-mass drop, m (float; ``a`` its tube radius, m): Hertz's line contact plus the
    fibres' shortening (the plugin test ``test_sag.py``)."""
    w = RHO * G * math.pi * a ** 2
    E_star = E / (1.0 - nu ** 2)
    b = math.sqrt(4.0 * w * a / (math.pi * E_star))
    return 2.0 * w / (math.pi * E_star) * (math.log(4.0 * a / b) - 0.5) + RHO * G * a ** 2 / E


def body_setup(shape: str, E: float, n_grid: int):
    """The ball's or the block's :class:`~gasp_core.seam.setup.SimSetup` (two points a cell along each axis, its lowest
    points' extent on the ground's plane at ``GROUND``, domain ``[0, SIDE]^3``, ``contact = "grid"``, one thread)."""
    from gasp_core.seam.setup import Boundary, Material
    from .helpers import box_points, make_setup, sphere_points
    dx = SIDE / n_grid
    c = np.array([SIDE / 2, SIDE / 2, 0.0])
    if shape == "ball":
        x, p_vol = sphere_points(c, BALL_R, dx / 2)
        nu = 0.3
    else:
        half = np.array(BLOCK) / 2
        x, p_vol = box_points(c - half * [1, 1, 0], c + half * [1, 1, 2], dx / 2)
        nu = 0.0
    x = x + [0.0, 0.0, GROUND + 0.5 * p_vol ** (1.0 / 3.0) - x[:, 2].min()]
    mat = Material("jelly", model="elastic", E=E, nu=nu, rho=RHO)
    return make_setup(x, p_vol, mat, lo=np.zeros(3), hi=np.full(3, SIDE), n_grid=n_grid, frame_dt=1.0 / FPS,
                      boundaries=[Boundary("ground", height=GROUND, friction=MU)],
                      options={"contact": "grid", "threads": 1})


def _mean_drop(info, setup) -> float:
    from gasp_core.seam.runner import simulate
    xs, _ = simulate(info, setup, N_FRAMES)
    m = np.asarray(setup.p_mass, np.float64)
    zc = xs[:, :, 2] @ m / m.sum()
    return float(zc[0] - zc[1:].mean())


def donut_drop(engine: str, E: float, n_grid: int) -> tuple[float, float]:
    """The README donut's mean drop (m) and tube radius (m) on ``engine``, as ``test_sag.py``'s ``mean_drop``."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    scene = load_scene(ROOT / "examples" / "donut_jelly.toml")
    objs = [dataclasses.replace(o, position=(0.0, 0.0, 0.0), surface="passive", core_fraction=0.02,
                                material=dataclasses.replace(o.material, E=E, rho=RHO, viscosity=0.0))
            for o in scene.objects]
    scene = dataclasses.replace(scene, objects=objs, domain=dataclasses.replace(scene.domain, n_grid=n_grid),
                                engine=dataclasses.replace(scene.engine, name=engine))
    prep = prepare_scene(scene)
    setup = prep.setup
    setup.options = {**setup.options, "threads": 1, "contact": "grid"}
    a = 0.5 * float(np.ptp(setup.x[setup.material_mask, 2]))
    return _mean_drop(prep.info, setup), a


def sag_ratio(engine: str, shape: str, n_grid: int) -> tuple[float, float, float]:
    """``(ratio, measured, expected)``: the sag of ``shape`` (``"ball"``, ``"block"``, ``"donut"``) on ``engine`` at
    ``n_grid``, ``drop(E) - drop(10 E)`` (m) over the estimate's ``delta(E) - delta(10 E)`` (m), ``E`` the shape's
    (module docstring)."""
    if shape == "donut":
        (soft, a), (stiff, _) = donut_drop(engine, DONUT_E, n_grid), donut_drop(engine, 10 * DONUT_E, n_grid)
        expected = donut_sag(DONUT_E, a) - donut_sag(10 * DONUT_E, a)
    else:
        from gasp_core.seam.plugins import get_engine
        info = get_engine(engine)
        E = BALL_E if shape == "ball" else BLOCK_E
        soft, stiff = (_mean_drop(info, body_setup(shape, e, n_grid)) for e in (E, 10 * E))
        est = ball_sag if shape == "ball" else block_sag
        expected = est(E) - est(10 * E)
    return (soft - stiff) / expected, soft - stiff, expected
