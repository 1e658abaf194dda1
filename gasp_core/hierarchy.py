"""Core Gaussians by BIRCH clustering; sub-Gaussians follow their core's triangle.

GASP paper Sec. 3 ("Hierarchy"): only Core Gaussians are simulated and the sub-Gaussians take
their motion "inspired by D-MiSo". Here every cluster of Gaussian means (scikit-learn's
:class:`~sklearn.cluster.Birch`) gets one Core Gaussian whose triangle spans the cluster: centred on
the members' centroid, its in-plane axes the two principal axes of the members' means, its in-plane
scales their standard deviations. Each sub-Gaussian's triangle vertices are stored in the core
triangle's affine frame ``A = [l n, v2 - v1, v3 - v1]`` (``n`` the unit normal, ``l = sqrt(|e2 x e3|)``
so that the frame stays well conditioned), as D-MiSo binds sub-Gaussians to ``v1 + a . [n, e2, e3]``;
each frame they are rebuilt as ``v1' + A' a`` and go through ``T^-1`` like any triangle. A core that
moves rigidly carries its subs rigidly; a stretched or sheared core stretches them the same way.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .games import EPS


@dataclass(frozen=True)
class Hierarchy:
    """Cores and the binding of every Gaussian to one core.

    Attributes
    ----------
    core_tri : ndarray, shape (k, 3, 3), float64
        Rest triangles of the Core Gaussians, same frame as the input means.
    core_of : ndarray, shape (n,), int64
        Core index of each Gaussian.
    local : ndarray, shape (n, 3, 3), float64
        Each Gaussian's triangle vertices in its core's affine frame (row j = vertex j).
    """

    core_tri: np.ndarray
    core_of: np.ndarray
    local: np.ndarray

    @property
    def n_cores(self) -> int:
        return len(self.core_tri)


def affine_frames(tri: np.ndarray) -> np.ndarray:
    """Affine frames ``A = [l n, e2, e3]`` (columns) of triangles, shape (k, 3, 3).

    ``e2 = v2 - v1``, ``e3 = v3 - v1``, ``n = unit(e2 x e3)``, ``l = sqrt(|e2 x e3|)``. For a
    degenerate triangle ``n`` is zero and ``A`` is singular; callers guard with :func:`solve_local`.
    """
    e2 = tri[:, 1] - tri[:, 0]
    e3 = tri[:, 2] - tri[:, 0]
    c = np.cross(e2, e3)
    area2 = np.linalg.norm(c, axis=1, keepdims=True)
    n_scaled = c / np.sqrt(np.where(area2 > 0, area2, 1.0))   # = l * unit normal
    return np.stack([n_scaled, e2, e3], axis=2)


def build_hierarchy(means: np.ndarray, triangles: np.ndarray, core_fraction: float,
                    seed_threshold: float | None = None) -> Hierarchy:
    """Cluster Gaussians with BIRCH and bind each to its cluster's Core Gaussian.

    Parameters
    ----------
    means : ndarray, shape (n, 3)
        Gaussian means (metres, world frame).
    triangles : ndarray, shape (n, 3, 3)
        Their GaMeS triangles (``gaussians_to_triangles``), same frame.
    core_fraction : float
        Cores per Gaussian, in (0, 1]: ``k = max(1, round(core_fraction * n))`` clusters.
    seed_threshold : float, optional
        BIRCH subcluster radius to start from (metres); default ``extent / sqrt(k)``. It is
        rescaled until BIRCH finds between ``k`` and ``3 k`` subclusters, which the global
        (agglomerative) step then merges into exactly ``k`` clusters.

    Returns
    -------
    Hierarchy

    Raises
    ------
    ValueError
        If ``core_fraction`` is not in (0, 1] or the shapes disagree.

    Notes
    -----
    The paper gives no BIRCH parameters (NOTES.md); ``branching_factor`` is scikit-learn's 50.
    Core triangle of a cluster with fewer than 3 members or a degenerate spread: the member
    nearest the centroid's own triangle, so every core triangle is non-degenerate at rest.
    """
    from sklearn.cluster import Birch

    means = np.asarray(means, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.float64)
    n = len(means)
    if tri.shape != (n, 3, 3):
        raise ValueError(f"build_hierarchy: triangles must be ({n}, 3, 3), got {tri.shape}")
    if not 0.0 < core_fraction <= 1.0:
        raise ValueError(f"build_hierarchy: core_fraction must be in (0, 1], got {core_fraction}")
    k = max(1, int(round(core_fraction * n)))
    if k >= n:
        labels = np.arange(n)
    else:
        ext = float(np.ptp(means, axis=0).max()) or 1.0
        thr = seed_threshold or ext / np.sqrt(k)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")       # sklearn warns when subclusters < n_clusters; we retry
            for _ in range(8):
                b = Birch(threshold=thr, n_clusters=None).fit(means)
                m = len(b.subcluster_centers_)
                if k <= m <= 3 * k:
                    break
                # subcluster count of a surface scales like threshold^-2: aim at 1.5 k
                thr *= float(np.clip(np.sqrt(m / (1.5 * k)), 0.3, 3.0))
            if m < k:
                raise RuntimeError(f"build_hierarchy: BIRCH found only {m} subclusters for {k} cores")
            b.set_params(n_clusters=k).partial_fit()   # global clustering step only
            labels = b.predict(means)
    _, labels = np.unique(labels, return_inverse=True)
    k = int(labels.max()) + 1

    # per-cluster centroid and covariance of the means, vectorised
    count = np.bincount(labels, minlength=k).astype(np.float64)
    centre = np.stack([np.bincount(labels, means[:, d], minlength=k) for d in range(3)], 1) / count[:, None]
    d = means - centre[labels]
    outer = np.einsum("ni,nj->nij", d, d).reshape(n, 9)
    cov = np.stack([np.bincount(labels, outer[:, j], minlength=k) for j in range(9)], 1)
    cov = cov.reshape(k, 3, 3) / count[:, None, None]
    evals, evecs = np.linalg.eigh(cov)                      # ascending
    s2 = np.sqrt(np.maximum(evals[:, 2], 0.0))
    s3 = np.sqrt(np.maximum(evals[:, 1], 0.0))
    core_tri = np.stack([centre, centre + s2[:, None] * evecs[:, :, 2],
                         centre + s3[:, None] * evecs[:, :, 1]], axis=1)
    bad = (count < 3) | ~(s3 > 1e-3 * s2) | ~(s2 > EPS)
    if bad.any():   # the member nearest the centroid lends its own triangle
        dist = np.linalg.norm(d, axis=1)
        order = np.lexsort((dist, labels))
        first = order[np.searchsorted(labels[order], np.arange(k))]
        core_tri[bad] = tri[first[bad]]
    A = affine_frames(core_tri)
    rel = tri - core_tri[labels][:, None, 0, :]                        # (n, 3 vertices, 3)
    local = np.linalg.solve(A[labels][:, None], rel[..., None])[..., 0]  # A a = rel
    return Hierarchy(core_tri=core_tri, core_of=labels.astype(np.int64), local=local)


def sub_triangles(h: Hierarchy, core_tri_t: np.ndarray) -> np.ndarray:
    """Every Gaussian's triangle from its moved core triangle: ``v1' + A' a``.

    Parameters
    ----------
    h : Hierarchy
    core_tri_t : ndarray, shape (k, 3, 3)
        Moved core triangles.

    Returns
    -------
    ndarray, shape (n, 3, 3), float64
        Triangles to pass through ``T^-1``. A core that degenerated (zero area) keeps its
        subs' normal offsets at zero, so they collapse onto its plane rather than turning NaN.
    """
    A = affine_frames(np.asarray(core_tri_t, dtype=np.float64))
    Ac = A[h.core_of]
    return core_tri_t[h.core_of][:, None, 0, :] + np.einsum("nij,nvj->nvi", Ac, h.local)
