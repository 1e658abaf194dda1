"""The flowing body's touch at its surface (round 75, issue 67; ``docs/contact.md`` "Round 75: the flowing body's touch
at its surface").

``gasp_core.mpm.fields.flow_touch`` marks a node where a point of a flowing body (field A) has field B's gathered
volume fraction at or above ``flow_touch_level``: before round 75 one level for every point, ``FLOW_TOUCH_DELTA`` cells
off B's surface. A flowing body's points are its fill, and its Gaussians lie half a point spacing further out, so the
sand's own surface ended 0.38-0.55 dx inside a jelly ball. :func:`flow_levels` gives each body its own level, its
points' reach (half their spacing, :func:`flow_spacing`) added to ``FLOW_TOUCH_DELTA``; each MPM plugin's touch
kernel reads it per body.
"""
from __future__ import annotations

import numpy as np

from .fields_reference import FLOW_TOUCH_DELTA, flow_touch_level

#: The flowing body's touch at its surface (round 75, ``docs/contact.md`` "Round 75: the flowing body's touch at its
#: surface"): a point of a flowing body marks where it lies within ``FLOW_TOUCH_DELTA`` cells of B's surface PLUS half
#: its body's point spacing (:func:`flow_levels`), so the body's surface, not its points' centres, stops
#: ``FLOW_TOUCH_DELTA`` off B's (the rule :mod:`gasp_core.mpm.gap_touch` gives two solids). False: every flowing point
#: at ``FLOW_TOUCH_DELTA`` (the rule of rounds 37-74, the catch): the fill held 0.04 dx outside a ball's Gaussians left
#: the sand's own Gaussians, half a fill spacing further out, 0.38-0.55 dx inside it (issue 67's must-show).
FLOW_REACH = True
#: The flowing body's reach is at most this many cells (:func:`flow_levels`): a point's stencil reaches 1.5.
FLOW_REACH_MAX = 1.0

def flow_spacing(setup) -> np.ndarray:
    """Per body (shape (n_materials,), metres) its material points' spacing: the 90th percentile of its points'
    ``p_vol ** (1/3)`` over those with volume (a fill lattice's spacing where most points are whole cells; a body's
    massless surface points, a flowing body's Gaussians, and its cut boundary cells left out, one outsized point
    ignored); 0 for a body without volume."""
    n_mat = getattr(setup, "n_material", None)
    n = len(setup.x) if n_mat is None else int(n_mat)
    vol = np.broadcast_to(np.asarray(setup.p_vol, float), (len(setup.x),))[:n]
    body = np.asarray(setup.body_id)[:n]
    out = np.zeros(len(setup.materials))
    for b in range(len(setup.materials)):
        v = vol[(body == b) & (vol > 0)]
        if len(v):
            out[b] = float(np.percentile(v, 90)) ** (1.0 / 3.0)
    return out


def flow_levels(setup) -> np.ndarray:
    """The flowing body's touch level per body (shape (n_materials,), float64, a volume fraction of a cell, what the
    engines' ``flow_mark`` compares field B's gathered volume fraction at a point of field A with): with
    :data:`FLOW_REACH` :func:`flow_touch_level` at ``FLOW_TOUCH_DELTA + 0.5 s_b / dx`` cells (``s_b``
    :func:`flow_spacing`, at most :data:`FLOW_REACH_MAX` cells; the point's own surface ``FLOW_TOUCH_DELTA`` off B's,
    the reach of :func:`gasp_core.mpm.gap_touch.body_delta`), else ``flow_touch_level()`` for every body (the rule
    before). Bodies of field B get the same formula; the engines read A's only."""
    if not FLOW_REACH:
        return np.full(len(setup.materials), flow_touch_level())
    reach = FLOW_TOUCH_DELTA + 0.5 * flow_spacing(setup) / float(setup.dx)
    reach = np.round(np.clip(reach, FLOW_TOUCH_DELTA, FLOW_REACH_MAX), 3)
    return np.array([flow_touch_level(float(r)) for r in reach], np.float64)
