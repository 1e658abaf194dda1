"""``surface = "auto"``: passive surface points where the model difference dies out, else material.

The rule (measured, ``docs/speed_accuracy.md``, "Quality levels"): passive surface points (massless,
advected by the grid, :mod:`gasp_core.seam.passive`) cost 0.32 % of the object size on the sand guitar,
whose motion dies out, but 2.6 % by frame 12 on the bouncing (viscous) jelly donut, more than the full
model's own grid error there (1.8 %): an elastic body keeps the two models' different mass
distributions ringing. They also need a fill to ride on. So an object's surface is passive when

* its material is not an elastic solid (``jelly``, ``neo_hookean``: :data:`ELASTIC`), and
* its fill is on and the footprints enclose a volume (``FillReport.method == "six-ray"``), and
* the filled solid spans at least :data:`MIN_SOLID_CELLS` grid cells (``volume / dx^3``), so the
  grid resolves the body the vertices follow; a ``brittle`` body needs only some interior fill point (below):

otherwise every triangle vertex is simulated as material (the full model: elastic bodies, open
shells, footprint shells with ``fill = false`` such as the kitchen's leaves, bodies a few cells
across). The rule's inputs and its choice are recorded per object in ``run.json`` (``surface_rule``).

**A brittle body** with a closed fill takes the passive surface at every ``n_grid`` (issue 66, round 34): as
material, a body a few cells thick has its mass on its skin (the fill made with the faces' shares leaves no interior
point), and a brittle shell is broken through everywhere at a landing, its points drifting apart into a swelling
cloud that no count of pieces calls pieces (docs/fracture.md, "The brittle README donut from 1 m": the README donut
placed 1 m up in its default domain, n_grid 64, 45 cells of solid, 136 872 skin points, broken through everywhere and
filling 71 times the cells it filled at rest 10 frames after it lands; with its 351 fill points under a passive
skin: one cracked piece, 16 % of it broken through, 0.99 times the cells, 8-11 times less CPU, both engines alike).
"""
from __future__ import annotations

import dataclasses
import math

from gasp_core.maps.fill import FillResult

#: the least solid, in grid cells, that passive surface points may ride on
MIN_SOLID_CELLS = 64
#: elastic solids: a bounce keeps the surface model's difference alive, so they keep the full model
ELASTIC = ("jelly", "neo_hookean")


def surface_rule(fill_on: bool, n_vertices: int, fr: FillResult, dx: float,
                 material: str) -> tuple[bool, dict]:
    """Whether an ``auto`` object's surface is passive, and the rule's inputs for ``run.json``.

    Parameters
    ----------
    fill_on : bool
        The object's ``fill`` key.
    n_vertices : int
        Triangle vertices (the surface points).
    fr : FillResult
        The object's fill made for a passive surface (``surface_mass = False``).
    dx : float
        Grid spacing, metres.
    material : str
        The object's material name.

    Returns
    -------
    passive : bool
    record : dict
        ``surface`` (the choice), ``n_surface_points``, ``n_fill_points``, ``surface_per_fill``,
        ``solid_cells``, ``fill_method``, ``min_solid_cells``, ``material``, ``rule`` (the rule in words).
    """
    n_fill = len(fr.fill_x)
    cells = float(fr.volume) / dx ** 3 if n_fill else 0.0
    resolved = cells >= MIN_SOLID_CELLS or (material == "brittle" and n_fill > 0)
    passive = bool(material not in ELASTIC and fill_on and fr.report.method == "six-ray" and resolved)
    return passive, {
        "surface": "passive" if passive else "material", "n_surface_points": int(n_vertices),
        "n_fill_points": int(n_fill), "surface_per_fill": (n_vertices / n_fill) if n_fill else None,
        "solid_cells": round(cells, 1), "fill_method": fr.report.method, "min_solid_cells": MIN_SOLID_CELLS,
        "material": material,
        "rule": f"passive when the material is not elastic ({', '.join(ELASTIC)}), the fill is on, the footprints "
                f"enclose a volume and the solid spans at least {MIN_SOLID_CELLS} grid cells (a brittle body: any "
                f"interior fill point); else material"}


