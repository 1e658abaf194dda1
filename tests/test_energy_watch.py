"""The energy watchdog (round 60, ``gasp_core.seam.energy_watch``): a run that gains energy stops as a blow-up.

Two-sided: the watchdog's own reading of motions whose energy is known (a ballistic point: exactly ``-m g^2 dt^2 / 8``
from its start; a gain just over and just under the allowance), a broken engine that multiplies its velocities each
frame stopped at the first frame whose gain passes the allowance (computed here from the unwatched run's positions,
not by the watchdog) on both grid engines, the same engine unbroken running to the end, round 59's AFLIP defect
(``FIELD_OLD_VELOCITY = False``, a jelly ball on a jelly box at 140 substeps a frame: before round 60 it ran on with
points at 10 m/s) stopped with the new cause and the fixed rule running on, and ``gasp simulate`` keeping the frames
before the stop (exit 3, ``run.json`` ``energy``). The family of scenes measured: docs/mpm.md "Round 60: the energy
watchdog" (``benchmarks/studies/energy_watch_family.py``).
"""
from __future__ import annotations

import dataclasses
import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.colliders.model import Impulse
from gasp_core.errors import EngineDivergence
from gasp_core.seam import energy_watch
from gasp_core.seam.energy_watch import ALLOWANCE, CAUSE_ENERGY, EnergyWatch, unwatched
from gasp_core.seam.runner import left_grid
from gasp_core.seam.setup import Material, SimSetup

ENGINES = [e for e in ("taichi_mpm", "warp_mpm") if importlib.util.find_spec(f"gasp_{e}") is not None]
STUDIES = Path(__file__).resolve().parents[1] / "benchmarks" / "studies"
G, DT = 9.81, 1.0 / 30.0


def _points(v=(0.0, 0.0, 0.0), n=5, gravity=(0.0, 0.0, -G)) -> SimSetup:
    """``n`` points (1e-6 m^3 of rho 1000: 1 g each) at z 0.2-0.4 m in a 1 m box, moving at ``v``."""
    x = np.column_stack([np.full(n, 0.5), np.full(n, 0.5), np.linspace(0.2, 0.4, n)])
    return SimSetup(x=x, v=np.tile(v, (n, 1)), p_vol=np.full(n, 1e-6), body_id=np.zeros(n, int),
                    materials=[Material("jelly", rho=1000.0)], gravity=np.array(gravity), domain_lo=np.zeros(3),
                    domain_hi=np.ones(3), n_grid=16, frame_dt=DT)


def _ballistic(setup: SimSetup, t: float) -> np.ndarray:
    return setup.x + setup.v * t + 0.5 * setup.gravity * t * t


@pytest.mark.parametrize("v", [(0.0, 0.0, 0.0), (0.0, 0.0, 2.0), (1.5, 0.0, -1.0)])
def test_a_ballistic_point_reads_its_start_less_g2_dt2_over_8(v):
    """Free flight, thrown up, down or sideways: each frame's energy (mean velocity, midpoint height) is exactly the
    start's less ``m g^2 dt^2 / 8`` a point, to roundoff (the end position would read +- ``m g v dt / 2``)."""
    s = _points(v)
    w = EnergyWatch(s)
    m = s.p_mass.sum()
    for k in range(1, 6):
        w.check(k, _ballistic(s, (k - 1) * DT), _ballistic(s, k * DT))
        e = w.energies(_ballistic(s, (k - 1) * DT), _ballistic(s, k * DT)).sum()
        assert e - w.e0 == pytest.approx(-m * G * G * DT * DT / 8, rel=1e-6, abs=1e-12)


def test_the_scale_is_the_start_kinetic_energy_and_gravity_across_the_domain():
    s = _points((0.0, 3.0, 4.0))
    m = s.p_mass.sum()
    assert EnergyWatch(s).scale == pytest.approx(0.5 * m * 25.0 + m * G * 1.0)


@pytest.mark.parametrize("over", [True, False])
def test_a_gain_past_the_allowance_stops_the_run_and_one_below_does_not(over):
    """The points at rest lifted so that their potential gains ``(ALLOWANCE +- 1 %) S`` in the frame (at rest: no
    kinetic energy, the midpoint at the lift)."""
    s = _points()
    w = EnergyWatch(s)
    lift = (1.01 if over else 0.99) * ALLOWANCE * w.scale / (s.p_mass.sum() * G)
    x = s.x + [0.0, 0.0, lift]
    if over:
        with pytest.raises(EngineDivergence) as e:
            w.check(3, x, x)
        assert e.value.frame == 3 and e.value.cause == CAUSE_ENERGY
    else:
        w.check(3, x, x)
        assert w.largest == pytest.approx(0.99 * ALLOWANCE)


