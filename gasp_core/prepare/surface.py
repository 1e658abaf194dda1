"""``surface = "auto"``: passive surface points where the object's fill can carry them, else material.

The rule (measured, ``docs/speed_accuracy.md``, "Quality levels"): passive surface points (massless,
advected by the grid, :mod:`gasp_core.seam.passive`) cost the model 0.3-0.6 % of the object size on the
README donut and guitar, where the interior fill is a solid that the grid resolves; they cannot work
where there is no fill to ride on. So an object's surface is passive when

* its fill is on and the footprints enclose a volume (``FillReport.method == "flood"``), and
* the filled solid spans at least :data:`MIN_SOLID_CELLS` grid cells (``volume / dx^3``), so the
  grid resolves the body the vertices follow;

otherwise every triangle vertex is simulated as material (the full model: open shells, footprint
shells with ``fill = false`` such as the kitchen's leaves, bodies a few cells across). The rule's
inputs and its verdict are recorded per object in ``run.json`` (``surface_rule``).
"""
from __future__ import annotations

from gasp_core.maps.fill import FillResult

#: the least solid, in grid cells, that passive surface points may ride on
MIN_SOLID_CELLS = 64


def surface_rule(fill_on: bool, n_vertices: int, fr: FillResult, dx: float) -> tuple[bool, dict]:
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

    Returns
    -------
    passive : bool
    record : dict
        ``surface`` (the choice), ``n_surface_points``, ``n_fill_points``, ``surface_per_fill``,
        ``solid_cells``, ``fill_method``, ``min_solid_cells``, ``rule`` (the rule in words).
    """
    n_fill = len(fr.fill_x)
    cells = float(fr.volume) / dx ** 3 if n_fill else 0.0
    passive = bool(fill_on and fr.report.method == "flood" and cells >= MIN_SOLID_CELLS)
    return passive, {
        "surface": "passive" if passive else "material", "n_surface_points": int(n_vertices),
        "n_fill_points": int(n_fill), "surface_per_fill": (n_vertices / n_fill) if n_fill else None,
        "solid_cells": round(cells, 1), "fill_method": fr.report.method, "min_solid_cells": MIN_SOLID_CELLS,
        "rule": "passive when the fill is on, the footprints enclose a volume and the solid spans at least "
                f"{MIN_SOLID_CELLS} grid cells; else material"}
