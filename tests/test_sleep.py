"""Sleep (``gasp_core.seam.sleep``, scene key ``sleep``): a scene at rest stops being simulated and its frames
repeat; what can still move it keeps it awake; a run that slept resumes as it ran."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.colliders.model import Motion
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.runner import RunStats, run_engine
from gasp_core.seam.setup import Boundary
from gasp_core.seam.sleep import SLEEP_DRIFT, SLEEP_FRAMES, SLEEP_TOL, SleepWatch, sleep_blockers
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.scenes_rest import BODY, DX, FRAME_DT, LO, N_GRID, SIDE

needs_package("gasp_warp_mpm")
N_FRAMES = 40


def slab(v=(0.0, 0.0, 0.0), drop=0.0):
    """The conformance slab (4 x 4 x 2 dx, E 1e5 Pa) on the ground, let go ``drop`` m above it at velocity ``v``."""
    lo = np.array([-2 * DX, -2 * DX, drop])
    x, p_vol = box_points(lo, lo + np.array([4 * DX, 4 * DX, 2 * DX]), DX / 2)
    s = make_setup(x, p_vol, BODY, lo=LO, hi=LO + SIDE, n_grid=N_GRID, frame_dt=FRAME_DT,
                   boundaries=[Boundary("ground", height=0.0, friction=0.0)])
    s.v = np.broadcast_to(np.asarray(v, float), x.shape).copy()
    return s


def frames(setup, sleep, n=N_FRAMES, **kw):
    stats = RunStats()
    xs = [np.array(r.x) for r in run_engine(get_engine("warp_mpm"), setup, n, stats, sleep=sleep, **kw)]
    return xs, stats


def test_a_resting_slab_falls_asleep_and_its_frames_stay_where_the_awake_run_goes():
    awake, s_awake = frames(slab(drop=0.5 * DX), sleep=False)
    asleep, s_sleep = frames(slab(drop=0.5 * DX), sleep=True)
    k = s_sleep.asleep_after
    assert s_awake.asleep_after is None and k is not None and SLEEP_FRAMES < k < N_FRAMES - 5
    # before it sleeps, the same run; after, its frames repeat frame k, and no substep is paid for them
    assert all(np.array_equal(a, b) for a, b in zip(awake[:k], asleep[:k]))
    assert all(np.array_equal(x, asleep[k - 1]) for x in asleep[k:]) and s_sleep.frame_s[k:] == [0.0] * (N_FRAMES - k)
    # what the awake run still did after frame k: its centroid within the rest tolerance a frame, times the
    # frames left, and every point within one frame's vibration
    drift = max(float(np.linalg.norm((a - asleep[k - 1]).mean(axis=0))) for a in awake[k:])
    assert drift <= SLEEP_DRIFT * DX * (N_FRAMES - k), drift / DX
    assert max(float(np.abs(a - asleep[k - 1]).max()) for a in awake[k:]) <= SLEEP_TOL * DX


def test_a_slab_still_sliding_stays_awake():
    # a sleep that looked at the points' vibration alone would stop this slab: it slides at 0.06 dx a frame (three
    # times the centroid's rest tolerance, under the points' one) on a frictionless ground for the whole run
    speed = 3 * SLEEP_DRIFT * DX / FRAME_DT
    xs, stats = frames(slab(v=(speed, 0.0, 0.0)), sleep=True)
    assert stats.asleep_after is None
    step = np.mean(xs[-1][:, 0] - xs[-2][:, 0])
    assert step == pytest.approx(speed * FRAME_DT, rel=0.2)


def test_what_can_still_move_a_scene_keeps_it_awake():
    s = slab()
    assert sleep_blockers(s, 0.0) == []
    moving = dataclasses.replace(s, colliders=[type("C", (), {"name": "box", "motion": Motion(velocity=(0.1, 0, 0))})()])
    assert sleep_blockers(moving, 1.0) == ["collider 'box' moves"]
    w = SleepWatch(moving)
    x = np.zeros((3, 3))
    assert not any(w.update(f, x, x) for f in range(1, 3 * SLEEP_FRAMES))   # at rest, but the collider may come


def test_a_run_that_slept_resumes_bit_for_bit():
    full, stats = frames(slab(drop=0.5 * DX), sleep=True)
    k = stats.asleep_after
    cut = k + 2                                          # a checkpoint taken while asleep
    states = {}
    for r in run_engine(get_engine("warp_mpm"), slab(drop=0.5 * DX), cut, sleep=True):
        states[r.frame] = r.get_state()
    for at in (k - 2, cut):                              # before it fell asleep, and while asleep
        rest = [np.array(r.x) for r in run_engine(get_engine("warp_mpm"), slab(drop=0.5 * DX), N_FRAMES,
                                                  start_frame=at, state=states[at], sleep=True)]
        assert all(np.array_equal(a, b) for a, b in zip(full[at:], rest)), at
