"""The rotation taking an object's up to world +z: its ``up_axis`` (one of six), a stated ``up = [x, y, z]``, or
``up = "auto"`` from the support plane of the scan (:mod:`gasp_core.gs.support`). Composition with ``rotation``:
:func:`gasp_core.prepare.placement.place`, ``docs/scene_reference.md``."""
from __future__ import annotations

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.support import UP_SURE, estimate_up, rotation_to_z
from gasp_core.prepare.placed import UP_ROTATIONS


def up_rotation(g: Gaussians, up_axis: str, up=None, name: str = "object") -> np.ndarray:
    """The rotation (3, 3) taking the file's up to world +z: ``up`` a vector (3,) in the file frame, any
    direction (:func:`rotation_to_z`); ``"auto"`` the up vector of :func:`estimate_up`; None the signed axis
    ``up_axis`` (``UP_ROTATIONS``, :mod:`gasp_core.prepare.placed`).

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
        if e.up is None:
            lean = ("" if e.lean is None else
                    f"; the best candidate plane's normal is {np.round(e.lean.normal, 3).tolist()} (not a verdict)")
            raise SceneError(f"object '{name}': up = \"auto\" is unsure (confidence {e.confidence:.2f} < {UP_SURE}): "
                             f"{e.figures}{lean}; state up = [x, y, z] or up_axis (gasp info gives the figures)")
        up = e.up
    return rotation_to_z(up)
