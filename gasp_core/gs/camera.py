"""Pinhole camera in the world frame (metres, z up), automatic framing, and a ground-grid background.

Camera frame as in 3DGS/OpenCV: x right, y down, z forward (depth). A point ``p`` maps to
pixel ``u = f x / z + cx``, ``v = f y / z + cy``, pixel ``i`` covering ``[i, i + 1)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from gasp_core.errors import SceneError


@dataclass
class Camera:
    """A pinhole camera looking from ``position`` at ``look_at``, world z up.

    Attributes
    ----------
    position, look_at : ndarray, shape (3,)
        Metres, world frame.
    fov_deg : float
        Vertical field of view, degrees (0 < fov < 180).
    width, height : int
        Image size, pixels.
    near : float
        Points closer than this depth (metres) are not drawn.
    rotation : ndarray, shape (3, 3), optional
        World -> camera rotation, rows right, down, forward (OpenCV); when given it sets the
        orientation (a capture's camera may roll), and ``look_at`` only fixes the forward row.

    Raises
    ------
    SceneError
        (a ``ValueError``) If the field of view or size is out of range, a position is not finite
        or ``position == look_at``; the message names the parameter.
    """

    position: np.ndarray
    look_at: np.ndarray
    fov_deg: float = 40.0
    width: int = 640
    height: int = 480
    near: float = 1e-3
    rotation: np.ndarray | None = None

    def __post_init__(self):
        self.position = np.asarray(self.position, dtype=np.float64).reshape(3)
        self.look_at = np.asarray(self.look_at, dtype=np.float64).reshape(3)
        if not 0.0 < float(self.fov_deg) < 180.0:
            raise SceneError(f"camera fov_deg: expected 0 < fov < 180 degrees, got {self.fov_deg}")
        if int(self.width) < 2 or int(self.height) < 2:
            raise SceneError(f"camera resolution: expected at least 2x2 pixels, got {self.width}x{self.height}")
        self.width, self.height = int(self.width), int(self.height)
        for what, v in (("position", self.position), ("look_at", self.look_at)):
            if not np.isfinite(v).all():
                raise SceneError(f"camera {what}: expected finite x, y, z (metres), got {v.tolist()}")
        if self.rotation is not None:   # before the look_at test: a zero rotation's look_at is the position
            self.rotation = np.asarray(self.rotation, dtype=np.float64).reshape(3, 3)
            if not np.allclose(self.rotation @ self.rotation.T, np.eye(3), atol=1e-4) \
                    or np.linalg.det(self.rotation) < 0:
                raise SceneError("camera rotation: expected a proper rotation matrix (orthonormal, det +1)")
        if np.linalg.norm(self.look_at - self.position) < 1e-12:
            raise SceneError(f"camera position and look_at are the same point {self.position.tolist()}")

    @classmethod
    def from_pose(cls, position, rotation, focal_px: float, width: int, height: int, near: float = 1e-3) -> "Camera":
        """A camera at ``position`` with world -> camera ``rotation`` (rows right, down, forward) and a
        vertical focal length ``focal_px`` in pixels for an image ``width`` x ``height``."""
        rotation = np.asarray(rotation, dtype=np.float64).reshape(3, 3)
        fov = float(np.degrees(2.0 * np.arctan(0.5 * height / focal_px)))
        position = np.asarray(position, dtype=np.float64).reshape(3)
        return cls(position, position + rotation[2], fov, width, height, near, rotation)

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (square pixels)."""
        return 0.5 * self.height / np.tan(np.radians(self.fov_deg) / 2.0)

    @property
    def cx(self) -> float:
        return 0.5 * self.width

    @property
    def cy(self) -> float:
        return 0.5 * self.height

    def world_to_camera(self) -> tuple[np.ndarray, np.ndarray]:
        """``(W, t)`` with ``p_cam = W p_world + t``; rows of ``W`` are right, down, forward."""
        if self.rotation is not None:
            return self.rotation, -self.rotation @ self.position
        fwd = self.look_at - self.position
        fwd /= np.linalg.norm(fwd)
        up = np.array([0.0, 0.0, 1.0])
        if abs(fwd @ up) > 0.999:          # looking straight down or up: use +y as screen up
            up = np.array([0.0, 1.0, 0.0])
        right = np.cross(fwd, up)
        right /= np.linalg.norm(right)
        down = np.cross(fwd, right)
        W = np.stack([right, down, fwd])
        return W, -W @ self.position

    def project_points(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates ``(n, 2)`` and depths ``(n,)`` of world points ``x`` (n, 3)."""
        W, t = self.world_to_camera()
        pc = np.asarray(x, dtype=np.float64) @ W.T + t
        z = pc[:, 2]
        uv = np.stack([self.focal_px * pc[:, 0] / z + self.cx, self.focal_px * pc[:, 1] / z + self.cy], 1)
        return uv, z

    def rays(self) -> np.ndarray:
        """World-frame ray directions through pixel centres, shape (height, width, 3) (not unit)."""
        W, _ = self.world_to_camera()
        u = (np.arange(self.width) + 0.5 - self.cx) / self.focal_px
        v = (np.arange(self.height) + 0.5 - self.cy) / self.focal_px
        d = np.stack(np.broadcast_arrays(u[None, :], v[:, None], np.ones((1, 1))), axis=-1)
        return d @ W


def auto_camera(lo, hi, width: int = 640, height: int = 480, fov_deg: float = 40.0,
                azimuth_deg: float = -60.0, elevation_deg: float = 25.0, margin: float = 1.1) -> Camera:
    """A camera that sees the whole box ``[lo, hi]`` (world, metres), looking at its centre.

    It sits at ``azimuth_deg`` around +z (0 = on +x, -90 = on -y) and ``elevation_deg`` above the
    box centre, far enough that the box's bounding sphere (times ``margin``) fits the narrower
    field of view.
    """
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = 0.5 * (lo + hi)
    radius = max(0.5 * float(np.linalg.norm(hi - lo)), 1e-3)
    half_v = np.radians(fov_deg) / 2.0
    half_h = np.arctan(np.tan(half_v) * width / height)
    dist = margin * radius / np.sin(min(half_v, half_h))
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    direction = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    return Camera(centre + dist * direction, centre, fov_deg, width, height, near=1e-3 * dist)


def fit_to_box(cam: Camera, lo, hi, margin: float = 1.1, steps: int = 4) -> Camera:
    """``cam`` moved along its line of sight to the centre of the box ``[lo, hi]`` (world, metres) until the
    projection of the box's 8 corners spans the picture's width or height divided by ``margin`` (the tighter of
    the two): :func:`auto_camera` fits the box's bounding sphere, which leaves a flat box small. Each step
    scales the distance by the corners' largest offset from the picture centre over the half picture (exact for
    points at the centre's depth); a corner behind the camera stops it."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    centre = 0.5 * (lo + hi)
    corners = np.array([[(lo, hi)[i >> k & 1][k] for k in range(3)] for i in range(8)])
    for _ in range(steps):
        uv, z = cam.project_points(corners)
        if np.any(z <= cam.near):
            break
        k = margin * max(np.max(np.abs(uv[:, 0] - cam.cx)) / cam.cx, np.max(np.abs(uv[:, 1] - cam.cy)) / cam.cy)
        d = (cam.position - centre) * k
        cam = Camera(centre + d, centre, cam.fov_deg, cam.width, cam.height, near=1e-3 * float(np.linalg.norm(d)))
    return cam


def nice_step(x: float) -> float:
    """The 1, 2, 5 x 10^k number nearest below ``x`` (grid spacing)."""
    k = np.floor(np.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10**k <= x:
            return float(m * 10**k)
    return float(10**k)


def ground_background(cam: Camera, ground_z: float, spacing: float, extent: float, centre=(0.0, 0.0),
                      sky=(0.93, 0.94, 0.96), floor=(0.80, 0.80, 0.78), line=(0.45, 0.45, 0.45)) -> np.ndarray:
    """Background image: a ground plane at height ``ground_z`` with grid lines every ``spacing`` metres.

    The grid fades out beyond ``extent`` metres from ``centre`` (x, y); above the horizon, a flat sky.

    Returns
    -------
    ndarray, shape (height, width, 3), float64
    """
    d = cam.rays()
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (ground_z - cam.position[2]) / d[..., 2]
    hit = np.isfinite(s) & (s > 0)
    s = np.where(hit, s, 0.0)
    gx = (cam.position[0] + s * d[..., 0] - centre[0]) / spacing
    gy = (cam.position[1] + s * d[..., 1] - centre[1]) / spacing
    # line coverage from the distance to the nearest line over its screen-space rate (antialiased)
    cover = np.zeros(gx.shape)
    for g in (gx, gy):
        dist = np.abs(g - np.round(g))
        gv, gu = np.gradient(g)
        fw = np.abs(gu) + np.abs(gv) + 1e-9
        cover = np.maximum(cover, np.clip(1.0 - dist / fw, 0.0, 1.0))
    r = np.hypot(gx, gy) * spacing
    fade = np.clip(1.5 - r / extent, 0.0, 1.0)
    cover = cover * fade * hit
    floor_c = np.asarray(floor) * (1 - cover[..., None]) + np.asarray(line) * cover[..., None]
    img = np.where(hit[..., None], floor_c, np.asarray(sky))
    return img
