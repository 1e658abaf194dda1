"""Pieces as a user counts them (issue 66, item 4), on both MLS-MPM engines: a brittle ball (radius 0.1 m, E 200 kPa,
f_t 10 kPa, G_f 15 J/m^2; :func:`gasp_core.testing.scenes_pieces.ball_setup`) landing at 1, 2, 4, 7 and 10 m/s at
n_grid 28 and 32, 12 frames of 0.01 s (from the landing until before its fragments fall back onto each other).

- On every frame the run's count (:class:`gasp_core.run.pieces.PieceTracker`, its pieces of 1 % of the mass or more)
  equals the parts counted from the frames alone, with no damage read
  (:class:`gasp_core.testing.pieces_count.FramePieces`: separated by a gap of at least 1 dx, 1 % of the mass or more)
  within +-1; the count (crumbs apart) and the count with the crumbs never decrease. Measured (2026-11-26, both
  engines alike): 0 difference on every frame 0-12 of the 20 runs; 1 piece at 1, 2 and 4 m/s (at 4 m/s 83 % of the
  points broken, the ball swollen by half a cell a link but not apart), 21-145 at 7 and 10 m/s at frame 12 (the ball
  broken through at its first touch, its fragments scattering). From frame 13 the fragments meet again and the
  frames-only count, which rejoins what touches, runs up to 24 over the tracker's, which never rejoins (n_grid 28,
  10 m/s, by frame 20; 6-7 at n_grid 32; benchmarks/pieces_family.py).
- Shown to catch the labelling before issue 66 (damage alone: each point its own piece once all are broken, its 1 %
  count 0 against 5-45) and a tracker that forgets its cut links (its count falls, 77 to 69 at 7 m/s, n_grid 28, frame
  17: ``FORGET_FRAMES``).
- The pieces of 5 % of the mass or more at the last frame do not grow with the speed: 1, 1, 1, 8, 0 (n_grid 28) and
  1, 1, 1, 12, 0 (32) on both engines (their peak over the frames: 1, 1, 1, 12, 4 and 1, 1, 1, 12, 12). The
  physics, not the count: at 7 and 10 m/s the whole ball is broken (d = 1) within two frames of the touch and
  scatters as ever finer fragments, the frames-only count agreeing; left a strict xfail with the figures.
"""
from __future__ import annotations

import pytest

from gasp_core.seam.plugins import engines
from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup, counted_run
from test_pieces import DamageAlone, Forgets

N_FRAMES = 12
GRIDS = (28, 32)


def _names():
    return [n for n in ("taichi_mpm", "warp_mpm") if n in engines() and engines()[n].unavailable_reason() is None]


def failures(r: dict, what: str) -> list[str]:
    """What a :func:`counted_run` breaks: the 1 % counts apart by more than 1 on a frame, a count that decreases."""
    out = []
    for f, (t, ref) in enumerate(zip(r["tracker_1"], r["frames_1"])):
        if abs(t - ref) > 1:
            out.append(f"{what} frame {f}: {t} pieces of 1 % by the tracker, {ref} from the frames alone")
    for key, seq in (("pieces", r["tracker"]), ("pieces and crumbs", [a + b for a, b in zip(r["tracker"],
                                                                                          r["debris"])])):
        down = [f for f in range(1, len(seq)) if seq[f] < seq[f - 1]]
        if down:
            out.append(f"{what}: {key} decrease at frame {down[0]}: {seq[down[0] - 1]} -> {seq[down[0]]}")
    return out


def family_failures(name: str, cases, tracker=None, n_frames: int = N_FRAMES) -> list[str]:
    out = []
    for n_grid, speed in cases:
        s = ball_setup(speed, n_grid)
        t = None if tracker is None else tracker(s.x, s.body_id, s.p_mass, s.p_vol, gap=s.dx)
        out += failures(counted_run(name, s, n_frames, t), f"{name} n_grid {n_grid} {speed} m/s")
    return out


#: frames the forgetful tracker's catch runs: past the fragments' meeting again (frame 13 on), where a tracker that
#: forgets its cut links rejoins them (its count falls: 77 -> 69 at 7 m/s, 137 -> 131 at 10, frame 17, n_grid 28, both
#: engines, round 33). Before round 33's crack band weight it fell at frame 12 (33 -> 29 at 7 m/s), within
#: ``N_FRAMES``; with it not before frame 17.
FORGET_FRAMES = 20


@pytest.mark.parametrize("name", _names())
def test_the_count_is_the_frames_count_and_never_decreases_at_10_m_s(name):
    assert not family_failures(name, [(28, 10.0)])


@pytest.mark.parametrize("name", _names())
def test_the_family_check_catches_damage_alone_and_a_tracker_that_forgets(name):
    assert family_failures(name, [(28, 7.0), (28, 10.0)], DamageAlone)
    bad = family_failures(name, [(28, 7.0), (28, 10.0)], Forgets, FORGET_FRAMES)
    assert any("decrease" in b for b in bad), bad


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_count_is_the_frames_count_and_never_decreases_over_the_family(name):
    assert not family_failures(name, [(g, v) for g in GRIDS for v in SPEEDS])


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="the physics: at 7 and 10 m/s the ball is broken through at the touch and "
                                       "scatters finer the faster (5 % pieces at the last frame 1, 1, 1, 8, 0 at "
                                       "n_grid 28; 1, 1, 1, 12, 0 at 32); Grady's size at v / R gives fragments of "
                                       "12, 3.9, 1.9 % of the ball at 4, 7, 10 m/s (docs/fracture.md)")
@pytest.mark.parametrize("name", _names())
def test_the_pieces_of_5_percent_never_decrease_with_speed(name):
    for n_grid in GRIDS:
        big = [counted_run(name, ball_setup(v, n_grid), N_FRAMES)["tracker_5"][-1] for v in SPEEDS]
        assert all(b >= a for a, b in zip(big, big[1:])), (n_grid, big)
