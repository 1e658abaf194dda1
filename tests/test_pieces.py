"""Pieces (gasp_core/run/pieces.py, issues 52 and 66): the parts that have come apart, from the geometry and the
damage together, links once cut kept cut, crumbs counted apart.

Known answers on a lattice: a bar of 20 x 4 x 4 points (spacing h, each of mass 1 kg) is one piece; a layer of broken
points (d = 1) across it does not part it until the two sides have moved apart by more than the gap (a grid cell), and
then it is two pieces whose masses are the points on each side (the broken layer goes with the side it has not left);
a bar pulled open with no point broken stays one (an elastic stretch is not a crack); pushed back together, a bar cut
in two stays two (the count never decreases); a body broken everywhere and pulled apart into blocks is as many pieces
as blocks, not a point a piece (the dust of issue 66); a crumb under 0.1 % of its body's mass is debris, and a piece
that crumbles whole leaves its heaviest crumb a piece; the tracker's state, saved and restored, gives the same rows as
one never stopped; two bodies that touch are two pieces; a passive point takes its nearest material point's piece;
one point of outsized volume neither widens the links nor asks for unbounded memory (the bundled guitar made brittle
died in ``query_pairs``). The checks are shown to catch the labelling before issue 66 (damage alone: each broken point
a piece when none is whole) and a tracker that forgets its cut links.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.errors import GaspError
from gasp_core.run.pieces import PieceTracker

H = 0.01   # lattice spacing, m


def bar(nx: int = 20):
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(4), np.arange(4), indexing="ij"), -1).reshape(-1, 3) * H
    return g.astype(np.float64), np.ones(len(g)), np.full(len(g), H ** 3)


def pulled(x, right, by):
    return x + np.where(right, by, 0.0)[:, None] * [1, 0, 0]


def broken_bar():
    """:func:`bar` with its layer 7 of 0..19 broken (``d`` 1 there, 0 elsewhere) and ``right``, the points past it:
    ``(x, m, v, d, right)``."""
    x, m, v = bar()
    return x, m, v, np.where(np.isclose(x[:, 0], 7 * H), 1.0, 0.0), x[:, 0] > 7.5 * H


class Forgets(PieceTracker):
    """A broken tracker: it forgets its cut links every frame (the geometry of the frame alone)."""

    def labels(self, x, damage):
        self.cut[:] = False
        self._lab = self._counted = None
        return super().labels(x, damage)


class DamageAlone(PieceTracker):
    """The labelling before issue 66: links through broken points cut at once; with nothing whole, each broken point
    its own piece; no debris."""

    def labels(self, x, damage):
        d = np.zeros(len(self.mass)) if damage is None else np.asarray(damage)
        if (d >= 0.9).all():
            lab = np.arange(len(self.mass))
        else:
            self.cut[:] = (d[self.pairs[:, 0]] >= 0.9) | (d[self.pairs[:, 1]] >= 0.9)
            self._lab = None
            lab = super().labels(x, None)
        self._counted = np.ones(lab.max() + 1, bool)           # no crumbs then
        return lab


def test_an_intact_bar_is_one_piece_of_its_whole_mass():
    x, m, v = bar()
    row, changed = PieceTracker(x, np.zeros(len(x), int), m, v).row(x, np.zeros(len(x)))
    assert row == {"pieces": 1, "piece_mass": [float(len(x))], "debris": 0, "debris_mass": 0.0, "broken_mass": 0.0,
                   "cut_links": 0} and changed


def test_a_broken_layer_parts_the_bar_once_it_has_opened_by_the_gap():
    x, m, v, d, right = broken_bar()
    t = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    # a face link across the layer opens by the pull, an edge link by less (sqrt((1 + p)^2 + 1) - sqrt 2 spacings):
    # the bar parts once both have opened past the gap (a pull of 2.27 h)
    for by, pieces in ((0.0, 1), (1.9 * H, 1), (2.3 * H, 2), (5 * H, 2)):
        row, _ = t.row(pulled(x, right, by), d)
        assert row["pieces"] == pieces, (by, row)
    assert row["piece_mass"] == [12 * 16.0, 8 * 16.0]          # layers 8..19; 0..6 and the broken layer 7
    elastic = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    assert elastic.row(pulled(x, right, 5 * H), np.zeros(len(x)))[0]["pieces"] == 1   # no point broken: stretched


def test_the_row_says_how_much_is_broken_and_how_many_links_have_opened():
    """Round 80: ``broken_mass`` is the mass at or above ``BROKEN`` and ``cut_links`` the links cut (opened past the
    gap with a point broken), so a crack that has not parted the body is in the row: the bar's broken layer 7 (16
    points of 1 kg) counts 16 kg from the first frame it is broken, and its links across open only once pulled past
    the gap. A tracker that reads the damage alone (every link of a broken point cut) is caught: it cuts them at
    once."""
    x, m, v, d, right = broken_bar()
    rows = {}
    for cls in (PieceTracker, DamageAlone):
        t = cls(x, np.zeros(len(x), int), m, v, gap=2 * H)
        rows[cls] = [t.row(pulled(x, right, by), d)[0] for by in (0.0, 1.0 * H, 2.3 * H)]
    got = [(r["broken_mass"], r["cut_links"] > 0, r["pieces"]) for r in rows[PieceTracker]]
    assert got == [(16.0, False, 1), (16.0, False, 1), (16.0, True, 2)], got
    t = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    assert t.row(pulled(x, right, 5 * H), None)[0]["broken_mass"] == 0.0      # no damage read: nothing broken
    assert rows[DamageAlone][0]["cut_links"] > 0                              # cut before any opened: caught


def test_a_bar_cut_in_two_stays_two_when_pushed_back_and_a_forgetful_tracker_is_caught():
    x, m, v, d, right = broken_bar()
    counts = {}
    for cls in (PieceTracker, Forgets):
        t = cls(x, np.zeros(len(x), int), m, v, gap=2 * H)
        counts[cls] = [t.row(pulled(x, right, by), d)[0]["pieces"] for by in (0.0, 3 * H, 0.5 * H, 0.0)]
    assert counts[PieceTracker] == [1, 2, 2, 2]
    assert counts[Forgets] == [1, 2, 1, 1]                     # the count went down: caught


def blocks(n=4):
    """A cube of (4n)^3 points, every point broken, moved apart into n^3 blocks of 4^3 (3 spacings between)."""
    g = np.stack(np.meshgrid(*[np.arange(4 * n)] * 3, indexing="ij"), -1).reshape(-1, 3)
    x = g * H
    return x, x + (g // 4) * 3 * H, np.ones(len(g)), np.full(len(g), H ** 3)


def test_a_body_broken_everywhere_and_pulled_into_blocks_is_as_many_pieces_and_damage_alone_is_caught():
    x, moved, m, v = blocks()
    d = np.ones(len(x))
    t = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    assert t.row(x, d)[0]["pieces"] == 1                        # broken through, not yet apart: one piece
    row = t.row(moved, d)[0]
    assert row["pieces"] == 64 and row["piece_mass"] == [64.0] * 64 and row["debris"] == 0
    old = DamageAlone(x, np.zeros(len(x), int), m, v, gap=2 * H)
    assert old.row(x, d)[0]["pieces"] == len(x)                 # dust: a point a piece (caught)


def test_crumbs_under_the_debris_share_are_counted_apart_and_a_piece_ground_whole_leaves_one():
    x, m, v = bar(20)                                           # 320 points; debris under 1 % here: 3.2 kg
    t = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H, debris=0.01)
    d = np.ones(len(x))
    tip = np.flatnonzero(x[:, 0] > 18.5 * H)                   # layer 19: 16 points
    moved = x.copy()
    moved[tip, 0] += 3 * H                                      # the tip comes off whole: a piece of 16 kg
    row = t.row(moved, d)[0]
    assert (row["pieces"], row["debris"]) == (2, 0)
    moved[tip] += np.stack([np.zeros(16), np.arange(16) * 3 * H, np.zeros(16)], 1)  # then grinds into 16 crumbs
    row = t.row(moved, d)[0]
    assert (row["pieces"], row["debris"], row["debris_mass"]) == (2, 15, 15.0), row
    assert row["piece_mass"] == [304.0, 1.0]                    # the heaviest crumb (the first) stays a piece


def test_a_restored_state_gives_the_rows_of_a_tracker_never_stopped_and_a_lost_one_is_caught():
    x, moved, m, v = blocks(2)
    d = np.ones(len(x))
    frames = [x, moved, x, (x + moved) / 2]                   # apart, then pushed back together
    one = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    rows = [one.row(f, d)[0] for f in frames]
    two = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    for f in frames[:2]:
        two.row(f, d)
    resumed = {}
    for restore in (True, False):                             # False: a checkpoint without the pieces
        again = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
        if restore:
            again.restore({k: a.copy() for k, a in two.state().items()})
        resumed[restore] = [again.row(f, d)[0] for f in frames[2:]]
    assert resumed[True] == rows[2:] and [r["pieces"] for r in rows] == [1, 8, 8, 8]
    assert [r["pieces"] for r in resumed[False]] == [1, 1]   # caught
    for bad in ({}, {**two.state(), "cut": np.zeros(3, bool)}, {**two.state(), "counted": np.ones(99, bool)}):
        with pytest.raises(GaspError, match="--discard"):   # a damaged checkpoint: one line, not a traceback
            PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H).restore(bad)


def test_one_outsized_point_volume_neither_widens_the_links_nor_the_memory():
    x, m, v = bar(200)   # 3,200 points
    v = v.copy()
    v[5] = 1.0           # one point of a cubic metre (an open shell's stray volume): links of 1.5 m under the max
    t = PieceTracker(x, np.zeros(len(x), int), m, v)
    assert len(t.pairs) <= 18 * len(x) // 2 + len(x)
    d = np.where(np.isclose(x[:, 0], 100 * H), 1.0, 0.0)
    # the links stay a lattice's: one broken layer opened by two spacings parts the bar
    assert t.row(pulled(x, x[:, 0] > 100.5 * H, 2.5 * H), d)[0]["pieces"] == 2


def test_touching_bodies_are_separate_pieces_and_passive_points_follow_their_host():
    x, m, v = bar()
    body = (x[:, 0] > 9.5 * H).astype(int)
    xp = np.vstack([x, [[-0.5 * H, 0.0, 0.0], [19.4 * H, 0.0, 0.0]]])
    mp, vp, bp = np.concatenate([m, [0.0, 0.0]]), np.concatenate([v, [0.0, 0.0]]), np.concatenate([body, [0, 1]])
    t = PieceTracker(xp, bp, mp, vp)
    lab = t.labels(xp, np.zeros(len(xp)))
    assert len(np.unique(lab)) == 2 and lab[-2] == lab[0] and lab[-1] == lab[len(x) - 1]


def test_the_frames_only_count_parts_blocks_apart_by_more_than_the_gap_and_counts_1_percent_parts():
    """gasp_core/testing/pieces_count.py, the reference of tests/test_pieces_family.py, on known answers: the cube of
    64 blocks moved 3 spacings apart is 64 parts (each 1.6 % of the mass) with a gap of 2 spacings, 1 with a gap of
    4; with parts of 2 % counted, none."""
    from gasp_core.testing.pieces_count import FramePieces
    x, moved, m, _ = blocks()
    assert FramePieces(x, m, 1.5 * H, 2 * H).count(x) == 1
    assert FramePieces(x, m, 1.5 * H, 2 * H).count(moved) == 64
    assert FramePieces(x, m, 1.5 * H, 4 * H).count(moved) == 1
    assert FramePieces(x, m, 1.5 * H, 2 * H).count(moved, share=0.02) == 0
    kept, alone = FramePieces(x, m, 1.5 * H, 2 * H, remember=True), FramePieces(x, m, 1.5 * H, 2 * H)
    assert [kept.count(y) for y in (x, moved, x)] == [1, 64, 64]   # round 77: apart once, apart for good
    assert [alone.count(y) for y in (x, moved, x)] == [1, 64, 1]   # each frame alone: together again


def test_the_console_names_the_last_frames_pieces_and_says_a_whole_body_cracked():
    """``gasp simulate``'s result line (round 80, ``pieces.summary_clause``): nothing without a brittle body; one
    piece with links cut reads as cracked, with its broken share; several pieces and crumbs are counted."""
    from gasp_core.run.pieces import summary_clause
    x, m, v, d, right = broken_bar()
    t = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    rows = [t.row(x, None)[0], t.row(pulled(x, right, 1.0 * H), d)[0]]
    assert summary_clause([{"frame": 0, "wall_s": 1.0}]) == ""
    assert summary_clause(rows) == "; last frame: 1 piece (5.0 % of the brittle mass broken), 0 crumbs"
    rows.append(t.row(pulled(x, right, 2.1 * H), d)[0])                   # the face links open first: cracked
    assert rows[-1]["pieces"] == 1 and rows[-1]["cut_links"] > 0, rows[-1]
    assert summary_clause(rows) == "; last frame: 1 piece, cracked (5.0 % of the brittle mass broken), 0 crumbs"
    rows.append(t.row(pulled(x, right, 3 * H), d)[0])
    assert summary_clause(rows) == "; last frame: 2 pieces (5.0 % of the brittle mass broken), 0 crumbs"
