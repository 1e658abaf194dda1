"""Grady's cells laid on a soft brittle body at its landing and parted at their faces by both MLS-MPM engines (issue
66 item 4; ``gasp_core.run.grady_cells``; ``docs/fracture.md`` "Round 102: Grady's cells in the engines").

- The layout: none where the landing does not break the body (1 m/s) or Grady's fragments do not fit it twice (2
  m/s), more cells the faster (2, 8, 11 at 4, 7, 10 m/s on the pieces family's ball at n_grid 32), laid no narrower than 2.3 grid cells with a warning (8 at 10
  m/s on n_grid 28, where Grady's are 1.8 cells across), ``SimSetup.cells`` checked.
- The pieces: a link between two cells is cut once it opens past its gap, with no damage read; a link inside a cell
  is not.
- The engines (both, n_grid 28, 7 m/s): the cells part after the landing (their speed relative to their common
  centre at frame 8 is at least 0.3 m/s; 0.42 on both, round 102) and the run counts the parts; an engine whose
  cells' contact never runs (the fields move as one) keeps them together (0.2 m/s and under) and counts one piece.
- A run that meets the landing later (``gasp_core.run.fragment_run.frames``): the cells are laid after the frame
  before it, on a new engine, and recorded.
"""
from __future__ import annotations

import warnings
from contextlib import closing

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.run import grady_cells
from gasp_core.run.pieces import PieceTracker, tracker_for
from gasp_core.seam.plugins import engines
from gasp_core.seam.runner import RunStats
from gasp_core.testing.scenes_pieces import ball_setup, counted_run

#: The cells' speed relative to their common centre at frame 8, m/s: parted at least, held at most.
PARTED, HELD = 0.3, 0.2


def _names():
    return [n for n in ("taichi_mpm", "warp_mpm") if n in engines() and engines()[n].unavailable_reason() is None]


def _laid(speed: float, n_grid: int):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return grady_cells.laid(ball_setup(speed, n_grid))


def test_the_layout_grows_with_the_landing_speed_and_none_where_it_does_not_break():
    counts = []
    for v in (1.0, 2.0, 4.0, 7.0, 10.0):
        s, rec = _laid(v, 32)
        counts.append(0 if rec is None else rec["cells"])
        assert (s.cells is None) == (rec is None)
    assert counts[:2] == [0, 0] and all(b >= a for a, b in zip(counts, counts[1:])) and counts[-1] > 4 * counts[2], counts
    s, _ = _laid(7.0, 28)
    cell, inside = grady_cells.decode(s.cells)
    assert cell.min() == 0 and 0.1 < inside.mean() < 0.5   # the band: the points beside another cell


