"""Passive surface points vs full vertices vs the hierarchy, end to end, on the real scenes.

For the README donut (``examples/donut_jelly.toml``) and the guitar (``examples/guitar_sand.toml``)
each variant runs the scene's engine for its frames: ``prepare_s`` (read, place, flatten, hierarchy,
fill), ``build_s`` (engine build, kernel compilation) and the frames (``step_frame`` and read-back),
the same figures as ``run.json``; writing PLY files is left out (the same for every variant). The
variants:

- ``full``: every triangle vertex a material point (today's default, ``surface = "material"``);
- ``passive``: vertices massless and carried (``surface = "passive"``), the fill the whole solid;
  a grid engine moves them itself (feature ``passive_points``: G2P every substep);
- ``passive-embed``: the same setup, but the engine's ``passive_points`` feature is masked so the core
  moves the passive points with its MLS embedding in the material points (once per frame);
- ``core=f``: the hierarchy at ``core_fraction = f`` (material surface);
- ``passive+core=f``: both.

Accuracy: the Gaussians' means (``T^-1`` of the moved triangles, :func:`gasp_core.run.frames.rebuild`)
of every frame against a reference run, as a share of the object's size (the diagonal of the
bounding box of the reference's frame-0 means, as in ``docs/speed_accuracy.md``): the mean over
Gaussians, the 99th percentile and the max, the worst frame, and the per-frame mean.
The reference is the ``full`` run unless ``--reference-grid`` gives a finer grid. The runs are
sequential in one process (the machine is shared: each row records the load average), so the
ratios of one run compare like with like.

Usage::

    python benchmarks/bench_passive.py                        # donut and guitar
    python benchmarks/bench_passive.py --scenes donut --frames 12 --variants full,passive

Writes ``benchmarks/results/bench_passive.json`` and ``benchmarks/results/bench_passive.md``.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import platform
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
SCENES = {"donut": ROOT / "examples" / "donut_jelly.toml", "guitar": ROOT / "examples" / "guitar_sand.toml"}


def variant_scene(scene, variant: str, n_grid: int | None):
    """The scene with ``surface`` / ``core_fraction`` / ``n_grid`` set for ``variant``."""
    surface = "passive" if variant.startswith("passive") else "material"
    core = 1.0
    for part in variant.split("+"):
        if part.startswith("core="):
            core = float(part[5:])
    objs = [dataclasses.replace(o, surface=surface, core_fraction=core) for o in scene.objects]
    dom = scene.domain if n_grid is None else dataclasses.replace(scene.domain, n_grid=n_grid)
    return dataclasses.replace(scene, objects=objs, domain=dom)


def run_variant(scene, n_frames: int, threads: int | None, embed: bool = False) -> dict:
    """Prepare, build and step; the means of every frame per object and the timings."""
    from gasp_core.run.frames import rebuild
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.seam.runner import RunStats, run_engine

    load0 = os.getloadavg()
    t0 = time.perf_counter()
    prep = prepare_scene(scene)
    if embed:    # the core's embedding instead of the engine's own passive G2P
        caps = prep.info.capabilities
        prep.info = dataclasses.replace(prep.info, capabilities=dataclasses.replace(
            caps, features=caps.features - {"passive_points"}))
    if threads is not None and any(o.name == "threads" for o in prep.info.options):
        prep.setup.options["threads"] = threads
    prepare_s = time.perf_counter() - t0
    stats = RunStats()
    prev = [o.rot_rest for o in prep.objects]
    means = [[rebuild(o, prep.setup.x, prev[k])[0].means.copy() for k, o in enumerate(prep.objects)]]
    t1 = time.perf_counter()
    for rec in run_engine(prep.info, prep.setup, n_frames, stats):
        frame = []
        for k, o in enumerate(prep.objects):
            g, prev[k], _ = rebuild(o, rec.x, prev[k])
            frame.append(g.means.copy())
        means.append(frame)
    total = time.perf_counter() - t0
    sim = float(sum(stats.frame_s))
    return {"prepare_s": prepare_s, "build_s": stats.build_s, "frames_s": sim,
            "end_to_end_s": prepare_s + stats.build_s + sim, "wall_s": total,
            "rebuild_s": total - prepare_s - stats.build_s - sim - (t1 - t0 - prepare_s),
            "n_points": len(prep.setup.x), "n_passive": int(prep.setup.n_passive),
            "n_material": int(len(prep.setup.x) - prep.setup.n_passive),
            "n_substeps": stats.engine.get("n_substeps"), "mass": stats.engine.get("mass"),
            "mass_setup": float(prep.setup.p_mass.sum()),
            "fill_volume": [o.fill_report.volume for o in prep.objects],
            "load_start": list(load0), "load_end": list(os.getloadavg()),
            "means": [np.stack([f[k] for f in means]) for k in range(len(prep.objects))]}


def errors(means, ref) -> dict:
    """Means' distance to the reference per frame, as a share of the object size (worst frame)."""
    out = {"mean": 0.0, "p99": 0.0, "max": 0.0, "per_frame_mean": None}
    for m, r in zip(means, ref):
        size = float(np.linalg.norm(np.ptp(r[0], axis=0)))              # bounding-box diagonal, frame 0
        d = np.linalg.norm(m - r, axis=2) / size                         # (frames, n)
        pf = d.mean(axis=1)
        out["per_frame_mean"] = pf if out["per_frame_mean"] is None else np.maximum(out["per_frame_mean"], pf)
        out["mean"] = max(out["mean"], float(pf.max()))
        out["p99"] = max(out["p99"], float(np.quantile(d, 0.99, axis=1).max()))
        out["max"] = max(out["max"], float(d.max()))
    out["per_frame_mean"] = [float(v) for v in out["per_frame_mean"]]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default="donut,guitar")
    ap.add_argument("--variants", default="full,passive,core=0.5,core=0.2,passive+core=0.2")
    ap.add_argument("--frames", type=int, default=None, help="frames per run (default: the scene's)")
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--reference-grid", type=int, default=None,
                    help="n_grid of a finer full run used as the reference (default: the full run)")
    ap.add_argument("--out", default=str(RESULTS / "bench_passive"))
    args = ap.parse_args(argv)
    from gasp_core.scene.spec import load_scene

    rows, report = [], {"machine": {"cpus": os.cpu_count(), "platform": platform.platform()}, "scenes": {}}
    for name in args.scenes.split(","):
        scene = load_scene(SCENES[name])
        n_frames = args.frames or scene.n_frames
        runs = {}
        for variant in args.variants.split(","):
            r = run_variant(variant_scene(scene, variant, None), n_frames, args.threads, embed="embed" in variant)
            runs[variant] = r
            print(f"{name} {variant}: {r['end_to_end_s']:.1f} s end to end ({r['n_material']} material, "
                  f"{r['n_passive']} passive points), load {r['load_start'][0]:.1f}", flush=True)
        ref_name = "full"
        if args.reference_grid:
            ref_name = f"full n_grid {args.reference_grid}"
            runs[ref_name] = run_variant(variant_scene(scene, "full", args.reference_grid), n_frames, args.threads)
        ref = runs[ref_name]["means"]
        base = runs["full"]["end_to_end_s"]
        for variant, r in runs.items():
            e = errors(r["means"], ref)
            row = {"scene": name, "variant": variant, "frames": n_frames, "speedup": base / r["end_to_end_s"],
                   **{k: v for k, v in r.items() if k != "means"}, "err_mean": e["mean"], "err_p99": e["p99"],
                   "err_max": e["max"], "err_per_frame_mean": e["per_frame_mean"], "reference": ref_name}
            rows.append(row)
        report["scenes"][name] = {"frames": n_frames, "reference": ref_name}
    report["rows"] = rows
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(report, indent=1))
    os.replace(tmp, out.with_suffix(".json"))
    lines = ["# Passive surface points vs full vertices vs hierarchy (bench_passive.py)", "",
             f"Machine: {os.cpu_count()} CPU cores, shared; load average per row. End to end = prepare_s + "
             f"build_s + frames (no PLY writing). Error: distance of the Gaussians' means to the reference "
             f"run's, share of the object size (bounding-box diagonal of the frame-0 means), worst frame "
             f"(mean over Gaussians / 99th pct / max).", "",
             "| scene | variant | material pts | passive pts | substeps | prepare s | build s | frames s | "
             "end to end s | speed-up vs full | err mean | err p99 | err max | load |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['variant']} | {r['n_material']} | {r['n_passive']} | {r['n_substeps']} | "
                     f"{r['prepare_s']:.1f} | {r['build_s']:.1f} | {r['frames_s']:.1f} | {r['end_to_end_s']:.1f} | "
                     f"{r['speedup']:.2f} | {r['err_mean']:.2%} | {r['err_p99']:.2%} | {r['err_max']:.2%} | "
                     f"{r['load_start'][0]:.1f} |")
    for name in report["scenes"]:
        by = {r["variant"]: r for r in rows if r["scene"] == name}
        for v in [v for v in by if v.startswith("passive") and "full" in by]:
            p = by[v]
            ok = p["speedup"] >= 3.0 and p["err_mean"] <= 0.01
            lines += ["", f"{name}, {v} vs full: {p['speedup']:.2f}x end to end, worst frame's mean error "
                      f"{p['err_mean']:.2%} of the object size (target: >= 3x and <= 1 % on every frame: "
                      f"{'met' if ok else 'not met'}). Mean error per frame, % (frame 0 first): "
                      + " ".join(f"{100 * v:.2f}" for v in p["err_per_frame_mean"])]
    lines += ["", "Mass simulated vs the setup's (kg): " + "; ".join(
        f"{r['scene']} {r['variant']} {r['mass']:.4g} / {r['mass_setup']:.4g}" for r in rows if r["mass"])]
    tmp = out.with_suffix(".md.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    os.replace(tmp, out.with_suffix(".md"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
