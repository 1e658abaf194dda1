"""Colliders, impulses and force fields: what a scene asks of an engine beyond its bodies and boundaries.

Everything here is data in the world frame (metres, seconds, z up) that every engine can read from
:class:`~gasp_core.seam.setup.SimSetup` (``colliders``, ``forces``, ``impulses``):

- :class:`Collider`: a rigid obstacle, as a **signed distance field** sampled on a regular grid in
  the collider's own frame (negative inside, metres) with its gradient, the triangles it came from
  (when it came from a mesh), a Coulomb ``friction`` and a prescribed rigid motion
  (:meth:`Collider.pose` at time ``t``: rotation ``R``, translation ``T``, linear and angular
  velocity). A static collider has no motion. Built by :mod:`gasp_core.colliders.sdf` (from a
  closed triangle mesh, a static object's Gaussians or a box).
- :class:`Impulse`: a velocity change given to whatever is inside a box or sphere between ``t0``
  and ``t1`` (``mode = "add"``, PhysGaussian's ``impulse``), or a velocity imposed there
  (``mode = "set"``, PhysGaussian's ``enforce_particle_translation``; ``ramp`` raises it from 0 linearly).
- :class:`ForceField`: ``wind`` (quadratic drag on the body's surface towards a wind velocity, a
  uniform speed plus optional divergence-free turbulence, deterministic for a seed) or ``attractor``
  (an **acceleration** towards a point, m/s^2, mass independent like gravity, with a falloff).

Grid (MPM) engines apply all three on the grid nodes: :mod:`gasp_core.mpm.grid_tables` packs
them into the flat arrays their kernels read (``grid_tables``), and the time-dependent part of one
frame (``frame_table``: collider poses and impulse weights per substep). Colliders follow
the MLS-MPM reference code (Hu et al. 2018) and PhysGaussian: at a node inside the collider (``phi <= 0``), the velocity
relative to the collider's velocity there loses its normal component if approaching, and its
tangential part is reduced by Coulomb friction.

Engine features (``gasp_core.seam.engine.FEATURES``): ``static_colliders``, ``moving_colliders``,
``impulse``, ``wind``, ``attractors`` (:func:`gasp_core.seam.build.needs`).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from gasp_core.errors import SceneError

#: Wind turbulence: number of Fourier modes of the divergence-free field.
TURBULENCE_MODES = 16
#: Floats per collider in :func:`grid_tables` ``col_meta`` and per substep pose in :func:`frame_table`.
COL_META, COL_POSE = 9, 18
#: Floats per force row and per turbulence mode (:func:`grid_tables`).
FORCE_ROW, MODE_ROW = 12, 8
#: Floats per impulse row (:func:`grid_tables`).
IMPULSE_ROW = 11
#: A set impulse's ``constrain``: every velocity component imposed, or only the one along ``velocity_change``.
CONSTRAINS = ("all", "along")
FALLOFFS = ("none", "inverse_square")
#: The error for a wind given as an acceleration (the scene format before issue 17).
WIND_ACCELERATION_REMOVED = (
    "wind is a drag law on the body's surface, F = 1/2 rho_air C_d A |u - v| (u - v): 'strength' (an acceleration, "
    "m/s^2) is no longer read; give 'speed' (wind speed, m/s) with 'direction', and optionally 'air_density' "
    "(kg/m^3, default 1.2) and 'drag_coefficient' (C_d, default 1.0); 'turbulence' is now an RMS wind speed, m/s")


@dataclass
class Motion:
    """Prescribed rigid motion of a collider, world frame.

    Attributes
    ----------
    velocity : (3,) float
        Constant linear velocity, m/s (ignored with ``path``).
    angular_velocity : (3,) float
        Constant angular velocity about the collider's origin (its ``position``), rad/s.
    path : ndarray, shape (k, 4), or None
        Keyframes ``[t, x, y, z]`` (s, m) of the origin, times increasing: linearly interpolated,
        held before the first and after the last.
    """

    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    path: np.ndarray | None = None

    @property
    def moving(self) -> bool:
        return self.path is not None or bool(np.any(self.velocity)) or bool(np.any(self.angular_velocity))


def rotvec_matrix(w: np.ndarray) -> np.ndarray:
    """Rotation matrix of the rotation vector ``w`` (axis times angle, rad), Rodrigues."""
    a = float(np.linalg.norm(w))
    if a == 0.0:
        return np.eye(3)
    k = w / a
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(a) * K + (1.0 - math.cos(a)) * K @ K


@dataclass
class Collider:
    """A rigid obstacle as a signed distance field (see the module notes).

    Attributes
    ----------
    name : str
        For messages (``[[collider]] #1``, a file name).
    phi : ndarray, shape (nx, ny, nz), float64
        Signed distance at the samples ``origin + (i, j, k) * h`` of the collider frame, metres,
        negative inside.
    grad : ndarray, shape (nx, ny, nz, 3), float64
        Its gradient (central differences), dimensionless; the outward normal where normalised.
    origin : ndarray, shape (3,)
        Collider-frame position of sample ``(0, 0, 0)``, metres.
    h : float
        Sample spacing, metres.
    friction : float
        Coulomb friction coefficient (0 slip; large sticks).
    position : ndarray, shape (3,)
        World position of the collider frame's origin at ``t = 0``, metres.
    rotation : ndarray, shape (3, 3)
        World rotation of the collider frame at ``t = 0``.
    motion : Motion
    triangles : ndarray, shape (m, 3, 3) or None
        Collider-frame triangles (metres) when built from a mesh, for engines that collide with
        meshes.
    source : str
        Where it came from, for ``run.json``: ``mesh:<file>``, ``gaussians:<file>``,
        ``object:<name>``; empty for colliders built in code.
    """

    name: str
    phi: np.ndarray
    grad: np.ndarray
    origin: np.ndarray
    h: float
    friction: float = 0.5
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    motion: Motion = field(default_factory=Motion)
    triangles: np.ndarray | None = None
    source: str = ""

    @property
    def moving(self) -> bool:
        return self.motion.moving

    def pose(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(R, T, v, w)`` at time ``t`` (s): world rotation, world origin (m), linear (m/s) and angular (rad/s) velocity.

        A collider-frame point ``p`` is at ``R p + T``; a world point ``X`` attached to the collider
        moves at ``v + w x (X - T)``.
        """
        m = self.motion
        w = np.asarray(m.angular_velocity, float)
        R = rotvec_matrix(w * t) @ self.rotation
        if m.path is not None:
            ts, ps = m.path[:, 0], m.path[:, 1:]
            T = np.array([np.interp(t, ts, ps[:, d]) for d in range(3)])
            k = int(np.searchsorted(ts, t, side="right"))
            if 0 < k < len(ts):
                v = (ps[k] - ps[k - 1]) / (ts[k] - ts[k - 1])
            else:
                v = np.zeros(3)
        else:
            v = np.asarray(m.velocity, float)
            T = np.asarray(self.position, float) + v * t
        return R, T, v, w

    def distance(self, X: np.ndarray, t: float = 0.0) -> np.ndarray:
        """Signed distance (m, negative inside) of world points ``X`` (n, 3) at time ``t``; +inf off the field's grid."""
        R, T, _, _ = self.pose(t)
        p = (np.asarray(X, float) - T) @ R
        u = (p - self.origin) / self.h
        dims = np.array(self.phi.shape)
        off = ((u < 0) | (u > dims - 1)).any(axis=1)
        out = ndimage.map_coordinates(self.phi, u.T, order=1, mode="nearest")
        out[off] = np.inf
        return out


@dataclass
class Impulse:
    """A velocity change (``add``) or an imposed velocity (``set``) inside a region between ``t0`` and ``t1``.

    Attributes
    ----------
    shape : {"box", "sphere"}
    lo, hi : (3,) float
        Box corners, metres (``box``).
    centre : (3,) float
        Sphere centre, metres, and ``radius`` (m) (``sphere``).
    velocity_change : (3,) float
        ``add``: total velocity change, m/s, spread evenly over ``[t0, t1]`` (all at once in the
        substep holding ``t0`` when ``t1 == t0``). ``set``: the velocity imposed, m/s.
    t0, t1 : float
        Seconds.
    mode : {"add", "set"}
    ramp : float
        ``set`` only: seconds over which the imposed velocity rises linearly from 0 at ``t0`` to
        ``velocity_change`` at ``t0 + ramp``, then holds until ``t1`` (:meth:`ramp_factor`); 0 (default):
        ``velocity_change`` from ``t0``. Finite, in ``[0, t1 - t0]``.
    constrain : {"all", "along"}
        ``set``: every velocity component imposed (default), or only the one along ``velocity_change`` (nonzero),
        those across it left free (a per-degree-of-freedom constraint; docs/colliders.md).

    Raises
    ------
    SceneError
        ``ramp`` negative, not finite, past ``t1 - t0``, or not 0 with ``mode = "add"``; a bad ``constrain``.
    """

    shape: str
    velocity_change: tuple[float, float, float]
    t0: float = 0.0
    t1: float = 0.0
    lo: tuple[float, float, float] = (0.0, 0.0, 0.0)
    hi: tuple[float, float, float] = (0.0, 0.0, 0.0)
    centre: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0
    mode: str = "add"
    ramp: float = 0.0
    constrain: str = "all"

    def __post_init__(self):
        r = self.ramp
        real = isinstance(r, numbers.Real) and not isinstance(r, bool)
        if not (real and math.isfinite(r) and 0.0 <= r <= self.t1 - self.t0 + 1e-12):
            raise SceneError(f"impulse 'ramp' must be a finite number of seconds in [0, t1 - t0 = "
                             f"{self.t1 - self.t0:g}], got {r!r}")
        if self.constrain not in CONSTRAINS or (self.constrain == "along" and (
                self.mode != "set" or not np.linalg.norm(np.asarray(self.velocity_change, float)) > 0.0)):
            raise SceneError(f"impulse 'constrain' must be one of {list(CONSTRAINS)} ('along' with mode = 'set' and a "
                             f"nonzero velocity_change, its direction), got {self.constrain!r} with mode = "
                             f"{self.mode!r}, velocity_change {list(self.velocity_change)}")
        if r > 0.0 and self.mode != "set":
            raise SceneError(f"impulse 'ramp' = {r:g} s is for mode = 'set' only (an 'add' impulse spreads its "
                             f"change evenly over [t0, t1]), got mode = {self.mode!r}")

    def weight(self, t: float, dt: float) -> float:
        """Share of ``velocity_change`` given in the substep ``[t, t + dt)`` (``add``), or 1/0 active (``set``: its
        midpoint in ``[t0, t1]``; the share imposed then is :meth:`ramp_factor` at that midpoint)."""
        if self.mode == "set":
            return 1.0 if (self.t0 <= t + 0.5 * dt and t + 0.5 * dt <= self.t1 + 1e-12) else 0.0
        if self.t1 <= self.t0:
            return 1.0 if t <= self.t0 < t + dt else 0.0
        overlap = min(t + dt, self.t1) - max(t, self.t0)
        return max(0.0, overlap) / (self.t1 - self.t0)

    def ramp_factor(self, t: float) -> float:
        """``set``: the share of ``velocity_change`` imposed at time ``t`` (s): ``(t - t0) / ramp`` clipped to
        [0, 1], or 1 with no ramp. The grid engines take it at each substep's midpoint
        (:func:`gasp_core.mpm.grid_tables.frame_table`), so a point carried through the ramp moves
        ``velocity_change * (t - t0)^2 / (2 ramp)`` exactly."""
        if self.ramp <= 0.0:
            return 1.0
        return min(1.0, max(0.0, (t - self.t0) / self.ramp))

    def contains(self, X: np.ndarray) -> np.ndarray:
        X = np.asarray(X, float)
        if self.shape == "box":
            return np.all((X >= np.asarray(self.lo)) & (X <= np.asarray(self.hi)), axis=1)
        return np.linalg.norm(X - np.asarray(self.centre), axis=1) <= self.radius


@dataclass
class ForceField:
    """Wind (a drag law on the surface) or an attractor (an acceleration field, m/s^2).

    ``wind`` is the field-standard quadratic drag on the body's surface,

        ``F = 1/2 rho_air C_d A |u - v| (u - v)``,

    with ``u`` the wind velocity, ``v`` the body's and ``A`` the area the body shows the relative
    wind (its projection on the plane normal to ``u - v``): a body in wind reaches a terminal
    velocity (a falling one ``sqrt(2 m g / (rho_air C_d A))`` in still air). Grid engines apply it
    at the nodes on the body's windward surface (docs/colliders.md).

    Attributes
    ----------
    kind : {"wind", "attractor"}
    direction : (3,) float
        ``wind``: unit direction of the mean wind velocity.
    speed : float
        ``wind``: mean wind speed, m/s (``u = speed * direction``).
    air_density : float
        ``wind``: density of the air (or other fluid) ``rho_air``, kg/m^3 (default 1.2, air at 20 C).
    drag_coefficient : float
        ``wind``: ``C_d``, dimensionless (default 1.0; about 0.47 for a sphere, 1.05 for a cube face on).
    strength : float
        ``attractor``: acceleration towards ``point`` at distance ``radius`` (negative repels), m/s^2.
        Must be 0 for ``wind`` (the old wind acceleration; :class:`~gasp_core.errors.SceneError`).
    turbulence : float
        ``wind``: RMS of the turbulent wind velocity, m/s (0: uniform wind).
    turbulence_scale : float
        ``wind``: wavelength of the turbulence, metres.
    turbulence_time : float
        ``wind``: period over which the turbulence changes, seconds (inf: frozen).
    seed : int
        ``wind``: random seed of the turbulence (same seed, same field).
    point : (3,) float
        ``attractor``: metres.
    radius : float
        ``attractor``: softening radius, metres; inside it the pull falls linearly to 0 at ``point``.
    falloff : {"none", "inverse_square"}
        ``attractor``: ``|a| = strength`` beyond ``radius``, or ``strength (radius / r)^2``.

    Raises
    ------
    SceneError
        ``wind`` with a non-zero ``strength`` (wind is no longer an acceleration), or a negative
        ``speed``, ``air_density`` or ``drag_coefficient``.
    """

    kind: str
    direction: tuple[float, float, float] = (1.0, 0.0, 0.0)
    strength: float = 0.0
    turbulence: float = 0.0
    turbulence_scale: float = 0.5
    turbulence_time: float = math.inf
    seed: int = 0
    point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.05
    falloff: str = "none"
    speed: float = 0.0
    air_density: float = 1.2
    drag_coefficient: float = 1.0

    def __post_init__(self):
        if self.kind == "wind":
            if self.strength != 0.0:
                raise SceneError(WIND_ACCELERATION_REMOVED)
            if not (self.speed >= 0.0 and self.air_density >= 0.0 and self.drag_coefficient >= 0.0):
                raise SceneError(f"wind needs speed >= 0 (m/s), air_density >= 0 (kg/m^3) and drag_coefficient >= 0; "
                                 f"got {self.speed}, {self.air_density}, {self.drag_coefficient}")

    @property
    def drag_factor(self) -> float:
        """``1/2 rho_air C_d``, kg/m^3: drag force per unit area per (m/s)^2."""
        return 0.5 * self.air_density * self.drag_coefficient

    def wind_velocity(self, X: np.ndarray, t: float = 0.0) -> np.ndarray:
        """``wind``: the wind velocity ``u`` at world points ``X`` (n, 3) and time ``t``, m/s (reference for the kernels)."""
        X = np.asarray(X, float)
        u = np.broadcast_to(self.speed * np.asarray(self.direction, float), X.shape).copy()
        for row in self.modes():
            u += row[3:6] * np.sin(X @ row[:3] + row[7] * t + row[6])[:, None]
        return u

    def modes(self) -> np.ndarray:
        """Turbulence modes, shape (K, 8): wave vector k (1/m), amplitude A (m/s, A . k = 0), phase, omega (rad/s).

        The turbulent wind velocity is ``sum A sin(k . x + omega t + phase)``: divergence-free
        (each ``A`` is perpendicular to its ``k``), smooth, with RMS ``turbulence``; the same
        ``seed`` gives the same field.
        """
        if self.kind != "wind" or self.turbulence == 0.0:
            return np.zeros((0, MODE_ROW))
        rng = np.random.default_rng(self.seed)
        K = TURBULENCE_MODES
        d = rng.normal(size=(K, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        a = np.cross(d, rng.normal(size=(K, 3)))
        a /= np.linalg.norm(a, axis=1, keepdims=True)
        k = d * (2.0 * math.pi / self.turbulence_scale)
        A = a * self.turbulence * math.sqrt(2.0 / K)
        phase = rng.uniform(0.0, 2.0 * math.pi, size=K)
        omega = (np.zeros(K) if not math.isfinite(self.turbulence_time)
                 else rng.uniform(0.5, 1.5, size=K) * 2.0 * math.pi / self.turbulence_time)
        return np.column_stack([k, A, phase, omega])

    def acceleration(self, X: np.ndarray, t: float = 0.0) -> np.ndarray:
        """``attractor``: the field at world points ``X`` (n, 3), m/s^2 (reference for the kernels).

        Raises
        ------
        ValueError
            For ``wind``, which is a drag law (:meth:`wind_velocity`), not an acceleration.
        """
        X = np.asarray(X, float)
        if self.kind == "wind":
            raise ValueError("wind is a drag law, not an acceleration: see ForceField.wind_velocity")
        r_vec = np.asarray(self.point, float) - X
        r = np.linalg.norm(r_vec, axis=1)
        mag = np.where(r >= self.radius,
                       self.strength * ((self.radius / np.maximum(r, 1e-300)) ** 2 if self.falloff == "inverse_square"
                                        else 1.0),
                       self.strength * r / self.radius)
        return r_vec / np.maximum(r, 1e-300)[:, None] * mag[:, None]


# --------------------------------------------------------------------------- engine needs
def check_start(colliders, x: np.ndarray, name_of=None) -> None:
    """Refuse simulated points that start inside a collider (more than a quarter sample deep).

    Raises
    ------
    SceneError
        Naming the collider, the count and the first point.
    """
    for c in colliders:
        d = c.distance(x, 0.0)
        inside = d < -0.25 * c.h
        if inside.any():
            k = int(np.flatnonzero(inside)[0])
            raise SceneError(f"collider '{c.name}': {int(inside.sum())} simulated point(s) start inside it "
                             f"(first at {np.round(x[k], 4).tolist()}, {-d[k]:.3g} m deep); move the object "
                             "or the collider apart")
