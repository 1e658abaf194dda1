"""``gasp info``: the file's summary (:func:`gasp_core.gs.describe.describe`), a suggested ``scale`` for a
stated real size, and the solid a default scene would simulate: filled volume, and mass at a density."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.special import expit

from gasp_core.gs.describe import describe
from gasp_core.maps.fill import fill_interior, fill_spacing
from gasp_core.prepare.placement import UP_ROTATIONS, prepare_object
from gasp_core.scene.spec import ObjectSpec
from gasp_core.scene.tables import DomainSpec

def info(path: Path, size: float | None = None, rho: float | None = None, n_grid: int = DomainSpec.n_grid) -> dict:
    """:func:`describe`'s summary plus the extent along the guessed up axis, a ``scale`` and the filled solid.

    Parameters
    ----------
    path : Path
        A Gaussian Splatting file (``.splatv`` at model time 0.5).
    size : float, optional
        The object's real height along the up axis (metres); gives ``suggested_scale``.
    rho : float, optional
        Density, kg/m^3; gives ``mass_kg``.
    n_grid : int
        Grid of the default scene whose fill is reported (padding and particles per cell: the defaults).

    Returns
    -------
    dict
        ``describe``'s keys, then ``height`` (file units, along the up axis; ``+z`` when unknown),
        ``suggested_scale`` (with ``size``), ``filled_volume`` (m^3 at ``suggested_scale``, else in file
        units cubed), ``volume_unit``, ``fill_method``, ``fill_confidence``, ``fill_sealed``,
        ``fill_bbox_share``, ``n_floaters``, ``fill_warning`` and ``mass_kg`` (with ``rho``).

    Raises
    ------
    FileNotFoundError, SceneError
        As :func:`gasp_core.gs.io.read_gaussians`.
    """
    d = describe(path)
    if d["count"] == 0:
        return d
    up = d["up_axis_guess"] if d["up_axis_guess"] != "unknown" else "+z"
    height = float((np.asarray(d["bbox_max"]) - np.asarray(d["bbox_min"])) @ np.abs(UP_ROTATIONS[up][2]))
    d["height"] = height
    scale = 1.0
    if size is not None:
        scale = size / height if height > 0 else 1.0
        d["suggested_scale"] = scale
        d["scale_note"] = f"scale = {scale:.6g} makes the {height:.4g}-unit height along {up} {size:g} m"
    spec = ObjectSpec(file=Path(path), up_axis=up, scale=scale,
                      dynamic_time=0.5 if Path(path).suffix.lower() == ".splatv" else None)
    o = prepare_object(spec)
    opaque = expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= spec.min_opacity
    ext = float(np.ptp(o.tri_rest.reshape(-1, 3), axis=0).max())
    dom = DomainSpec()
    h = fill_spacing(ext * (1 + 2 * dom.padding) / n_grid, dom.particles_per_cell)
    fr = fill_interior(o.tri_rest.reshape(-1, 3), h, splats=o.tri_rest[opaque], name=o.name,
                       unit="m" if size is not None else "file units")
    r = fr.report
    d.update({"filled_volume": fr.volume, "volume_unit": "m^3" if size is not None else "file units^3",
              "fill_method": r.method, "fill_confidence": r.confidence, "fill_sealed": r.sealed,
              "fill_bbox_share": round(r.bbox_share, 4), "fill_n_grid": n_grid, "n_floaters": o.n_floaters,
              "fill_warning": r.warning or "none"})
    if rho is not None:
        d["mass_kg"] = rho * fr.volume
        if size is None:
            d["mass_note"] = "mass with 1 file unit = 1 m; pass --size for the real scale"
    return d
