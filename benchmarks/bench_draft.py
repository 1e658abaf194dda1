"""``--quality draft`` against ``default`` on every example scene (issue 55: draft must never simulate more
points nor cost more time than default): simulated points, substeps a frame, and the cost of the frames after the
first (wall and CPU seconds a frame), for ``default``, ``draft``, and the draft before issue 55 (``draft`` with
every object's ``surface = "passive"`` and ``surface_points = "vertices"``, what that level gave then).

Each run is a ``gasp simulate SCENE --quality Q --frames F --json`` process of its own; the first frame (the
engine's build, kernels loaded or compiled) is left out of the per-frame figures. CPU seconds are the process's
user + system time over the frames after the first (``run.json``'s ``frames`` rows). Run:
``python benchmarks/bench_draft.py [--frames 3] [--scenes donut_jelly,...]``; writes
``benchmarks/results/bench_draft.md`` and ``.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The example scenes the installed core engines run (the Blender ones need bpy in a venv of its own).
SCENES = ("donut_jelly", "donut_wind", "donut_on_guitar", "donut_mesh", "donut_wood", "guitar_sand", "kitchen_spinach")
VARIANTS = ("default", "draft", "draft before issue 55")


def old_draft_scene(scene: Path, where: Path) -> Path:
    """``scene`` with ``surface = "passive"`` and ``surface_points = "vertices"`` on every object that is not static,
    its paths made absolute."""
    import tomli_w
    data = tomllib.loads(scene.read_text())
    for o in data.get("object", []):
        for key in ("file", "mesh", "select_mask"):
            if isinstance(o.get(key), str):
                o[key] = str((scene.parent / o[key]).resolve())
        sel = o.get("select")
        if isinstance(sel, dict) and isinstance(sel.get("mask"), str):
            sel["mask"] = str((scene.parent / sel["mask"]).resolve())
        if not o.get("static"):
            o["surface"], o["surface_points"] = "passive", "vertices"
    for c in data.get("collider", []):
        for key in ("file", "mesh"):
            if isinstance(c.get(key), str):
                c[key] = str((scene.parent / c[key]).resolve())
    out = where / scene.name
    out.write_text(tomli_w.dumps(data))
    return out


def run(scene: Path, quality: str, frames: int, out: Path) -> dict:
    """One ``gasp simulate`` process; its points, substeps and per-frame cost after the first frame."""
    cmd = [sys.executable, "-m", "gasp_core", "simulate", str(scene), "--quality", quality, "--frames", str(frames),
           "-o", str(out), "--overwrite", "--json"]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    events = [json.loads(ln) for ln in p.stdout.splitlines() if ln.startswith("{")]
    result = next((e for e in events if e["event"] == "result"), None)
    if p.returncode != 0 or result is None:
        return {"error": (p.stderr.strip().splitlines() or ["?"])[-1]}
    record = json.loads((out / "run.json").read_text())
    rows = [r for r in record["frames"] if r["frame"] >= 2] if isinstance(record.get("frames"), list) else []
    wall = [r["wall_s"] for r in rows if "wall_s" in r]
    cpu = [r["cpu_s"] for r in rows if "cpu_s" in r]
    return {"n_points": result["n_points"], "n_substeps": result["n_substeps"],
            "wall_s_per_frame": sum(wall) / len(wall) if wall else None,
            "cpu_s_per_frame": sum(cpu) / len(cpu) if cpu else None,
            "sim_s_per_frame": result.get("sim_s_per_frame")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--out", default="bench_draft")
    args = ap.parse_args()
    table = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in args.scenes.split(","):
            scene = ROOT / "examples" / f"{name}.toml"
            old = old_draft_scene(scene, tmp)
            table[name] = {}
            for variant, (path, q) in zip(VARIANTS, ((scene, "default"), (scene, "draft"), (old, "draft"))):
                table[name][variant] = run(path, q, args.frames, tmp / f"{name}_{q}_{len(table[name])}")
                print(name, variant, table[name][variant], flush=True)
    load = os.getloadavg()
    res = ROOT / "benchmarks" / "results"
    (res / f"{args.out}.json").write_text(json.dumps({"frames": args.frames, "load_avg": load, "table": table},
                                                     indent=1))
    lines = [f"# draft against default (`python benchmarks/bench_draft.py --frames {args.frames}`)", "",
             f"Every example scene the core engines run, {args.frames} frames, the frames after the first timed "
             "(sim s a frame: the run's result, every frame; wall and CPU s a frame: its frame rows from frame 2). "
             f"Machine: "
             f"{os.cpu_count()} cores, {platform.platform()}, load average {load[0]:.1f} at the end (shared: "
             "times are inflated and noisy, the points and substeps are exact).", "",
             "| scene | level | points | substeps/frame | sim s/frame | wall s/frame | CPU s/frame |",
             "|---|---|---:|---:|---:|---:|---:|"]
    fmt = lambda v: "-" if v is None else f"{v:.2f}"  # noqa: E731
    for name, rows in table.items():
        for variant, r in rows.items():
            if "error" in r:
                lines.append(f"| {name} | {variant} | failed: {r['error']} | | | | |")
                continue
            lines.append(f"| {name} | {variant} | {r['n_points']:,} | {r['n_substeps']} | {fmt(r['sim_s_per_frame'])}"
                         f" | {fmt(r['wall_s_per_frame'])} | {fmt(r['cpu_s_per_frame'])} |")
    (res / f"{args.out}.md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