def choose_surface_points(spec):
    """``spec`` (an :class:`gasp_core.scene.spec.ObjectSpec`) with ``surface_points = "auto"`` resolved.

    ``"centres"`` (PhysGaussian's layout, :mod:`gasp_core.maps.centres`) where the trade's rule picks it: an
    elastic body (:data:`ELASTIC`) whose surface is simulated as material (``surface`` ``"material"``, or
    ``"auto"``, which keeps elastic bodies' surfaces material) or is passive (``draft``'s; issue 55: its three
    vertices per Gaussian made ``draft`` heavier than ``default``, 151,503 points against 65,036 on the README
    donut, 60,255 with the centres and 61 substeps a frame against 69), all of its Gaussians simulated
    (``core_fraction = 1``) and no ``mesh``. Measured on the README donut (12 frames, against the full vertex
    model at ``cfl = 0.4``): 0.33 U of shape, every event in its band, renders 33.3 dB from the reference's
    against the twin's 28.6, 1.5x less CPU. Elsewhere ``"vertices"``: on the passive surface of a material that is
    not elastic the centres give the same means and cost more (the sand guitar: 0.87x), and no other material was
    measured. Any other value is
    returned unchanged.
    """
    if spec.surface_points != "auto":
        return spec
    centres = (spec.mesh is None and not spec.static and spec.core_fraction == 1.0
               and spec.surface in ("auto", "material", "passive") and spec.material.name in ELASTIC)
    return dataclasses.replace(spec, surface_points="centres" if centres else "vertices")


def brittle_skin_warning(name: str, rule: dict | None, n_grid: int) -> str:
    """A warning (empty when none) for a ``brittle`` object whose closed fill spans fewer than
    :data:`MIN_SOLID_CELLS` grid cells (issue 66; docs/fracture.md, "The brittle README donut from 1 m").

    With interior fill points (:func:`surface_rule` makes its surface passive): the body is a few crack bands
    (``dx``) thick and breaks coarsely (the README donut placed 1 m up at n_grid 64, 45 cells: one cracked piece, 16 %
    of it broken through). With none (its surface simulated as material, the faces' shares putting all of its mass
    on its skin): a brittle shell is broken through everywhere at an impact and its points drift apart into a
    swelling cloud, not pieces (that donut before round 34: 71 times the cells it filled at rest).

    Parameters
    ----------
    name : str
        The object's name.
    rule : dict or None
        Its :func:`surface_rule` record (None: ``surface`` set by the scene, no rule applied).
    n_grid : int
        The scene's ``n_grid``; the warning names the one that gives :data:`MIN_SOLID_CELLS` cells (the solid's
        cells grow as ``n_grid^3``).
    """
    if (rule is None or rule["material"] != "brittle" or rule["fill_method"] != "six-ray"
            or not 0 < rule["solid_cells"] < MIN_SOLID_CELLS):
        return ""
    need = math.ceil(n_grid * (MIN_SOLID_CELLS / rule["solid_cells"]) ** (1.0 / 3.0))
    head = f"object '{name}': a brittle body of {rule['solid_cells']:g} grid cells of solid (under {MIN_SOLID_CELLS})"
    if rule["surface"] == "material":
        return (f"{head}, so its mass rides on its {rule['n_surface_points']} surface points: where it breaks "
                f"through, a brittle shell turns to a swelling cloud of points, not pieces (docs/fracture.md); "
                f"n_grid = {need} gives it {MIN_SOLID_CELLS} cells and an interior")
    return (f"{head}, {rule['n_fill_points']} fill points under a passive surface: it is a few crack bands (dx) "
            f"thick and breaks coarsely (docs/fracture.md); n_grid = {need} gives it {MIN_SOLID_CELLS} cells")
