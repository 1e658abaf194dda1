"""A selected region in its whole scene costs what the region alone costs (issue 9 A).

Two runs of ``gasp simulate`` on the same physics, one after another in this run:

* ``region in scene``: ``examples/kitchen_spinach.toml`` as it stands: the real dynamic kitchen
  (62,442 Gaussians) at ``dynamic_time = 0.5``, the spinach box simulated, the other Gaussians
  static and written in every frame;
* ``region cut out``: the same 351 selected Gaussians (``psi(V, 0.5)`` then the box) written to a
  PLY of their own and simulated with the same placement, material, ground, domain and grid.

Each run is its own subprocess (Taichi keeps process-global state), so both pay the same JIT
compile in frame 1. Figures per run: simulated points, substeps, ``prepare_s`` (read, place,
select, flatten, fill), frame 1 (compile), the engine's seconds over frames 2..N, the writer's
seconds over all frames, and the process wall time.

Usage::

    python benchmarks/bench_region.py              # 10 frames
    python benchmarks/bench_region.py --frames 4

Writes ``benchmarks/results/bench_region.json`` and ``benchmarks/results/bench_region.md``.
"""
from __future__ import annotations

import argparse
import json
import platform
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import tomli_w  # pip install -e ".[studies]"

ROOT = Path(__file__).resolve().parents[1]
KITCHEN = ROOT / "examples" / "kitchen_spinach.toml"
RESULTS = ROOT / "benchmarks" / "results"


def cut_out(tmp: Path) -> tuple[Path, int]:
    """Write the selected region as its own PLY and a scene simulating it alone."""
    from gasp_core.gs.io import write_gaussians
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    scene = load_scene(KITCHEN)
    prep = prepare_scene(scene)
    o = prep.objects[0]
    ply = write_gaussians(tmp / "spinach_region.ply", o.gaussians.subset(o.moving))
    data = tomllib.loads(KITCHEN.read_text())
    obj = dict(data["object"][0])
    for k in ("select", "dynamic_time"):
        obj.pop(k)
    obj["file"] = str(ply)
    data["object"] = [obj]
    # the same grid: the region's default domain, written out
    data["domain"] = dict(data["domain"], lo=prep.setup.domain_lo.tolist(), hi=prep.setup.domain_hi.tolist())
    path = tmp / "spinach_region.toml"
    path.write_text(tomli_w.dumps(data))
    return path, len(o.moving)


def run(scene: Path, out: Path, frames: int) -> dict:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out),
                    "--frames", str(frames), "-q"], check=True)
    wall = time.perf_counter() - t0
    r = json.loads((out / "run.json").read_text())
    sim = [f["sim_s"] for f in r["frames"][1:]]
    return {"wall_s": wall, "n_points": r["n_points"], "n_gaussians": r["n_gaussians"],
            "n_selected": r["n_selected"], "n_static": r["n_static"],
            "n_substeps": r["engine_stats"].get("n_substeps"), "prepare_s": r["prepare_s"],
            "build_s": r["build_s"], "frame1_s": sim[0], "sim_s_after_frame1": sum(sim[1:]),
            "write_s": sum(f["write_s"] for f in r["frames"]), "run_wall_s": r["wall_s"],
            "bytes_per_frame": (out / r["objects"][0]["name"] / "frame_0000.ply").stat().st_size}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=10)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        cut, n = cut_out(tmp)
        rows = {"region in scene": run(KITCHEN, tmp / "scene_out", args.frames),
                "region cut out": run(cut, tmp / "cut_out", args.frames)}
    a, b = rows["region in scene"], rows["region cut out"]
    doc = {"frames": args.frames, "machine": platform.platform(), "python": platform.python_version(),
           "runs": rows, "ratio_sim_after_frame1": a["sim_s_after_frame1"] / b["sim_s_after_frame1"],
           "ratio_wall": a["wall_s"] / b["wall_s"]}
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "bench_region.json").write_text(json.dumps(doc, indent=1) + "\n")
    keys = ["n_gaussians", "n_selected", "n_static", "n_points", "n_substeps", "prepare_s", "build_s", "frame1_s",
            "sim_s_after_frame1", "write_s", "run_wall_s", "wall_s", "bytes_per_frame"]
    md = [f"# Region in its scene vs the region alone ({args.frames} frames, taichi_mpm, CPU)", "",
          "`python benchmarks/bench_region.py` (see its docstring). Seconds unless stated.", "",
          "| figure | region in scene | region cut out |", "|---|---|---|"]
    for k in keys:
        fa, fb = a[k], b[k]
        fmt = (lambda v: f"{v:.2f}") if isinstance(fa, float) else str
        md.append(f"| {k} | {fmt(fa)} | {fmt(fb)} |")
    md += ["", f"Engine time over frames 2..{args.frames}, in scene / alone: {doc['ratio_sim_after_frame1']:.2f}; "
           f"process wall time: {doc['ratio_wall']:.2f}.", ""]
    (RESULTS / "bench_region.md").write_text("\n".join(md))
    print("\n".join(md))


if __name__ == "__main__":
    main()
