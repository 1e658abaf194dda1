"""Pieces (gasp_core/run/pieces.py, issue 52): connected parts of points linked through undamaged material.

Known answers on a lattice: a bar of 20 x 4 x 4 points (spacing h, each of mass 1 kg) is one piece; one layer of
broken points (d = 1) across it splits it in two whose masses are the points on each side, the broken layer's
points going to the nearer side by current position; a layer damaged below :data:`BROKEN` keeps it whole while it
has not opened, and a bar pulled open by more than the gap (a grid cell, issue 66: a dog-bone with a 4.7 mm gap was
"1 piece") is two whatever its damage; two bodies that touch are two pieces; a passive point takes its nearest
material point's piece; one point of outsized volume neither widens the links nor asks for unbounded memory (the
bundled guitar made brittle died in ``query_pairs``). The checks are shown to catch a labelling that links through
broken points and one that ignores the opening.
"""
from __future__ import annotations

import numpy as np

from gasp_core.run.pieces import BROKEN, PieceTracker

H = 0.01   # lattice spacing, m


def bar(nx: int = 20):
    g = np.stack(np.meshgrid(np.arange(nx), np.arange(4), np.arange(4), indexing="ij"), -1).reshape(-1, 3) * H
    return g.astype(np.float64), np.ones(len(g)), np.full(len(g), H ** 3)


def test_an_intact_bar_is_one_piece_of_its_whole_mass():
    x, m, v = bar()
    row, changed = PieceTracker(x, np.zeros(len(x), int), m, v).row(x, np.zeros(len(x)))
    assert row == {"pieces": 1, "piece_mass": [float(len(x))]} and changed


def test_a_broken_layer_splits_the_bar_at_it_and_a_damaged_one_does_not():
    x, m, v = bar()
    t = PieceTracker(x, np.zeros(len(x), int), m, v)
    d = np.where(np.isclose(x[:, 0], 7 * H), 1.0, 0.0)          # layer 7 of 0..19
    moved = x + np.where(x[:, 0] > 7.5 * H, 0.05, 0.0)[:, None] * [1, 0, 0]   # the right part pulled away
    row, changed = t.row(moved, d)
    assert row["pieces"] == 2 and changed
    assert row["piece_mass"] == [12 * 16.0, 8 * 16.0]          # layers 8..19; 0..6 and the broken layer 7
    row, changed = t.row(x, np.where(d > 0, 0.99 * BROKEN, 0.0))   # damaged below BROKEN, not opened: whole
    assert row["pieces"] == 1 and changed


def test_a_bar_pulled_open_by_more_than_the_gap_is_two_pieces_whatever_its_damage():
    x, m, v = bar()
    t = PieceTracker(x, np.zeros(len(x), int), m, v, gap=2 * H)
    right = x[:, 0] > 7.5 * H
    for pull, pieces in ((1.9 * H, 1), (2.1 * H, 2), (10 * H, 2)):
        moved = x + np.where(right, pull, 0.0)[:, None] * [1, 0, 0]
        row, _ = t.row(moved, np.zeros(len(x)))
        assert row["pieces"] == pieces, (pull, row)
    assert row["piece_mass"] == [12 * 16.0, 8 * 16.0]

    class IgnoresTheOpening(PieceTracker):   # the labelling before issue 66: damage alone parts the pieces
        def labels(self, x, damage):
            return super().labels(self.x_rest, damage)
    broken = IgnoresTheOpening(x, np.zeros(len(x), int), m, v, gap=2 * H)
    broken.x_rest = x
    assert broken.row(x + np.where(right, 10 * H, 0.0)[:, None] * [1, 0, 0], np.zeros(len(x)))[0]["pieces"] == 1


def test_one_outsized_point_volume_neither_widens_the_links_nor_the_memory():
    x, m, v = bar(200)   # 3,200 points
    v = v.copy()
    v[5] = 1.0           # one point of a cubic metre (an open shell's stray volume): links of 1.5 m under the max
    t = PieceTracker(x, np.zeros(len(x), int), m, v)
    assert len(t.pairs) <= 18 * len(x) // 2 + len(x)
    d = np.where(np.isclose(x[:, 0], 100 * H), 1.0, 0.0)
    assert t.row(x, d)[0]["pieces"] == 2     # the links stay a lattice's: one broken layer still parts the bar


def test_touching_bodies_are_separate_pieces_and_passive_points_follow_their_host():
    x, m, v = bar()
    body = (x[:, 0] > 9.5 * H).astype(int)
    xp = np.vstack([x, [[-0.5 * H, 0.0, 0.0], [19.4 * H, 0.0, 0.0]]])
    mp, vp, bp = np.concatenate([m, [0.0, 0.0]]), np.concatenate([v, [0.0, 0.0]]), np.concatenate([body, [0, 1]])
    t = PieceTracker(xp, bp, mp, vp)
    lab = t.labels(xp, np.zeros(len(xp)))
    assert len(np.unique(lab)) == 2 and lab[-2] == lab[0] and lab[-1] == lab[len(x) - 1]


def test_the_split_check_catches_a_labelling_that_links_through_broken_points():
    x, m, v = bar()
    d = np.where(np.isclose(x[:, 0], 7 * H), 1.0, 0.0)

    class LinksThroughBroken(PieceTracker):
        def labels(self, x, damage):
            return super().labels(x, None)

    assert LinksThroughBroken(x, np.zeros(len(x), int), m, v).row(x, d)[0]["pieces"] == 1
