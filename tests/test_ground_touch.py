"""The ground's contact detected from the points (issue 67, rounds 35-36; ``gasp_taichi_mpm.touch``,
``gasp_warp_mpm.touch``, docs/contact.md "Round 35: the contact detected from the points" and "Round 36: the touched
layer on both engines, the default", "Round 47: the touch test tied to the point's extent"): on both MPM engines, on
by default (``touch_contact`` True; a point of sand, snow or liquid touches under ``touch_delta`` 0.25 cells, a point
of a body that does not flow when its lowest extent, its height less half its own spacing ``h``, lies under
``touch_margin h`` above the plane, ``touch_margin`` 1).

The grid contact stops the node layers at and below a ground's plane; the free layer above takes 1/8 of the base's
shear and none of the ground's friction, so ``tests/test_elastic_slope.py``'s jelly block at 30 degrees, mu 0.6 creeps
119.5 mm in 1 s after the settle where Coulomb says it sticks (both engines, the switch off). With the switch on, that
layer takes the ground's Coulomb rule in the columns where a point of a flowing body lies under ``touch_delta`` cells
above the plane (a pass over the points after each P2G): 0.0008 mm on both engines; every slide of the 3 x 3 family
within 0.00 % of ``g (sin theta - mu cos theta)`` (docs/contact.md). A body rests about ``touch_delta`` above the
plane: a sand block dropped 10 cm (n_grid 32) rests with its lowest point 0.250 dx above it (0.155 with the switch
off; 1.19 with the layer stopped in every column, the catch ``touch_delta`` 1e9).

Checked here, on each engine: where the switch acts (default tier), the issue's 30 degrees at mu 0.6 held by default
and not with the switch off (default tier: the catch), with the contact chosen per body only the flowing body's
columns marked (default tier; the catch: every body marking), the 3 x 3 family at both deltas (slow), the sand
block's rest within 0.3 dx of the rule before, and the catch: every column touched rests it more than a cell up
(slow).
"""
from __future__ import annotations

import numpy as np
import pytest
from slopes import ENGINES
from test_elastic_slope import MUS, THETAS, check, measure

from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, make_setup

DELTAS = (0.25, 0.5)
#: ``touch_margin`` values (of a point's half spacing, the jelly's test since round 47): the default and half of it.
MARGINS = (1.0, 0.5)


def _switch_class(engine: str):
    """The class that holds engine ``engine``'s switch (``touch_contact``, ``touch_delta``)."""
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate
        return GridUpdate
    from gasp_warp_mpm.engine import WarpMPMEngine
    return WarpMPMEngine


def touch(monkeypatch, engine: str, delta: float | None, attr: str = "touch_delta") -> None:
    """The switch on with ``attr`` (``touch_delta``, cells: sand, snow, liquid; ``touch_margin``, of a point's half
    spacing: the bodies that do not flow) = ``delta`` (None: off, the rule before)."""
    cls = _switch_class(engine)
    monkeypatch.setattr(cls, "touch_contact", delta is not None)
    if delta is not None:
        monkeypatch.setattr(cls, attr, float(delta))


def _solver(e):
    """The object holding ``touch_on`` and the touched columns (taichi_mpm's solver, or the warp_mpm engine)."""
    return getattr(e, "solver", e)


def marked(e) -> np.ndarray:
    """Ground 0's touched columns, (n_grid, n_grid) bool."""
    s = _solver(e)
    ng = int(s.n_grid)
    return np.asarray(s.ground_touch.to_numpy()[0] if hasattr(s.ground_touch, "to_numpy")
                      else s.ground_touch.numpy()[:ng * ng].reshape(ng, ng)) != 0


def _block(contact: str):
    x, vol = box_points((0.4, 0.4, 0.1), (0.5, 0.5, 0.15), 1.0 / 32)
    return make_setup(x, vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0), hi=(1, 1, 1), n_grid=16,
                      boundaries=[Boundary("ground", height=0.0625, friction=0.5)], options={"contact": contact})


@pytest.mark.parametrize("engine", ENGINES)
def test_the_switch_is_on_by_default_and_acts_on_the_grid_contacts_rule_only(engine, monkeypatch):
    cls = _switch_class(engine)
    assert cls.touch_contact is True and cls.touch_delta == 0.25 and cls.touch_margin == 1.0
    assert _solver(build_engine(get_engine(engine), _block("grid"))).touch_on is True
    assert _solver(build_engine(get_engine(engine), _block("particle"))).touch_on is False
    touch(monkeypatch, engine, None)
    assert _solver(build_engine(get_engine(engine), _block("grid"))).touch_on is False


