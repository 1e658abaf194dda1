"""The rotation taking an object's up to world +z: its ``up_axis`` (one of six), a stated ``up = [x, y, z]``, or
``up = "auto"`` from the support plane of the scan (:mod:`gasp_core.gs.support`). Composition with ``rotation``:
:func:`gasp_core.prepare.placement.place`, ``docs/scene_reference.md``. An object whose scene states neither
``up_axis`` nor ``up`` takes the up axis ``gasp info`` guesses where that guess is sure (:func:`resolve_up_axis`).
"""
from __future__ import annotations

import dataclasses
import hashlib
import warnings
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.support import UP_SURE, camera_up, estimate_up, rotation_to_z, with_cameras
from gasp_core.prepare.placed import UP_ROTATIONS


def up_rotation(g: Gaussians, up_axis: str, up=None, name: str = "object", cameras: Path | None = None) -> np.ndarray:
    """The rotation (3, 3) taking the file's up to world +z: ``up`` a vector (3,) in the file frame, any
    direction (:func:`rotation_to_z`); ``"auto"`` the up vector of :func:`estimate_up`, checked against the
    capture's cameras where ``cameras`` (a graphdeco ``cameras.json``) exists (:func:`with_cameras`: they confirm
    it, veto it, or decide alone when upright); None the signed axis ``up_axis`` (``UP_ROTATIONS``,
    :mod:`gasp_core.prepare.placed`).

    Raises
    ------
    SceneError
        ``up = "auto"`` where the estimate is unsure, naming ``name``, the figures and the best candidate
        plane's normal (a candidate, not a verdict).
    """
    if up is None:
        return UP_ROTATIONS[up_axis]
    if isinstance(up, str):
        e = estimate_up(g)
        if cameras is not None and Path(cameras).is_file():
            e = with_cameras(e, camera_up(cameras))
        if e.up is None:
            lean = ("" if e.lean is None else
                    f"; the best candidate plane's normal is {np.round(e.lean.normal, 3).tolist()} (not a verdict)")
            raise SceneError(f"object '{name}': up = \"auto\" is unsure (confidence {e.confidence:.2f} < {UP_SURE}): "
                             f"{e.figures}{lean}; state up = [x, y, z] or up_axis (gasp info gives the figures)")
        up = e.up
    return rotation_to_z(up)


#: Guesses of :func:`resolve_up_axis` by file, cameras and a sample of the means (at most 16 kept).
_GUESSES: dict = {}


def resolve_up_axis(spec, g: Gaussians, name: str | None = None):
    """``spec`` (an :class:`~gasp_core.scene.spec.ObjectSpec`) with its up axis settled: unchanged where the scene
    states ``up_axis`` or ``up``; else the axis :func:`gasp_core.gs.up_axis.guess_up` guesses from ``g`` (and a
    ``cameras.json`` beside the file) where the guess is sure (confidence >= :data:`gasp_core.gs.up_axis.UP_SURE`,
    what ``gasp info`` calls a guess rather than unsure), else ``+z`` as before (issue 68: a guitar whose scene left
    ``up_axis`` out lay on its side without a word). Either way one warning line names the object, the axis used
    and the key that pins it. The spec returned has ``up_axis_stated`` true, so the object is not guessed again."""
    if spec.up_axis_stated or spec.up is not None:
        return spec
    from gasp_core.errors import SceneError
    from gasp_core.gs.up_axis import UP_SURE, guess_up
    name = name or Path(spec.file).stem
    cameras = Path(spec.file).parent / "cameras.json"
    key = (str(spec.file), str(cameras), cameras.is_file() and cameras.stat().st_mtime_ns, g.n,
           hashlib.sha1(np.ascontiguousarray(g.means[:: max(1, g.n // 4096)]).tobytes()).hexdigest())
    u = _GUESSES.get(key)
    if u is None:
        try:
            u = guess_up(g, cameras)
        except SceneError:        # a cameras.json that is not one: guessed from the Gaussians alone
            u = guess_up(g, None)
        if len(_GUESSES) >= 16:
            _GUESSES.pop(next(iter(_GUESSES)))
        _GUESSES[key] = u         # the same file prepared again (a resume, the studio, the tests): guessed once
    if u.up != "unknown":
        warnings.warn(f"object '{name}': no up_axis in the scene; using the guessed up axis {u.up} (confidence "
                      f"{u.confidence:.2f}: {u.method}, as gasp info says); up_axis = \"{u.up}\" in its [[object]] "
                      f"pins it", stacklevel=3)
        return dataclasses.replace(spec, up_axis=u.up, up_axis_stated=True)
    lean = f", leaning to {u.lean}" if u.lean else ""
    warnings.warn(f"object '{name}': no up_axis in the scene and the guess is unsure (confidence "
                  f"{u.confidence:.2f} < {UP_SURE}{lean}); kept the default up_axis = \"{spec.up_axis}\"; state "
                  f"up_axis in its [[object]] (gasp info gives the figures)", stacklevel=3)
    return dataclasses.replace(spec, up_axis_stated=True)
