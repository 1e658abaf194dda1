"""The flat Gaussians of a file and their normals: what the support plane (:mod:`gasp_core.gs.support`) and an
object's base (:mod:`gasp_core.gs.object_up`) are fitted to."""
from __future__ import annotations

import numpy as np

from gasp_core.gs.gaussians import Gaussians, quat_to_rotmat

#: A Gaussian is flat (it has a normal) when its smallest scale is below this share of its largest.
FLAT_RATIO = 0.2


def flat_normals(g: Gaussians, keep: np.ndarray | None = None):
    """Rows, means (m, 3), unit normals (m, 3) and opacity weights (m,) of the flat Gaussians of ``g`` among
    the rows ``keep`` (bool, shape (n,); all when None)."""
    s = g.scales.astype(np.float64)
    flat = s.min(axis=1) < FLAT_RATIO * s.max(axis=1)
    if keep is not None:
        flat &= keep
    rows = np.flatnonzero(flat)
    R = quat_to_rotmat(g.rotations[rows]).astype(np.float64)
    normal = R[np.arange(len(rows)), :, np.argmin(s[rows], axis=1)]
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    w = 1.0 / (1.0 + np.exp(-np.clip(g.opacities[rows].astype(np.float64), -50.0, 50.0)))
    return rows, g.means[rows].astype(np.float64), normal, w
