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
- Round 77, finer grids (n_grid 40-64, 20 frames; ``docs/fracture.md`` "Round 77"): once the fragments meet again
  (after the walls, from frame 8-10 at n_grid 64) the frames-only count joins what touches, so the check reads the
  frames-only count that keeps a link open once it has opened (``FramePieces(remember=True)``; still no damage read):
  0 difference on every frame. Against the memoryless count the tracker parts at 10 m/s by 8-12 from n_grid 48.
- Shown to catch the labelling before issue 66 (damage alone: each point its own piece once all are broken, its 1 %
  count 0 against 5-45) and a tracker that forgets its cut links (its count falls, 77 to 69 at 7 m/s, n_grid 28, frame
  17: ``FORGET_FRAMES``).
- The pieces of 5 % of the mass or more at the last frame do not grow with the speed: 1, 1, 1, 12, 0 at n_grid 28 and
  32 on both engines (round 82; n_grid 28 gave 8 at 7 m/s in earlier rounds) (their peak over the frames: 1, 1, 1, 12, 4 and 1, 1, 1, 12, 12). At 7 and
  10 m/s the whole ball is broken (d = 1) within two frames of the touch and scatters as ever finer fragments, the
  frames-only count agreeing. Round 80: that is not the physics' answer either. Grady's mean fragment with the
  masses' spread about it (Grady & Kipp 1985; Mott) expects 3.4-5.5, 5.2-7.1 and 3.8-5.3 pieces of 5 % at 4, 7 and
  10 m/s, so the runs fall short at 4 and 10 m/s (docs/fracture.md); left a strict xfail with the figures.
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


def failures(r: dict, what: str, ref_key: str = "frames_1") -> list[str]:
    """What a :func:`counted_run` breaks: the 1 % counts apart by more than 1 on a frame (against ``ref_key``: the
    frames alone, ``frames_1``, or with the links once opened kept open, ``frames_kept_1``), a count that decreases."""
    out = []
    for f, (t, ref) in enumerate(zip(r["tracker_1"], r[ref_key])):
        if abs(t - ref) > 1:
            out.append(f"{what} frame {f}: {t} pieces of 1 % by the tracker, {ref} from the frames alone ({ref_key})")
    for key, seq in (("pieces", r["tracker"]), ("pieces and crumbs", [a + b for a, b in zip(r["tracker"],
                                                                                          r["debris"])])):
        down = [f for f in range(1, len(seq)) if seq[f] < seq[f - 1]]
        if down:
            out.append(f"{what}: {key} decrease at frame {down[0]}: {seq[down[0] - 1]} -> {seq[down[0]]}")
    return out


def family_failures(name: str, cases, tracker=None, n_frames: int = N_FRAMES, ref_key: str = "frames_1") -> list[str]:
    out = []
    for n_grid, speed in cases:
        s = ball_setup(speed, n_grid)
        t = None if tracker is None else tracker(s.x, s.body_id, s.p_mass, s.p_vol, gap=s.dx)
        out += failures(counted_run(name, s, n_frames, t), f"{name} n_grid {n_grid} {speed} m/s", ref_key)
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


#: Round 77: finer grids than the test's, over frames 0-20 (past the fragments' meeting again).
FINE_GRIDS = (40, 48, 56, 64)
FINE_FRAMES = 20


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_count_is_the_kept_frames_count_and_never_decreases_on_finer_grids(name):
    """Round 77 (``docs/fracture.md`` "Round 77"): at n_grid 40-64 and every speed, over 20 frames, the tracker's
    pieces of 1 % equal the frames-only count whose links, once opened past their gap, stay open
    (``FramePieces(remember=True)``: the parts a user saw come apart stay apart in a heap; still no damage read),
    within +-1, and its counts never decrease. Measured (2026-12-04, both engines alike): 0 difference on every
    frame of the 20 runs. Against the memoryless count the tracker parts at 10 m/s from frame 12 (n_grid 48: 12
    against 20), 11 (56) and 10 (64: 1-2 against 10-14): the spray reaches the walls by frame 7-9 and its fragments
    meet again, which the frames alone join into one part."""
    assert not family_failures(name, [(g, v) for g in FINE_GRIDS for v in SPEEDS], n_frames=FINE_FRAMES,
                               ref_key="frames_kept_1")


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_finer_grid_check_catches_damage_alone_and_a_tracker_that_forgets(name):
    """The catch of the check above on its grids: the labelling before issue 66 (damage alone: 12-15 apart at
    10 m/s, n_grid 48 and 64) and a tracker that forgets its cut links (its count falls at frame 10-12)."""
    cases = [(48, 10.0), (64, 10.0)]
    assert family_failures(name, cases, DamageAlone, FINE_FRAMES, "frames_kept_1")
    bad = family_failures(name, cases, Forgets, FINE_FRAMES, "frames_kept_1")
    assert any("decrease" in b for b in bad), bad


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="at 7 and 10 m/s the ball is broken through at the touch and scatters finer "
                                       "the faster (5 % pieces at the last frame 1, 1, 1, 12, 0 at n_grid 28 and 32, "
                                       "round 82; 8 at 7 m/s, n_grid 28, before). Grady's mean fragment at v / R is 12, 3.9, 1.9 % of the ball at "
                                       "4, 7, 10 m/s, but with the masses' spread (Grady & Kipp 1985; Mott) 3.4-5.5, "
                                       "5.2-7.1 and 3.8-5.3 pieces of 5 % are expected there (round 80): the runs fall "
                                       "short at 4 and 10 m/s; the 7 m/s pieces are 1.2-1.5 cells across, not "
                                       "converged; round 99: at frame 30 they are 0 at 7 m/s too (1, 1, 1, 0, 0), "
                                       "and neither a rotating crack nor Grady's cells as a sub-grid closure meet it "
                                       "(docs/fracture.md 'Round 99'); round 100: DFG alone does not either, and Grady's "
                                       "cells parted by DFG meet it on n_grid 48 only, in a study solver "
                                       "(docs/fracture.md 'Round 100'); round 101: the cells parted by a side taken from "
                                       "the cells meet it on n_grid 28, 32 and 48 in that solver (1, 1, 1, 7, 8 at 28), "
                                       "not yet ported to the engines (docs/fracture.md 'Round 101')")
@pytest.mark.parametrize("name", _names())
def test_the_pieces_of_5_percent_never_decrease_with_speed(name):
    for n_grid in GRIDS:
        big = [counted_run(name, ball_setup(v, n_grid), N_FRAMES)["tracker_5"][-1] for v in SPEEDS]
        assert all(b >= a for a, b in zip(big, big[1:])), (n_grid, big)
