"""PhysGaussian's layout: one simulated point per Gaussian, its centre, and ``F`` estimated from its neighbours.

With ``[[object]] surface_points = "centres"`` a Gaussian hands the engine its centre ``m`` only (a third of
the GaMeS triangle's three vertices ``v1 = m, v2 = m + s2 r2, v3 = m + s3 r3``), as a material or a passive
point like the vertices (``surface``). Engines return positions only, so the deformation gradient of each
centre is estimated here, engine-independently, from the motion of its ``k`` nearest **rest** neighbours
among the object's carried points (the fill and the other centres), by weighted least squares (the
moving-least-squares strain estimate of meshless methods, e.g. Zhu & Bridson 2005; Belytschko et al. 1996)::

    F = (sum_j w_j dx_j dX_j^T) (sum_j w_j dX_j dX_j^T)^-1,   dX_j = X_j - X_c at rest,  dx_j = x_j - x_c now

with ``w_j = exp(-(|dX_j| / h)^2)``, ``h`` the distance to the ``k``-th neighbour. The neighbours, weights and
the inverse are fixed at rest (:func:`build_centre_frame`); a frame costs one ``(n, k, 3) x (n, k, 3)``
contraction (:func:`deformation_gradients`). The Gaussian is then rebuilt from the triangle ``[x_c,
x_c + F s2 r2, x_c + F s3 r3]`` by the object's own ``rebuild`` rule (:func:`centre_triangles`): with
``rebuild = "covariance"`` that is exactly ``F Sigma F^T`` in the Gaussian's plane (PhysGaussian, Xie et al.
2024, Eq. 6; :func:`gasp_core.maps.games.triangles_to_gaussians_covariance`), with the mean the moved centre.

Degenerate neighbourhoods (a guard): where ``sum w dX dX^T`` has an eigenvalue below :data:`RANK_TOL` times
its largest, that direction is not observed. A planar neighbourhood (rank 2: an object without fill, a
shell) gets ``F`` exact in its plane and the plane's unit normal carried to the moved plane's unit normal
(so a rigid rotation stays exact); a line or a point (rank < 2) gets ``F = I`` and is counted.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

#: ``[[object]] surface_points``: the GaMeS triangle's three vertices (the paper's), the Gaussian's centre alone
#: (PhysGaussian's layout, this module), or ``"auto"`` (the levels ``draft`` and ``default``): centres on an
#: elastic body (its surface material, or passive as at the level ``draft``), where the trade's rule picks them,
#: else vertices
#: (:func:`gasp_core.prepare.surface.choose_surface_points`; docs/speed_accuracy.md, "PhysGaussian's layout").
SURFACE_POINTS = ("vertices", "centres", "auto")
#: Neighbours per centre in the least-squares fit of ``F``.
K_NEIGHBOURS = 16
#: An eigenvalue of ``sum w dX dX^T`` below this times its largest marks an unobserved direction.
RANK_TOL = 1e-3


@dataclass
class CentreFrame:
    """The rest neighbourhoods of one object's centres, fixed at rest (:func:`build_centre_frame`).

    Attributes
    ----------
    centre_rows : ndarray, shape (n,), int64
        Rows of the centres in ``SimSetup.x``.
    idx : ndarray, shape (n, k), int64
        Rows of each centre's neighbours in ``SimSetup.x``.
    g : ndarray, shape (n, k, 3), float64
        ``w_j B^+ dX_j`` (1/m), so that ``F = sum_j dx_j g_j^T``; ``B = sum w dX dX^T``, ``B^+`` its inverse on
        the observed directions.
    rank : ndarray, shape (n,), int64
        Observed directions of each neighbourhood (3 normally; 2 planar; less degenerate).
    t1, t2, normal : ndarray, shape (n, 3), float64
        For planar neighbourhoods: two unit in-plane directions and the unit normal, ``t1 x t2 = normal``.
    """

    centre_rows: np.ndarray
    idx: np.ndarray
    g: np.ndarray
    rank: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    normal: np.ndarray

    @property
    def n_degenerate(self) -> int:
        """Centres whose neighbourhood observes fewer than two directions (they take ``F = I``)."""
        return int((self.rank < 2).sum())


def build_centre_frame(x_rest: np.ndarray, centre_rows: np.ndarray, neighbour_rows: np.ndarray,
                       k: int = K_NEIGHBOURS) -> CentreFrame:
    """Each centre's ``k`` nearest rest neighbours among ``neighbour_rows``, their weights and ``B^+``.

    Parameters
    ----------
    x_rest : ndarray, shape (N, 3), float
        Rest positions of every point of the setup, metres.
    centre_rows : ndarray, shape (n,), int
        Rows of the centres.
    neighbour_rows : ndarray, shape (m,), int
        Rows a centre may take as neighbours (the object's fill and centres); a centre never takes itself.

    Returns
    -------
    CentreFrame

    Raises
    ------
    ValueError
        If there are fewer than two neighbour rows, or ``k < 3``.
    """
    x_rest = np.asarray(x_rest, dtype=np.float64)
    centre_rows, neighbour_rows = np.asarray(centre_rows, np.int64), np.asarray(neighbour_rows, np.int64)
    if len(neighbour_rows) < 2 or k < 3:
        raise ValueError(f"build_centre_frame: needs k >= 3 (got {k}) and 2 or more neighbour rows "
                         f"(got {len(neighbour_rows)})")
    kk = min(k + 1, len(neighbour_rows))
    dist, pos = cKDTree(x_rest[neighbour_rows]).query(x_rest[centre_rows], k=kk)
    dist, pos = dist.reshape(len(centre_rows), kk), pos.reshape(len(centre_rows), kk)
    idx = neighbour_rows[pos]
    keep = idx != centre_rows[:, None]                       # drop the centre itself, keep k others
    order = np.argsort(~keep, axis=1, kind="stable")[:, :kk - 1]
    idx, dist = np.take_along_axis(idx, order, 1), np.take_along_axis(dist, order, 1)
    dX = x_rest[idx] - x_rest[centre_rows][:, None]          # (n, k, 3)
    h = np.maximum(dist.max(axis=1, keepdims=True), 1e-30)
    w = np.exp(-(dist / h) ** 2)
    B = np.einsum("nk,nki,nkj->nij", w, dX, dX)
    evals, evecs = np.linalg.eigh(B)                         # ascending
    good = evals > RANK_TOL * np.maximum(evals[:, 2:3], 1e-300)
    inv = np.where(good, 1.0 / np.where(good, evals, 1.0), 0.0)
    Bp = np.einsum("nia,na,nja->nij", evecs, inv, evecs)
    g = w[:, :, None] * np.einsum("nij,nkj->nki", Bp, dX)
    t1, t2 = evecs[:, :, 1], evecs[:, :, 2]
    return CentreFrame(centre_rows=centre_rows, idx=idx, g=g, rank=good.sum(axis=1), t1=t1, t2=t2,
                       normal=np.cross(t1, t2))


def deformation_gradients(frame: CentreFrame, x: np.ndarray) -> np.ndarray:
    """``F`` of every centre from the current positions ``x`` (shape (N, 3), metres): shape (n, 3, 3).

    Exact for any affine motion of a neighbourhood of rank 3; planar ones (rank 2) are exact in their plane
    and carry their normal to the moved plane's unit normal; rank < 2 gives the identity.
    """
    x = np.asarray(x, dtype=np.float64)
    dx = x[frame.idx] - x[frame.centre_rows][:, None]
    F = np.einsum("nki,nkj->nij", dx, frame.g)
    planar = np.flatnonzero(frame.rank == 2)
    if len(planar):
        a = np.einsum("nij,nj->ni", F[planar], frame.t1[planar])
        b = np.einsum("nij,nj->ni", F[planar], frame.t2[planar])
        c = np.cross(a, b)
        c /= np.maximum(np.linalg.norm(c, axis=1, keepdims=True), 1e-300)
        F[planar] += c[:, :, None] * frame.normal[planar][:, None, :]
    F[frame.rank < 2] = np.eye(3)
    return F


def centre_triangles(frame: CentreFrame, x: np.ndarray, tri_rest: np.ndarray) -> np.ndarray:
    """The moved GaMeS triangles ``[x_c, x_c + F e2, x_c + F e3]`` (``e2 = s2 r2``, ``e3 = s3 r3`` the rest edges),
    shape (n, 3, 3), metres; ``F`` from :func:`deformation_gradients`. Rebuilt with ``rebuild = "covariance"`` they
    give the Gaussian ``(x_c, F Sigma F^T)`` (:func:`gasp_core.maps.games.triangles_to_gaussians_covariance`)."""
    F = deformation_gradients(frame, x)
    c = np.asarray(x, dtype=np.float64)[frame.centre_rows]
    edges = np.asarray(tri_rest, dtype=np.float64)[:, 1:] - np.asarray(tri_rest, dtype=np.float64)[:, :1]
    return np.concatenate([c[:, None], c[:, None] + np.einsum("nij,nej->nei", F, edges)], axis=1)
