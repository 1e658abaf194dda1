"""GaMeS mesh-mode Gaussians from a triangle mesh: flat splats on its faces, for scenes with a known volume.

A closed mesh's volume is known exactly (divergence theorem), so Gaussians laid on it test the interior fill
against an answer that does not come from the fill; removing faces makes the open captures real scans are.
"""
from __future__ import annotations

import numpy as np

from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
from gasp_core.maps.games import EPS


def mesh_splats(vertices, faces, n: int, seed: int = 0, sigma_factor: float = 0.5,
                opacity: float = 4.0) -> Gaussians:
    """``n`` flat Gaussians on the faces of a triangle mesh (GaMeS mesh mode), at uniform random points.

    Parameters
    ----------
    vertices : array_like, shape (v, 3), float
        Mesh vertices (any unit; the Gaussians use the same).
    faces : array_like, shape (f, 3), int
        Triangles (vertex indices).
    n : int
        Number of Gaussians; faces are drawn in proportion to their area.
    seed : int
        Random seed.
    sigma_factor : float
        In-plane scale ``sigma_factor * sqrt(area / n)`` (0.5: half the mean spacing).
    opacity : float
        Opacity logit of every Gaussian.

    Returns
    -------
    Gaussians
        Thin axis (scale :data:`gasp_core.maps.games.EPS`) along the face normal (rotation column 0), the
        two in-plane axes along the face's first edge and across it; grey, SH degree 0.
    """
    rng = np.random.default_rng(seed)
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces)]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    cross = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(cross, axis=1)
    f = rng.choice(len(tri), n, p=area / area.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    means = tri[f, 0] + u[:, None] * e1[f] + v[:, None] * e2[f]
    r2 = e1[f] / np.linalg.norm(e1[f], axis=1, keepdims=True)
    normal = cross[f] / np.linalg.norm(cross[f], axis=1, keepdims=True)
    r3 = np.cross(normal, r2)
    s = sigma_factor * np.sqrt(area.sum() / n)
    scales = np.column_stack([np.full(n, EPS), np.full(n, s), np.full(n, s)])
    return Gaussians(means=means, scales=scales, rotations=rotmat_to_quat(np.stack([normal, r2, r3], axis=2)),
                     opacities=np.full(n, opacity, np.float32), sh_dc=np.full((n, 3), 0.5, np.float32))
