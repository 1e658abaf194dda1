"""Mesh mode against the full-vertex run on the real donut (issue 31): the same scene, once with every Gaussian's
three triangle vertices simulated (``examples/donut_jelly.toml``) and once with the Gaussians bound to a mesh of
8,992 vertices (``examples/donut_mesh.toml``, the mesh from ``examples/make_donut_mesh.py``), on one engine,
one after the other in one process.

Figures: per frame, the distance between each Gaussian's mean in the two runs, as a share of the object's
size (largest side of the frame-0 means' bounding box): median, 99th percentile and maximum over all
Gaussians and over the bound ones (those not left static as far from the mesh); the centroids' gap; points
simulated; process CPU time (user + sys, all threads) and wall time of each run (prepare + frames).

Usage::

    python benchmarks/bench_mesh_mode.py                       # taichi_mpm, 12 frames
    python benchmarks/bench_mesh_mode.py --engine warp_mpm --frames 12

Writes ``benchmarks/results/bench_mesh_mode.json`` and ``.md`` (``bench_mesh_mode_passive.*`` with ``--surface passive``, ``bench_mesh_mode_passive_same_solid.*`` with
``--same-solid`` too: the mesh run then takes the full run's domain and fill points, so the material is the same and
the figures measure the binding alone).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import time
import warnings
from pathlib import Path

import numpy as np

from gasp_core.prepare.scene import prepare_scene
from gasp_core.run.frames import iter_frames
from gasp_core.scene.spec import load_scene

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


def prepare(path: Path, engine: str, surface: str | None = None):
    """The prepared scene (``surface`` replacing the objects'), its CPU and wall time and its warnings."""
    scene = load_scene(path)
    if surface is not None:
        scene.objects = [dataclasses.replace(o, surface=surface) for o in scene.objects]
    c0, w0 = time.process_time(), time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        prep = prepare_scene(scene, engine)
    return prep, {"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0,
                  "warnings": [str(w.message) for w in caught]}


def same_solid(mesh, full) -> None:
    """Give the mesh run the full run's solid: its domain and fill points (passive surfaces in both, so the fill
    alone is the material and the two runs' material points move the same; only the surface differs)."""
    ms, fs = mesh.setup, full.setup
    nv, fill = ms.n_render, slice(fs.n_render, len(fs.x))
    ms.x = np.concatenate([ms.x[:nv], fs.x[fill]])
    ms.v = np.concatenate([ms.v[:nv], fs.v[fill]])
    ms.p_vol = np.concatenate([ms.p_vol[:nv], fs.p_vol[fill]])
    ms.body_id = np.concatenate([ms.body_id[:nv], fs.body_id[fill]])
    ms.passive = np.concatenate([np.ones(nv, bool), np.zeros(len(fs.x) - fs.n_render, bool)])
    ms.domain_lo, ms.domain_hi = fs.domain_lo.copy(), fs.domain_hi.copy()
    mesh.objects[0] = dataclasses.replace(mesh.objects[0], fill_slice=slice(nv, len(ms.x)))


def run(prep, timing: dict, n_frames: int) -> dict:
    """Means of every frame (file frame), points, CPU and wall time of one run (prepare + frames)."""
    c0, w0 = time.process_time(), time.perf_counter()
    means = [gs[0].means.copy() for _, gs, _ in iter_frames(prep, n_frames)]
    o = prep.objects[0]
    return {"means": np.stack(means), "cpu_s": timing["cpu_s"] + time.process_time() - c0,
            "wall_s": timing["wall_s"] + time.perf_counter() - w0, "warnings": timing["warnings"],
            "n_points": int(len(prep.setup.x)), "n_surface_points": int(prep.setup.n_render),
            "n_fill": int(o.fill_slice.stop - o.fill_slice.start),
            "bound": None if o.moving is None else o.moving,
            "distance": None if o.surface.form != "mesh" else o.surface.binding.distance, "mesh": None if o.surface.form != "mesh" else
            {k: v for k, v in o.surface.binding.report.items() if k != "far_rows"},
            "domain": [prep.setup.domain_lo.tolist(), prep.setup.domain_hi.tolist()]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--surface", choices=("material", "passive"), default=None,
                    help="replace the objects' surface (default: the scenes' own, 'auto' -> material for jelly); "
                         "'passive': the same fill is the solid in both runs, only the surface differs")
    ap.add_argument("--same-solid", action="store_true",
                    help="with --surface passive: the mesh run takes the full run's domain and fill points")
    args = ap.parse_args()
    if args.same_solid and args.surface != "passive":
        ap.error("--same-solid needs --surface passive")
    mesh_prep = prepare(ROOT / "examples" / "donut_mesh.toml", args.engine, args.surface)
    full_prep = prepare(ROOT / "examples" / "donut_jelly.toml", args.engine, args.surface)
    if args.same_solid:
        same_solid(mesh_prep[0], full_prep[0])
    mesh = run(*mesh_prep, args.frames)
    full = run(*full_prep, args.frames)
    stem = "bench_mesh_mode" + (f"_{args.surface}" if args.surface else "") + ("_same_solid" if args.same_solid else "")
    size = float(np.ptp(full["means"][0], axis=0).max())
    d = np.linalg.norm(mesh["means"] - full["means"], axis=2) / size          # (frames + 1, n)
    bound = np.arange(d.shape[1]) if mesh["bound"] is None else mesh["bound"]
    deep = mesh["distance"] > 0.02 * size            # bound Gaussians more than 2 % of the size from their face
    rows = []
    for k in range(1, args.frames + 1):
        rows.append({"frame": k, "median": float(np.median(d[k])), "p99": float(np.percentile(d[k], 99)),
                     "max": float(d[k].max()), "bound_p99": float(np.percentile(d[k, bound], 99)),
                     "bound_max": float(d[k, bound].max()), "over_1pct": float(np.mean(d[k, bound] > 0.01)),
                     "deep_p99": float(np.percentile(d[k, bound[deep]], 99)) if deep.any() else 0.0,
                     "centroid": float(np.linalg.norm(mesh["means"][k].mean(0) - full["means"][k].mean(0)) / size),
                     "fall_full": float(full["means"][0][:, 2].mean() - full["means"][k][:, 2].mean()) / size})
    out = {"engine": args.engine, "frames": args.frames, "surface": args.surface or "scene's own (auto)",
           "same_solid": args.same_solid, "size_m": size, "host": platform.node(),
           "cpus": os.cpu_count(), "note": "CPU = process user+sys (all threads); the machine was shared (loaded)",
           **{f"{name}_{key}": r[key] for name, r in (("mesh", mesh), ("full", full))
              for key in ("cpu_s", "wall_s", "n_points", "n_surface_points", "n_fill", "warnings")},
           "mesh": mesh["mesh"], **{f"{name}_domain": r["domain"] for name, r in (("mesh", mesh), ("full", full))}, "cpu_ratio_full_over_mesh": full["cpu_s"] / mesh["cpu_s"], "per_frame": rows}
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{stem}.json").write_text(json.dumps(out, indent=1))
    lines = [f"# Mesh mode vs full-vertex run: real donut, {args.engine}, {args.frames} frames, surface "
             f"{out['surface']}" + (", the full run's solid in both" if args.same_solid else ""), "",
             f"Object size {size:.4f} m. Points simulated: mesh {mesh['n_points']} ({mesh['n_surface_points']} mesh "
             f"vertices + {mesh['n_fill']} fill), full {full['n_points']} ({full['n_surface_points']} triangle vertices "
             f"+ {full['n_fill']} fill).", "",
             f"Time (prepare + frames, one process, loaded machine): mesh {mesh['cpu_s']:.1f} s CPU / "
             f"{mesh['wall_s']:.1f} s wall; full {full['cpu_s']:.1f} s CPU / {full['wall_s']:.1f} s wall; CPU ratio "
             f"full/mesh {out['cpu_ratio_full_over_mesh']:.2f}.", "",
             "Distance between the two runs' means, share of the object size:", "",
             f"(bound: the {len(bound)} Gaussians bound to the mesh; deep: the {int(deep.sum())} of them farther than 2 % "
             "of the size from their face, the donut's interior; over 1 %: share of the bound ones beyond 1 % of the size)",
             "", "| frame | median | p99 | max | bound p99 | bound max | over 1 % | deep p99 | centroid gap | fall (full) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['frame']} | {r['median']:.4f} | {r['p99']:.4f} | {r['max']:.4f} | {r['bound_p99']:.4f} | "
              f"{r['bound_max']:.4f} | {r['over_1pct']:.4f} | {r['deep_p99']:.4f} | {r['centroid']:.4f} | "
              f"{r['fall_full']:.4f} |" for r in rows]
    (RESULTS / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
