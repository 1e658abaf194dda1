"""The ``constrain`` key of a set impulse (round 44, GASP issue 66 item 1; docs/colliders.md "[[impulse]]"):
``"all"`` (default) imposes every velocity component, ``"along"`` only the one along ``velocity_change``'s direction
``a``, the components across it left as the grid update gives them (a finite-element code's per-degree-of-freedom
constraint, here in the frame of ``a``).

- the scene key: ``"all"`` or ``"along"``, ``"along"`` with ``mode = "set"`` and a nonzero ``velocity_change`` only;
  else one line naming ``constrain``; the model refuses the same built by hand;
- the tables: an ``"along"`` set impulse's mode is ``IMPULSE_SET_ALONG`` (2), counted by ``count_along``;
- both grid engines, the known answer: a free jelly block inside an ``"along"`` set box, gravity off, started at
  ``-0.5 a + u n`` (``n`` across ``a``, ``u`` 0.2 m/s), pulled at ``v`` 0.3 m/s along ``a = e_x`` and along ``a`` at
  45 deg in xy: its velocity is ``v a + u n`` within 1 % (two-sided, every point within 2 %) after 1 and 4 frames.

The catch: the same block in an ``"all"`` box (today's default) loses ``u`` (its velocity ``v a``) and fails.
"""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import gasp_core.mpm.grid_tables as gt
from gasp_core.colliders.model import Impulse
from gasp_core.errors import SceneError
from gasp_core.scene.extras import _impulse
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import box_points, make_setup

ENGINES = [e for e, mod in (("taichi_mpm", "gasp_taichi_mpm"), ("warp_mpm", "gasp_warp_mpm"))
           if importlib.util.find_spec(mod) is not None]
V_PULL, U_ACROSS, V_START = 0.3, 0.2, -0.5
FRAME_DT = 0.02
FRAMES = (1, 4)
TOL = 0.01
#: the pull's direction: along x, and at 45 deg in xy
ANGLES = (0.0, 45.0)


# --------------------------------------------------------------------------- the scene key
def _read(**keys):
    base = {"shape": "box", "lo": [0, 0, 0], "hi": [1, 1, 1], "velocity_change": [1, 0, 0], "mode": "set",
            "t0": 0.0, "t1": 0.5}
    return _impulse({**base, **keys}, "[[impulse]] #1", Path("s.toml"))


@pytest.mark.parametrize("keys, match", [
    ({"constrain": "normal"}, r"\[\[impulse\]\] #1\.constrain.*normal"),
    ({"constrain": 1}, r"\[\[impulse\]\] #1\.constrain"),
    ({"constrain": "Along"}, r"\[\[impulse\]\] #1\.constrain"),
    ({"constrain": "along", "mode": "add"}, r"\[\[impulse\]\] #1\.constrain: only mode = 'set' takes 'along'"),
    ({"constrain": "along", "velocity_change": [0, 0, 0]}, r"\[\[impulse\]\] #1\.constrain = 'along' needs a nonzero"),
])
def test_a_bad_constrain_is_one_line_naming_the_key(keys, match):
    with pytest.raises(SceneError, match=match) as e:
        _read(**keys)
    assert "\n" not in str(e.value)


def test_constrain_left_out_is_all_and_along_is_read():
    assert _read().constrain == "all" and _read(constrain="all").constrain == "all"
    assert _read(constrain="along").constrain == "along"
    assert _read(mode="add", constrain="all").constrain == "all"


@pytest.mark.parametrize("kw", [{"constrain": "x"}, {"constrain": "along", "mode": "add"},
                                {"constrain": "along", "velocity_change": (0.0, 0.0, 0.0)}])
def test_the_model_refuses_a_bad_constrain_built_by_hand(kw):
    with pytest.raises(SceneError, match="constrain"):
        Impulse("box", **{"velocity_change": (1.0, 0, 0), "t0": 0.0, "t1": 1.0, "mode": "set", **kw})


