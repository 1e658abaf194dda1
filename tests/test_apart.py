"""The Gaussians that span two pieces, the specks away from every piece, and the rule that puts a crumb's or a
left-behind Gaussian back on its piece (``gasp_core.run.apart``, issue 66 "What a user sees"), on known layouts.

Each check is shown failing on a broken variant (the catch): a counter without the tips misses a Gaussian stretched
across a gap, one that ignores its reach calls every Gaussian a speck or none, and the rule before (the Gaussians drawn
where the map puts them) leaves the crumb's and the left-behind Gaussians as specks.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gasp_core.run import apart
from gasp_core.run.apart import PieceContext, apart_masks, apart_row, hold_to_pieces

REACH = 0.014
H = 0.005


def slab(x0: float, x1: float) -> np.ndarray:
    """A lattice of points (spacing ``H``) over ``[x0, x1] x [0, 0.04] x [0, 0.02]``, metres."""
    g = np.meshgrid(np.arange(x0, x1 + 1e-9, H), np.arange(0, 0.04 + 1e-9, H), np.arange(0, 0.02 + 1e-9, H),
                    indexing="ij")
    return np.stack([a.ravel() for a in g], 1)


def layout():
    """Two slabs 3 cm apart (pieces 0 and 1) and Gaussians flat in z (normal z, in-plane x and y): on piece 0, across
    the gap (centre mid-gap, 2 sigma reaching both), in the air, and at 0.9 and 1.1 reach above piece 1's top."""
    a, b = slab(0.0, 0.05), slab(0.08, 0.13)
    points, piece = np.concatenate([a, b]), np.repeat([0, 1], [len(a), len(b)])
    means = np.array([[0.025, 0.02, 0.02], [0.065, 0.02, 0.02], [0.06, 0.02, 0.10],
                      [0.10, 0.02, 0.02 + 0.9 * REACH], [0.10, 0.02, 0.02 + 1.1 * REACH]])
    rot = np.broadcast_to(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (5, 3, 3)).copy()
    scales = np.array([[1e-6, 0.004, 0.004], [1e-6, 0.011, 0.004], [1e-6, 0.004, 0.004],
                       [1e-6, 0.002, 0.002], [1e-6, 0.002, 0.002]])
    return means, rot, scales, points, piece


def layout_problems(masks=apart_masks) -> list[str]:
    """What ``masks`` gets wrong on :func:`layout` (none for :func:`apart_masks`)."""
    means, rot, scales, points, piece = layout()
    spanning, specks = masks(means, rot, scales, points, piece, REACH)
    want_span, want_speck = [False, True, False, False, False], [False, True, True, False, True]
    out = []
    if list(spanning) != want_span:
        out.append(f"spanning {list(spanning)} != {want_span}")
    if list(specks) != want_speck:
        out.append(f"specks {list(specks)} != {want_speck}")
    return out


def test_the_counter_finds_the_gaussian_across_the_gap_and_the_specks_on_a_known_layout():
    assert layout_problems() == []


def test_catch_a_counter_without_tips_or_reach_fails_the_layout(monkeypatch):
    def no_reach(means, rot, scales, points, piece, reach):
        return apart_masks(means, rot, scales, points, piece, 10.0)

    def far_reach(means, rot, scales, points, piece, reach):
        return apart_masks(means, rot, scales, points, piece, 0.5 * reach)

    assert layout_problems(no_reach) and layout_problems(far_reach)
    monkeypatch.setattr(apart, "TIPS", 0.0)           # the centre alone: a Gaussian across the gap is not seen
    assert any("spanning" in p for p in layout_problems())


def test_the_counter_refuses_a_bad_reach_and_counts_nothing_on_no_gaussians():
    means, rot, scales, points, piece = layout()
    with pytest.raises(ValueError):
        apart_masks(means, rot, scales, points, piece, 0.0)
    s, k = apart_masks(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)), points, piece, REACH)
    assert s.shape == k.shape == (0,)


