"""``model = "auto"`` sees what will land on a body (issue 53 item 4): a ball under a falling sand column is routed
by the load it will carry, and the line says so; the same ball alone, or beside the column, takes the rigid limit."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from gasp_core.prepare.route import loads, resolve_models
from gasp_core.seam import Boundary, Material, SimSetup
from gasp_core.mpm.substeps import CFL

R, RHO_BALL, E_BALL = 0.05, 1000.0, 1.0e6          # a rubber-like ball, resting on the ground
COLUMN = (0.06, 0.06, 0.15)                          # the sand column, m
RHO_SAND, LOW = 1500.0, 0.20                         # its bottom 10 cm over the ball's top


def _points(n, lo, hi, rng):
    return rng.uniform(lo, hi, (n, 3))


def scene(offset_x: float = 0.0, sand: bool = True) -> SimSetup:
    rng = np.random.default_rng(53)
    d = rng.normal(size=(3000, 3))
    ball = R * d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0, 1, (3000, 1)) ** (1 / 3) + [0.2, 0.2, R]
    xs, vols, ids = [ball], [np.full(3000, 4 / 3 * math.pi * R ** 3 / 3000)], [np.zeros(3000, int)]
    mats = [Material("jelly", E=E_BALL, nu=0.3, rho=RHO_BALL)]
    if sand:
        c = np.array([0.2 + offset_x, 0.2, LOW])
        col = _points(2000, c - [COLUMN[0] / 2, COLUMN[1] / 2, 0], c + [COLUMN[0] / 2, COLUMN[1] / 2, COLUMN[2]], rng)
        xs.append(col), vols.append(np.full(2000, np.prod(COLUMN) / 2000)), ids.append(np.ones(2000, int))
        mats.append(Material("sand", E=1e6, nu=0.3, rho=RHO_SAND))
    x = np.concatenate(xs)
    return SimSetup(x=x, v=np.zeros((len(x), 3)), p_vol=np.concatenate(vols), body_id=np.concatenate(ids),
                    materials=mats, gravity=np.array([0, 0, -9.81]), domain_lo=np.zeros(3),
                    domain_hi=np.full(3, 0.5), n_grid=40, boundaries=[Boundary("ground", height=0.0)])


def route(setup):
    names = ["ball", "sand"][:len(setup.materials)]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = resolve_models(setup, names, frozenset({"rigid_limit"}), CFL)
    return out[0], [str(x.message) for x in w]


def test_a_ball_under_a_sand_column_carries_its_load():
    s = scene()
    (load, nothing) = loads(s, ["ball", "sand"])
    sand_mass = RHO_SAND * np.prod(COLUMN)
    top = float(s.x[s.body_id == 0, 2].max())
    low = float(s.x[s.body_id == 1, 2].min())
    speed = math.sqrt(2 * 9.81 * (low - top))
    assert nothing is None                                          # nothing lands on the sand
    assert load["mass"] == pytest.approx(sand_mass, rel=1e-9) and load["speed"] == pytest.approx(speed, rel=1e-9)
    r, lines = route(s)
    volume = 4 / 3 * math.pi * R ** 3
    assert r["strain_load"] == pytest.approx(math.sqrt(sand_mass * speed ** 2 / (E_BALL * volume)), rel=1e-6)
    assert r["model"] == "elastic" and r["deformation_cells"] > 0.25
    assert "under the load of 'sand'" in r["why"]


def test_the_same_ball_alone_or_beside_the_column_is_rigid():
    for s in (scene(sand=False), scene(offset_x=0.15)):
        r, lines = route(s)
        assert r["model"] == "rigid", r["why"]
        assert r["strain_load"] == 0.0 and "load" not in r["why"]
        assert any("rigid limit" in line for line in lines)
