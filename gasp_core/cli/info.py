"""``gasp info``: the file's summary (:func:`gasp_core.gs.describe.describe`), a suggested ``scale`` for a
stated real size, and the solid a default scene would simulate: filled volume, and mass at a density."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
from scipy.special import expit

from gasp_core.errors import SceneError
from gasp_core.gs.describe import describe
from gasp_core.gs.registry import is_dynamic
from gasp_core.gs.splatv import MIDDLE_TIME
from gasp_core.maps.fill import fill_interior, fill_spacing
from gasp_core.prepare.assembly import build_setup
from gasp_core.prepare.placed import UP_ROTATIONS
from gasp_core.prepare.placement import prepare_object
from gasp_core.prepare.stand import stand_estimate
from gasp_core.scene.spec import ObjectSpec, parse_scene
from gasp_core.scene.tables import DomainSpec

def info(path: Path, size: float | None = None, rho: float | None = None, n_grid: int = DomainSpec.n_grid,
         up: str | None = None) -> dict:
    """:func:`describe`'s summary plus the extent along the up axis, a ``scale`` and the filled solid.

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
    up : str, optional
        The up axis, stated (``"+x"`` ... ``"-z"``): replaces the guess.

    Returns
    -------
    dict
        ``describe``'s keys, then ``height`` (file units, along the up axis), ``suggested_scale`` (with
        ``size``); when the up axis is unknown (unsure guess, none stated), no ``height`` but
        ``up_axis_candidates``: per axis ``"x" "y" "z"`` its ``height`` and (with ``size``) ``scale``, and the
        fill below is in the file's frame (``+z`` up, the scene default). Then ``filled_volume`` (m^3 at
        ``suggested_scale``, else in file units cubed), ``volume_unit``, ``fill_method``, ``fill_confidence``,
        ``fill_sealed``, ``fill_bbox_share``, ``n_floaters``, ``fill_warning`` and ``mass_kg`` (with ``rho``),
        with it also ``stand_E_crit_Pa`` (Pa: the Young's modulus the object needs to stand on a ground in
        ``gasp simulate``, :mod:`gasp_core.prepare.stand`, from the points and ``dx`` of a default scene at
        ``n_grid`` with it lying on a ground, the same as ``gasp simulate`` warns with; in file units unless a
        scale is known), ``stand_E_static_Pa`` (its buckling part, before the factor for gravity switched on at
        once) and ``stand_com_inside``.

    Raises
    ------
    FileNotFoundError, SceneError
        As :func:`gasp_core.gs.io.read_gaussians`.
    """
    d = describe(path)
    if d["count"] == 0:
        return d
    if up is not None:
        d.update(up_axis_guess=up, up_axis_confidence=1.0, up_axis_method="stated (--up)",
                 up_axis_note="stated: the figures below are along it")
    up, scale, known = _height_and_scale(d, size)
    spec = ObjectSpec(file=Path(path), up_axis=up, scale=scale,
                      dynamic_time=MIDDLE_TIME if is_dynamic(path) else None)
    o = prepare_object(spec)
    opaque = expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= spec.min_opacity
    ext = float(np.ptp(o.tri_rest.reshape(-1, 3), axis=0).max())
    if not ext > 0:
        raise SceneError(f"{path}: its {o.gaussians.n} Gaussian(s) span 0 units (all at one point, of zero size): "
                         "no solid to fill or simulate")
    dom = DomainSpec()
    h = fill_spacing(ext * (1 + 2 * dom.padding) / n_grid, dom.particles_per_cell)
    fr = fill_interior(o.tri_rest.reshape(-1, 3), h, splats=o.tri_rest[opaque], name=o.name,
                       unit="m" if known and size is not None else "file units")
    r = fr.report
    d.update({"filled_volume": fr.volume, "volume_unit": "m^3" if known and size is not None else "file units^3",
              "fill_method": r.method, "fill_confidence": r.confidence, "fill_sealed": r.sealed,
              "fill_bbox_share": round(r.bbox_share, 4), "fill_n_grid": n_grid, "n_floaters": o.n_floaters,
              "fill_warning": r.warning or "none"})
    if rho is not None:
        d["mass_kg"] = rho * fr.volume
        est = _stand(spec, rho, n_grid)
        if est is not None:   # the E it needs to stand on a ground (gasp_core.prepare.stand), as gasp simulate
            d["stand_E_crit_Pa"] = est.E_crit
            d["stand_E_static_Pa"] = est.E_static
            d["stand_com_inside"] = est.com_over_footprint
            if not known:
                d["stand_note"] = "standing along +z, the scene default (no up axis chosen: pass --up=AXIS)"
        for c in d.get("up_axis_candidates", {}).values():
            if "scale" in c:
                c["mass_kg"] = rho * fr.volume * c["scale"] ** 3
        if not known or size is None:
            d["mass_note"] = ("mass with 1 file unit = 1 m; pass --size for the real scale" if known else
                              "mass with 1 file unit = 1 m, standing along +z (the scene default): pass --up=AXIS "
                              "and --size for the real scale")
    return d


def _stand(spec: ObjectSpec, rho: float, n_grid: int):
    """The :class:`~gasp_core.prepare.stand.StandEstimate` ``gasp simulate`` judges the object by, standing on a
    ground at its lowest point in a default scene (quality ``default``, jelly of density ``rho``, the grid
    ``n_grid``): the same points and ``dx`` as :func:`gasp_core.prepare.assembly.build_setup` builds, so the same
    ``E``. None when the solid has fewer than 4 points with volume."""
    file = Path(spec.file).resolve()   # resolved once here: a relative path is not read against the scene's folder
    data = {"domain": {"n_grid": n_grid}, "boundary": [{"kind": "ground", "height": 0.0}],
            "object": [{"file": str(file), "up_axis": spec.up_axis, "scale": spec.scale,
                        "material": {"name": "jelly", "E": 1e5, "nu": 0.3, "rho": rho}}]}
    scene = parse_scene(data, file.parent / "gasp-info.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # the fill's own warnings are reported above, once
        s, _ = build_setup(scene, [prepare_object(o) for o in scene.objects])
    if (s.p_vol > 0).sum() < 4:
        return None
    g = np.asarray(s.gravity, dtype=np.float64)
    return stand_estimate(s.x, s.p_vol, rho, float(np.linalg.norm(g)), -g / np.linalg.norm(g), dx=s.dx)


def _height_and_scale(d: dict, size: float | None) -> tuple[str, float, bool]:
    """Adds ``height`` and ``suggested_scale`` along ``d``'s up axis, or ``up_axis_candidates`` when it is unknown
    (:func:`info`); returns the up axis the fill uses (``+z`` when unknown), the scale and whether it is known."""
    extent = np.asarray(d["bbox_max"]) - np.asarray(d["bbox_min"])
    scale, known = 1.0, d["up_axis_guess"] != "unknown"
    if known:
        up = d["up_axis_guess"]
        height = float(extent @ np.abs(UP_ROTATIONS[up][2]))
        d["height"] = height
        if size is not None:
            scale = size / height if height > 0 else 1.0
            d["suggested_scale"] = scale
            d["scale_note"] = f"scale = {scale:.6g} makes the {height:.4g}-unit height along {up} {size:g} m"
    else:
        up = "+z"
        d["up_axis_candidates"] = {a: {"height": float(h)} | ({"scale": size / float(h)} if size and h > 0 else {})
                                   for a, h in zip("xyz", extent)}
        if size is not None:
            d["scale_note"] = (f"no up axis chosen: the scale that makes the height {size:g} m along each axis is "
                               "under up_axis_candidates; pass --up=AXIS for the figures along one")
    return up, scale, known