def broken_body(angle: float):
    """A body of two slabs (pieces 0 and 1) with a crumb (label 2) between them, and one surface Gaussian per surface
    point; piece 1 turned by ``angle`` (rad, about z) and moved 5 cm, the crumb flung 20 cm up, and one surface point
    of piece 0 left 4 cm behind its material and one of piece 1 left at rest. Returns ``(obj, x_rest, x, labels,
    pieces, mass, (the one of piece 0, the one of piece 1, where piece 1's motion takes that one))``."""
    a, b, c = slab(0.0, 0.05), slab(0.08, 0.13), slab(0.055, 0.075)[:6]
    fill = np.concatenate([a, b, c])
    lab_fill = np.repeat([0, 1, 2], [len(a), len(b), len(c)])
    top = fill[fill[:, 2] > 0.019]                         # the surface: the top layer, 1 mm up
    surf = top + [0, 0, 0.001]
    n_s = len(surf)
    x_rest = np.concatenate([surf, fill])
    host = np.argmin(np.linalg.norm(surf[:, None] - fill[None], axis=2), axis=1)
    labels = np.concatenate([lab_fill[host], lab_fill])
    mass = np.concatenate([np.zeros(n_s), np.full(len(fill), 1e-3)])
    c_, s_ = np.cos(angle), np.sin(angle)
    R = np.array([[c_, -s_, 0], [s_, c_, 0], [0, 0, 1.0]])
    x = x_rest.copy()
    one = labels == 1
    x[one] = (x_rest[one] - [0.105, 0.02, 0.01]) @ R.T + [0.105 + 0.05, 0.02, 0.01]
    x[labels == 2] += [0, 0, 0.2]
    behind = np.flatnonzero(labels[:n_s] == 0)[0]
    x[behind] += [0, 0, 0.04]
    rigid = x[one][0]                                      # where piece 1's motion takes its first surface point
    x[np.flatnonzero(one)[0]] = x_rest[np.flatnonzero(one)[0]]   # left behind at rest, 5 cm from its piece
    rot_rest = np.broadcast_to(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (n_s, 3, 3)).copy()
    scales_rest = np.tile([1e-6, 0.002, 0.002], (n_s, 1))
    tri = np.stack([surf, surf + 0.002 * rot_rest[:, :, 1], surf + 0.002 * rot_rest[:, :, 2]], 1)
    sm = SimpleNamespace(tri_rest=tri, rot_rest=rot_rest, scales_rest=scales_rest, anchors=lambda: np.arange(n_s))
    obj = SimpleNamespace(surface=sm, vertex_slice=slice(0, n_s), fill_slice=slice(n_s, len(x_rest)))
    return obj, x_rest, x, labels, np.array([True, True, False]), mass, (behind, np.flatnonzero(one)[0], rigid)


@pytest.mark.parametrize("angle", [0.0, 0.7])
@pytest.mark.parametrize("hold", [True, False])
def test_a_crumbs_and_a_left_behind_gaussian_go_with_their_piece(angle, hold):
    """With the rule, the crumb's Gaussians and the one left behind are drawn on piece 0 (their hosts' piece) at
    their rest offset from the host, and no speck is left; the Gaussians of piece 1 are held to it turned by its
    rotation only if the map left them (here: they moved with it, so they are not held). Without the rule (the catch:
    the map's positions) the crumb's and the left-behind Gaussians are specks."""
    obj, x_rest, x, labels, pieces, mass, (behind, behind1, rigid) = broken_body(angle)
    n = len(obj.surface.tri_rest)
    means, rot, scales = x[:n].copy(), obj.surface.rot_rest.copy(), obj.surface.scales_rest.copy()
    ctx = PieceContext(mass, pieces, REACH, x_rest, hold)
    if hold:
        held = hold_to_pieces(obj, x, labels, ctx, rot.copy(), means, rot, scales)
        crumb = labels[:n] == 2
        assert crumb.any() and held[crumb].all() and held[behind] and held[behind1], (held.sum(), crumb.sum())
        assert held.sum() == crumb.sum() + 2, held.sum()           # the others stay where the map drew them
        np.testing.assert_allclose(means[behind], x_rest[behind], atol=1e-12)   # piece 0 did not move
        np.testing.assert_allclose(means[behind1], rigid, atol=1e-9)           # piece 1's rigid motion
        np.testing.assert_allclose(rot[behind1][:, 2], [-np.sin(angle), np.cos(angle), 0], atol=1e-9)
        np.testing.assert_allclose(means[crumb], x_rest[:n][crumb], atol=1e-12)  # on piece 0, at rest
    row = apart_row(means, rot, scales, x[n:], labels[n:], mass[n:], pieces, REACH)
    if hold:
        assert row["specks"] == 0, row
    else:
        assert row["specks"] == int((labels[:n] == 2).sum()) + 2, row


