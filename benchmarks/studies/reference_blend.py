"""Round 57: how far the ``reference`` quality level moved when ``transfer_damping = "rate"`` became the default.

The ``reference`` level steps at cfl 0.2 (``gasp_core/scene/quality.py``), more substeps than the engines' reference
step for the transfers' damping (cfl 0.4), so since round 56 its runs blend AFLIP with ``alpha = 1 - n_ref / n``
(``gasp_core/mpm/transfer.py`` ``blend_alpha``, about 1/2). This runs, as a user does (``gasp simulate`` in a fresh
process, ``benchmarks/bench_trade.py``'s ``run_variant``), one scene at the ``reference`` level three ways:

* ``reference``: the level as it is now (``transfer_damping = "rate"``, the default);
* ``reference_step``: the same with ``transfer_damping = "step"`` (``alpha = flip``, the runs before round 56);
* ``reference_twin``: the level with the scene's ``n_grid`` x 0.75 (the level scales it by 1.5: 96 -> 72 on the
  README scenes), the twin whose distance to ``reference`` is the level's uncertainty U;

and then the split accuracy report (``benchmarks/bench_accuracy.py``) of ``reference_step`` (and the twin) against
``reference``, every figure also in units of U. ``reference_step`` within a fraction of 1 U of ``reference``: the
blend moved the level by less than its own uncertainty.

Usage::

    python benchmarks/studies/reference_blend.py --scene donut --frames 12 --keep /tmp/levels57/refblend

Writes ``benchmarks/results/reference_blend_<scene>_f<frames>.{json,md}`` (timings) and
``benchmarks/results/accuracy_reference_blend_<scene>_f<frames>.{json,md}`` (the report).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tomllib
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
import bench_accuracy  # noqa: E402
from bench_trade import RESULTS, SCENES, run_variant, variant_scene  # noqa: E402

#: name -> (domain keys as a fraction of the scene's n_grid, engine options)
RUNS = {"reference": (1.0, {}), "reference_step": (1.0, {"transfer_damping": "step"}),
        "reference_twin": (0.75, {})}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="donut")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--keep", type=Path, required=True, help="the run folders go here, one per run")
    ap.add_argument("--runs", default=",".join(RUNS), help="which of " + ", ".join(RUNS))
    args = ap.parse_args(argv)
    src = SCENES[args.scene]
    n_grid = int(tomllib.loads(src.read_text()).get("domain", {}).get("n_grid", 64))
    args.keep.mkdir(parents=True, exist_ok=True)
    stem = RESULTS / f"reference_blend_{args.scene}_f{args.frames}"
    doc = json.loads(stem.with_suffix(".json").read_text()) if stem.with_suffix(".json").exists() else {
        "scene": str(src.relative_to(HERE.parents[1])), "n_frames": args.frames, "threads": args.threads, "runs": {}}
    for name in [r.strip() for r in args.runs.split(",") if r.strip()]:
        frac, opts = RUNS[name]
        dom = {} if frac == 1.0 else {"n_grid": int(round(n_grid * frac))}
        scene = variant_scene(src, {}, dom, args.frames, args.keep / f"{name}.toml",
                              {"threads": args.threads, **opts}, quality="reference")
        print(f"[reference_blend] {args.scene} {name} ...", flush=True)
        load0 = os.getloadavg()[0]
        rec = run_variant(scene, args.keep / name, 4 * 3600.0)
        rec.update(keys={**dom, **opts}, load_avg_1min=[load0, os.getloadavg()[0]])
        if rec["returncode"] == 0:
            run = json.loads((args.keep / name / "run.json").read_text())
            rec["engine_stats"] = run.get("engine_stats")
        doc["runs"][name] = rec
        print(f"[reference_blend]   {json.dumps({k: v for k, v in rec.items() if k != 'engine_stats'})}", flush=True)
        stem.with_suffix(".json").write_text(json.dumps(doc, indent=1, default=str))
    lines = [f"# The `reference` level, transfer_damping rate against step (`{doc['scene']}`, {args.frames} frames)",
             "", "benchmarks/studies/reference_blend.py; CPU seconds of the whole `gasp simulate` process, one engine "
             "thread.", "", "| run | keys | points | substeps/frame | CPU s | wall s | load |",
             "|---|---|---:|---:|---:|---:|---|"]
    for name, r in doc["runs"].items():
        if r["returncode"] != 0:
            lines.append(f"| {name} | {r['keys']} | failed (exit {r['returncode']}) | | | | |")
            continue
        lines.append(f"| {name} | {r['keys']} | {r['n_points']:,} | {r['n_substeps']} | {r['process_cpu_s']:.1f} | "
                     f"{r['process_wall_s']:.1f} | {r.get('load_avg_1min')} |")
    stem.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    done = [n for n, r in doc["runs"].items() if r["returncode"] == 0]
    if {"reference", "reference_twin"} <= set(done):
        cands = [n for n in ("reference_step",) if n in done]
        bench_accuracy.main(["--runs", str(args.keep), "--reference", "reference", "--twin", "reference_twin",
                             "--candidates", ",".join(cands + ["reference_twin"]), "--default-level",
                             "reference_step", "--timings", str(stem.with_suffix(".json")),
                             "--tag", f"reference_blend_{args.scene}_f{args.frames}"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