@pytest.mark.parametrize("engine", ENGINES)
def test_the_block_holds_at_30_degrees_mu_0_6(engine, monkeypatch):
    problem = check(30, 0.6, measure(engine, 30, 0.6, "grid"))   # the default: the switch on
    assert problem is None, f"{engine}: {problem}"
    touch(monkeypatch, engine, None)   # the catch: the rule before creeps (119.5 mm)
    assert check(30, 0.6, measure(engine, 30, 0.6, "grid")) is not None


def _two_blocks() -> SimSetup:
    """A jelly block (x < 0.5) and a sand block (x > 0.5) on a ground at 0.125 m, their lowest points 0.05 dx above
    it (within ``touch_delta``), ``contact = "auto"`` (the contact chosen per body), n_grid 16."""
    dx = 1.0 / 16
    z = 0.125 - 0.2 * dx
    xj, vj = box_points((0.2, 0.4, z), (0.35, 0.6, z + 0.075), dx / 2)
    xs, vs = box_points((0.65, 0.4, z), (0.8, 0.6, z + 0.075), dx / 2)
    vol = np.concatenate([np.broadcast_to(vj, len(xj)), np.broadcast_to(vs, len(xs))])
    return SimSetup(x=np.vstack([xj, xs]), v=0.0, p_vol=vol,
                    body_id=np.repeat([0, 1], [len(xj), len(xs)]),
                    materials=[Material("jelly", E=1e5, nu=0.3, rho=1000.0),
                               Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16,
                    boundaries=[Boundary("ground", height=0.125, friction=0.5)], frame_dt=0.01,
                    options={"contact": "auto"})


@pytest.mark.parametrize("engine", ENGINES)
def test_with_the_contact_chosen_per_body_only_flowing_bodies_mark(engine):
    e = build_engine(get_engine(engine), _two_blocks())
    s = _solver(e)
    assert s.touch_on is True
    e.step_frame()
    cols = marked(e)
    assert cols[8:].any() and not cols[:8].any(), np.argwhere(cols)   # the sand's columns, none of the jelly's
    if hasattr(s.flows, "to_numpy"):   # the catch: every body marks -> the jelly's columns too
        s.flows.fill(1)
    else:
        s.flows.fill_(1)
    e.step_frame()
    assert marked(e)[:8].any()


@pytest.mark.slow
@pytest.mark.parametrize("margin", MARGINS)
@pytest.mark.parametrize("mu", MUS)
@pytest.mark.parametrize("theta", THETAS)
@pytest.mark.parametrize("engine", ENGINES)
def test_the_slope_family_meets_coulomb(engine, theta, mu, margin, monkeypatch):
    touch(monkeypatch, engine, margin, "touch_margin")   # the jelly block: the test of a body that does not flow
    problem = check(theta, mu, measure(engine, theta, mu, "grid"))
    assert problem is None, f"{engine}, touch_margin {margin}: {problem}"


def rest_gap(monkeypatch, engine: str, delta: float | None) -> float:
    """The lowest point's height above the plane (cells) of a sand block dropped 10 cm (n_grid 32), after 1.5 s."""
    from gasp_core.testing.kit import resolve_engine, run_trace
    touch(monkeypatch, engine, delta)
    n = 32
    dx, z0 = 1.0 / n, 3.0 / n
    x, vol = box_points((0.4, 0.4, z0 + 0.1), (0.6, 0.6, z0 + 0.2), dx / 2)
    sand = Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)
    s = make_setup(x, vol, sand, hi=(1, 1, 1), n_grid=n, frame_dt=0.02,
                   boundaries=[Boundary("ground", height=z0, friction=0.5)], options={"contact": "grid"})
    tr = run_trace(resolve_engine(engine), s, 75)
    assert np.abs(tr.v[-1]).max() < 0.02   # at rest
    return float((tr.x[-1][:, 2].min() - z0) / dx)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_dropped_block_rests_on_the_plane(engine, monkeypatch):
    gap = rest_gap(monkeypatch, engine, DELTAS[0])
    assert 0.0 <= gap < 0.3 + 0.155, (engine, gap)   # within 0.3 dx of the rule before (0.155 dx)
    gap = rest_gap(monkeypatch, engine, 1e9)   # the catch: every column touched (the layer stopped): a cell up
    assert gap > 1.0, (engine, gap)
