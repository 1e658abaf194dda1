"""The velocity a dynamic model gives its simulated part when physics takes over (issue 31, item 2).

A dynamic model ``psi(V, t)`` (``.splatv``) is released at model time ``s = dynamic_time``. Its simulated points
start with the model's own motion rather than at rest: each triangle vertex ``T(psi(V, t))`` moves with
``(T(psi(V, s + frame_dt)) - T(psi(V, s))) / frame_dt`` (world frame, m/s; model time in seconds, as
``psi(V, s + k frame_dt)`` is frame ``k``), the finite difference over one frame. Fill points take the
velocity of their nearest surface point; Core Gaussians (``core_fraction < 1``) the mean velocity of their
members' vertices. A scene that sets ``velocity`` or ``angular_velocity`` keeps those instead.

What is not simulated (the unselected rows, a static dynamic object) keeps following the model: frame ``k``
writes them as ``psi(V, s + k frame_dt)`` (:func:`background_at`, called by :func:`gasp_core.run.frames.rebuild`).
"""
from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.prepare.placed import PreparedObject
from gasp_core.prepare.selection import flat_world



def vertex_velocities(o: PreparedObject, frame_dt: float) -> np.ndarray:
    """Velocities of the object's simulated surface points from its dynamic model, m/s, shape (k, 3).

    The rows match the object's surface points (:meth:`gasp_core.maps.surface.SurfaceMap.points`): the
    triangle vertices of the simulated Gaussians, their centres alone, or the Core Gaussians' four points.

    Raises
    ------
    SceneError
        From reading the model again (:func:`gasp_core.gs.splatv.read_splatv`).
    """
    path = Path(o.spec.file)
    later = splatv_at(*_model(str(path), path.stat().st_mtime_ns), o.spec.dynamic_time + frame_dt)
    tri1 = flat_world(later, o.placement)[3]
    if o.moving is not None:
        tri1 = tri1[o.moving]
    return o.surface.velocities((tri1 - o.tri_rest) / frame_dt)          # (n, 3, 3) -> the map's points


def fill_velocities(surface_x: np.ndarray, surface_v: np.ndarray, fill_x: np.ndarray) -> np.ndarray:
    """Each fill point takes its nearest surface point's velocity, shape (m, 3)."""
    if not len(fill_x):
        return np.zeros((0, 3))
    return surface_v[cKDTree(surface_x).query(fill_x)[1]]


@functools.lru_cache(maxsize=4)
def _model(path: str, mtime_ns: int):
    """The dynamic model of ``path`` (read once per file version)."""
    return read_splatv(path)


def follows_model(o: PreparedObject) -> bool:
    """Whether some rows of ``o`` are not simulated and follow its dynamic model frame by frame: a ``.splatv``
    object that is static or simulates only part of its rows (a selection, floaters), unless its
    ``background = "frozen"``."""
    return (o.spec.dynamic_time is not None and o.spec.background == "model"
            and (o.spec.static or o.moving is not None))


def background_at(o: PreparedObject, g: Gaussians, t: float) -> Gaussians:
    """``g`` (the whole file at one frame, file frame) with every row that is not simulated set to the model at
    ``s + t``: ``psi(V, dynamic_time + t)``'s means, rotations, opacities and extra fields (the splaTV model keeps
    scales and colours constant); ``g`` itself when ``o`` does not follow its model (:func:`follows_model`).

    Raises
    ------
    SceneError
        From reading the model (:func:`gasp_core.gs.splatv.read_splatv`).
    """
    if not follows_model(o):
        return g
    path = Path(o.spec.file)
    psi = splatv_at(*_model(str(path), path.stat().st_mtime_ns), o.spec.dynamic_time + t)
    if o.spec.static:
        return psi
    keep = np.ones(g.n, bool)
    keep[o.moving] = False
    means, rotations, opacities = g.means.copy(), g.rotations.copy(), g.opacities.copy()
    means[keep], rotations[keep], opacities[keep] = psi.means[keep], psi.rotations[keep], psi.opacities[keep]
    extra = {k: np.where(keep, psi.extra[k], v) if k in psi.extra else v for k, v in g.extra.items()}
    return dataclasses.replace(g, means=means, rotations=rotations, opacities=opacities, extra=extra)
