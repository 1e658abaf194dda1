"""The pieces a click in the studio selects: a still object's connected pieces (:func:`piece_labels`), and on a
dynamic model what moves with the clicked splat (:func:`motion_pick`; issue 54).

A dynamic scene is ``psi(V, s)`` (the paper's dynamic scenes: a splaTV model, :mod:`gasp_core.gs.splatv`). In a captured
kitchen the spinach is stirred while the pan, the counter and the room stay, and the pan touches the leaves
everywhere, so the connected piece of a still capture (``grow``) joins them. On a dynamic model the studio's click
uses the model's own motion instead:

1. **displacement** ``dv`` of each Gaussian (world metres): the largest distance of its centre from where it is at
   the object's ``dynamic_time``, over :data:`N_TIMES` model times in [0, 1], counting only the times at which the
   model draws it (temporal opacity factor at least :data:`DRAWN`, the viewer's own cut);
2. **moving**: ``dv`` above :data:`TAU_FACTOR` times the object's median ``dv`` (the model's own still level);
3. **linked**: two moving Gaussians closer than the link distance, the median distance of a moving Gaussian to its
   :data:`K_LINK`-th nearest moving one (from the data); the moving pieces are the connected components, and those
   of fewer than ``K_LINK + 1`` Gaussians are left out as specks;
4. **the piece clicked**: of the moving pieces with a member within the link distance of the clicked Gaussian, or
   whose convex hull holds it, the largest;
5. **the selection**: every Gaussian whose centre lies in that piece's convex hull (the still leaves inside a heap,
   which a motion threshold alone leaves out). A click near no moving piece falls back to the connected piece.

Measured on the kitchen (``benchmarks/kitchen_click.py``, ``docs/colliders.md``): the 12 of 16 clicks whose
ray meets a leaf select the same 342 Gaussians, and the spinach so selected lands in the pan with none beyond its wall.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Model times sampled in [0, 1] for each Gaussian's displacement.
N_TIMES = 21
#: A Gaussian counts at a model time where its temporal opacity factor is at least this (the viewer skips below it).
DRAWN = 0.02
#: Moving: displacement above this multiple of the object's median displacement.
TAU_FACTOR = 3.0
#: The link distance is the median distance of a moving Gaussian to its K_LINK-th nearest moving one.
K_LINK = 4
#: At most this many links a distinct centre, where the link distance would give more (a dense pile of centres).
MAX_LINKS_PER_POINT = 64


def piece_labels(means: np.ndarray, radii: np.ndarray, linking: np.ndarray) -> np.ndarray:
    """Which piece each Gaussian belongs to, shape (n,), int: the connected pieces of the opaque Gaussians
    (:func:`gasp_core.prepare.selection.component_labels`), and each faint one (``linking`` false) joins the piece
    of its nearest opaque Gaussian when either splat holds the other's centre (the same link rule), so that a
    selected object takes its faint halo with it instead of leaving it hanging where it was."""
    from scipy.spatial import cKDTree
    from gasp_core.prepare.selection import component_labels
    label = component_labels(means, radii, linking)
    faint, opaque = np.flatnonzero(~linking), np.flatnonzero(linking)
    if len(faint) and len(opaque):
        dist, j = cKDTree(means[opaque]).query(means[faint])
        near = opaque[j]
        joins = dist <= np.maximum(radii[faint], radii[near])
        label[faint[joins]] = label[near[joins]]
    return label


@dataclass
class MovingPieces:
    """The moving pieces of a dynamic object (module notes, steps 1-3).

    Attributes
    ----------
    rows : ndarray, shape (k,), int64
        The moving Gaussians' rows.
    labels : ndarray, shape (k,), int
        Their piece, 0 .. number of pieces - 1.
    link : float
        The link distance, metres.
    tau : float
        The moving threshold on the displacement, metres.
    """

    rows: np.ndarray
    labels: np.ndarray
    link: float
    tau: float


def displacement(base, motion: dict, s: float, scale: float) -> np.ndarray:
    """Each Gaussian's largest distance from its place at model time ``s`` (module notes, step 1).

    Parameters
    ----------
    base, motion
        The model, from :func:`gasp_core.gs.splatv.read_splatv`.
    s : float
        The object's ``dynamic_time``.
    scale : float
        File units to metres (the placement's scale; its rotation keeps lengths).

    Returns
    -------
    ndarray, shape (n,), float64
        Metres.
    """
    from gasp_core.gs.splatv import splatv_at
    at = splatv_at(base, motion, s).means
    dv = np.zeros(base.n)
    for t in np.linspace(0.0, 1.0, N_TIMES):
        g = splatv_at(base, motion, float(t))
        drawn = g.extra["temporal_opacity"] >= DRAWN
        dv = np.maximum(dv, np.where(drawn, np.linalg.norm(g.means - at, axis=1), 0.0))
    return float(scale) * dv


def moving_pieces(means: np.ndarray, dv: np.ndarray) -> MovingPieces | None:
    """The moving pieces (module notes, steps 2 and 3) of Gaussians at ``means`` (n, 3), world metres, with
    displacements ``dv`` (n,), metres; None when fewer than ``K_LINK + 1`` Gaussians move (a still model).

    The work is bounded by the input (issue 68: 20,000 moving Gaussians at one point were linked at distance 0, about
    2e8 pairs, 6.35 GB and a ``MemoryError``): Gaussians at one centre are one node
    (:func:`gasp_core.maps.occupancy.distinct_points`), each counted for its multiplicity in the link distance, and
    where the links between distinct centres would exceed :data:`MAX_LINKS_PER_POINT` a centre, each centre links
    to at most that many of its nearest within the link distance instead of to all of them."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree
    from gasp_core.maps.occupancy import distinct_points
    tau = TAU_FACTOR * float(np.median(dv))
    rows = np.flatnonzero(dv > tau)
    if len(rows) <= K_LINK:
        return None
    points, inverse, mult = distinct_points(means[rows])
    m = len(points)
    tree = cKDTree(points)
    # the K_LINK-th nearest other Gaussian of each, counting the Gaussians at its own centre and at each neighbour's
    k = min(K_LINK + 1, m)
    dist, idx = tree.query(points, k=k)
    dist, idx = dist.reshape(m, k), idx.reshape(m, k)
    reach = np.cumsum(mult[idx], axis=1)            # Gaussians within each neighbour's distance, itself included
    kth = dist[np.arange(m), np.argmax(reach > K_LINK, axis=1)]
    link = float(np.median(np.repeat(kth, mult)))
    if tree.count_neighbors(tree, link) - m <= 2 * MAX_LINKS_PER_POINT * m:
        pairs = tree.query_pairs(link, output_type="ndarray")
        src, dst = pairs[:, 0], pairs[:, 1]
    else:      # a dense pile of distinct centres: each to its nearest within the link distance
        near_d, near = tree.query(points, k=min(MAX_LINKS_PER_POINT + 1, m), distance_upper_bound=link)
        near_d, near = near_d.reshape(m, -1), near.reshape(m, -1)
        ok = np.isfinite(near_d)
        src, dst = np.broadcast_to(np.arange(m)[:, None], near.shape)[ok], near[ok]
    graph = coo_matrix((np.ones(len(src), np.int8), (src, dst)), shape=(m, m))
    return MovingPieces(rows, connected_components(graph, directed=False)[1][inverse], link, tau)


def _hull(points: np.ndarray):
    """The Delaunay triangulation of ``points`` (its ``find_simplex`` tests the convex hull), or None when they span
    no volume (fewer than 5, or flat)."""
    from scipy.spatial import Delaunay, QhullError
    if len(points) < 5:
        return None
    try:
        return Delaunay(points)
    except QhullError:
        return None


def motion_pick(means: np.ndarray, hit: int, mp: MovingPieces) -> np.ndarray | None:
    """The selection of a click whose ray met row ``hit`` (module notes, steps 4 and 5).

    Parameters
    ----------
    means : ndarray, shape (n, 3)
        World metres, the object's Gaussians as the page shows them (at its ``dynamic_time``).
    hit : int
        The row the click met.
    mp : MovingPieces
        From :func:`moving_pieces`.

    Returns
    -------
    ndarray, shape (n,), bool, or None
        The Gaussians in the clicked piece's convex hull (its members where it spans no volume); None when no moving
        piece is within the link distance of the hit or holds it.
    """
    x = means[mp.rows]
    sizes = np.bincount(mp.labels)
    near = {k for k in np.unique(mp.labels[np.linalg.norm(x - means[hit], axis=1) <= mp.link]).tolist()
            if sizes[k] > K_LINK}
    for lab in np.flatnonzero(sizes > K_LINK):
        if lab in near:
            continue
        pts = x[mp.labels == lab]
        if np.all(means[hit] >= pts.min(axis=0)) and np.all(means[hit] <= pts.max(axis=0)):
            tri = _hull(pts)
            if tri is not None and tri.find_simplex(means[hit]) >= 0:
                near.add(int(lab))
    if not near:
        return None
    lab = max(near, key=lambda k: sizes[k])
    sel = np.zeros(len(means), bool)
    sel[mp.rows[mp.labels == lab]] = True
    tri = _hull(x[mp.labels == lab])
    if tri is not None:
        sel |= tri.find_simplex(means) >= 0
    return sel
