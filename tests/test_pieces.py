"""Pieces (gasp_core/run/pieces.py, issue 52): connected parts of points linked through undamaged material.

Known answers on a lattice: a bar of 20 x 4 x 4 points (spacing h, each of mass 1 kg) is one piece; one layer of
broken points (d = 1) across it splits it in two whose masses are the points on each side, the broken layer's
points going to the nearer side by current position; a layer damaged below :data:`BROKEN` keeps it whole; two
bodies that touch are two pieces; a passive point takes its nearest material point's piece. The check is shown to
catch a labelling that links through broken points (one piece where there are two).
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
    row, changed = t.row(moved, np.where(d > 0, 0.99 * BROKEN, 0.0))
    assert row["pieces"] == 1 and changed


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
