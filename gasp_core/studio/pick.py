"""What a click or a drawn box in the studio picks: ray casting against splats and screen-space boxes.

A click gives a ray (origin and unit direction, world metres, from the browser's camera). The splat it
"hits" is the one a renderer shows at that pixel: along the ray, splats are composited front to back with
alpha ``a_i = opacity_i exp(-d_i^2 / 2)`` (``d_i`` the ray's Mahalanobis distance to splat ``i``'s centre at
its closest approach, 3DGS's 2D footprint seen along the ray), and the picked splat is the one at which the
accumulated opacity ``1 - prod(1 - a_j)`` first reaches one half: the *median depth* splat of 2DGS (Huang
et al. 2024, Sec. 4.2), so a faint halo in front of an object does not steal the click. No splat: the ray
reaches the background (accumulated opacity stays below one half).

A box drawn on the screen picks every Gaussian whose centre projects inside it and lies in front of the
camera (viser's camera: OpenCV axes, +z forward, +y down; vertical field of view ``fov``; screen
coordinates in [0, 1], (0, 0) the upper-left corner).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gasp_core.gs.gaussians import quat_to_rotmat

#: Accumulated opacity at which the ray has "hit" (2DGS's median depth).
HIT_OPACITY = 0.5
#: Splats whose alpha along the ray is below this are skipped (3DGS's rasteriser skips alpha < 1/255).
MIN_ALPHA = 1.0 / 255.0
#: A flat splat's thin axis is taken as at least this fraction of its widest, so that its footprint seen
#: edge-on is a thin ellipse rather than a division by 1e-8.
THIN_FLOOR = 1e-2


@dataclass(frozen=True)
class Hit:
    """A click's hit: ``row`` of the splat, its ``depth`` along the ray (metres), the ``opacity`` reached."""

    row: int
    depth: float
    opacity: float


def ray_pick(means: np.ndarray, rotmats: np.ndarray, scales: np.ndarray, opacities: np.ndarray,
             origin, direction, candidates: np.ndarray | None = None) -> Hit | None:
    """The splat a ray sees first (module notes), or None when it reaches the background.

    Parameters
    ----------
    means : ndarray, shape (n, 3)
        Centres, world metres.
    rotmats : ndarray, shape (n, 3, 3)
        World rotation of each splat's axes (column ``j`` is the axis ``scales[:, j]`` measures).
    scales : ndarray, shape (n, 3)
        Standard deviations along the axes, metres.
    opacities : ndarray, shape (n,)
        Activated opacities in [0, 1].
    origin, direction : array-like, shape (3,)
        The ray, world metres; ``direction`` need not be unit length.
    candidates : ndarray of int, optional
        Rows that may be hit (default all).

    Returns
    -------
    Hit or None
    """
    o = np.asarray(origin, np.float64)
    d = np.asarray(direction, np.float64)
    d = d / np.linalg.norm(d)
    rows = np.arange(len(means)) if candidates is None else np.asarray(candidates, np.int64)
    if not len(rows):
        return None
    s = np.maximum(scales[rows], THIN_FLOOR * scales[rows].max(axis=1, keepdims=True))
    s = np.maximum(s, 1e-12)
    R = rotmats[rows]
    op = np.einsum("nji,nj->ni", R, o - means[rows]) / s      # origin in each splat's unit frame
    dp = np.einsum("nji,j->ni", R, d) / s                     # direction in each splat's unit frame
    dd = np.einsum("ni,ni->n", dp, dp)
    od = np.einsum("ni,ni->n", op, dp)
    t = -od / dd                                              # closest approach, metres along the ray
    m2 = np.maximum(np.einsum("ni,ni->n", op, op) - od ** 2 / dd, 0.0)
    alpha = np.clip(opacities[rows], 0.0, 0.99) * np.exp(-0.5 * m2)
    front = np.flatnonzero((t > 0) & (alpha >= MIN_ALPHA))
    if not len(front):
        return None
    order = front[np.argsort(t[front], kind="stable")]
    acc = 1.0 - np.cumprod(1.0 - alpha[order])
    k = int(np.searchsorted(acc, HIT_OPACITY))
    if k >= len(order):
        return None
    i = order[k]
    return Hit(int(rows[i]), float(t[i]), float(acc[k]))


def world_frames(g, R, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Each Gaussian's world axes and scales under the placement ``x = scale R x_file + t``: shapes (n, 3, 3), (n, 3)."""
    return np.einsum("ij,njk->nik", np.asarray(R, np.float64), quat_to_rotmat(g.rotations)), scale * g.scales


def camera_project(points: np.ndarray, position, wxyz, fov: float, aspect: float) -> tuple[np.ndarray, np.ndarray]:
    """Screen coordinates of world points seen by a viser camera.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        World metres.
    position : (3,)
        Camera centre, world metres.
    wxyz : (4,)
        Camera orientation (``P_world = R p_camera``, OpenCV camera axes).
    fov : float
        Vertical field of view, radians.
    aspect : float
        Width over height.

    Returns
    -------
    uv : ndarray, shape (n, 2)
        Screen position, (0, 0) upper left, (1, 1) lower right.
    depth : ndarray, shape (n,)
        Distance in front of the camera along its axis, metres (<= 0: behind).
    """
    R = quat_to_rotmat(np.asarray(wxyz, np.float64))
    pc = (np.asarray(points, np.float64) - np.asarray(position, np.float64)) @ R   # camera frame
    z = pc[:, 2]
    f = 0.5 / np.tan(0.5 * fov)                               # focal length in screen heights
    with np.errstate(divide="ignore", invalid="ignore"):
        u = 0.5 + f * pc[:, 0] / z / aspect
        v = 0.5 + f * pc[:, 1] / z
    return np.stack([u, v], axis=1), z


def box_rows(means: np.ndarray, position, wxyz, fov: float, aspect: float, screen_min, screen_max,
             candidates: np.ndarray | None = None) -> np.ndarray:
    """Rows whose centres project inside the screen box ``[screen_min, screen_max]`` and lie in front of the camera.

    Returns
    -------
    rows : ndarray of int64, sorted
    """
    rows = np.arange(len(means)) if candidates is None else np.asarray(candidates, np.int64)
    uv, z = camera_project(means[rows], position, wxyz, fov, aspect)
    lo, hi = np.minimum(screen_min, screen_max), np.maximum(screen_min, screen_max)
    inside = (z > 0) & np.all((uv >= lo) & (uv <= hi), axis=1)
    return np.sort(rows[inside])
