"""The cost and the mass of the fill by shares against the fill by whole cells, in one run (issue 66 item 3).

The README donut (``examples/donut_jelly.toml``) is prepared as ``gasp simulate`` prepares it, and its object's fill
(:func:`gasp_core.maps.fill.fill_interior` with the scene's points, spacing and floor) is timed both ways, alternating,
``--rounds`` times each (the least CPU and wall time kept): **whole** cells, every cell whose centre ``phi`` puts
inside holding ``h^3`` (the default before issue 66; :func:`whole_cells` puts it in place of
:func:`gasp_core.maps.fill_shares.cell_fractions`), and **shares**, the default now. With ``--family`` the mass error
of each specimen of ``tests/test_fill_mass.py`` at ``n_grid`` 32, 48 and 64 is measured both ways too.

Writes ``benchmarks/results/fill_cost.json`` (or the path given with ``--out``): per fill, the CPU and wall seconds,
the volume (m^3), the mass at the scene's ``rho`` (kg), the points and the median ``p_vol^(1/3)`` (the contact's
stable step reads it, ``gasp_core.mpm.contact.contact_dt``), the cProfile of one share fill (the ten functions
of most own time) and the machine's load.

Run:  python benchmarks/fill_cost.py [--rounds 3] [--family] [--out path.json]
"""
from __future__ import annotations

import argparse
import cProfile
import io
import json
import os
import pstats
import sys
import time
from pathlib import Path

import numpy as np

import gasp_core.maps.fill as fill_mod
import gasp_core.maps.fill_shares as shares_mod
import gasp_core.prepare.assembly as assembly
from gasp_core.prepare.scene import prepare_scene
from gasp_core.scene.spec import load_scene

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "donut_jelly.toml"


def whole_cells(seed, deep, phi, vlo, voxel, splats, lo, h, floor=None):
    """The fill before issue 66: each cell whose centre ``phi`` puts inside (and not under ``floor``) is whole, its
    point at the centre (the same cells as ``np.argwhere(inside)`` in :func:`gasp_core.maps.fill.fill_interior`)."""
    inside = fill_mod._centre_masks(phi, vlo, voxel, lo, seed.shape, h, fill_mod.band(h, voxel))[0]
    inside = fill_mod._above(inside, lo, h, floor)[0]
    cells = np.argwhere(inside)
    return cells, np.ones(len(cells)), shares_mod.cell_centres(cells, lo, h)


def scene_fill_call(scene_path: Path = SCENE) -> tuple[dict, float]:
    """The arguments of the fill ``gasp simulate`` makes for the scene's first object, and its ``rho``."""
    calls = []
    original = assembly.fill_interior

    def record(points, h, **kw):
        calls.append({"points": points, "h": h, **{k: v for k, v in kw.items() if k != "check_points"}})
        return original(points, h, **kw)
    assembly.fill_interior = record
    try:
        scene = load_scene(scene_path)
        prepare_scene(scene)
    finally:
        assembly.fill_interior = original
    return calls[-1], float(scene.objects[0].material.rho)


def timed_fill(call: dict, way: str) -> tuple[float, float, object]:
    """CPU and wall seconds of one fill ``way`` (``"whole"`` or ``"shares"``) and its result."""
    saved = shares_mod.cell_fractions
    if way == "whole":
        shares_mod.cell_fractions = whole_cells
    try:
        args = dict(call)
        points, h = args.pop("points"), args.pop("h")
        c0, w0 = time.process_time(), time.perf_counter()
        fr = fill_mod.fill_interior(points, h, **args)
        return time.process_time() - c0, time.perf_counter() - w0, fr
    finally:
        shares_mod.cell_fractions = saved


def profile_of(call: dict, top: int = 10) -> list[str]:
    """The ``top`` functions of most own time in one share fill (cProfile lines)."""
    prof = cProfile.Profile()
    prof.enable()
    timed_fill(call, "shares")
    prof.disable()
    out = io.StringIO()
    pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(top)
    return [line.rstrip() for line in out.getvalue().splitlines() if line.strip()][-top - 1:]


def donut(rounds: int) -> dict:
    """Both fills of the README donut, alternating, ``rounds`` times each."""
    call, rho = scene_fill_call()
    timed_fill(call, "shares")             # imports and first-touch out of the timings
    runs = {"whole": [], "shares": []}
    for _ in range(rounds):
        for way in runs:
            runs[way].append(timed_fill(call, way))
    rec = {"scene": str(SCENE.relative_to(ROOT)), "h_m": float(call["h"]), "rho": rho, "rounds": rounds}
    for way, got in runs.items():
        fr = got[-1][2]
        vols = np.concatenate([fr.p_vol_surface, fr.p_vol_fill])
        rec[way] = {"cpu_s": round(min(g[0] for g in got), 3), "wall_s": round(min(g[1] for g in got), 3),
                    "volume_m3": fr.volume, "mass_kg": round(rho * fr.volume, 4), "points": int(len(vols)),
                    "fill_points": int(len(fr.fill_x)), "median_h_mm": round(float(np.median(np.cbrt(vols))) * 1e3, 4)}
    rec["cpu_ratio"] = round(rec["shares"]["cpu_s"] / rec["whole"]["cpu_s"], 2)
    rec["mass_change"] = round(rec["shares"]["volume_m3"] / rec["whole"]["volume_m3"] - 1.0, 4)
    rec["profile_shares"] = profile_of(call)
    return rec


def family() -> list[dict]:
    """The mass error, centre offset and farthest point outside (``tests/test_fill_mass.py``'s ``measure``) of each
    specimen at n_grid 32, 48 and 64, both ways."""
    sys.path.insert(0, str(ROOT / "tests"))
    import test_fill_mass as fm
    rows = []
    for name in fm.SPECIMENS:
        for n_grid in (32, 48, 64):
            row = {"specimen": name, "n_grid": n_grid}
            for way in ("whole", "shares"):
                saved = shares_mod.cell_fractions
                shares_mod.cell_fractions = whole_cells if way == "whole" else saved
                try:
                    err, off, out, h = fm.measure(name, n_grid)
                finally:
                    shares_mod.cell_fractions = saved
                row[way] = {"mass_error": round(float(err), 5), "centre_h": round(off, 3), "outside_h": round(out, 3)}
            row["h_mm"] = round(h * 1e3, 3)
            rows.append(row)
            print(f"{name:32s} n_grid {n_grid}: whole {row['whole']['mass_error']:+.2%}, "
                  f"shares {row['shares']['mass_error']:+.2%}", flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--family", action="store_true", help="also the mass family of tests/test_fill_mass.py")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "fill_cost.json")
    a = ap.parse_args(argv)
    rec = {"load_before": os.getloadavg()[0], "donut": donut(a.rounds)}
    d = rec["donut"]
    print(f"README donut fill: whole {d['whole']['cpu_s']} s CPU ({d['whole']['wall_s']} s wall), shares "
          f"{d['shares']['cpu_s']} s ({d['shares']['wall_s']} s): {d['cpu_ratio']}x; mass {d['whole']['mass_kg']} -> "
          f"{d['shares']['mass_kg']} kg ({d['mass_change']:+.1%})", flush=True)
    if a.family:
        rows = family()
        rec["family"] = rows
        rec["family_worst"] = {way: max(abs(r[way]["mass_error"]) for r in rows) for way in ("whole", "shares")}
        print("worst mass error:", rec["family_worst"])
    rec["load_after"] = os.getloadavg()[0]
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(json.dumps(rec, indent=1) + "\n")
    print("wrote", a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