def test_points_out_of_the_grid_leave_the_count_with_their_energy():
    """A point thrown up at 30 m/s out of the grid (it freezes there): from that frame it is counted no more and its
    energy that frame is taken off the start's; the frame after reads the rest against that (the points at rest:
    their potential), whatever the frozen point's place. Without the feature ``left_domain`` it stays counted."""
    s = _points()
    v = s.v.copy()
    v[0] = (0.0, 0.0, 30.0)
    s = dataclasses.replace(s, v=v)
    x1 = s.x.copy()
    x1[0, 2] = 0.99   # its stencil past the grid's last node
    w, kept = EnergyWatch(s), EnergyWatch(s)
    e_start = w.e0
    left = w.energies(s.x, x1)[0]
    out = left_grid(x1, s)
    assert out.tolist() == [True, False, False, False, False]
    for watch, o in ((w, out), (kept, None)):
        watch.check(1, s.x, x1, o)
        watch.check(2, x1, x1, o)
    assert not w.counted[0] and w.counted[1:].all() and kept.counted.all()
    assert w.e0 == pytest.approx(e_start - left) and kept.e0 == e_start
    rest = w.potential(s.x)[1:].sum()
    assert w.largest == pytest.approx(max((w.energies(s.x, x1).sum() - e_start) / w.scale,
                                          (rest - (e_start - left)) / w.scale))


def test_scenes_with_work_the_runner_cannot_bound_are_not_watched():
    s = _points()
    assert unwatched(s) is None
    kick = Impulse(shape="box", velocity_change=(0.0, 0.0, 1.0), lo=(0, 0, 0), hi=(1, 1, 1))
    assert "impulses" in unwatched(dataclasses.replace(s, impulses=[kick]))
    assert unwatched(_points(gravity=(0.0, 0.0, 0.0))) == "no gravity and no initial motion"
    assert unwatched(_points(v=(1.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0))) is None
    w = EnergyWatch(dataclasses.replace(s, impulses=[kick]))
    w.check(1, s.x, s.x + 1.0)   # skipped: never raises
    assert w.record()["skipped"] and w.record()["largest_gain"] is None


def _sys_path():
    if str(STUDIES) not in sys.path:
        sys.path.insert(0, str(STUDIES))


def _first_over(setup: SimSetup, xs: np.ndarray) -> int | None:
    """The first frame whose energy (computed here: mean velocity, midpoint height, all points in the grid) passes
    ``ALLOWANCE`` of the scale, from an unwatched run's positions ``xs`` (frames + 1, n, 3)."""
    m, g = setup.p_mass, -setup.gravity
    def energy(a, b):
        u = (b - a) / setup.frame_dt
        return 0.5 * m @ (u * u).sum(1) + m @ ((a + b) / 2 @ g)
    e0 = 0.5 * m @ (setup.v * setup.v).sum(1) + m @ (setup.x @ g)
    scale = 0.5 * m @ (setup.v * setup.v).sum(1) + m.sum() * np.linalg.norm(g) * (setup.domain_hi - setup.domain_lo)[2]
    over = [k for k in range(1, len(xs)) if energy(xs[k - 1], xs[k]) - e0 > ALLOWANCE * scale]
    return over[0] if over else None


@pytest.mark.parametrize("engine", [pytest.param(e, marks=[] if e == "warp_mpm" else [pytest.mark.slow])
                                    for e in ENGINES])
