"""The velocity a dynamic model gives its simulated part when physics takes over (issue 31, item 2).

A dynamic model ``psi(V, t)`` (``.splatv``) is released at model time ``s = dynamic_time``. Its simulated points
start with the model's own motion rather than at rest: each triangle vertex ``T(psi(V, t))`` moves with
``(T(psi(V, s + frame_dt)) - T(psi(V, s))) / frame_dt`` (world frame, m/s; model time in seconds, as
``psi(V, s + k frame_dt)`` is frame ``k``), the finite difference over one frame. Fill points take the
velocity of their nearest surface point; Core Gaussians (``core_fraction < 1``) the mean velocity of their
members' vertices. A scene that sets ``velocity`` or ``angular_velocity`` keeps those instead.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.prepare.selection import flat_world

if TYPE_CHECKING:
    from gasp_core.prepare.placement import PreparedObject


def vertex_velocities(o: PreparedObject, frame_dt: float) -> np.ndarray:
    """Velocities of the object's simulated surface points from its dynamic model, m/s, shape (k, 3).

    The rows match :func:`gasp_core.prepare.placement.simulated_triangles` reshaped to (k, 3): the
    triangle vertices of the simulated Gaussians, or the Core Gaussians' four points.

    Raises
    ------
    SceneError
        From reading the model again (:func:`gasp_core.gs.splatv.read_splatv`).
    """
    base, motion = read_splatv(o.spec.file)
    later = splatv_at(base, motion, o.spec.dynamic_time + frame_dt)
    tri1 = flat_world(later, o.placement)[3]
    if o.moving is not None:
        tri1 = tri1[o.moving]
    v = (tri1 - o.tri_rest) / frame_dt                                    # (n, 3, 3)
    if o.hierarchy is None:
        return v.reshape(-1, 3)
    h = o.hierarchy
    member = np.repeat(h.core_of, 3)
    count = np.bincount(member, minlength=h.n_cores)[:, None]
    mean = np.stack([np.bincount(member, v.reshape(-1, 3)[:, d], minlength=h.n_cores) for d in range(3)], 1) / count
    return np.repeat(mean, 4, axis=0)


def fill_velocities(surface_x: np.ndarray, surface_v: np.ndarray, fill_x: np.ndarray) -> np.ndarray:
    """Each fill point takes its nearest surface point's velocity, shape (m, 3)."""
    if not len(fill_x):
        return np.zeros((0, 3))
    return surface_v[cKDTree(surface_x).query(fill_x)[1]]
