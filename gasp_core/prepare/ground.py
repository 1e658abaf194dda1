"""``[[boundary]] kind = "ground", height = "auto"``: the ground on the support found in the scan.

:func:`resolve_ground` replaces each such height, once the objects are placed (:func:`gasp_core.prepare.scene.
prepare_scene`), by :func:`support_height` of the first simulated object:

- **a selection** (``select``) in a capture: the support beneath what moves. Among the unselected Gaussians
  whose centres lie over the selection's footprint (its x-y bounding box, world frame), those below the
  selection's bottom (its 1st percentile of z) by at most its own height (1st to 99th percentile of z) are the
  surface it rests on; the ground is their opacity-weighted median z. At least :data:`MIN_BENEATH` of them.
- **a whole object**: its support plane (:func:`gasp_core.gs.support.estimate_up`), whose normal must be within
  :data:`MAX_TILT` degrees of the object's placed up (world +z); the ground is the median world z of the
  plane's flat Gaussians (``up = "auto"`` gives that plane's normal exactly).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.support import estimate_up, plane_rows
from gasp_core.prepare.placed import PreparedObject

#: The height of a ground the scan places.
AUTO = "auto"
#: Fewest unselected Gaussians beneath a selection that make a support.
MIN_BENEATH = 10
#: A whole object's support plane may be tilted this much (degrees) from its placed up.
MAX_TILT = 5.0


def _weighted_median(v: np.ndarray, w: np.ndarray) -> float:
    order = np.argsort(v)
    c = np.cumsum(w[order])
    return float(v[order][np.searchsorted(c, 0.5 * c[-1])])


def support_height(o: PreparedObject) -> tuple[float, str]:
    """World height (m) of the support under ``o`` (module notes) and how it was found, in words.

    Raises
    ------
    SceneError
        Nothing beneath a selection, or a whole object with no sure support plane or one tilted more than
        :data:`MAX_TILT` from its up; the message names the object and says to state the height.
    """
    g, pl = o.gaussians, o.placement
    x = pl.to_world(g.means.astype(np.float64))
    if o.moving is not None and o.spec.select is not None:
        sel = np.zeros(g.n, dtype=bool)
        sel[o.moving] = True
        lo_xy, hi_xy = x[sel, :2].min(axis=0), x[sel, :2].max(axis=0)
        z_lo, z_hi = np.quantile(x[sel, 2], [0.01, 0.99])
        under = (~sel & np.all((x[:, :2] >= lo_xy) & (x[:, :2] <= hi_xy), axis=1)
                 & (x[:, 2] < z_lo) & (x[:, 2] >= z_lo - (z_hi - z_lo)))
        if under.sum() < MIN_BENEATH:
            raise SceneError(f"object '{o.name}': ground height = \"auto\" found {int(under.sum())} Gaussian(s) "
                             f"beneath the selection (needs {MIN_BENEATH}); state the ground's height")
        w = 1.0 / (1.0 + np.exp(-np.clip(g.opacities[under].astype(np.float64), -50.0, 50.0)))
        return _weighted_median(x[under, 2], w), (f"the median of the {int(under.sum())} unselected Gaussians "
                                                  f"beneath the selection")
    e = estimate_up(g)
    if e.plane is None:
        raise SceneError(f"object '{o.name}': ground height = \"auto\" found no sure support plane ({e.figures}); "
                         "state the ground's height")
    tilt = float(np.degrees(np.arccos(np.clip((pl.R @ e.plane.normal)[2], -1.0, 1.0))))
    if tilt > MAX_TILT:
        raise SceneError(f"object '{o.name}': its support plane is tilted {tilt:.1f} degrees from its placed up "
                         f"(at most {MAX_TILT:g}): use up = \"auto\", or state the ground's height")
    rows = plane_rows(g, e.plane)
    if not len(rows):       # an object's base (issue 68) whose splats are tilted more than plane_rows takes
        raise SceneError(f"object '{o.name}': ground height = \"auto\": no flat Gaussian lies on its support "
                         f"plane ({e.figures}); state the ground's height")
    return float(np.median(x[rows, 2])), f"the support plane's {len(rows)} flat Gaussians"


def resolve_ground(scene, objects: list[PreparedObject]):
    """``scene`` with every ground of height ``"auto"`` set to :func:`support_height` of the first simulated
    object of ``objects``; the scene itself when there is none."""
    if not has_auto_ground(scene):
        return scene
    moving = [o for o in objects if not o.spec.static]
    h, _ = support_height(moving[0])
    return dataclasses.replace(scene, boundaries=[dataclasses.replace(b, height=h) if b.height == AUTO else b
                                                  for b in scene.boundaries])


def has_auto_ground(scene) -> bool:
    """Whether a ground of ``scene`` waits for :func:`resolve_ground`."""
    return any(b.kind == "ground" and b.height == AUTO for b in scene.boundaries)
