"""The velocity a dynamic model gives its simulated part when physics takes over (issue 31, item 2).

A dynamic model ``psi(V, t)`` (``.splatv``) is released at model time ``s = dynamic_time``. Its simulated points
start with the model's own motion rather than at rest: each triangle vertex ``T(psi(V, t))`` moves with
``(T(psi(V, s + frame_dt)) - T(psi(V, s))) / frame_dt`` (world frame, m/s; model time in seconds, as
``psi(V, s + k frame_dt)`` is frame ``k``), the finite difference over one frame. Fill points take the
velocity of their nearest surface point; Core Gaussians (``core_fraction < 1``) the mean velocity of their
members' vertices. A scene that sets ``velocity`` or ``angular_velocity`` keeps those instead.

What is not simulated (the unselected rows, a static dynamic object) keeps following the model: frame ``k``
writes them as ``psi(V, s + k frame_dt)`` (:func:`background_at`, called by :func:`gasp_core.run.frames.rebuild`),
held at the model's last time past it (:func:`model_time`; said in one line, :func:`beyond_model_lines`).
The rows of it that stay still (:func:`still_rows`) keep their opacity at ``s`` (issue 68): the model's temporal
opacity swaps still Gaussians in and out over its time, so the kitchen's still part went from mean alpha 0.402 at
``s = 0.5`` to 0.377 at time 1 though nothing in it moves.
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



#: The model times a splaTV model covers: normalised, its capture from 0 to 1 (:func:`gasp_core.gs.splatv.splatv_at`).
MODEL_START, MODEL_END = 0.0, 1.0


def model_time(o: PreparedObject, t: float) -> float:
    """The model time at ``t`` seconds into the run, ``dynamic_time + t``, held within the time the model covers
    (:data:`MODEL_START` to :data:`MODEL_END`): past its end the polynomial motion and the temporal opacity are
    extrapolations (issue 68: the kitchen's still part faded, mean alpha 0.370 to 0.267, sampled up to 1.5)."""
    return min(max(float(o.spec.dynamic_time) + float(t), MODEL_START), MODEL_END)


def beyond_model_lines(objects: list[PreparedObject], frame_dt: float, n_frames: int) -> list[str]:
    """One line for each object whose rows follow its dynamic model (:func:`follows_model`) past the time the model
    covers within the run's ``n_frames`` frames (frame ``k`` at ``dynamic_time + k frame_dt``): they are held at
    :data:`MODEL_END` from the first frame beyond it."""
    lines = []
    for o in objects:
        s = o.spec.dynamic_time
        end = None if s is None else s + n_frames * frame_dt
        if not follows_model(o) or end <= MODEL_END + 1e-9:
            continue
        first = max(0, int(np.floor((MODEL_END - s) / frame_dt + 1e-9)) + 1)
        lines.append(f"object '{o.name}': its dynamic model covers model time [{MODEL_START:g}, {MODEL_END:g}], the "
                     f"run's {n_frames} frames from dynamic_time = {s:g} reach {end:.3g}: what follows the model is "
                     f"held at time {MODEL_END:g} from frame {first} (n_frames <= {first - 1} or an earlier "
                     "dynamic_time stays within it)")
    return lines


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
    later = splatv_at(*_model(str(path), path.stat().st_mtime_ns), model_time(o, frame_dt))
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


#: A row that follows its model is still when its centre moves less than this share of the model's robust diagonal
#: (1st to 99th percentile box at ``s``) over the model time from ``s`` to :data:`MODEL_END`, sampled at
#: :data:`STILL_SAMPLES` times. The kitchen (diagonal 42.7 file units, 3.4 m): 51,039 of its 62,442 Gaussians move
#: less than 0.43 units (3.4 cm) from s = 0.5 on; the cook, the pan's contents and the model's drifting splats more.
STILL_SHARE = 0.01
STILL_SAMPLES = 16


@functools.lru_cache(maxsize=4)
def _still(path: str, mtime_ns: int, s: float) -> np.ndarray:
    base, motion = _model(path, mtime_ns)
    x0 = splatv_at(base, motion, s).means
    lo, hi = np.quantile(x0, [0.01, 0.99], axis=0)
    reach = np.zeros(base.n)
    for t in np.linspace(s, max(s, MODEL_END), STILL_SAMPLES):
        reach = np.maximum(reach, np.linalg.norm(splatv_at(base, motion, float(t)).means - x0, axis=1))
    return reach < STILL_SHARE * float(np.linalg.norm(hi - lo))


def still_rows(o: PreparedObject) -> np.ndarray:
    """Bool (n,): the rows of ``o``'s dynamic model whose centres move less than :data:`STILL_SHARE` of its robust
    diagonal over the model time from ``dynamic_time`` to :data:`MODEL_END` (what any run from there plays)."""
    path = Path(o.spec.file)
    return _still(str(path), path.stat().st_mtime_ns, min(max(float(o.spec.dynamic_time), MODEL_START), MODEL_END))


def follows_model(o: PreparedObject) -> bool:
    """Whether some rows of ``o`` are not simulated and follow its dynamic model frame by frame: a ``.splatv``
    object that is static or simulates only part of its rows (a selection, floaters), unless its
    ``background = "frozen"``."""
    return (o.spec.dynamic_time is not None and o.spec.background == "model"
            and (o.spec.static or o.moving is not None))


def background_at(o: PreparedObject, g: Gaussians, t: float) -> Gaussians:
    """``g`` (the whole file at one frame, file frame) with every row that is not simulated set to the model at
    ``s + t``: ``psi(V, dynamic_time + t)``'s means, rotations, opacities and extra fields (the splaTV model keeps
    scales and colours constant), except that the still rows (:func:`still_rows`) keep the opacity (and
    ``temporal_opacity``) of ``o.gaussians``, the model at ``s`` (issue 68: the still part kept fading as the
    model's temporal opacity swapped its Gaussians); ``g`` itself when ``o`` does not follow its model
    (:func:`follows_model`).

    Raises
    ------
    SceneError
        From reading the model (:func:`gasp_core.gs.splatv.read_splatv`).
    """
    if not follows_model(o):
        return g
    path = Path(o.spec.file)
    psi = splatv_at(*_model(str(path), path.stat().st_mtime_ns), model_time(o, t))
    still = still_rows(o)
    at_s = o.gaussians           # the model at s: the opacity a still row keeps
    if o.spec.static:
        extra = {k: np.where(still, at_s.extra[k], v) if k in at_s.extra and k in ("temporal_opacity",) else v
                 for k, v in psi.extra.items()}
        return dataclasses.replace(psi, opacities=np.where(still, at_s.opacities, psi.opacities), extra=extra)
    keep = np.ones(g.n, bool)
    keep[o.moving] = False
    plays = keep & ~still
    means, rotations, opacities = g.means.copy(), g.rotations.copy(), g.opacities.copy()
    means[keep], rotations[keep] = psi.means[keep], psi.rotations[keep]
    opacities[plays] = psi.opacities[plays]
    opacities[keep & still] = at_s.opacities[keep & still]
    extra = {}
    for k, v in g.extra.items():
        if k not in psi.extra:
            extra[k] = v
        elif k == "temporal_opacity":
            extra[k] = np.where(plays, psi.extra[k], np.where(keep, at_s.extra.get(k, v), v))
        else:
            extra[k] = np.where(keep, psi.extra[k], v)
    return dataclasses.replace(g, means=means, rotations=rotations, opacities=opacities, extra=extra)
