"""The trapezoidal stress (round 69, issue 66 item 6 "No energy is gained"; ``stress_at = "trapezoid"``, warp_mpm's
``trapezoid.py``; docs/fracture.md "Round 69: the trapezoidal stress").

Fast, the known answer (``benchmarks/studies/free_vibration.py``): a free jelly bar in its first longitudinal mode, no
ground, no gravity, 4 periods at cfl 0.8. "trapezoid" keeps the energy that "start" keeps (within 2 %), and "mid"
loses it as a Rayleigh damping of coefficient ``dt/2`` predicts (the log of its energy kept against start's within 5
% of the prediction's: round 68's reading, measured). Its catch (a fresh process): the end gradient alone in the
increment and the midpoint (``trapezoid.TRAP_WEIGHT = 1``: round 68's "mid") fails the first check. taichi_mpm
takes "trapezoid" with one pass alone (``stress_passes`` > 1 refused); slow, its free bar and its catch
(``MidStress.trap_weight = 1``). Slow (both engines), the ledger's family: under "trapezoid" the elastic step's
gain read with its own offset (a whole step: ``free_vibration.py --ledger``; since round 70 the ledger books ``F``'s
owed increment, ``energy_ledger.OWED``, and reads it unpaired) stays under 1 % of the energy brought on
the ball at n_grid 32 and 48, 2 and 4.43 m/s, and the README jelly donut at cfl 0.8, and the energy left is within 3
points of "start"'s (no damping class); its catch (``TRAP_WEIGHT = 1``) leaves the ball at n_grid 32, 4.43 m/s 4
points lower.
"""
from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "benchmarks" / "studies"))

KEPT_TOL = 0.02       # the trapezoid's energy kept against start's, two-sided
DECAY_TOL = 0.05      # mid's log decay against the Rayleigh prediction's, two-sided
GAIN = 0.01           # tests/test_energy_ledger.py's gate
LEFT_TOL = 0.03       # the energy left against start's, two-sided (of E0)


def bar(at: str, weight: float | None = None, engine: str = "warp_mpm") -> dict:
    """``free_vibration.run`` on ``engine``, n_grid 32, cfl 0.8 (with warp_mpm's ``TRAP_WEIGHT`` set first in a fresh
    process)."""
    if weight is None:
        from free_vibration import run
        return run(engine, 32, 0.8, at, 1)
    code = ("import json, sys; sys.path[:0] = ['benchmarks', 'benchmarks/studies']; import gasp_warp_mpm.trapezoid "
            f"as t; t.TRAP_WEIGHT = {weight!r}; from free_vibration import run; "
            f"print(json.dumps(run('warp_mpm', 32, 0.8, {at!r}, 1)))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True, text=True,
                         env=os.environ.copy()).stdout
    return json.loads(out.strip().splitlines()[-1])


def kept_check(trap: dict, start: dict) -> bool:
    return abs(trap["kept"] / start["kept"] - 1.0) < KEPT_TOL


def rayleigh_ratio(mid: dict, start: dict) -> float:
    """The log of mid's energy kept against start's over the log that a damping ``beta = dt/2`` predicts."""
    from free_vibration import PERIODS
    w = start["omega_meas"]
    pred = -(mid["dt"] / 2) * w * w * (PERIODS - 1) * 2 * math.pi / mid["omega_bar"]
    return math.log(mid["kept"] / start["kept"]) / pred


@pytest.fixture(scope="module")
def free_bar():
    pytest.importorskip("gasp_warp_mpm")
    return {at: bar(at) for at in ("start", "mid", "trapezoid")}


def test_the_trapezoid_keeps_the_free_bars_energy(free_bar):
    assert kept_check(free_bar["trapezoid"], free_bar["start"]), (free_bar["trapezoid"]["kept"],
                                                                  free_bar["start"]["kept"])


def test_mid_damps_the_free_bar_as_rayleigh_damping_of_half_a_step(free_bar):
    r = rayleigh_ratio(free_bar["mid"], free_bar["start"])
    assert abs(r - 1.0) < DECAY_TOL, r