def test_the_hidden_gaussians_are_not_counted_as_specks():
    """``run.json``'s ``specks`` and ``spanning`` count what is drawn: the capture's hidden inside
    (:mod:`gasp_core.gs.unseen`, ``shown`` False) is left out. Without the hold the crumb's Gaussians and the two left
    behind are specks; hiding every other one of them halves the count, hiding none keeps it (the catch: ``shown``
    ignored)."""
    obj, x_rest, x, labels, pieces, mass, (behind, behind1, rigid) = broken_body(0.0)
    n = len(obj.surface.tri_rest)
    means, rot, scales = x[:n].copy(), obj.surface.rot_rest.copy(), obj.surface.scales_rest.copy()
    args = (means, rot, scales, x[n:], labels[n:], mass[n:], pieces, REACH)
    specks = apart_row(*args)["specks"]
    assert specks == int((labels[:n] == 2).sum()) + 2 and specks >= 3, specks
    shown = np.ones(n, bool)
    speck_rows = np.flatnonzero((labels[:n] == 2) | np.isin(np.arange(n), [behind, behind1]))
    shown[speck_rows[::2]] = False
    assert apart_row(*args, shown=shown)["specks"] == specks - len(speck_rows[::2])
    assert apart_row(*args, shown=np.ones(n, bool))["specks"] == specks


@pytest.mark.parametrize("dot", [True, False])
def test_the_skin_of_crumbled_material_is_drawn_as_a_dot_on_its_piece(dot, monkeypatch):
    """A piece (a slab 5 cm long) and, beside it, a crumb 3 cm long flung 20 cm up (all the material there crumbled),
    a surface Gaussian 1 mm over each top point. The crumb's Gaussians within the reach of the piece at rest are held
    at their rest offset from their host; those further (no piece under them, round 60) are drawn as a dot at their
    host (``apart.CRUMBLED_DOT``): no speck is left. The catch: the rule before (at their rest offset, 15-30 mm from
    the piece) leaves each of those a speck."""
    monkeypatch.setattr(apart, "CRUMBLED_DOT", dot)
    a, c = slab(0.0, 0.05), slab(0.055, 0.085)
    fill = np.concatenate([a, c])
    lab_fill = np.repeat([0, 1], [len(a), len(c)])
    surf = fill[fill[:, 2] > 0.019] + [0, 0, 0.001]
    n_s = len(surf)
    x_rest = np.concatenate([surf, fill])
    near = np.argmin(np.linalg.norm(surf[:, None] - fill[None], axis=2), axis=1)
    labels = np.concatenate([lab_fill[near], lab_fill])
    mass = np.concatenate([np.zeros(n_s), np.full(len(fill), 1e-3)])
    x = x_rest.copy()
    x[labels == 1] += [0, 0, 0.2]
    rot_rest = np.broadcast_to(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), (n_s, 3, 3)).copy()
    scales_rest = np.tile([1e-6, 0.002, 0.002], (n_s, 1))
    tri = np.stack([surf, surf + 0.002 * rot_rest[:, :, 1], surf + 0.002 * rot_rest[:, :, 2]], 1)
    sm = SimpleNamespace(tri_rest=tri, rot_rest=rot_rest, scales_rest=scales_rest, anchors=lambda: np.arange(n_s))
    obj = SimpleNamespace(surface=sm, vertex_slice=slice(0, n_s), fill_slice=slice(n_s, len(x_rest)))
    pieces = np.array([True, False])
    means, rot, scales = x[:n_s].copy(), rot_rest.copy(), scales_rest.copy()
    held = hold_to_pieces(obj, x, labels, PieceContext(mass, pieces, REACH, x_rest, True), rot.copy(), means, rot,
                          scales)
    crumb = labels[:n_s] == 1
    far = crumb & (np.linalg.norm(surf[:, None] - a[None], axis=2).min(axis=1) > REACH)
    assert held[crumb].all() and far.sum() >= 10 and (crumb & ~far).sum() >= 10, (crumb.sum(), far.sum())
    np.testing.assert_allclose(means[crumb & ~far], surf[crumb & ~far], atol=1e-12)   # at rest: piece 0 is still
    row = apart_row(means, rot, scales, x[n_s:], labels[n_s:], mass[n_s:], pieces, REACH)
    if dot:
        host = n_s + np.argmin(np.linalg.norm(surf[far][:, None] - a[None], axis=2), axis=1)
        np.testing.assert_allclose(means[far], x[host], atol=1e-12)
        np.testing.assert_allclose(scales[far], scales_rest[far] * apart.DOT, rtol=1e-12)
        assert row["specks"] == 0, row
    else:
        assert row["specks"] == int(far.sum()), (row, int(far.sum()))