def test_an_engine_that_gains_energy_is_stopped_at_the_frame_it_passes_the_allowance(engine, monkeypatch):
    """The bounce scene's engine with every point's velocity times 1.2 after each frame (1 s on warp_mpm, 9 s on
    taichi_mpm: the slow tier):
    stopped with ``CAUSE_ENERGY`` at the first frame an independent reading of the unwatched run puts over the
    allowance, its earlier frames yielded; the unbroken engine runs all 36 frames."""
    _sys_path()
    from energy_watch_family import build, scaled
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.runner import RunStats, run_engine
    setup, n = build(engine, "bounce")
    info = scaled(engines()[engine], 1.2)
    xs = [setup.x]
    with monkeypatch.context() as mp:
        mp.setattr(energy_watch, "ALLOWANCE", float("inf"))
        try:   # unwatched, it runs until points leave the grid faster than a cell a substep (frame 30)
            for r in run_engine(info, setup, n):
                xs.append(r.x)
        except EngineDivergence:
            pass
    xs = np.stack(xs)
    want = _first_over(setup, xs)
    assert want is not None and 2 < want < n, want
    seen = []
    with pytest.raises(EngineDivergence) as e:
        for r in run_engine(info, setup, n):
            seen.append(r.frame)
    assert e.value.frame == want and e.value.cause == CAUSE_ENERGY and seen == list(range(1, want))
    stats = RunStats()
    assert len(list(run_engine(engines()[engine], setup, n, stats))) == n
    assert stats.energy["largest_gain"] < 0.01 * ALLOWANCE


def _pair(engine: str, old: bool, frames: int, monkeypatch):
    """Round 59's pair (``finestep_pair.py``: a jelly ball 5 mm above a jelly box, n_grid 32, 140 substeps a frame)
    with the AFLIP rule before round 59 (``old``) or after: the frames it ran and how it stopped."""
    _sys_path()
    from energy_watch_family import build
    from gasp_core.mpm import fields
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.runner import RunStats, run_engine
    monkeypatch.setattr(fields, "FIELD_OLD_VELOCITY", not old)
    setup, _ = build(engine, "finestep:140:jelly:0:0")
    stats, done = RunStats(), []
    try:
        for r in run_engine(engines()[engine], setup, frames, stats):
            done.append(r.frame)
    except EngineDivergence as e:
        return done, e, stats
    return done, None, stats


@pytest.mark.parametrize("engine", [pytest.param(e, marks=[] if e == "warp_mpm" else [pytest.mark.slow])
                                    for e in ENGINES])
def test_round_59s_aflip_defect_is_stopped_and_the_fixed_rule_runs_on(engine, monkeypatch):
    """The old rule: points flung to 10 m/s from frame 3, the run went on to its end before round 60 (taichi_mpm,
    ``energy_watch_family.py taichi_mpm finestep_old:140:jelly:0:0 --no-watch``); now stopped with ``CAUSE_ENERGY``
    by frame 4 (measured: frame 4, 4.75 of the scale, taichi_mpm). The fixed rule runs the same 5 frames, its
    largest gain under 1 % of the allowance. 5 s on warp_mpm, 22 s on taichi_mpm (the slow tier)."""
    done, err, _ = _pair(engine, True, 5, monkeypatch)
    assert err is not None and err.cause == CAUSE_ENERGY and err.frame <= 4 and done == list(range(1, err.frame))
    done, err, stats = _pair(engine, False, 5, monkeypatch)
    assert err is None and done == [1, 2, 3, 4, 5] and stats.energy["largest_gain"] < 0.01 * ALLOWANCE


def test_gasp_simulate_keeps_the_frames_before_an_energy_stop(tmp_path, capsys, write_scene, donut_small, monkeypatch):
    """``gasp simulate`` with taichi_mpm's step broken (velocities times 1.5 after each frame): exit 3, the one error
    line names the energy and the frame, ``run.json`` says ``diverged`` at the frame after the last kept one and
    records the gain over the allowance (issue 41's keeping, as every divergence)."""
    from gasp_testing import needs_package, scene_text
    needs_package("gasp_taichi_mpm")
    from gasp_core.cli.main import main
    from gasp_taichi_mpm.engine import TaichiMPMEngine
    step = TaichiMPMEngine.step_frame

    def broken(self):
        step(self)
        st = self.get_state()
        st["v"] = np.asarray(st["v"]) * 1.5
        self.set_state(st)
    monkeypatch.setattr(TaichiMPMEngine, "step_frame", broken)
    out = tmp_path / "out"
    code = main(["simulate", str(write_scene(scene_text(donut_small, n_frames=30, n_grid=16))), "-o", str(out), "-q"])
    err = capsys.readouterr().err
    assert code == 3, err
    lines = [ln for ln in err.strip().splitlines() if ln.startswith("gasp: error:")]
    assert len(lines) == 1 and "energy gained" in lines[0], err
    record = json.loads((out / "run.json").read_text())
    assert record["status"] == "diverged" and record["diverged"]["frame"] == len(record["frames"])
    assert record["energy"]["largest_gain"] > ALLOWANCE and record["energy"]["skipped"] is None
