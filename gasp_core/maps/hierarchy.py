"""Core Gaussians by linear-time clustering; sub-Gaussians follow their core's affine frame.

GASP paper Sec. 3 ("Hierarchy"): only Core Gaussians are simulated and the sub-Gaussians take
their motion "inspired by D-MiSo". The paper clusters with BIRCH; scikit-learn's
:class:`~sklearn.cluster.Birch` inserts points one by one in Python and its global step to exactly
``k`` clusters is agglomerative, quadratic in the subcluster count (108 s and 4.9 GB for 24,796
subclusters on the 45k donut). Here the clusters are built in ``O(n log n)``:

1. **Grid seeds.** The Gaussian means are binned into cubic cells; the cell size is found by
   bisection (on its logarithm) so that at least ``k`` cells are occupied, and the ``k`` most
   populated cells' centroids are the seeds (ties: by cell order).
2. **Surplus cells.** Means in the occupied cells beyond the ``k`` most populated go to the
   nearest kept centroid (:class:`scipy.spatial.cKDTree`); optional Lloyd (k-means) steps
   (``lloyd_steps``, default ``LLOYD_STEPS = 0``: a cell is already compact, diameter at most
   ``sqrt(3)`` cell sizes, and each step costs a nearest-seed query of every mean).

Each cluster gets one Core Gaussian whose *frame* encloses its members: a tetrahedron ``v1, v2,
v3, v4`` with ``v1`` the members' centroid and ``v2 - v1``, ``v3 - v1``, ``v4 - v1`` along the
principal axes of the members' triangle vertices (largest, middle, smallest variance), each as long
as the members reach along it, and at least ``MIN_AXIS`` times the longest reach. Every member
triangle vertex ``p`` is stored as ``a = A^-1 (p - v1)`` with ``A = [v2 - v1, v3 - v1, v4 - v1]``, so
``|a_j| <= 1`` for every coefficient (the bound: members lie in the frame's box), and each frame it
is rebuilt as ``p' = v1' + A' a``. This is exact for any affine motion of the core's four points
(rigid motions included): the sub-Gaussians move by the same map. ``v1, v2, v3`` are the core's
GaMeS triangle (its in-plane axes); ``v4`` samples the motion across the surface, off it by the
cluster's thickness or ``MIN_AXIS`` times its extent, whichever is larger.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.errors import SceneError

#: Shortest frame axis, as a share of the longest: bounds the coefficients' conditioning.
MIN_AXIS = 0.1
#: Lloyd (k-means) steps after the grid seeding; each is a nearest-seed query of every mean.
LLOYD_STEPS = 0


@dataclass(frozen=True)
class Hierarchy:
    """Cores and the binding of every Gaussian to one core.

    Attributes
    ----------
    core_points : ndarray, shape (k, 4, 3), float64
        Rest frames of the Core Gaussians (``v1`` centroid, ``v2, v3`` in-plane axes, ``v4``
        across), same frame as the input means; these ``4 k`` points are simulated.
    core_of : ndarray, shape (n,), int64
        Core index of each Gaussian.
    local : ndarray, shape (n, 3, 3), float64
        Each Gaussian's triangle vertices in its core's frame (row j = vertex j); ``|local| <= 1``.
    """

    core_points: np.ndarray
    core_of: np.ndarray
    local: np.ndarray

    @property
    def n_cores(self) -> int:
        return len(self.core_points)

    @property
    def core_tri(self) -> np.ndarray:
        """The cores' GaMeS triangles ``v1, v2, v3``, shape (k, 3, 3)."""
        return self.core_points[:, :3]


def frames(core_points: np.ndarray) -> np.ndarray:
    """Affine frames ``A = [v2 - v1, v3 - v1, v4 - v1]`` (columns) of core tetrahedra, shape (k, 3, 3)."""
    return np.swapaxes(core_points[:, 1:] - core_points[:, :1], 1, 2)


def check_core_fraction(core_fraction: float, n: int, where: str = "core_fraction") -> int:
    """Number of cores ``k = round(core_fraction * n)`` for ``n`` Gaussians.

    Raises
    ------
    SceneError
        One line naming ``where``: not a number in (0, 1], no Gaussians (``n = 0``), or fewer than one core.
    """
    try:
        f = float(core_fraction)
    except (TypeError, ValueError):
        raise SceneError(f"{where} = {core_fraction!r} must be a number in (0, 1]") from None
    if not 0.0 < f <= 1.0:
        raise SceneError(f"{where} = {core_fraction!r} must be in (0, 1]")
    if n < 1:
        raise SceneError(f"{where}: no Gaussians to build cores from; expected at least one")
    k = int(round(f * n))
    if k < 1:
        raise SceneError(f"{where} = {core_fraction!r} gives {f * n:.3g} cores for {n} Gaussians; "
                         f"use at least {1.0 / n:.3g}")
    return min(k, n)


