"""Sub-triangle Gaussians for GaMeS triangles the alpha rule clamps where the body has not broken (issue 52: "a tear
that stays closed until it parts").

The control rule (GASP paper Eq. alpha_rule, :func:`gasp_core.maps.games.alpha_rule`) caps a stretched Gaussian's
scale at ``alpha`` times its rest value, so where a neck stretches past ``alpha`` before it tears the clamped
Gaussians no longer reach their neighbours and the surface shows holes. Here each such triangle is split: in the
moved triangle's affine frame ``p(a, b) = v1 + a e2 + b e3`` (``e2 = v2 - v1``, ``e3 = v3 - v1``; at rest the
Gaussian's ``+-1 sigma`` footprint is the square ``a, b in [-1, 1]``, GaMeS' ``v2 = m + s2 r2``,
``v3 = m + s3 r3``), the square is cut into ``k2 x k3`` cells, ``k_i = ceil(lambda_i / alpha)`` with ``lambda_i``
the edge's stretch ``|e_i| / |e_i rest|`` (at most :data:`MAX_SPLIT`); cell ``(i, j)`` is the sub-triangle
``(c, c + e2 / k2, c + e3 / k3)``, ``c = p(-1 + (2 i + 1) / k2, -1 + (2 j + 1) / k3)``, rebuilt by the same
``T^-1`` (:func:`gasp_core.maps.games.triangles_to_gaussians`, the Gram-Schmidt of the paper) and held by the same
alpha rule against its **parent's** rest triangle (a stretch past ``MAX_SPLIT alpha`` stays clamped). Each
sub-Gaussian's scale is then ``lambda_i s_i / k_i``, at most ``alpha`` times the parent's rest scale, and the
``k2 x k3`` of them tile the ``+-1 sigma`` footprint the unclamped Gaussian had, at the spacing (twice the scale)
the rest tiling has (its tails past ``1 sigma`` are not reproduced). They take the parent's colour and opacity (the
run's sidecar, :mod:`gasp_core.run.split_output`); the parent's own row, clamped, is unchanged.

**Until it parts.** A triangle whose vertices fall in different pieces of a broken body straddles a crack and is not
split (:func:`gasp_core.run.frames.rebuild`). A body without pieces (plasticine tears without damage) is judged by its
material: a sub-Gaussian is kept only where the nearest fill point lies at most half a fill spacing ``h``
(:data:`GAP`) farther than the nearest fill point of the same spot at rest (:func:`near_material`), so once the two
sides of a tear draw apart the sub-Gaussians over the gap are dropped and the hole opens (measured on the plasticine
rod, ``benchmarks/tear_split.py``: one fill spacing still drew a sheet over most of the 13.7 cm gap in its fill
3 frames after it parted, with a thin line open in its middle).
"""
from __future__ import annotations

import numpy as np

from gasp_core.maps.games import alpha_rule, triangles_to_gaussians

__all__ = ["MAX_SPLIT", "split_triangles", "near_material"]

#: How much farther from the fill than at rest (in fill spacings) a sub-Gaussian may lie and still be drawn.
GAP = 0.5
#: The most cells along one edge (a stretch past ``MAX_SPLIT * alpha`` leaves its sub-Gaussians clamped again).
MAX_SPLIT = 8


def split_triangles(tri_rest: np.ndarray, tri_t: np.ndarray, rows: np.ndarray, alpha: float,
                    max_split: int = MAX_SPLIT):
    """The sub-triangle Gaussians of the triangles ``rows`` (see the module's text).

    Parameters
    ----------
    tri_rest, tri_t : ndarray, shape (n, 3, 3), float
        Rest and moved triangles (``v1, v2, v3``), world frame, metres; ``tri_t`` before any clamp.
    rows : ndarray, shape (m,), int
        The triangles to split (those the alpha rule clamped and that straddle no crack).
    alpha : float
        The control rule's factor (> 0).
    max_split : int
        The most cells along an edge.

    Returns
    -------
    parent : ndarray, shape (k,), int64
        The row of ``tri_t`` each sub-Gaussian comes from (``k = sum k2 k3`` over ``rows``).
    means, rot, scales : ndarray, shapes (k, 3), (k, 3, 3), (k, 3), float64
        World frame, metres (``scales[:, 0]`` GaMeS' ``eps``), each in-plane scale at most ``alpha`` times the
        parent's rest scale.
    centres_rest : ndarray, shape (k, 3), float64
        The same spots ``p(a, b)`` on the rest triangle (for :func:`near_material`).
    """
    rows = np.asarray(rows, np.int64)
    tr, tt = np.asarray(tri_rest, np.float64)[rows], np.asarray(tri_t, np.float64)[rows]
    e0, et = tr[:, 1:] - tr[:, :1], tt[:, 1:] - tt[:, :1]                    # (m, 2, 3): e2, e3
    stretch = np.linalg.norm(et, axis=2) / np.maximum(np.linalg.norm(e0, axis=2), 1e-300)
    k = np.clip(np.ceil(stretch / alpha - 1e-9), 1, max_split).astype(np.int64)   # (m, 2)
    count = k[:, 0] * k[:, 1]
    which = np.repeat(np.arange(len(rows)), count)
    q = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    k2, k3 = k[which, 0], k[which, 1]
    a = -1.0 + (2 * (q // k3) + 1) / k2
    b = -1.0 + (2 * (q % k3) + 1) / k3

    def sub(t, e):
        c = t[which, 0] + a[:, None] * e[which, 0] + b[:, None] * e[which, 1]
        return np.stack([c, c + e[which, 0] / k2[:, None], c + e[which, 1] / k3[:, None]], axis=1)

    sub_rest, sub_t = sub(tr, e0), sub(tt, et)
    means, rot, scales, _ = triangles_to_gaussians(sub_t)
    _, _, scales_rest, _ = triangles_to_gaussians(tr)
    scales, _ = alpha_rule(tr[which], sub_t, scales, scales_rest[which], alpha)   # against the parent's rest
    return rows[which], means, rot, scales, sub_rest[:, 0]


def near_material(centres: np.ndarray, centres_rest: np.ndarray, fill: np.ndarray, fill_rest: np.ndarray,
                  h: float) -> np.ndarray:
    """Which spots still lie on material: the nearest moved fill point to ``centres`` is at most ``h`` farther than
    the nearest rest fill point to ``centres_rest``, shape (k,), bool.

    ``centres``, ``centres_rest`` (k, 3) and ``fill``, ``fill_rest`` (m, 3) in metres, world frame; ``h`` the fill
    spacing, metres (the tolerance is :data:`GAP` times it). With no fill point every spot is kept."""
    if len(fill) == 0 or len(centres) == 0:
        return np.ones(len(centres), bool)
    from scipy.spatial import cKDTree
    d_0 = cKDTree(fill_rest).query(centres_rest)[0]
    d_t = cKDTree(fill).query(centres, distance_upper_bound=float(d_0.max()) + GAP * h + 1e-12)[0]   # inf past it
    return d_t <= d_0 + GAP * h