def test_the_free_bar_check_catches_the_end_gradient_alone(free_bar):
    """The catch: ``TRAP_WEIGHT = 1`` (the increment by the end gradient, the midpoint at ``(I + dt/2 C_n) F``)."""
    assert not kept_check(bar("trapezoid", weight=1.0), free_bar["start"])


def test_taichi_mpm_takes_the_trapezoid_of_one_pass_alone():
    from gasp_core.seam import EngineError
    flags = pytest.importorskip("gasp_taichi_mpm.mid_stress").stress_flags
    from gasp_taichi_mpm import TaichiMPMConfig as Cfg
    assert [flags(Cfg(stress_at=a)) for a in ("start", "mid", "trapezoid")] == [(False, False), (True, False),
                                                                               (False, True)]
    assert flags(True) == (True, False)
    with pytest.raises(EngineError, match="stress_passes"):
        flags(Cfg(stress_at="trapezoid", stress_passes=2))


def test_the_options_are_declared():
    from gasp_core.mpm.options import MPMConfig
    m = pytest.importorskip("gasp_warp_mpm")
    assert MPMConfig().stress_passes == 1
    assert m.WarpMPMConfig(stress_at="trapezoid", stress_passes=3).stress_passes == 3
    assert any(o.name == "stress_passes" for o in m.OPTIONS)


@pytest.mark.slow
def test_taichi_mpm_keeps_the_free_bars_energy_and_its_catch(monkeypatch):
    """taichi_mpm's trapezoid (one pass): the free bar as warp_mpm's check; its catch ``MidStress.trap_weight = 1``."""
    pytest.importorskip("gasp_taichi_mpm")
    from gasp_taichi_mpm.mid_stress import MidStress
    start = bar("start", engine="taichi_mpm")
    assert kept_check(bar("trapezoid", engine="taichi_mpm"), start)
    monkeypatch.setattr(MidStress, "trap_weight", 1.0)
    assert not kept_check(bar("trapezoid", engine="taichi_mpm"), start)


FAMILY = [("ball", 32, 2.0, None), ("ball", 32, 4.43, None), ("ball", 48, 2.0, None), ("ball", 48, 4.43, None),
          ("donut", 48, 4.43, 0.8)]


def family_run(body, n_grid, speed, cfl, at, weight=None, engine="warp_mpm") -> dict:
    if weight is None:
        from energy_ledger_family import run
        return run(body, engine, n_grid, speed, 40.0, cfl=cfl, stress_at=at)
    code = ("import json, sys; sys.path[:0] = ['benchmarks']; import gasp_warp_mpm.trapezoid as t; "
            f"t.TRAP_WEIGHT = {weight!r}; from energy_ledger_family import run; r = run({body!r}, 'warp_mpm', "
            f"{n_grid}, {speed}, 40.0, cfl={cfl!r}, stress_at={at!r}); "
            "print(json.dumps({k: r[k] for k in ('E0', 'E_end', 'elastic_own_worst')}))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, capture_output=True, text=True,
                         env=os.environ.copy()).stdout
    return json.loads(out.strip().splitlines()[-1])


def left_check(trap: dict, start: dict) -> bool:
    return abs(trap["E_end"] / trap["E0"] - start["E_end"] / start["E0"]) < LEFT_TOL


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@pytest.mark.parametrize("body,n_grid,speed,cfl", FAMILY)
def test_the_trapezoid_gains_under_one_percent_and_does_not_damp(body, n_grid, speed, cfl, engine):
    pytest.importorskip("gasp_taichi_mpm" if engine == "taichi_mpm" else "gasp_warp_mpm")
    trap = family_run(body, n_grid, speed, cfl, "trapezoid", engine=engine)
    start = family_run(body, n_grid, speed, cfl, "start", engine=engine)
    assert 0.0 <= trap["elastic_own_worst"] / trap["E0"] < GAIN, trap["elastic_own_worst"] / trap["E0"]
    assert left_check(trap, start), (trap["E_end"] / trap["E0"], start["E_end"] / start["E0"])


@pytest.mark.slow
def test_the_damping_check_catches_the_end_gradient_alone():
    pytest.importorskip("gasp_warp_mpm")
    trap = family_run("ball", 32, 4.43, None, "trapezoid", weight=1.0)
    start = family_run("ball", 32, 4.43, None, "start")
    assert not left_check(trap, start), (trap["E_end"] / trap["E0"], start["E_end"] / start["E0"])


