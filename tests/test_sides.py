"""A Gaussian spans two pieces when its 2-sigma ellipse reaches the side of a piece not its own, whatever the crack's
width, and the rule keeps each Gaussian on its own side (``gasp_core.run.sides``, issue 66 "What a user sees"), on
hand-built layouts: two blocks of material points ``g`` apart (0.5, 1 and 2 grid cells), flat Gaussians on their tops.

Known answers: a Gaussian on block A away from the crack, and one whose tip stops at A's edge (wholly on A beside the
crack), do not span; one stretched from A over the crack onto B does, and so does one of A drawn wholly on B's side.
The rule trims the one stretched across so that its tip stops within one step of the crack's mid-plane, leaves the
others exactly as they were, and hands the one on B's side to the hold. Each is shown failing on a broken variant: a
counter without tips, one that counts a Gaussian near two pieces, one without the Gaussian's own piece, and the rule
before (nothing trimmed). The pull rule: a centre the hold leaves on B's side is pulled to A's (without its host it stays
counted), and crack faces on A's edge are counted and trimmed to A's side (drawn as made, one reaches B's side).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from gasp_core.run import apart
from gasp_core.run.apart import apart_masks
from gasp_core.run.sides import FRACTIONS, keep_to_side

DX = 0.01                 # the grid cell, m
REACH = 1.5 * DX
H = 0.5 * DX              # the fill spacing
LIFT = 0.5 * DX           # the surface above the top layer of fill
GAPS = (0.5, 1.0, 2.0)    # in cells


def block(x0: float, x1: float) -> np.ndarray:
    """Points ``H`` apart over ``[x0, x1] x [0, 0.04] x [0, 0.02]``, metres."""
    g = np.meshgrid(np.arange(x0, x1 + 1e-9, H), np.arange(0, 0.04 + 1e-9, H), np.arange(0, 0.02 + 1e-9, H),
                    indexing="ij")
    return np.stack([a.ravel() for a in g], 1)


def layout(gap: float):
    """Blocks A (piece 0, x in [0, 0.05]) and B (piece 1) ``gap`` cells apart, and four Gaussians flat on the tops
    (normal z, ``r2`` along x), all of A: ``on`` (centre 2.5 cm from the crack, tips 1 cm either side), ``beside``
    (its +x tip at A's edge), ``across`` (centre 3 mm inside A's edge, tip 1 cm onto B), ``on_b`` (drawn wholly on
    B's top, 1.5 cm from its edge). Returns ``(means, rot, scales, points, piece, own, x_mid)``: ``x_mid`` the
    crack's mid-plane."""
    a, b0 = block(0.0, 0.05), 0.05 + gap * DX
    b = block(b0, b0 + 0.05)
    points, piece = np.concatenate([a, b]), np.repeat([0, 1], [len(a), len(b)])
    z = 0.02 + LIFT
    means = np.array([[0.025, 0.02, z], [0.045, 0.02, z], [0.047, 0.02, z], [b0 + 0.015, 0.02, z]])
    half = np.array([0.01, 0.005, (b0 + 0.01 - 0.047), 0.005])       # the 2-sigma half-length along x
    scales = np.stack([np.full(4, 1e-6), half / 2, np.full(4, 0.002)], 1)
    rot = np.broadcast_to(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (4, 3, 3)).copy()
    return means, rot, scales, points, piece, np.zeros(4, np.int64), 0.05 + gap * DX / 2


WANT = [False, False, True, True]


def counted(masks=apart_masks, gap: float = 1.0) -> list[bool]:
    means, rot, scales, points, piece, own, _ = layout(gap)
    return [bool(v) for v in masks(means, rot, scales, points, piece, REACH, own)[0]]


@pytest.mark.parametrize("gap", GAPS)
def test_spanning_is_reaching_another_pieces_side_whatever_the_gap(gap):
    assert counted(gap=gap) == WANT


def near_two(means, rot, scales, points, piece, reach, own=None, tree=None):
    """A broken counter: a Gaussian whose centre or tips are within reach of two pieces' material."""
    arms = [2 * scales[:, j, None] * rot[:, :, j] for j in (1, 2)]
    out = np.zeros(len(means), bool)
    for p in (means, means + arms[0], means - arms[0], means + arms[1], means - arms[1]):
        hits = cKDTree(points).query_ball_point(p, reach)
        out |= np.array([len(set(piece[h])) > 1 for h in hits])
    return out, np.zeros(len(means), bool)


def test_catch_counters_without_tips_near_two_pieces_or_without_its_own_piece(monkeypatch):
    assert any(counted(near_two, g) != WANT for g in GAPS)          # counts the one beside a narrow crack
    assert counted(lambda *a: apart_masks(*a[:6]), 1.0) != WANT     # without its own piece: on B is not seen
    monkeypatch.setattr(apart, "TIPS", 0.0)                          # the centre alone misses the one across
    assert counted(gap=1.0) != WANT


def kept(gap: float, trim: bool = True):
    """The layout after :func:`keep_to_side` (``trim``: False, the rule before: nothing done); the Gaussians, the
    rows handed to the hold, and the layout."""
    means, rot, scales, points, piece, own, x_mid = layout(gap)
    m, r, s = means.copy(), rot.copy(), scales.copy()
    handed = []
    if trim:
        keep_to_side(m, r, s, own, cKDTree(points), piece, REACH, apart.TIPS, lambda idx: handed.extend(idx))
    return m, r, s, handed, (means, rot, scales, points, piece, own, x_mid)


@pytest.mark.parametrize("gap", GAPS)
def test_the_rule_trims_the_one_across_to_the_mid_plane_and_leaves_the_others(gap):
    m, r, s, handed, (means, rot, scales, points, piece, own, x_mid) = kept(gap)
    assert handed == [3]                                             # drawn on B's side: to the hold
    np.testing.assert_array_equal(m, means)
    np.testing.assert_array_equal(r, rot)
    np.testing.assert_array_equal(s[[0, 1]], scales[[0, 1]])        # on A: untouched
    tip = m[2, 0] + 2 * s[2, 1]
    step = 2 * scales[2, 1] * (FRACTIONS[-1] - FRACTIONS[-2])
    assert x_mid - step - 1e-9 <= tip <= x_mid + 1e-9, (tip, x_mid, step)   # up to the mid-plane, within a step
    assert (s[2, 1:] <= scales[2, 1:]).all() and s[2, 2] > 0
    span = apart_masks(m[:3], r[:3], s[:3], points, piece, REACH, own[:3])[0]
    assert not span.any(), span


def test_catch_the_rule_before_leaves_the_one_across():
    m, r, s, handed, lay = kept(1.0, trim=False)
    assert apart_masks(m[:3], r[:3], s[:3], *lay[3:5], REACH, lay[5][:3])[0].tolist() == [False, False, True]


def pulled(gap: float, with_hosts: bool = True):
    """The layout after :func:`keep_to_side` with a hold that leaves the Gaussian drawn on B's side where it is (as
    where two pieces have come together after the break) and, with ``with_hosts``, each Gaussian's host (the point of
    A under it; the rule before the pull rule: none). Returns the Gaussians, the rows pulled, and the layout."""
    means, rot, scales, points, piece, own, x_mid = layout(gap)
    hosts = points[cKDTree(points[piece == 0]).query(means)[1]] if with_hosts else None
    m, r, s = means.copy(), rot.copy(), scales.copy()
    out = keep_to_side(m, r, s, own, cKDTree(points), piece, REACH, apart.TIPS, lambda idx: None, hosts)
    return m, r, s, out[2], (means, rot, scales, points, piece, own, x_mid)


@pytest.mark.parametrize("gap", GAPS)
def test_a_centre_the_hold_leaves_on_another_side_is_pulled_to_its_own(gap):
    m, r, s, was_pulled, (means, rot, scales, points, piece, own, x_mid) = pulled(gap)
    assert was_pulled.tolist() == [False, False, False, True]
    np.testing.assert_array_equal(m[:3], means[:3])                  # the others: not moved
    assert m[3, 0] <= x_mid + 1e-9, (m[3, 0], x_mid)                   # on A's side of the crack's mid-plane
    assert (s[3, 1:] <= scales[3, 1:]).all() and s[3, 1:].min() > 0
    assert not apart_masks(m, r, s, points, piece, REACH, own)[0].any()


def test_catch_without_its_host_the_one_on_b_stays_counted():
    m, r, s, was_pulled, lay = pulled(1.0, with_hosts=False)
    assert not was_pulled.any()
    assert apart_masks(m, r, s, *lay[3:5], REACH, lay[5])[0].tolist() == [False, False, False, True]


def faces(gap: float):
    """Two crack faces of A standing on its edge (normal z, in-plane x and y, ``FACE`` 0.9 of the 0.5-cell fill
    spacing): one 2 cm from the crack, one at A's last column, its 2-sigma ellipse 0.9 cell across onto B's side."""
    from gasp_core.maps.crack_faces import FACE, THIN
    _, _, _, points, piece, own, x_mid = layout(gap)
    means = np.array([[0.03, 0.02, 0.01], [0.05, 0.02, 0.01]])
    rot = np.broadcast_to(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (2, 3, 3)).copy()
    scales = np.tile([THIN * H, FACE * H, FACE * H], (2, 1))
    return means, rot, scales, points, piece, np.zeros(2, np.int64), x_mid


@pytest.mark.parametrize("gap", GAPS)
def test_crack_faces_are_counted_and_kept_to_their_side(gap):
    from gasp_core.run.sides import keep_faces_to_side
    means, rot, scales, points, piece, own, x_mid = faces(gap)
    assert apart_masks(means, rot, scales, points, piece, REACH, own)[0].tolist() == [False, gap < 2]
    s = scales.copy()
    shown, k = keep_faces_to_side(means, rot, s, np.ones(2, bool), own, cKDTree(points), piece, REACH, apart.TIPS)
    assert k == int(gap < 2)
    np.testing.assert_array_equal(s[0], scales[0])
    assert shown.all() and not apart_masks(means, rot, s, points, piece, REACH, own)[0].any()


def test_catch_faces_drawn_as_made_reach_the_other_side():
    means, rot, scales, points, piece, own, _ = faces(1.0)        # the rule before the pull rule: faces not kept
    assert apart_masks(means, rot, scales, points, piece, REACH, own)[0].any()


# The gap rule: across a gap only where the two pieces are apart there (gasp_core.run.sides, "Apart there"). The blocks
# are ``g`` cells apart point to point: 0.5 cell is the fill spacing (the pieces touch), 1 cell opens them by half a
# cell (under the gap of 1 dx the pieces are told apart by), 2 and 3 cells by 1.5 and 2.5 (apart).
OPENING = H + DX          # opening(): the fill spacing plus the gap (dx)
TOUCH, APART = (0.5, 1.0), (2.0, 3.0)


def gap_tree(points, piece, opening=OPENING):
    from gasp_core.run.sides import PieceTree
    return PieceTree(points, piece, opening)


@pytest.mark.parametrize("gap", TOUCH + APART)
def test_spanning_counts_only_where_the_pieces_are_apart(gap):
    means, rot, scales, points, piece, own, _ = layout(gap)
    span = apart_masks(means, rot, scales, points, piece, REACH, own, gap_tree(points, piece))[0]
    assert span.tolist() == (WANT if gap in APART else [False, False, False, True])   # on B, 3 cells from A: drawn
    #                                                                            on another piece where they are apart


@pytest.mark.parametrize("gap", TOUCH + APART)
def test_the_rule_leaves_what_overlaps_a_touching_piece_and_trims_across_a_gap(gap):
    means, rot, scales, points, piece, own, x_mid = layout(gap)
    m, r, s = means.copy(), rot.copy(), scales.copy()
    hosts = points[cKDTree(points[piece == 0]).query(means)[1]]
    handed = []
    tree = gap_tree(points, piece)
    held, trimmed, was_pulled = keep_to_side(m, r, s, own, tree, piece, REACH, apart.TIPS,
                                             lambda idx: handed.extend(idx), hosts)
    assert handed == [3]                                             # drawn on B away from A: to the hold
    if gap in TOUCH:                                                 # no gap where it crosses: drawn as before
        assert not (held[:3] | trimmed[:3] | was_pulled[:3]).any()
        np.testing.assert_array_equal(s[:3], scales[:3])
        np.testing.assert_array_equal(m[:3], means[:3])
    else:
        assert trimmed[2] and not trimmed[:2].any()
        tip = m[2, 0] + 2 * s[2, 1]
        assert x_mid - 2 * scales[2, 1] / STEPS_ - 1e-9 <= tip <= x_mid + 1e-9
    assert not apart_masks(m, r, s, points, piece, REACH, own, tree)[0].any()


STEPS_ = 8


@pytest.mark.parametrize("gap", TOUCH)
def test_crack_faces_where_the_pieces_touch_are_left_whole(gap):
    from gasp_core.run.sides import keep_faces_to_side
    means, rot, scales, points, piece, own, _ = faces(gap)
    s = scales.copy()
    shown, k = keep_faces_to_side(means, rot, s, np.ones(2, bool), own, gap_tree(points, piece), piece, REACH,
                                  apart.TIPS)
    assert k == 0 and shown.all()
    np.testing.assert_array_equal(s, scales)


def test_catch_round_33s_rule_trims_the_faces_where_the_pieces_touch():
    from gasp_core.run.sides import keep_faces_to_side
    means, rot, scales, points, piece, own, _ = faces(0.5)
    s = scales.copy()
    assert keep_faces_to_side(means, rot, s, np.ones(2, bool), own, cKDTree(points), piece, REACH, apart.TIPS)[1] == 1
    assert (s[1] < scales[1]).any()


def wedge():
    """Blocks A and B whose crack opens along y: B's points ``0.5 + 2.5 y / 4 cm`` cells from A's edge (touching at
    y = 0, 3 cells apart at y = 4 cm); two Gaussians of A stretched to x = 9 cm, onto B, at y = 2 mm (the pieces
    touch there: opened by under 0.25 cell) and at y = 3.8 cm (2.4 cells apart)."""
    a = block(0.0, 0.05)
    b = block(0.0, 0.05)
    b[:, 0] += 0.05 + (0.5 + 2.5 * b[:, 1] / 0.04) * DX
    points, piece = np.concatenate([a, b]), np.repeat([0, 1], [len(a), len(b)])
    z = 0.02 + LIFT
    means = np.array([[0.047, 0.002, z], [0.047, 0.038, z]])
    scales = np.tile([1e-6, (0.09 - 0.047) / 2, 0.001], (2, 1))
    rot = np.broadcast_to(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (2, 3, 3)).copy()
    return means, rot, scales, points, piece, np.zeros(2, np.int64)


def test_apart_is_decided_where_the_gaussian_reaches_not_per_pair_of_pieces():
    means, rot, scales, points, piece, own = wedge()
    tree = gap_tree(points, piece)
    assert apart_masks(means, rot, scales, points, piece, REACH, own, tree)[0].tolist() == [False, True]
    s = scales.copy()
    trimmed = keep_to_side(means.copy(), rot, s, own, tree, piece, REACH, apart.TIPS, lambda idx: None)[1]
    assert trimmed.tolist() == [False, True]


@pytest.mark.parametrize("opening, want", [(0.0, [True, True]), (10 * DX, [False, False])])
def test_catch_an_opening_of_nothing_or_of_the_whole_body_misses_the_wedge(opening, want):
    means, rot, scales, points, piece, own = wedge()
    tree = gap_tree(points, piece, opening)            # 0: apart wherever another side is; 10 cells: never apart
    assert apart_masks(means, rot, scales, points, piece, REACH, own, tree)[0].tolist() == want


def test_the_opening_is_the_fill_spacing_plus_the_gap():
    from gasp_core.run.sides import opening
    vol = np.full(100, H ** 3)
    vol[:5] = (3 * H) ** 3                              # a few outsized points (an open shell's) do not widen it
    assert opening(vol, DX) == pytest.approx(H + DX, rel=1e-12)
    with pytest.raises(ValueError):
        opening(np.zeros(0), DX)


def test_a_crack_face_across_a_gap_is_still_trimmed():
    """Blocks 1.6 cells apart (opened by 1.1 cells: apart): the face at A's last column, 0.9 cell across, reaches past
    the mid-plane (0.8 cell) and is trimmed with the gap rule as with the pull rule's."""
    from gasp_core.run.sides import keep_faces_to_side
    means, rot, scales, points, piece, own, _ = faces(1.6)
    tree = gap_tree(points, piece)
    assert apart_masks(means, rot, scales, points, piece, REACH, own, tree)[0].tolist() == [False, True]
    s = scales.copy()
    shown, k = keep_faces_to_side(means, rot, s, np.ones(2, bool), own, tree, piece, REACH, apart.TIPS)
    assert k == 1 and shown.all() and (s[1] < scales[1]).any()
    assert not apart_masks(means, rot, s, points, piece, REACH, own, tree)[0].any()
