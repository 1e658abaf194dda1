"""Floaters: Gaussians detached from the object they were captured with, found before the domain is sized.

A trained capture always holds a few Gaussians far from its object (background blobs, noise in the air).
Simulated, one of them decides the grid: a 600-Gaussian ball of 0.1 m plus one Gaussian 1000 m away gets a
125 m cell. So before the domain is sized the simulated rows are split into connected pieces and the small,
detached ones are left out of the physics (written unchanged in every frame, like a selection's static
rest; ``keep_floaters = true`` keeps them).

Rule (:func:`find_floaters`):

1. **Connectivity at the splat spacing.** Two Gaussians are linked when their centres are closer than
   ``LINK`` times the 90th percentile of the nearest-neighbour distance (the spacing the occupancy voxel of
   :func:`gasp_core.maps.occupancy.density_voxel` is taken from); a splat big enough to bridge a gap is
   judged by its size instead (3). Components come from :func:`scipy.sparse.csgraph.connected_components`.
2. **Small pieces, outside.** A component holding less than ``MAX_SHARE`` of the Gaussians whose
   Gaussians lie outside the bounding box of the rest (every larger piece: the object), grown by
   ``MARGIN`` times its largest extent, is a floater. A small piece near the object (on the real donut, 34
   Gaussians about 8 mm from its surface) stays simulated: it does not decide the grid and would hang in
   the air if left static.
3. **Size.** A Gaussian whose footprint radius (``SPLAT_SIGMA`` times its largest scale) exceeds the
   object's largest extent is a floater too (a background splat behind a small object).

Objects of fewer than ``MIN_GAUSSIANS`` Gaussians are never split.

Coincident Gaussians (equal centres) are searched once (:func:`gasp_core.maps.occupancy.distinct_points`): a k-d tree cannot split
equal points, so its query on 200,000 Gaussians at one point compared every pair (over 60 s, no answer);
the result is the same as for the full list, at O(n log n) for the sort.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from gasp_core.maps.occupancy import SPLAT_SIGMA, distinct_points, nearest_other

#: Link distance, times the 90th percentile of the nearest-neighbour distance.
LINK = 3.0
#: A connected piece with less than this share of the Gaussians is a floater.
MAX_SHARE = 0.01
#: How far outside the object's bounding box a small piece must lie to float, times its largest extent.
MARGIN = 0.05
#: Objects with fewer Gaussians are never split.
MIN_GAUSSIANS = 20


def find_floaters(means: np.ndarray, max_scales: np.ndarray) -> np.ndarray:
    """Which Gaussians are floaters (module notes).

    Parameters
    ----------
    means : ndarray, shape (n, 3), float
        Centres, metres (world frame).
    max_scales : ndarray, shape (n,), float
        Each Gaussian's largest scale, metres.

    Returns
    -------
    ndarray, shape (n,), bool
        True for a floater. Never all True: at least the largest piece is kept.
    """
    means = np.asarray(means, dtype=np.float64)
    n = len(means)
    out = np.zeros(n, bool)
    if n < MIN_GAUSSIANS:
        return out
    points, inverse, mult = distinct_points(means)
    if len(points) > 1:
        tree = cKDTree(points)
        nearest = nearest_other(points, mult, tree)        # a twin is at distance 0
        link = LINK * float(np.quantile(nearest[inverse], 0.9))
    else:
        link = 0.0                                                            # all at one point: one piece
    if link > 0:
        label = linked_pieces(tree, points, link)[inverse]
        counts = np.bincount(label)
        small = counts[label] < MAX_SHARE * n
        if small.all():
            small = label != np.argmax(counts)
        lo, hi = means[~small].min(axis=0), means[~small].max(axis=0)
        pad = MARGIN * float(np.max(hi - lo))
        away = ((means < lo - pad) | (means > hi + pad)).any(axis=1)
        out = small & np.isin(label, np.unique(label[small & away]))   # the whole piece, when any of it is away
    body = means[~out]
    extent = float(np.max(body.max(axis=0) - body.min(axis=0)))
    big = SPLAT_SIGMA * np.asarray(max_scales, dtype=np.float64) > extent
    if extent > 0 and big.sum() < 0.5 * (~out).sum():
        out |= big
    return out


#: Gaussians whose links are gathered at once by :func:`linked_pieces` (its memory: their links, not all).
CHUNK = 2048


def linked_pieces(tree: cKDTree, means: np.ndarray, link: float) -> np.ndarray:
    """Connected pieces of the graph linking centres closer than ``link``: one label per Gaussian, equal within
    a piece (int, shape (n,)).

    The links of :data:`CHUNK` Gaussians at a time are merged into the labels found so far, so memory follows
    a chunk's links: all pairs at once took 935 MB for the 62,442 Gaussians of the bundled kitchen (about 900
    links each in its dense parts), and would grow with the capture."""
    n = len(means)
    label = np.arange(n)
    for s in range(0, n, CHUNK):
        pairs = cKDTree(means[s:s + CHUNK]).sparse_distance_matrix(tree, link, output_type="ndarray")
        a, b = label[pairs["i"] + s], label[pairs["j"]]
        a, b = a[a != b], b[a != b]
        if len(a):
            graph = coo_matrix((np.ones(len(a), np.int8), (a, b)), shape=(n, n))
            label = connected_components(graph, directed=False)[1][label]
    return label