def test_the_tables_carry_along_as_its_own_set_mode():
    class S:
        colliders, forces = [], []
        impulses = [Impulse("box", (1.0, 0, 0), t1=1.0, mode="set", constrain="along"),
                    Impulse("box", (1.0, 0, 0), t1=1.0, mode="set"), Impulse("box", (1.0, 0, 0), t1=1.0)]
    ex = gt.grid_tables(S)
    modes = ex.impulses.reshape(-1, gt.IMPULSE_ROW)[:, gt.IM_MODE]
    assert modes.tolist() == [gt.IMPULSE_SET_ALONG, gt.IMPULSE_SET, gt.IMPULSE_ADD] and gt.count_along(ex) == 1
    S.impulses = S.impulses[1:]
    assert gt.count_along(gt.grid_tables(S)) == 0


# --------------------------------------------------------------------------- both engines
def frame(angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The pull's direction ``a`` and the direction ``n`` across it (both in xy, (3,))."""
    t = math.radians(angle_deg)
    return np.array([math.cos(t), math.sin(t), 0.0]), np.array([-math.sin(t), math.cos(t), 0.0])


def block_failures(engine: str, angle_deg: float, constrain: str) -> list[str]:
    """A jelly block (0.4-0.55 m, n_grid 16, f64, no gravity) started at ``V_START a + U_ACROSS n`` inside a set box
    (0.2-0.8 m) at ``V_PULL a`` with ``constrain``: its mean velocity after :data:`FRAMES` against ``V_PULL a +
    U_ACROSS n`` (what ``"along"`` must give), within :data:`TOL` of it, every point within twice that."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    a, n = frame(angle_deg)
    x, p_vol = box_points((0.4, 0.4, 0.4), (0.55, 0.55, 0.55), 1.0 / 48)
    st = make_setup(x, p_vol, Material("jelly", E=5e4, nu=0.3, rho=1000.0),
                    v=np.tile(V_START * a + U_ACROSS * n, (len(x), 1)), gravity=(0, 0, 0), n_grid=16,
                    frame_dt=FRAME_DT, options={"precision": "f64"})
    st.impulses = [Impulse("box", tuple(V_PULL * a), t0=0.0, t1=1.0, mode="set", constrain=constrain,
                           lo=(0.2, 0.2, 0.2), hi=(0.8, 0.8, 0.8))]
    want = V_PULL * a + U_ACROSS * n
    eng = build_engine(engines()[engine], st)
    bad = []
    try:
        for f in range(1, max(FRAMES) + 1):
            eng.step_frame()
            if f in FRAMES:
                vel = np.asarray(eng.velocities(), np.float64)
                got = vel.mean(axis=0)
                err = float(np.linalg.norm(got - want) / np.linalg.norm(want))
                worst = float(np.abs(vel - want).max() / np.abs(want).max())
                if not err <= TOL or not worst <= 2 * TOL:
                    bad.append(f"{engine} {angle_deg:g} deg {constrain} frame {f}: mean v along {got @ a:.5f}, "
                               f"across {got @ n:.5f} against {V_PULL:g}, {U_ACROSS:g} (off by {100 * err:.2f} %, "
                               f"worst point {100 * worst:.2f} %)")
    finally:
        eng.close()
    return bad


@pytest.mark.parametrize("angle_deg", ANGLES)
@pytest.mark.parametrize("engine", ENGINES)
def test_an_along_set_box_imposes_the_pull_and_leaves_the_velocity_across_it(engine, angle_deg):
    bad = block_failures(engine, angle_deg, "along")
    assert bad == [], bad


@pytest.mark.parametrize("angle_deg", ANGLES)
@pytest.mark.parametrize("engine", ENGINES)
def test_the_check_catches_a_box_that_imposes_every_component(engine, angle_deg):
    """``"all"`` sets the block's velocity to ``V_PULL a``: the across part ``U_ACROSS`` is lost (55 % off)."""
    bad = block_failures(engine, angle_deg, "all")
    assert len(bad) == len(FRAMES) and all("across 0.00000" in b for b in bad), bad
