"""Checks of an object's Gaussians against its placement, before any work (the values in the scene file
itself are checked by :mod:`gasp_core.scene`)."""
from __future__ import annotations

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.scene.spec import ObjectSpec
from gasp_core.scene.values import MAX_COORD


def check_object(spec: ObjectSpec, g) -> None:
    """Check an object's Gaussians against its placement before any work.

    Parameters
    ----------
    spec : ObjectSpec
    g : Gaussians
        As read from ``spec.file`` (file units).

    Raises
    ------
    SceneError
        If there are no Gaussians, or if placed with ``spec.scale`` and ``spec.position`` a
        Gaussian's centre would lie beyond :data:`MAX_COORD` metres from the origin on some axis,
        or a Gaussian's largest scale would exceed :data:`MAX_COORD` metres; the message names the
        file, the value and the limit.
    """
    f = spec.file
    if g.n == 0:
        raise SceneError(f"{f}: the file has 0 Gaussians; nothing to simulate")
    x = g.means
    lo, hi = x.min(axis=0), x.max(axis=0)
    pos = max(abs(p) for p in spec.position)
    if spec.recentre:  # centred on position horizontally, bottom at position: within one extent of it
        reach = spec.scale * float(np.max(hi - lo)) + pos
    else:
        reach = spec.scale * float(np.max(np.maximum(np.abs(lo), np.abs(hi)))) + pos
    if not reach <= MAX_COORD:
        raise SceneError(f"{f}: placed with scale = {spec.scale:g} at position = {list(spec.position)}, the "
                         f"Gaussians reach {reach:.3g} m from the origin; expected at most {MAX_COORD:g} m "
                         "(engines compute in float32; check 'scale' and the file's units)")
    s_max = spec.scale * float(g.scales.max())
    if not s_max <= MAX_COORD:
        k = int(np.argmax(g.scales.max(axis=1)))
        raise SceneError(f"{f}: Gaussian {k} has a scale of {s_max:.3g} m after scale = {spec.scale:g}; "
                         f"expected at most {MAX_COORD:g} m")
