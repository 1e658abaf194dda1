"""Crack faces from the split triangles (issue 52, item 3, the second candidate; docs/fracture.md "Crack faces").

**A study, not part of GASP:** measured against the first candidate (``benchmarks/crack_faces.py --faces both``,
``benchmarks/results/crack_faces_compare[_rod].md``) it covered less (0.7-10.9 % of the donut pieces' silhouettes below
alpha 0.9 from their crack side, against 0.0-1.7 %), added more Gaussians (13 818 against 3 150 shown) and nothing at
all where the crack passed between triangles (the rod), so it was taken out of ``gasp_core`` and kept here for the
figures (``tests/test_crack_triangles.py`` still holds it to its known answers).

The first candidate (:mod:`gasp_core.maps.crack_faces`) puts a face on every fill point next to a crack. This one
uses only the surface: a GaMeS triangle whose shape points (:meth:`gasp_core.maps.surface.SurfaceMap.shape_rows`,
its ``v1, v2, v3`` in the triangles form) fall in different pieces is *split* by the crack, and the crack meets
the surface exactly there. Each piece's crack face is spanned by the split triangles around it, and is filled with
flat Gaussians:

- **Rim.** For each split triangle and each piece ``p`` among its vertices' pieces, the triangle's vertices in
  ``p`` are *rim points* of ``p`` against every other piece ``q`` of the triangle, at the current positions (they
  move with ``p``). The rim points of ``(p, q)`` are grouped into cracks by their rest positions (connected within
  :data:`LINK` fill spacings): a ring broken in two has two cracks between the same two pieces.
- **Plane.** A crack's face is the plane through its rim points' mean, its normal the direction of least spread of
  the rim points (a rim around a cross-section is a closed loop in that plane), turned to point out of ``p``: away
  from the mean of ``p``'s anchors (its Gaussians' centres) within the rim's reach (2 ``h`` past its farthest
  point from the mean), so a piece that curves back (a ring's arc) still faces its crack. A rim that does not span
  a plane (fewer than 3 points, or a second principal spread under half a spacing: a crack just starting at the
  surface) takes the normal from the split triangles' own normals instead: ``t x n_s``, ``t`` the rim's direction
  and ``n_s`` the triangles' mean normal (the crack face holds the rim and runs into the body along ``-n_s``),
  and gets one Gaussian per rim point, no fill.
- **Fill.** The face is the convex hull of the rim points in that plane, covered by a square grid of flat
  Gaussians ``h`` apart (at least one, at the rim's mean), ``h`` the fill spacing: scales ``(THIN h, FACE h,
  FACE h)`` along ``(n, e1, e2)`` as the first candidate's (:data:`gasp_core.maps.crack_faces.THIN`,
  :data:`~gasp_core.maps.crack_faces.FACE`), opacity as the caller chooses.
- **Colour.** Each Gaussian takes the DC colour of the split triangle (its own Gaussian) whose rim point is
  nearest to it in the plane.

The count varies from frame to frame with the cracks (none while the body is whole). What it cannot do: follow a
crack that is not plane (the face is the rim's plane) or a cross-section that is not convex (the hull overfills
it); the benchmark ``benchmarks/crack_faces.py --faces both`` measures it against the first candidate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay, cKDTree

from gasp_core.maps.crack_faces import FACE, THIN

#: Rim points closer than this many fill spacings at rest belong to the same crack.
LINK = 2.0


@dataclass(frozen=True)
class SplitTriangles:
    """A body's surface Gaussians as the second candidate reads them.

    Attributes
    ----------
    rows : ndarray, shape (n, k), int64
        Each simulated Gaussian's shape points (``SurfaceMap.shape_rows()``) as rows of the setup's points, the
        anchor first.
    rest : ndarray, shape (n, k, 3), float64
        Their rest positions, metres, world frame.
    sh_dc : ndarray, shape (n, 3), float64
        Each Gaussian's DC colour coefficients (3DGS degree 0).
    spacing : float
        The body's fill spacing ``h``, metres (the grid's and the Gaussians' size).
    """

    rows: np.ndarray
    rest: np.ndarray
    sh_dc: np.ndarray
    spacing: float


@dataclass(frozen=True)
class TriangleFaces:
    """The crack-face Gaussians of one frame (world frame, metres).

    Attributes
    ----------
    means : ndarray, shape (m, 3), float64
    rotations : ndarray, shape (m, 3, 3), float64
        Columns ``(n, e1, e2)``: ``n`` the face normal, out of the piece.
    scales : ndarray, shape (m, 3), float64
        ``(THIN h, FACE h, FACE h)``.
    sh_dc : ndarray, shape (m, 3), float64
    piece : ndarray, shape (m,), int64
        The point label (:meth:`gasp_core.run.pieces.PieceTracker.labels`) of the piece each face belongs to.
    """

    means: np.ndarray
    rotations: np.ndarray
    scales: np.ndarray
    sh_dc: np.ndarray
    piece: np.ndarray

    @property
    def n(self) -> int:
        return len(self.means)


def build_split_triangles(rows: np.ndarray, x_rest: np.ndarray, sh_dc: np.ndarray, spacing: float) -> SplitTriangles:
    """:class:`SplitTriangles` from each Gaussian's shape rows ``rows`` (n, k) into the setup's rest positions
    ``x_rest`` (metres), their DC colours ``sh_dc`` (n, 3) and the fill spacing (metres, > 0).

    Raises
    ------
    ValueError
        ``spacing`` not positive, or ``sh_dc`` not one row per Gaussian.
    """
    rows = np.asarray(rows, np.int64)
    if rows.ndim == 1:
        rows = rows[:, None]
    if not spacing > 0 or len(sh_dc) != len(rows):
        raise ValueError(f"split triangles need a positive spacing and one colour per Gaussian (got {spacing} m, "
                         f"{len(sh_dc)} colours for {len(rows)} Gaussians)")
    return SplitTriangles(rows, np.asarray(x_rest, np.float64)[rows], np.asarray(sh_dc, np.float64), float(spacing))


def _empty() -> TriangleFaces:
    return TriangleFaces(np.zeros((0, 3)), np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                         np.zeros(0, np.int64))


def rim_points(tris: SplitTriangles, labels: np.ndarray):
    """The rim (module notes): ``(tri, vert, p, q)``, int64 arrays of shape (r,): split triangle ``tri``'s vertex
    ``vert`` (column of ``rows``) lies in piece ``p`` and the triangle has a vertex in piece ``q != p``."""
    lab = np.asarray(labels)[tris.rows]                          # (n, k)
    split = np.flatnonzero((lab != lab[:, :1]).any(axis=1))
    if not len(split):
        z = np.zeros(0, np.int64)
        return z, z, z, z
    ls = lab[split]
    k = ls.shape[1]
    # every (vertex a, vertex b) of a split triangle in different pieces: a is a rim point of (lab a, lab b)
    a, b = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    a, b = a.ravel(), b.ravel()
    t = np.repeat(np.arange(len(split)), len(a))
    va, vb = np.tile(a, len(split)), np.tile(b, len(split))
    keep = ls[t, va] != ls[t, vb]
    t, va, vb = t[keep], va[keep], vb[keep]
    key = np.stack([t, va, ls[t, vb]], 1)
    key = np.unique(key, axis=0)                                 # one rim point per (triangle, vertex, other piece)
    t, va, q = key[:, 0], key[:, 1], key[:, 2]
    return split[t], va, ls[t, va], q


def split_triangle_faces(tris: SplitTriangles, x: np.ndarray, labels: np.ndarray, *, link: float = LINK
                         ) -> TriangleFaces:
    """The crack faces of the split triangles at positions ``x`` (n_points, 3, setup rows, metres) with the point
    ``labels`` (n_points,) of :meth:`gasp_core.run.pieces.PieceTracker.labels` (module notes); none where nothing
    is split. ``link``: rim points closer than ``link`` spacings at rest are one crack."""
    x = np.asarray(x, np.float64)
    labels = np.asarray(labels)
    tri, vert, p, q = rim_points(tris, labels)
    if not len(tri):
        return _empty()
    h = tris.spacing
    pos = x[tris.rows[tri, vert]]                                 # rim points now
    rest = tris.rest[tri, vert]
    anchors = x[tris.rows[:, 0]]
    alab = labels[tris.rows[:, 0]]
    near = cKDTree(anchors)
    out = []
    # cracks: per (p, q), the rim points connected within `link` spacings at rest
    pair = np.unique(np.stack([p, q], 1), axis=0, return_inverse=True)[1].ravel()
    ij = cKDTree(rest).query_pairs(link * h, output_type="ndarray")
    ij = ij[pair[ij[:, 0]] == pair[ij[:, 1]]]
    graph = csr_matrix((np.ones(len(ij)), (ij[:, 0], ij[:, 1])), shape=(len(tri), len(tri)))
    crack = connected_components(graph, directed=False)[1]
    for c in np.unique(crack):
        sel = np.flatnonzero(crack == c)
        piece = int(p[sel[0]])
        # the piece's side of the crack: its anchors within the rim's reach (2 h past its farthest point)
        c = pos[sel].mean(0)
        ball = np.asarray(near.query_ball_point(c, np.linalg.norm(pos[sel] - c, axis=1).max() + 2 * h), np.int64)
        ball = ball[alab[ball] == piece]
        out.append(_face(pos[sel], x, tris, tri[sel], anchors[ball].mean(0) if len(ball) else c, h, piece))
    parts = [o for o in out if o is not None]
    if not parts:
        return _empty()
    return TriangleFaces(*(np.concatenate([getattr(o, f) for o in parts]) for f in
                           ("means", "rotations", "scales", "sh_dc", "piece")))


def _tri_normals(tris: SplitTriangles, x: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Unit normals (r, 3) of the triangles ``tri`` at positions ``x`` (their first three shape points)."""
    v = x[tris.rows[tri, :3]]
    n = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-15)


