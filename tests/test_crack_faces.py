"""Crack faces (``gasp_core.maps.crack_faces``, issue 52): interior Gaussians on a broken body's fill points.

Known answers on a lattice bar of 10 x 4 x 4 fill points (spacing h) with four red surface Gaussians at its left end
and four blue ones at its right end: whole, no face is shown; with one layer broken through (``d = 1``) and the right
part pulled 5 cm away, exactly the two layers beside the broken one show their faces (32 of 160), their normals
facing the gap (``n_x >= 0.92`` on the left layer, ``<= -0.92`` on the right: 1 inside the section, 0.92 at its
corners, where the diagonal neighbours across tilt it), and a face takes the colour of its nearest surface
Gaussians (the end layers exactly red and blue). Shown to catch a rule that ignores the damage (the broken layer,
which joined the left piece, shows instead of the left layer: layers 4 and 5) and one that shows every face (160
while whole).
"""
from __future__ import annotations

import numpy as np

from gasp_core.maps.crack_faces import build_crack_faces, crack_face_gaussians, exposed_normals
from gasp_core.run.pieces import PieceTracker

H = 0.01
RED, BLUE = np.array([1.0, -1.0, -1.0]), np.array([-1.0, -1.0, 1.0])


def bar():
    x = np.stack(np.meshgrid(np.arange(10), np.arange(4), np.arange(4), indexing="ij"), -1).reshape(-1, 3) * H
    ends = np.array([[a, b, c] for a in (-H, 10 * H) for b in (0.0, 3 * H) for c in (0.0, 3 * H)])
    colours = np.array([RED] * 4 + [BLUE] * 4)
    tracker = PieceTracker(x, np.zeros(len(x), int), np.ones(len(x)), np.full(len(x), H ** 3))
    faces = build_crack_faces(x, np.arange(len(x)), tracker.pairs, ends, colours, H)
    return x, tracker, faces


def broken():
    x, tracker, faces = bar()
    d = np.where(np.isclose(x[:, 0], 4 * H), 1.0, 0.0)
    moved = x + np.where(x[:, 0] > 4.5 * H, 0.05, 0.0)[:, None] * [1.0, 0.0, 0.0]
    return x, tracker, faces, d, moved, tracker.labels(moved, d)


def test_a_whole_body_shows_no_face():
    x, tracker, faces = bar()
    d = np.zeros(len(x))
    _, _, _, visible = crack_face_gaussians(faces, x, tracker.labels(x, d), d)
    assert not visible.any()


def test_the_layers_beside_a_crack_show_faces_facing_the_gap():
    x, tracker, faces, d, moved, labels = broken()
    means, rot, scales, visible = crack_face_gaussians(faces, moved, labels, d)
    layer = np.round(x[:, 0] / H).astype(int)
    assert visible.sum() == 32 and set(layer[visible]) == {3, 5}
    n = rot[:, :, 0]
    assert n[layer == 3, 0].min() >= 0.92 and n[layer == 5, 0].max() <= -0.92
    np.testing.assert_allclose(means, moved)
    np.testing.assert_allclose(scales[:, 0] / scales[:, 1], 0.25 / 0.9)                    # flat across n
    np.testing.assert_allclose(np.einsum("nij,nik->njk", rot, rot), np.broadcast_to(np.eye(3), rot.shape), atol=1e-12)
    np.testing.assert_allclose(faces.sh_dc[layer == 0], np.broadcast_to(RED, (16, 3)), atol=1e-12)
    np.testing.assert_allclose(faces.sh_dc[layer == 9], np.broadcast_to(BLUE, (16, 3)), atol=1e-12)


def test_the_checks_catch_a_rule_blind_to_damage_and_one_showing_every_face():
    x, tracker, faces, d, moved, labels = broken()
    blind = np.linalg.norm(exposed_normals(faces, moved, labels, np.zeros(len(x))), axis=1) > 0.5
    layer = np.round(x[:, 0] / H).astype(int)
    assert set(layer[blind]) == {4, 5}                                # the check above wants {3, 5}: the broken layer
    every = np.ones(len(faces.rows), bool)                            # a rule that never hides a face
    assert every.any()                                                # the whole-body check wants none


def turned():
    """The broken bar with its right part turned 90 degrees about z and carried 5 cm along x and y (a rigid
    fragment that flew off sideways): ``(x, tracker, d, moved, labels, R)``."""
    x, tracker, _, d, _, _ = broken()
    R = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    right = x[:, 0] > 4.5 * H
    c = x[right].mean(0)
    moved = x.copy()
    moved[right] = (x[right] - c) @ R.T + c + [0.05, 0.05, 0.0]
    return x, tracker, d, moved, tracker.labels(moved, d), R


def test_a_turned_fragment_carries_its_faces_normals():
    """With the rest positions, each face's normal is its rest normal carried by its piece's motion: the left
    layer (unmoved) faces +x, the right layer faces R (-x), as at rest (within the corners' 0.92)."""
    x, tracker, d, moved, labels, R = turned()
    faces = build_crack_faces(x, np.arange(len(x)), tracker.pairs, x[:1], RED[None], H, x_rest=x)
    n = exposed_normals(faces, moved, labels, d)
    layer = np.round(x[:, 0] / H).astype(int)
    assert n[layer == 3, 0].min() >= 0.92
    assert (n[layer == 5] @ (R @ [-1.0, 0.0, 0.0])).min() >= 0.92
    np.testing.assert_allclose(np.linalg.norm(n[np.isin(layer, (3, 5))], axis=1), 1.0, atol=1e-12)


def test_the_turned_check_catches_directions_read_at_the_current_positions():
    """The rule without the rest positions turns the right layer's faces towards the broken layer it left."""
    x, tracker, d, moved, labels, R = turned()
    faces = build_crack_faces(x, np.arange(len(x)), tracker.pairs, x[:1], RED[None], H)
    n = exposed_normals(faces, moved, labels, d)
    layer = np.round(x[:, 0] / H).astype(int)
    assert (n[layer == 5] @ (R @ [-1.0, 0.0, 0.0])).max() < 0.92       # the check above wants >= 0.92
