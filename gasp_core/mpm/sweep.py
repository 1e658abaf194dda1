"""Bench sweeps of the MPM engines (``EngineInfo.sweep``): grid, Courant number, particles per cell, fill, precision."""
from __future__ import annotations

import itertools
from typing import Iterable, Sequence

# --------------------------------------------------------------------------- gasp bench
def grid_sweep(n_grid: Sequence[int], cfl: Sequence[float], particles_per_cell: Sequence[int],
               fill: Sequence[bool], precision: Sequence[str], core_fraction: Sequence[float],
               reference_n_grid: int | None = None, surface: Sequence[str] = ("material",)) -> tuple[list[dict], dict]:
    """Settings of a grid-engine sweep for ``gasp bench``, and its reference (the finest).

    ``n_grid`` x ``cfl`` are crossed (f32 if offered, most particles per cell, fill on, all
    Gaussians simulated); the others vary one at a time around the largest ``n_grid`` and smallest
    ``cfl``; one more run takes the cheapest value of every setting.

    Parameters
    ----------
    n_grid, cfl, particles_per_cell, fill, precision, core_fraction : sequences
        Values to try (``precision``: those the engine offers).
    surface : sequence of str
        The objects' ``surface`` models to try ("material": every triangle vertex simulated, the
        reference; "passive": the filled solid simulated, the vertices carried). With only
        "material" the key is left out of the settings.
    reference_n_grid : int, optional
        A finer grid for the reference run alone; default: the largest ``n_grid``.

    Returns
    -------
    settings : list of dict
        Keys ``n_grid, cfl, particles_per_cell, fill, precision, core_fraction``; no duplicates
        and never the reference itself.
    reference : dict
        The finest setting: largest grid, smallest ``cfl``, most particles per cell, fill on,
        ``f64`` where offered, all Gaussians.
    """
    ng, cf = sorted(n_grid), sorted(cfl)
    ppc, prec = sorted(particles_per_cell), list(precision)
    cores = sorted(core_fraction)
    fills = sorted(set(fill), reverse=True)
    lo_prec = "f32" if "f32" in prec else prec[0]
    ref = {"n_grid": max(ng[-1], reference_n_grid or 0), "cfl": cf[0], "particles_per_cell": ppc[-1],
           "fill": fills[0], "precision": "f64" if "f64" in prec else prec[0], "core_fraction": cores[-1]}
    surfaces = [v for v in surface if v != "material"]
    if surfaces:
        ref["surface"] = "material"
    out = []
    base = {**ref, "n_grid": ng[-1], "precision": lo_prec}
    for g, c in itertools.product(ng, cf):
        out.append({**base, "n_grid": g, "cfl": c})
    for key, values in (("particles_per_cell", ppc), ("fill", fills), ("precision", prec),
                        ("core_fraction", cores), ("surface", surfaces)):
        for v in values:
            out.append({**base, key: v})
    out.append({"n_grid": ng[0], "cfl": cf[-1], "particles_per_cell": ppc[0], "fill": fills[-1],
                "precision": lo_prec, "core_fraction": cores[0], **({"surface": surfaces[-1]} if surfaces else {})})
    return dedupe_settings(out, ref), ref


#: ``gasp bench`` sweep of a grid engine (``docs/speed_accuracy.md``), full and ``--quick``.
MPM_SWEEP = {"n_grid": (32, 48, 64, 80, 96), "cfl": (0.2, 0.4, 0.8), "particles_per_cell": (1, 8),
             "fill": (True, False), "precision": ("f32", "f64"), "core_fraction": (1.0, 0.5, 0.2),
             "surface": ("material", "passive")}
MPM_SWEEP_QUICK = {**MPM_SWEEP, "n_grid": (32, 48), "cfl": (0.4, 0.8), "particles_per_cell": (8,),
                   "fill": (True,), "precision": ("f32",), "surface": ("material",)}


def mpm_sweep(quick: bool, precisions: Iterable[str] = ("f32", "f64")) -> tuple[list[dict], dict]:
    """The ``gasp bench`` sweep of a grid engine (:data:`MPM_SWEEP` or :data:`MPM_SWEEP_QUICK`).

    Parameters
    ----------
    quick : bool
        The small sweep (``n_grid`` 32/48, ``cfl`` 0.4/0.8, f32, 8 particles per cell, fill on).
    precisions : iterable of str
        The precisions the engine offers; the sweep's are cut to them.

    Returns
    -------
    settings, reference
        As :func:`grid_sweep`.
    """
    values = dict(MPM_SWEEP_QUICK if quick else MPM_SWEEP)
    offered = set(precisions)
    values["precision"] = tuple(p for p in values["precision"] if p in offered) or tuple(sorted(offered))[:1]
    return grid_sweep(**values)


def dedupe_settings(settings: Iterable[dict], reference: dict | None = None) -> list[dict]:
    """``settings`` without repeats, in order, and without ``reference``."""
    seen = {tuple(sorted(reference.items()))} if reference is not None else set()
    out = []
    for s in settings:
        key = tuple(sorted(s.items()))
        if key not in seen:
            seen.add(key)
            out.append(s)
    return out