def _face(pos: np.ndarray, x: np.ndarray, tris: SplitTriangles, tri: np.ndarray, inside: np.ndarray, h: float,
          piece: int) -> TriangleFaces | None:
    """One crack's face on piece ``piece`` from its rim points ``pos`` (r, 3) of the split triangles ``tri``;
    ``inside`` a point of the piece (the mean of its anchors) to turn the normal out of it."""
    c = pos.mean(0)
    w, v = np.linalg.eigh(np.cov((pos - c).T) if len(pos) > 1 else np.zeros((3, 3)))   # ascending spreads
    planar = len(pos) >= 3 and w[1] > (0.5 * h) ** 2
    if planar:
        n, e1 = v[:, 0], v[:, 2]
        uv = (pos - c) @ np.stack([e1, np.cross(n, e1)], 1)
        lo, hi = uv.min(0), uv.max(0)
        cells = np.floor((hi - lo) / h + 1e-6)                   # a grid h apart, centred on the rim's box
        start = lo + 0.5 * (hi - lo - cells * h)
        gu, gv = (start[i] + h * np.arange(int(cells[i]) + 1) for i in (0, 1))
        grid = np.stack(np.meshgrid(gu, gv, indexing="ij"), -1).reshape(-1, 2)
        try:
            grid = grid[Delaunay(uv).find_simplex(grid) >= 0]
        except Exception:        # scipy.spatial.QhullError: the rim is collinear in the plane after all
            grid = np.zeros((0, 2))
        if not len(grid):
            grid = np.zeros((1, 2))
        means = c + grid @ np.stack([e1, np.cross(n, e1)])
        nearest = cKDTree(uv).query(grid)[1]
    else:                       # a rim that spans no plane: the split triangles' normals give the face's
        ns = _tri_normals(tris, x, tri).sum(0)
        t = v[:, 2]
        n = np.cross(t, ns)
        if np.linalg.norm(n) < 1e-9:
            return None
        n /= np.linalg.norm(n)
        e1 = t - (t @ n) * n
        e1 /= max(np.linalg.norm(e1), 1e-15)
        means, nearest = pos, np.arange(len(pos))
    if n @ (c - inside) < 0:
        n = -n
    e1 = e1 - (e1 @ n) * n
    e1 /= max(np.linalg.norm(e1), 1e-15)
    rot = np.broadcast_to(np.stack([n, e1, np.cross(n, e1)], 1), (len(means), 3, 3)).copy()
    scales = np.broadcast_to([THIN * h, FACE * h, FACE * h], (len(means), 3)).copy()
    return TriangleFaces(means, rot, scales, tris.sh_dc[tri[nearest]], np.full(len(means), piece, np.int64))
