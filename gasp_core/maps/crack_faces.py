"""Crack faces: interior Gaussians made from a broken body's fill points (issue 52, item 3; docs/fracture.md).

A capture is a surface: the interior fill (docs/fill.md) is simulated, never rendered, so a piece broken off a body
would show the inside of a hollow shell. Here every fill point of a body that can break carries one flat Gaussian,
hidden (opacity 0) while the material around it is whole, shown where a crack has opened next to it:

- **Exposed.** A fill point with ``d < BROKEN`` is exposed when one of its rest neighbours (the links of
  :class:`gasp_core.run.pieces.PieceTracker`, closer than 1.5 fill spacings at rest) is now in another piece or
  broken (``d >= BROKEN``): the crack runs between them.
- **Oriented.** Its normal ``n`` is the mean of the unit directions from the point to those neighbours across the
  crack: at rest, carried by the point's local deformation (Nanson's ``n ~ F^-T N``, ``F`` fitted to its links within
  its piece) when the rest positions are given, else at the current positions; the Gaussian is flat across ``n``:
  scales ``(THIN h, FACE h, FACE h)`` along ``(n, t1, t2)``, ``h`` the fill spacing, so the faces of a lattice's
  exposed layer overlap into a covered face (two at ``h`` apart leave alpha 0.98 between them at full opacity).
- **Coloured** from the nearest surface Gaussians at rest: the inverse-distance mean of the DC colour of the
  :data:`K_COLOUR` nearest (PhysGaussian fills its interior with its nearest particle's appearance; Xie et al.,
  CVPR 2024, "Internal Filling").

The module only computes the Gaussians from positions, piece labels and damage; it does not choose a form of the
surface map (``gasp_core.maps.surface``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: Damage at or above which a point is broken through (the pieces' rule, ``gasp_core.run.pieces.BROKEN``).
BROKEN = 0.9
#: In-plane standard deviation of a crack-face Gaussian, in fill spacings (measured on the shattered donut,
#: ``benchmarks/crack_faces.py``: 0.6 left 2.0-3.7 % of the pieces' silhouettes below alpha 0.9, 0.9 left 0.4-1.6 %).
FACE = 0.9
#: Its thickness across the face, in fill spacings (0.1 left 2.0-3.7 %, 0.25 with ``FACE`` 0.9 the figures above:
#: a face seen edge-on at a curved crack must still cover).
THIN = 0.25
#: Surface Gaussians whose colour a fill point takes.
K_COLOUR = 4


@dataclass(frozen=True)
class CrackFaces:
    """The crack-face Gaussians of a body's fill points.

    Attributes
    ----------
    rows : ndarray, shape (m,), int64
        The fill points, as rows of the positions the engine returns (setup order).
    pairs : ndarray, shape (k, 2), int64
        Rest neighbour links among the material points (setup rows; :attr:`PieceTracker.pairs`).
    sh_dc : ndarray, shape (m, 3), float64
        Each face's DC colour coefficients (3DGS's degree 0).
    spacing : float
        The fill spacing ``h``, metres.
    x_rest : ndarray, shape (n, 3), float64, or None
        Rest positions of every setup row (metres): with them a face's normal is its rest normal carried by the
        local deformation (:func:`exposed_normals`); None: the directions at the current positions.
    """

    rows: np.ndarray
    pairs: np.ndarray
    sh_dc: np.ndarray
    spacing: float
    x_rest: np.ndarray | None = None


def build_crack_faces(fill_rest: np.ndarray, rows: np.ndarray, pairs: np.ndarray, surface_means: np.ndarray,
                      surface_sh_dc: np.ndarray, spacing: float, x_rest: np.ndarray | None = None) -> CrackFaces:
    """The crack faces of the fill points ``rows`` (module notes).

    Parameters
    ----------
    fill_rest : ndarray, shape (m, 3)
        Their rest positions, metres, world frame.
    rows : ndarray, shape (m,), int
        Their rows in the setup.
    pairs : ndarray, shape (k, 2), int
        Rest neighbour links (setup rows).
    surface_means, surface_sh_dc : ndarray, shapes (s, 3)
        The body's surface Gaussians at rest: centres (metres, world frame) and DC colour coefficients.
    spacing : float
        Fill spacing, metres (> 0).
    x_rest : ndarray, shape (n, 3), optional
        Rest positions of every setup row, metres (:attr:`CrackFaces.x_rest`).

    Raises
    ------
    ValueError
        No surface Gaussian, or ``spacing`` not positive.
    """
    if len(surface_means) == 0 or not spacing > 0:
        raise ValueError(f"crack faces need surface Gaussians and a positive fill spacing (got {len(surface_means)} "
                         f"and {spacing} m)")
    k = min(K_COLOUR, len(surface_means))
    dist, idx = cKDTree(surface_means).query(fill_rest, k=k)
    dist, idx = np.reshape(dist, (len(fill_rest), k)), np.reshape(idx, (len(fill_rest), k))
    w = 1.0 / np.maximum(dist, 1e-9)
    sh = np.einsum("mk,mkc->mc", w / w.sum(1, keepdims=True), np.asarray(surface_sh_dc, np.float64)[idx])
    xr = None if x_rest is None else np.asarray(x_rest, np.float64)
    return CrackFaces(np.asarray(rows, np.int64), np.asarray(pairs, np.int64), sh, float(spacing), xr)


def exposed_normals(faces: CrackFaces, x: np.ndarray, labels: np.ndarray, damage: np.ndarray) -> np.ndarray:
    """Each fill point's face normal, shape (m, 3): unit, or 0 where no neighbour is across a crack (the face
    hidden). ``x`` (n, 3, setup rows): positions, m; ``labels`` (n,): pieces (:meth:`PieceTracker.labels`);
    ``damage`` (n,) in [0, 1].

    Without :attr:`CrackFaces.x_rest`: the mean unit direction to the neighbours across, at ``x``. With it: the
    crack face is a material surface, so its rest normal ``N`` (the mean unit rest direction to the neighbours
    across) is carried by the point's deformation gradient ``F`` (the least-squares fit of its links to intact
    neighbours of its own piece, rest to now), ``n ~ F^-T N`` (Nanson's formula); where those links do not span
    space, the first rule. The first rule turns a face to wherever the piece across has gone: a rigid fragment turned
    and carried sideways shows faces tilted off its cut (``tests/test_crack_faces.py``)."""
    x = np.asarray(x, np.float64)
    broken = np.asarray(damage) >= BROKEN
    i, j = faces.pairs[:, 0], faces.pairs[:, 1]
    across = (labels[i] != labels[j]) | broken[i] | broken[j]
    n = _mean_direction(x, i[across], j[across], broken)[faces.rows]
    if faces.x_rest is not None:
        xr = faces.x_rest
        N = _mean_direction(xr, i[across], j[across], broken)[faces.rows]
        a_, b_ = i[~across], j[~across]
        dX, dx = xr[b_] - xr[a_], x[b_] - x[a_]
        A, B = np.zeros((len(x), 3, 3)), np.zeros((len(x), 3, 3))
        for k in (a_, b_):
            np.add.at(A, k, np.einsum("ki,kj->kij", dx, dX))
            np.add.at(B, k, np.einsum("ki,kj->kij", dX, dX))
        A, B = A[faces.rows], B[faces.rows]
        ok = (np.linalg.norm(N, axis=1) > 1e-9) & (np.linalg.det(B / faces.spacing ** 2) > 1e-3)
        F = np.einsum("kij,kjl->kil", A[ok], np.linalg.inv(B[ok]))
        good = np.abs(np.linalg.det(F)) > 1e-6
        idx = np.flatnonzero(ok)[good]
        n[idx] = np.linalg.solve(np.transpose(F[good], (0, 2, 1)), N[idx][:, :, None])[:, :, 0]
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(norm > 1e-9, n / np.maximum(norm, 1e-12), 0.0)


def _mean_direction(x: np.ndarray, i: np.ndarray, j: np.ndarray, broken: np.ndarray) -> np.ndarray:
    """Per point (n, 3): the sum of the unit directions at ``x`` to its partners across (links ``i -> j``), not
    normalised; 0 on broken points (the gap itself, not a face)."""
    d = x[j] - x[i]
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    acc = np.zeros((len(x), 3))
    np.add.at(acc, i, d)
    np.add.at(acc, j, -d)
    acc[broken] = 0.0
    return acc


def crack_face_gaussians(faces: CrackFaces, x: np.ndarray, labels: np.ndarray, damage: np.ndarray):
    """The crack faces at positions ``x`` (module notes).

    Returns
    -------
    means : ndarray, shape (m, 3), metres
        The points.
    rotations : ndarray, shape (m, 3, 3)
        Columns ``(n, t1, t2)``.
    scales : ndarray, shape (m, 3), metres
        ``(THIN h, FACE h, FACE h)``.
    visible : ndarray, shape (m,), bool
        Exposed faces (opacity 1); the others are hidden (opacity 0).
    """
    n = exposed_normals(faces, x, labels, damage)
    visible = np.linalg.norm(n, axis=1) > 0.5
    n = np.where(visible[:, None], n, [1.0, 0.0, 0.0])
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    rot = np.stack([n, t1, np.cross(n, t1)], axis=2)
    h = faces.spacing
    scales = np.broadcast_to([THIN * h, FACE * h, FACE * h], (len(n), 3)).copy()
    return np.asarray(x, np.float64)[faces.rows], rot, scales, visible
