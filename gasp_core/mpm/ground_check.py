"""The grid engines' own check of a scene (their ``EngineInfo.check_scene``): an explicit domain must hold the
particle contact's ground node layers (issue 38; moved here from the core by issue 51, since only these engines
have that contact)."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.mpm.contact import contact_model, ground_node_layer
from gasp_core.mpm.rigid import step_view


#: Cells a scene's ``[domain] lo`` z must lie below a ground for the particle contact: its ground node layers
#: (``GRID_LAYERS_BELOW`` = 2 cells below the plane) and the resting points' stencil inside the grid (the
#: default domain's ``STENCIL_CELLS``, :func:`gasp_core.prepare.assembly.default_domain`).
GROUND_CELLS_BELOW = 3


def check_ground_in_grid(scene, options, setup=None) -> None:
    """Refuse an explicit ``[domain]`` whose floor lies so close under a ground (or at it) that the particle
    contact's ground node layers (:func:`gasp_core.mpm.contact.ground_node_layer`, two cells below the
    plane) fall outside the grid: a body then rests with its points' stencil below the grid and the run
    diverges (issue 38: ``lo`` z at the ground's height left the domain at frame 3). Decided on the scene alone
    (the domain, the objects' materials and the engine options), before any file is read; for the grid engines.

    Parameters
    ----------
    scene : Scene
    options : dict
        The engine options the run takes (``contact``; :func:`gasp_core.mpm.contact.contact_model`).
    setup : SimSetup, optional
        Once built and its bodies' models chosen: checked again only where a body is rigid, with the materials as
        the contact rule sees them (issue 40: a rigid body shows ``E = 1 Pa``,
        :func:`gasp_core.mpm.rigid.step_view`); None: the scene's materials. The engines' ``check_scene``
        (:class:`gasp_core.seam.engine.EngineInfo`).

    Raises
    ------
    SceneError
        In one line: the file, the ground's height, ``[domain] lo`` z, ``dx`` (m) and the lowest ``lo`` z that
        works (``GROUND_CELLS_BELOW`` cells below the ground at the ``dx`` that ``lo`` then gives), or
        ``contact = "grid"``.
    """
    dom = scene.domain
    grounds = [float(b.height) for b in scene.boundaries if b.kind == "ground"]
    if dom.lo is None or not grounds:
        return
    if setup is not None and not any(m.model == "rigid" for m in setup.materials):
        return                                   # the scene's own materials were checked before the files were read
    materials = ([o.material for o in scene.objects if not o.static] if setup is None
                 else list(step_view(setup).materials))
    if not materials or contact_model(SimpleNamespace(options=options, materials=materials)) not in ("particle",
                                                                                                "mixed"):
        return
    lo, hi, n = np.asarray(dom.lo, float), np.asarray(dom.hi, float), int(dom.n_grid)
    dx = float(np.max(hi - lo)) / n
    for h in grounds:
        if h < lo[2] or h >= hi[2] or ground_node_layer("particle", h, lo[2], dx) >= 0:
            continue
        side = float(np.max(hi[:2] - lo[:2]))           # lowering lo z lengthens z, which may then set dx
        want = h - GROUND_CELLS_BELOW * side / n
        if hi[2] - want > side:
            want = (h - GROUND_CELLS_BELOW * hi[2] / n) / (1.0 - GROUND_CELLS_BELOW / n)
        want = math.floor(want * 1e4) / 1e4
        raise SceneError(
            f"{scene.path}: the ground at height {h:g} m lies {(h - lo[2]) / dx:.2g} cells above [domain] lo z = "
            f"{lo[2]:g} m (dx = {dx:.3g} m): the particle contact's ground node layers start 2 cells below the "
            f"plane (docs/contact.md), outside the grid; set [domain] lo z to at most {want:g} m "
            f"({GROUND_CELLS_BELOW} cells below the ground), or the engine option contact = \"grid\"")