def resumed_apart(engine: str, names=None) -> tuple[bytes, bytes]:
    """The free bar under "trapezoid" (n_grid 32, cfl 0.8) run 2 frames, its state taken, 2 more; a fresh engine of the
    same setup given that state runs the same 2 frames: both ends' positions (bytes). ``names`` replaces the engine's
    :meth:`state_names` (the catch)."""
    from free_vibration import bar_setup
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    info = get_engine(engine)
    a = build_engine(info, bar_setup(32, 0.8, "trapezoid"))
    try:
        for _ in range(2):
            a.step_frame()
        if names is not None:
            a.state_names = lambda: names(a)
        state = a.get_state()
        for _ in range(2):
            a.step_frame()
        end_a = a.positions().tobytes()
    finally:
        a.close()
    b = build_engine(info, bar_setup(32, 0.8, "trapezoid"))
    try:
        if names is not None:
            b.state_names = lambda: names(b)
        b.set_state(state)
        for _ in range(2):
            b.step_frame()
        return end_a, b.positions().tobytes()
    finally:
        b.close()


@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_a_trapezoid_run_resumes_bit_for_bit(engine):
    """A resumed run continues the run it resumes, bit for bit (the feature ``state``): under "trapezoid" the state
    holds each point's last velocity gradient ``C_prev`` (``GridEngineBase.state_names``; the default run of round 69
    with the option on failed ``tests/test_resume.py``, ``test_sleep.py`` and ``test_three_bodies.py``'s resumes
    without it)."""
    pytest.importorskip(f"gasp_{engine}")
    a, b = resumed_apart(engine)
    assert a == b


def test_the_resume_check_catches_a_lost_c_prev():
    """The catch: the state without ``C_prev`` (round 69's first form) resumes the bar apart (warp_mpm)."""
    pytest.importorskip("gasp_warp_mpm")
    a, b = resumed_apart("warp_mpm", names=lambda eng: tuple(eng.STATE))
    assert a != b


def test_trial_passes_are_refused_beside_a_rigid_body():
    """``stress_passes`` > 1 runs trial substeps that restore the points alone: warp_mpm refuses it for a scene with a
    rigid body (an ``EngineError`` naming the option), and builds the same scene with one pass."""
    pytest.importorskip("gasp_warp_mpm")
    import dataclasses
    from free_vibration import bar_setup
    from gasp_core.seam import EngineError
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine

    def rigid(passes):
        s = bar_setup(32, 0.8, "trapezoid", passes)
        s.materials = [dataclasses.replace(m, model="rigid", E=1.0e10) for m in s.materials]
        return s
    with pytest.raises(EngineError, match="stress_passes = 2"):
        build_engine(get_engine("warp_mpm"), rigid(2))
    build_engine(get_engine("warp_mpm"), rigid(1)).close()


#: The return-mapping models: the trapezoid is the hyperelastic models' alone (round 70 checks they keep "start"'s
#: step, bit for bit, now that it is the default).
RETURN_MAPPING = ("metal", "sand", "snow", "plasticine", "brittle")


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_trapezoid_moves_the_hyperelastic_models_alone(engine):
    """Round 70 (the trapezoid the default): it moves a jelly and a neo-Hookean landing (``test_stress_at.landed``: a
    6 cm cube thrown down at 2 m/s, 2 frames) and leaves every return-mapping model's (metal, sand, snow, plasticine,
    brittle) bit for bit as under "start" (their return mapping's increment and stress: the default's change does not
    reach them). Its catch: the jelly's move itself (an option that did nothing would pass the second half)."""
    pytest.importorskip("gasp_taichi_mpm" if engine == "taichi_mpm" else "gasp_warp_mpm")
    sys.path.insert(0, str(ROOT / "tests"))
    from test_stress_at import landed
    for name in ("jelly", "neo_hookean"):
        assert np.abs(landed(engine, name, "trapezoid") - landed(engine, name, "start")).max() > 1e-6, name
    for name in RETURN_MAPPING:
        assert np.array_equal(landed(engine, name, "trapezoid"), landed(engine, name, "start")), name