def grid_clusters(means: np.ndarray, k: int, lloyd_steps: int = LLOYD_STEPS) -> np.ndarray:
    """Labels of ``k`` compact clusters of ``means`` (module notes, steps 1-2), shape (n,), int64.

    Clusters left empty (by a Lloyd step) are dropped, so there may be a few fewer than ``k``.
    """
    n = len(means)
    if k >= n:
        return np.arange(n)
    lo = means.min(axis=0)
    ext = float(np.ptp(means, axis=0).max()) or 1.0

    def cells(c: float):
        key = np.floor((means - lo) / c).astype(np.int64)
        dims = key.max(axis=0) + 1
        flat = np.ravel_multi_index(key.T, dims)
        return np.unique(flat, return_inverse=True, return_counts=True)

    a, b = np.log(ext * 2.0 ** -20), np.log(ext * 2.0)   # a: 2^20 cells a side (keys fit int64), b: one cell
    for _ in range(40):
        mid = 0.5 * (a + b)
        m = len(cells(np.exp(mid))[0])
        if m >= k:
            a = mid
        else:
            b = mid
        if b - a < 1e-3:
            break
    _, inv, count = cells(np.exp(a))
    keep = np.sort(np.argsort(-count, kind="stable")[:k])
    sums = np.stack([np.bincount(inv, means[:, d]) for d in range(3)], 1)
    seeds = sums[keep] / count[keep, None]
    new_id = np.full(len(count), -1)
    new_id[keep] = np.arange(len(keep))
    labels = new_id[inv]
    lost = labels < 0                      # members of the surplus (least populated) cells
    if lost.any():
        labels[lost] = cKDTree(seeds).query(means[lost])[1]
    for _ in range(lloyd_steps):
        cnt = np.bincount(labels, minlength=len(seeds))
        used = cnt > 0
        seeds = (np.stack([np.bincount(labels, means[:, d], minlength=len(seeds)) for d in range(3)], 1)
                 [used] / cnt[used, None])
        labels = cKDTree(seeds).query(means, workers=-1)[1]
    _, labels = np.unique(labels, return_inverse=True)
    return labels.astype(np.int64)


def build_hierarchy(means: np.ndarray, triangles: np.ndarray, core_fraction: float,
                    name: str = "core_fraction") -> Hierarchy:
    """Cluster Gaussians and bind each to its cluster's Core Gaussian frame.

    Parameters
    ----------
    means : ndarray, shape (n, 3)
        Gaussian means (metres, world frame).
    triangles : ndarray, shape (n, 3, 3)
        Their GaMeS triangles (``gaussians_to_triangles``), same frame.
    core_fraction : float
        Cores per Gaussian, in (0, 1]: about ``k = round(core_fraction * n)`` clusters.
    name : str
        How the error messages name the parameter (e.g. ``"scene.toml: object[0].core_fraction"``).

    Returns
    -------
    Hierarchy
        ``|local| <= 1`` for every coefficient.

    Raises
    ------
    SceneError
        If ``core_fraction`` is not in (0, 1] or gives fewer than one core, or there are no Gaussians.
    ValueError
        If the shapes disagree, or a mean is not finite (naming the first).
    """
    means = np.asarray(means, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.float64)
    n = len(means)
    if tri.shape != (n, 3, 3):
        raise ValueError(f"build_hierarchy: triangles must be ({n}, 3, 3), got {tri.shape}")
    bad = ~np.isfinite(means).all(axis=1) if means.ndim == 2 else np.zeros(0, bool)
    if bad.any():
        raise ValueError(f"build_hierarchy: means: non-finite mean at index {int(np.flatnonzero(bad)[0])}")
    k = check_core_fraction(core_fraction, n, name)
    labels = grid_clusters(means, k)
    k = int(labels.max()) + 1

    # principal axes of each cluster's triangle vertices (3 per member), vectorised
    pts = tri.reshape(-1, 3)
    lab3 = np.repeat(labels, 3)
    count = np.bincount(lab3, minlength=k).astype(np.float64)
    centre = np.stack([np.bincount(labels, means[:, d], minlength=k) for d in range(3)], 1)
    centre /= np.bincount(labels, minlength=k)[:, None]
    d = pts - centre[lab3]
    outer = np.einsum("ni,nj->nij", d, d).reshape(-1, 9)
    cov = np.stack([np.bincount(lab3, outer[:, j], minlength=k) for j in range(9)], 1).reshape(k, 3, 3)
    cov /= count[:, None, None]
    _, evecs = np.linalg.eigh(cov)                              # ascending variance
    axes = evecs[:, :, ::-1]                                    # columns: largest, middle, smallest
    proj = np.einsum("nij,ni->nj", axes[lab3], d)               # (3n, 3) coordinates along the axes
    order = np.argsort(lab3, kind="stable")
    starts = np.searchsorted(lab3[order], np.arange(k))
    reach = np.maximum.reduceat(np.abs(proj[order]), starts, axis=0)     # every cluster has members
    longest = reach.max(axis=1, keepdims=True)
    longest = np.where(longest > 0, longest, 1e-9)
    reach = np.maximum(reach, MIN_AXIS * longest)
    A = axes * reach[:, None, :]                                 # columns scaled
    core_points = np.concatenate([centre[:, None], centre[:, None] + np.swapaxes(A, 1, 2)], axis=1)
    # a = A^-1 (p - v1); A = axes diag(reach) with orthonormal axes, so A^-1 = diag(1/reach) axes^T
    local = (proj / reach[lab3]).reshape(n, 3, 3)
    return Hierarchy(core_points=core_points, core_of=labels, local=local)


def sub_triangles(h: Hierarchy, core_points_t: np.ndarray) -> np.ndarray:
    """Every Gaussian's triangle from its moved core frame: ``v1' + A' a``.

    Parameters
    ----------
    h : Hierarchy
    core_points_t : ndarray, shape (k, 4, 3) or (4 k, 3)
        Moved core points (``v1 .. v4`` of each core).

    Returns
    -------
    ndarray, shape (n, 3, 3), float64
        Triangles to pass through ``T^-1``; exact for any affine motion of each core's points.
    """
    cp = np.asarray(core_points_t, dtype=np.float64).reshape(-1, 4, 3)
    A = frames(cp)[h.core_of]
    return cp[h.core_of][:, None, 0, :] + np.einsum("nij,nvj->nvi", A, h.local)
