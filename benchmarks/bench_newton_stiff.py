"""Newton's implicit MPM against taichi_mpm on a stiff body, where explicit substeps grow with sqrt(E).

The README donut cut to every ``--every``-th Gaussian, as jelly with ``E = --E`` (default 1e7 Pa, 500x the
README's) and no viscosity, dropped 5 cm onto the ground, ``n_grid`` ``--n-grid``, ``--frames`` frames. Runs,
one ``gasp simulate`` process each, one after another: taichi_mpm (one thread) on ``n_grid`` and on its twin
``3/4 n_grid`` (U), and newton (its defaults: automatic implicit steps, 250 iterations). Figures: the process's
CPU seconds and wall, steps per frame, and newton's split error against taichi_mpm
(:func:`gasp_studies.trade.accuracy_report`: centroid, rotation, shape, events, each also in U of the
taichi_mpm run's twin).

Run: ``python benchmarks/bench_newton_stiff.py --frames 8`` (writes ``benchmarks/results/newton_stiff.{json,md}``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
import tomli_w

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_trade import SCENES, run_variant  # noqa: E402

from gasp_studies.accuracy import track_from_run_dir  # noqa: E402
from gasp_studies.trade import accuracy_report  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"


def stiff_scene(work: Path, every: int, E: float, n_grid: int, frames: int, engine: str) -> Path:
    """The donut cut to every ``every``-th Gaussian, jelly ``E``, no viscosity, on ``engine``."""
    from gasp_core.gs.io import read_gaussians, write_gaussians
    src = SCENES["donut"]
    doc = tomllib.loads(src.read_text())
    ply = work / "donut_cut.ply"
    if not ply.exists():
        g = read_gaussians(src.parent / doc["object"][0]["file"])
        write_gaussians(ply, g.subset(np.arange(0, g.n, every)))
    doc["n_frames"] = frames
    doc["engine"] = {"name": engine, "options": {"threads": 1} if engine == "taichi_mpm" else {}}
    doc["domain"]["n_grid"] = n_grid
    o = doc["object"][0]
    o["file"] = str(ply)
    o["material"]["E"] = E
    o["material"].pop("viscosity", None)
    path = work / f"{engine}_{n_grid}.toml"
    path.write_text(tomli_w.dumps(doc))
    return path


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--every", type=int, default=4)
    ap.add_argument("--E", type=float, default=1e7)
    ap.add_argument("--n-grid", type=int, default=32)
    args = ap.parse_args(argv)
    twin_grid = int(round(0.75 * args.n_grid))
    runs = {"taichi_mpm": ("taichi_mpm", args.n_grid), "taichi_mpm_twin": ("taichi_mpm", twin_grid),
            "newton": ("newton", args.n_grid)}
    rec, tracks = {}, {}
    with tempfile.TemporaryDirectory(prefix="gasp_stiff_") as tmp:
        work = Path(tmp)
        for name, (engine, n) in runs.items():
            print(f"[newton_stiff] {name} (n_grid {n}) ...", flush=True)
            r = run_variant(stiff_scene(work, args.every, args.E, n, args.frames, engine), work / name, 7200.0)
            r["load_avg_1min"] = os.getloadavg()[0]
            rec[name] = r
            print(f"[newton_stiff]   {json.dumps({k: v for k, v in r.items() if k != 'domain'})[:400]}", flush=True)
            if r["returncode"] == 0:
                tracks[name] = track_from_run_dir(work / name, name)
    report = None
    if {"taichi_mpm", "newton"} <= set(tracks):
        report = accuracy_report(tracks["newton"], tracks["taichi_mpm"], tracks.get("taichi_mpm_twin"))
    doc = {"args": vars(args), "runs": rec, "newton_vs_taichi": report,
           "speedup_cpu": (rec["taichi_mpm"].get("process_cpu_s", np.nan) / rec["newton"].get("process_cpu_s", np.nan)
                           if rec["newton"]["returncode"] == 0 else None)}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "newton_stiff.json").write_text(json.dumps(doc, indent=1, default=float))
    lines = [f"# Newton vs taichi_mpm on a stiff body (benchmarks/bench_newton_stiff.py)", "",
             f"`python benchmarks/bench_newton_stiff.py --frames {args.frames} --every {args.every} --E {args.E:g} "
             f"--n-grid {args.n_grid}`", "", "| run | n_grid | points | steps/frame | CPU s | wall s |",
             "|---|---:|---:|---:|---:|---:|"]
    for name, r in rec.items():
        lines.append(f"| {name} | {runs[name][1]} | {r.get('n_points', '-')} | {r.get('n_substeps', '-')} | "
                     f"{r.get('process_cpu_s', float('nan')):.1f} | {r.get('process_wall_s', float('nan')):.1f} |"
                     if r["returncode"] == 0 else f"| {name} | failed: {r.get('stderr', '')[-200:]!r} | | | | |")
    if report:
        f = next(iter(report["objects"].values()))
        lines += ["", f"Speed-up of newton over taichi_mpm, CPU: {doc['speedup_cpu']:.2f}x. newton against taichi_mpm "
                  f"(worst frames, / size): position {100 * f['worst']['position']:.2f} %, centroid "
                  f"{100 * f['worst']['centroid']:.2f} %, rotation {f['worst']['rotation_deg']:.2f} deg, shape "
                  f"{100 * f['worst']['shape']:.2f} % ({f.get('in_u', {}).get('shape', float('nan')):.2f} U of the "
                  f"taichi_mpm run's n_grid {twin_grid} twin); restitution {f['events_run']['restitution']:.3f} vs "
                  f"{f['events_ref']['restitution']:.3f}; first impact {1e3 * f['events_run']['impact_s']:.0f} vs "
                  f"{1e3 * f['events_ref']['impact_s']:.0f} ms."]
    (RESULTS / "newton_stiff.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
