"""``gasp info``: what a Gaussian Splatting file holds, and a guessed up axis with its confidence
(:mod:`gasp_core.gs.up_axis`)."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from gasp_core.gs.io import read_gaussians, refuse_one_point
from gasp_core.gs.registry import sniff
from gasp_core.gs.support import camera_up, estimate_up, with_cameras
from gasp_core.gs.up_axis import guess_up



def describe(path) -> dict[str, Any]:
    """Summary of a Gaussian Splatting file.

    Parameters
    ----------
    path : str or os.PathLike
        Anything :func:`read_gaussians` reads (:mod:`gasp_core.gs.registry`; a ``.splatv`` at t = 0.5).

    Returns
    -------
    dict
        ``count`` (int), ``sh_degree`` (int), ``layout`` (str), ``bbox_min``, ``bbox_max``
        (lists of 3 floats, file units), ``extent`` (list of 3 floats), ``up_axis_guess`` (str,
        one of ``"+x" "-x" "+y" "-y" "+z" "-z"`` or ``"unknown"`` when unsure), ``up_axis_confidence``
        (float in [0, 1]), ``up_axis_method`` (str: which cues decided, or why unsure), ``up_axis_lean`` (the
        best direction or axis even when unsure, ``""`` for none), ``up_axis_cues`` (list of str: each cue,
        its figures and what it said), ``up_axis_note`` (str),
        ``up_vector`` (list of 3 floats: the unit up vector in the file's frame, from the support plane in any
        direction, :mod:`gasp_core.gs.support`; None when unsure), ``up_confidence`` (float in [0, 1]),
        ``support_plane`` (None when unsure, else ``normal`` (the up vector), ``offset`` (file units: the plane
        is ``normal . x = offset``), ``share`` of the flat Gaussians on it, ``below`` share of the Gaussians
        beyond it), ``up_lean`` (the best candidate plane's normal even when unsure, or None), ``up_figures`` (str),
        ``flat_fraction`` (fraction of Gaussians with min/max scale ratio < 0.01),
        ``median_scale_ratio``. A file with no Gaussians gives only ``count``, ``sh_degree``,
        ``layout``.

    Raises
    ------
    FileNotFoundError, SceneError
        As :func:`read_gaussians`; SceneError also for a degenerate file of Gaussians all at one point
        (:func:`gasp_core.gs.io.refuse_one_point`).

    Notes
    -----
    Up axis: none of these layouts states one, so it is **guessed** from every cue the file and a
    ``cameras.json`` beside it give (:mod:`gasp_core.gs.up_axis`: cameras, flat-area asymmetry, support
    plane, longest axis, floaters); a guess to show the user, not a frame to trust: scene files state their
    own ``up_axis``.
    """
    path = Path(path)
    g = read_gaussians(path)         # any format of the registry; a .splatv at model time 0.5
    refuse_one_point(path, g)        # before the up-axis guess and the floater search
    x = g.means
    if g.n == 0:
        return {"count": 0, "sh_degree": g.sh_degree, "layout": g.layout}
    lo, hi = x.min(axis=0), x.max(axis=0)
    u = guess_up(g, path.parent / "cameras.json")
    e = estimate_up(g)
    if (path.parent / "cameras.json").is_file():
        e = with_cameras(e, camera_up(path.parent / "cameras.json"))
    ratio = g.scales.min(axis=1) / np.maximum(g.scales.max(axis=1), 1e-300)
    return {
        "count": g.n,
        "format": sniff(path).name,
        "sh_degree": g.sh_degree,
        "layout": g.layout,
        "bbox_min": lo.tolist(),
        "bbox_max": hi.tolist(),
        "extent": (hi - lo).tolist(),
        "up_axis_guess": u.up,
        "up_axis_confidence": round(u.confidence, 3),
        "up_axis_method": u.method,
        "up_axis_lean": u.lean or "none",
        "up_axis_cues": [c.line() for c in u.cues],
        "up_axis_note": ("a guess: state up_axis in the scene file" if u.up != "unknown" else
                         "unsure: the height and scale along each axis follow; state up_axis in the scene file "
                         "(gasp info --up=AXIS gives the figures along it)"),
        "up_vector": None if e.up is None else [round(float(v), 6) for v in e.up],
        "up_confidence": round(e.confidence, 3),
        "support_plane": None if e.plane is None else e.plane.as_dict(),
        "up_lean": None if e.lean is None else [round(float(v), 3) for v in e.lean.normal],
        "up_figures": e.figures,
        "flat_fraction": float(np.mean(ratio < 0.01)),
        "median_scale_ratio": float(np.median(ratio)),
    }
