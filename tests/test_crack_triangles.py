"""Crack faces from the split triangles (``benchmarks/studies/crack_triangles.py``, issue 52 item 3, the second
candidate: measured against the fill's and rejected, kept as a study for its figures; docs/fracture.md).

Known answers on a square tube of GaMeS triangles (spacing h = 1 cm, the tube 10 h long, its section 4 h x 4 h;
each triangle ``v1`` on the surface, ``v2 = v1 + h/2 x``, ``v3 = v1 + h/2`` along the section's perimeter):

- whole (one piece), no face;
- cut at ``x = 5 h`` (vertices at ``x >= 5 h`` in piece 1) and piece 1 pulled 5 cm along ``x``: the triangles with
  ``v1`` at ``x = 4.5 h`` are split; piece 0's face lies in the plane ``x = 4.5 h`` with its normal ``+x`` (out of
  the piece, into the gap), piece 1's in ``x = 5 h + 5 cm`` with ``-x``; each covers the whole section (every point
  of it within 0.75 h of a face Gaussian's centre) with 16 to 25 Gaussians (a grid h apart over 4 h x 4 h); each
  takes the colour of a split triangle (red), never that of the other triangles (blue);
- a ring's break (pieces 0 | 1 | 0 along the tube, cuts at 3 h and 7 h): two faces on each piece, one per crack,
  each in its own plane. Shown to catch grouping the rim by piece pair alone (``link`` without a limit: one face
  per piece, its plane across the tube) and a normal not turned out of its piece (checked by sign above).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
from crack_triangles import build_split_triangles, split_triangle_faces  # noqa: E402

H = 0.01
RED, BLUE = np.array([1.0, -1.0, -1.0]), np.array([-1.0, -1.0, 1.0])


def tube():
    """``(x_rest (3n, 3), rows (n, 3), colours (n, 3), v1 x-positions (n,))``: the tube's triangles, one row of
    points per vertex, ``v1`` every h/2 along x and along the section's perimeter."""
    tris = []
    s = np.arange(8) * 0.5 * H                                      # along each side of the section, 0 .. 3.5 h
    sides = [(lambda t: (t, 0.0), (1.0, 0.0)), (lambda t: (4 * H, t), (0.0, 1.0)),
             (lambda t: (4 * H - t, 4 * H), (-1.0, 0.0)), (lambda t: (0.0, 4 * H - t), (0.0, -1.0))]
    for xi in np.arange(20) * 0.5 * H:
        for at, d in sides:
            for t in s:
                y, z = at(t)
                v1 = np.array([xi, y, z])
                tris.append([v1, v1 + [0.5 * H, 0, 0], v1 + 0.5 * H * np.array([0.0, *d])])
    tri = np.array(tris)
    return tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), tri[:, 0, 0]


def _setup(colour_split_at):
    x, rows, x1 = tube()
    colours = np.where(np.isin(np.round(x1 / H, 6), colour_split_at)[:, None], RED, BLUE)
    return x, rows, build_split_triangles(rows, x, colours, H)


def _covers(means):
    """Every point of the section (a 0.2 h grid) within 0.75 h of a face centre, in the plane."""
    yz = np.stack(np.meshgrid(*[np.linspace(0.1 * H, 3.9 * H, 20)] * 2, indexing="ij"), -1).reshape(-1, 2)
    d = np.linalg.norm(yz[:, None, :] - means[None, :, 1:], axis=2).min(1)
    return bool((d < 0.75 * H).all())


def test_a_whole_tube_has_no_face():
    x, rows, tris = _setup([4.5])
    assert split_triangle_faces(tris, x, np.zeros(len(x), np.int64)).n == 0


def test_a_cut_tube_gets_a_face_on_each_side_facing_the_gap_coloured_by_the_split_triangles():
    x, rows, tris = _setup([4.5])
    labels = (x[:, 0] >= 5 * H - 1e-9).astype(np.int64)
    moved = x + np.where(labels == 1, 0.05, 0.0)[:, None] * [1.0, 0.0, 0.0]
    f = split_triangle_faces(tris, moved, labels)
    for piece, plane, sign in ((0, 4.5 * H, 1.0), (1, 5 * H + 0.05, -1.0)):
        k = f.piece == piece
        assert 16 <= k.sum() <= 25, k.sum()
        np.testing.assert_allclose(f.means[k, 0], plane, atol=1e-9)
        np.testing.assert_allclose(f.rotations[k, :, 0], np.broadcast_to([sign, 0.0, 0.0], (k.sum(), 3)), atol=1e-9)
        assert _covers(f.means[k])
    np.testing.assert_allclose(f.sh_dc, np.broadcast_to(RED, f.sh_dc.shape))           # the split triangles' own
    np.testing.assert_allclose(np.einsum("nij,nik->njk", f.rotations, f.rotations),
                               np.broadcast_to(np.eye(3), f.rotations.shape), atol=1e-12)
    np.testing.assert_allclose(f.scales[:, 0] / f.scales[:, 1], 0.25 / 0.9)


def _ring():
    x, rows, tris = _setup([2.5, 6.5])
    labels = ((x[:, 0] >= 3 * H - 1e-9) & (x[:, 0] < 7 * H - 1e-9)).astype(np.int64)   # 0 | 1 | 0
    moved = x.copy()
    moved[labels == 1, 2] += 0.05                                    # the middle piece lifted 5 cm
    return x, tris, labels, moved


def test_a_ring_broken_in_two_gets_one_face_per_crack():
    x, tris, labels, moved = _ring()
    f = split_triangle_faces(tris, moved, labels)
    planes = {(int(p), round(float(m[0]) / H, 6), round(float(n[0]), 6))
              for p, m, n in zip(f.piece, f.means, f.rotations[:, :, 0])}
    assert planes == {(0, 2.5, 1.0), (0, 7.0, -1.0), (1, 3.0, -1.0), (1, 6.5, 1.0)}, planes
    # without grouping the rim into cracks the two faces of a piece become one, across the tube
    merged = split_triangle_faces(tris, moved, labels, link=1e9)
    assert {round(float(m[0]) / H, 6) for m in merged.means[merged.piece == 0]} != {2.5, 7.0}
