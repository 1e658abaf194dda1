"""Sleep per body (``gasp_core.seam.body_sleep``, engines with the feature ``sleep``): a body at rest is frozen
while the others go on, what comes within its reach wakes it, and a run that slept and woke resumes bit for bit."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.colliders.model import Motion
from gasp_core.seam.body_sleep import BodySleep, REACH_CELLS
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.runner import run_engine
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.seam.sleep import SLEEP_FRAMES
from gasp_core.testing import scenes_sleep as S

DX = 0.01
FRAME_DT = 1.0 / 30.0


def two_bodies(gap_cells: float, model: str = "auto", passive=None) -> SimSetup:
    """Two 2 x 2 x 2-point cubes (dx / 2 apart) on the x axis, ``gap_cells`` dx between their facing points."""
    cube = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float) * DX / 2 + 0.5
    other = cube + np.array([DX / 2 + gap_cells * DX, 0.0, 0.0])
    mats = [Material("jelly"), Material("jelly", model=model)]
    p_vol = np.where(passive, 0.0, 1e-7) if passive is not None else 1e-7
    return SimSetup(x=np.concatenate([cube, other]), v=0.0, p_vol=p_vol, body_id=np.repeat([0, 1], 8).astype(np.int32),
                    materials=mats, gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=100, frame_dt=FRAME_DT, passive=passive)


def rest(w: BodySleep, x: np.ndarray, frames: int, start: int = 1) -> int:
    """``frames`` quiet frames of ``x``; the last frame number."""
    for f in range(start, start + frames):
        w.before_frame(f, x)
        w.after_frame(f, x, x)
    return start + frames - 1


def test_a_quiet_body_sleeps_while_a_moving_one_far_away_goes_on():
    s = two_bodies(gap_cells=20.0)
    w, x = BodySleep(s), s.x.copy()
    for f in range(1, SLEEP_FRAMES + 1):
        y = x.copy()
        y[8:, 1] += 0.5 * DX * f            # body 1 slides half a cell a frame, far from body 0
        w.after_frame(f, x if f == 1 else prev, y)
        prev = y
        assert w.asleep.tolist() == [f >= SLEEP_FRAMES, False], f
    assert w.events == [(SLEEP_FRAMES, 0, "slept")]
    assert w.last_move == pytest.approx(0.5 * DX)


@pytest.mark.parametrize("inside", [True, False])
def test_a_sleeping_body_wakes_exactly_when_an_awake_point_comes_within_its_reach(inside):
    s = two_bodies(gap_cells=20.0)
    w = BodySleep(s)
    w.can_sleep[1] = False                  # body 1 stays awake, at rest
    k = rest(w, s.x, SLEEP_FRAMES)
    assert w.asleep.tolist() == [True, False]
    reach = w.reach()
    assert reach == pytest.approx(9.81 * FRAME_DT ** 2 + REACH_CELLS * DX)   # no move in the last frame
    x = s.x.copy()
    edge = s.x[:8, 0].max()
    x[8:, 0] += (edge + reach * (0.99 if inside else 1.01)) - x[8:, 0].min()
    assert w.before_frame(k + 1, x) is inside
    assert bool(w.asleep[0]) is not inside
    assert w.events[-1] == ((k + 1, 0, "woke") if inside else (k, 0, "slept"))
    if inside:
        assert w.quiet[0] == 0              # and it must rest SLEEP_FRAMES frames again to sleep again
        rest(w, x, SLEEP_FRAMES - 1, k + 1)
        assert not w.asleep[0]


def test_bodies_in_touch_sleep_together_not_one_before_the_other():
    s = two_bodies(gap_cells=1.0)
    w = BodySleep(s)
    x = s.x.copy()
    for f in range(1, SLEEP_FRAMES + 3):    # body 1 jiggles (not at rest) for two frames more than body 0 rests
        y = x.copy()
        if f <= 2:
            y[8:, 2] += DX * (0.3 if f % 2 else -0.3)
        w.before_frame(f, x)
        w.after_frame(f, x, y)
        x = y
        asleep_now = w.asleep.tolist()
        assert asleep_now in ([False, False], [True, True]), (f, asleep_now)
    assert w.asleep.all() and w.events == [(SLEEP_FRAMES + 2, 0, "slept"), (SLEEP_FRAMES + 2, 1, "slept")]


def test_what_is_still_to_come_keeps_every_body_awake_and_rigid_or_passive_bodies_do_not_sleep_alone():
    s = two_bodies(gap_cells=20.0)
    moving = dataclasses.replace(s, colliders=[type("C", (), {"name": "b", "motion": Motion(velocity=(0.1, 0, 0))})()])
    w = BodySleep(moving)
    rest(w, s.x, 3 * SLEEP_FRAMES)
    assert not w.asleep.any()
    assert BodySleep(two_bodies(20.0, model="rigid")).can_sleep.tolist() == [True, False]
    passive = np.zeros(16, bool)
    passive[15] = True
    assert BodySleep(two_bodies(20.0, passive=passive)).can_sleep.tolist() == [True, False]


def test_the_watch_state_round_trips():
    s = two_bodies(gap_cells=20.0)
    w = BodySleep(s)
    w.can_sleep[1] = False
    k = rest(w, s.x, SLEEP_FRAMES + 2)
    x = s.x.copy()
    x[8:, 0] -= 19 * DX
    w.before_frame(k + 1, x)
    w.last_move = 0.123
    v = BodySleep(s)
    v.restore(w.state())
    assert (v.quiet.tolist(), v.asleep.tolist(), v.last_move, v.events) == \
        (w.quiet.tolist(), w.asleep.tolist(), w.last_move, w.events)
    assert [e[2] for e in v.events] == ["slept", "woke"]


# ------------------------------------------------------------------ the two balls, on the MPM engines

@pytest.fixture(scope="module")
def warp_balls():
    needs_package("gasp_warp_mpm")
    info = get_engine("warp_mpm")
    setup = S.build(info)
    awake, st_awake = S.frames(info, setup, sleep=False)
    assert st_awake.bodies == [] and st_awake.asleep_after is None   # sleep = false: no body is ever frozen
    asleep, stats = S.frames(info, setup, sleep=True)
    return info, setup, awake, asleep, stats


def test_the_ball_scene_passes_and_sleep_changes_nothing_before_a_sleeps(warp_balls):
    info, setup, awake, asleep, stats = warp_balls
    checks = S.ball_checks(setup, awake, asleep, stats)
    assert all(c.passed for c in checks), [str(c) for c in checks]
    ks = stats.bodies[0]["slept_after_frames"][0]
    assert all(np.array_equal(a, b) for a, b in zip(awake[:ks + 1], asleep[:ks + 1]))
    kw = stats.bodies[0]["woke_before_frames"][0]
    a = setup.body_id == 0
    assert all(np.array_equal(asleep[ks][a], asleep[f][a]) for f in range(ks, kw))   # frozen while asleep
    assert not np.array_equal(asleep[ks][setup.body_id == 1], asleep[kw - 1][setup.body_id == 1])   # B went on
    assert stats.bodies[1]["slept_after_frames"] == []


def test_the_ball_checks_fail_when_a_never_wakes(warp_balls, monkeypatch):
    info, setup, awake, _, _ = warp_balls
    monkeypatch.setattr(BodySleep, "before_frame", lambda self, frame, x: False)   # a watch that never wakes
    asleep, stats = S.frames(info, setup, sleep=True)
    failed = {c.name for c in S.ball_checks(setup, awake, asleep, stats) if not c.passed}
    assert failed == {"slept_first", "woke_in_time", "impact_depth", "impact_path", "no_pass_through"}, failed


def test_the_ball_checks_fail_when_a_never_sleeps(warp_balls, monkeypatch):
    info, setup, awake, _, _ = warp_balls
    monkeypatch.setattr(BodySleep, "after_frame", lambda self, frame, x_prev, x, flowing=None: False)   # a watch that never sleeps
    asleep, stats = S.frames(info, setup, sleep=True)
    assert all(np.array_equal(a, b) for a, b in zip(awake, asleep))
    failed = {c.name for c in S.ball_checks(setup, awake, asleep, stats) if not c.passed}
    assert failed == {"slept_first", "woke_in_time"}, failed


def test_the_ball_checks_fail_on_an_engine_that_ignores_a_wake(warp_balls):
    info, setup, awake, _, _ = warp_balls

    def deaf(setup):                        # an engine whose set_asleep never clears a flag
        engine = info.factory(setup)
        told = engine.set_asleep
        held = np.zeros(len(setup.materials), bool)

        def set_asleep(mask):
            held[:] |= np.asarray(mask, bool)
            told(held.copy())
        engine.set_asleep = set_asleep
        return engine
    asleep, stats = S.frames(dataclasses.replace(info, factory=deaf), setup, sleep=True)
    failed = {c.name for c in S.ball_checks(setup, awake, asleep, stats) if not c.passed}
    assert failed == {"impact_depth", "impact_path", "no_pass_through"}, failed


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_a_run_that_slept_and_woke_resumes_bit_for_bit(engine):
    needs_package(f"gasp_{engine}")
    info = get_engine(engine)
    n = 50
    full = [np.array(r.x) for r in run_engine(info, S.build(info), n, sleep=True)]
    states = {}
    for r in run_engine(info, S.build(info), 46, sleep=True):
        if r.frame in (30, 46):             # A asleep (after frame 23); A awake again (woken before frame 44)
            states[r.frame] = r.get_state()
    for at in (30, 46):
        rest_ = [np.array(r.x) for r in run_engine(info, S.build(info), n, start_frame=at, state=states[at], sleep=True)]
        assert len(rest_) == n - at and all(np.array_equal(a, b) for a, b in zip(full[at:], rest_)), at


def test_run_json_records_each_body_s_sleep(donut_run):
    import json
    meta = json.loads((donut_run / "run.json").read_text())
    (body,) = meta["sleep"]["bodies"]           # taichi_mpm has the feature: one record per body, named
    assert body["body"] == 0 and body["name"] == meta["objects"][0]["name"]
    assert isinstance(body["slept_after_frames"], list) and isinstance(body["woke_before_frames"], list)
    assert meta["sleep"]["enabled"] is True