def test_one_outsized_point_volume_does_not_widen_the_cells_links(monkeypatch):
    """Round 103: the cells' links (the band, the split's parts) take the body's spacing as the pieces do (the 90th
    percentile of ``p_vol^(1/3)``), so one point of 30 times the volume (a fill's stray share) leaves the band
    (the points beside another cell) as wide. The catch: the spacing of the largest volume (the rule before) widens
    the links three times and the band takes the whole ball."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = ball_setup(7.0, 28)
        odd = s.replace(p_vol=np.where(np.arange(len(s.p_vol)) == 0, 30 * s.p_vol, s.p_vol))
        good, odd_cells = grady_cells.laid(s)[0].cells, grady_cells.laid(odd)[0].cells
        monkeypatch.setattr(grady_cells, "body_spacing", lambda p_vol: float(np.cbrt(np.max(p_vol))))
        wide = grady_cells.laid(odd)[0].cells
    band = [1.0 - grady_cells.decode(c)[1].mean() for c in (good, odd_cells, wide)]
    # the outlier's volume changes the body's (Grady's count), not the band's width; the rule before: all band
    assert abs(band[1] - band[0]) < 0.02 and band[0] < 0.8 and band[2] > 0.99, band


def test_cells_under_the_grids_resolution_are_laid_larger_with_a_warning():
    with pytest.warns(UserWarning, match="fewer and larger"):
        _, rec = grady_cells.laid(ball_setup(10.0, 28))   # Grady's: 1.8 grid cells across, 16 of them
    assert rec["cells"] == 8, rec
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        grady_cells.laid(ball_setup(4.0, 28))   # 3.3


def test_encode_and_decode_and_the_setup_check():
    cell, band = np.array([0, 1, 2, 0]), np.array([True, False, True, False])
    c = grady_cells.encode(cell, band)
    assert c.tolist() == [0, -3, 2, -2]
    back, inside = grady_cells.decode(c)
    assert back.tolist() == cell.tolist() and inside.tolist() == (~band).tolist()
    s = ball_setup(7.0, 28)
    with pytest.raises(SceneError, match="SimSetup.cells"):
        s.replace(cells=np.zeros(3, int))
    with pytest.raises(SceneError, match="at most 255"):
        s.replace(cells=np.full(len(s.x), 256))


def test_a_link_between_two_cells_is_cut_once_open_without_damage():
    x = np.array([[0.0, 0, 0], [0.01, 0, 0], [0.02, 0, 0], [0.03, 0, 0]])
    t = PieceTracker(x, np.zeros(4, int), np.ones(4), np.full(4, 1e-6), gap=0.005)
    t.split_cells(grady_cells.encode([0, 0, 1, 1], [False, True, True, False]))
    apart = x + np.array([[0, 0, 0], [0.006, 0, 0], [0.02, 0, 0], [0.02, 0, 0]])   # both links inside opened too
    row = t.row(apart, None)[0]
    assert row["pieces"] == 2    # only the link across the cells' face is cut


def cell_motion(name: str, speed: float, n_grid: int, frames: int = 8) -> tuple[float, list]:
    """The cells' mean speed relative to their common centre at ``frames`` (m/s) and the run's 1 % pieces."""
    s, _ = _laid(speed, n_grid)
    cell = grady_cells.decode(s.cells)[0]
    from gasp_core.seam.build import build_engine
    e = build_engine(engines()[name], s)
    try:
        for _ in range(frames):
            e.step_frame()
        v = np.asarray(e.velocities())
    finally:
        e.close()
    cv = np.array([v[cell == c].mean(0) for c in range(cell.max() + 1)])
    return float(np.linalg.norm(cv - cv.mean(0), axis=1).mean()), counted_run(name, s, 30)["tracker_1"]


def _glued(monkeypatch, name: str) -> None:
    """A broken engine: the cells' contact never runs, so both fields move as one."""
    if name == "taichi_mpm":
        from gasp_taichi_mpm.cells import Cells
        monkeypatch.setattr(Cells, "cell_contact", lambda self: None)
    else:
        import gasp_warp_mpm.cells as wc
        real = wc.cell_launches
        monkeypatch.setattr(wc, "cell_launches", lambda eng, Ft: (real(eng, Ft)[0], []))


#: The landing the parting is checked on, m/s, on n_grid 28: every draw of its cells parts there (round 104, warp_mpm,
#: draws 0-4: relative speed 0.84, 0.70, 0.85, 0.60, 0.47 m/s, 3-6 pieces of 1 %); at 7 m/s, round 102's case, two draws
#: of five part (0.44 and 0.34; the others 0.18-0.24, one piece), so it passed on its draw alone.
PART_SPEED = 10.0


@pytest.mark.parametrize("name", _names())
def test_the_cells_part_after_the_landing(name):
    rel, pieces = cell_motion(name, PART_SPEED, 28)
    assert rel >= PARTED and pieces[-1] >= 2, (rel, pieces)


@pytest.mark.parametrize("name", _names())
def test_catch_an_engine_whose_cells_never_part(name, monkeypatch):
    """Glued: 0.036 m/s and one piece on both engines."""
    _glued(monkeypatch, name)
    rel, pieces = cell_motion(name, PART_SPEED, 28)
    assert rel <= HELD and pieces[-1] == 1, (rel, pieces)


@pytest.mark.parametrize("name", _names())
def test_a_run_lays_the_cells_after_the_frame_before_the_landing(name):
    from gasp_core.run import fragment_run
    s = ball_setup(7.0, 28)
    s = s.replace(x=s.x + np.array([0.0, 0.0, 0.1]), v=np.zeros_like(s.v) + np.array([0.0, 0.0, -6.5]))
    stats, t = RunStats(), tracker_for(s)
    info = engines()[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with closing(fragment_run.frames(info, s, stats, 6, tracker=t)) as recs:
            frames = [r.frame for r in recs]
    assert frames == [1, 2, 3, 4, 5, 6]
    rec = [f for f in stats.fragments if f.get("route") == "cells"]
    assert len(rec) == 1 and rec[0]["frame"] >= 1 and rec[0]["cells"] >= 4, stats.fragments
    assert t.cross.any()
