"""Bundled example scenes through ``gasp simulate`` on CUDA and on the same machine's CPU cores, in one device call
(issue 65 item 3: the whole frame a user waits for, the engine and what runs beside it: ``T^-1`` with the control
rule, the pieces, the crack faces, the writing).

For each ``example:frames`` and each device the scene is written with ``[engine] options.device`` set (the objects'
files made absolute) and run by ``python -m gasp_core simulate ... --frames N --yes`` in a process of its own, under
one deadline. From its ``run.json``: the median after frame 1 (which compiles) of the frame's wall time, of the
engine's part (``sim_s``) and of the writing (``write_s``), the substeps and points, and the last frame's pieces.

Writes ``gpu_scenes.json`` and ``gpu_scenes.md`` to ``--out`` (``$OUT`` on the device machine). Usage there
(``../shared/device``)::

    bash .device/setup.sh && PYTHONPATH=/tmp/site python3 benchmarks/gpu_scenes.py --out $OUT \
        --scenes donut_shatter:10,donut_jelly:20:cuda
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def scene_file(example: str, device: str, folder: Path, engine: str | None = None) -> Path:
    """``examples/<example>.toml`` with ``device`` in its engine options (and ``engine`` for its engine's name, where
    given) and its objects' files absolute, in ``folder``."""
    import tomli_w
    src = ROOT / "examples" / f"{example}.toml"
    data = tomllib.loads(src.read_text())
    data.setdefault("engine", {}).setdefault("options", {})["device"] = device
    if engine:
        data["engine"]["name"] = engine
    for o in data.get("object", []) + data.get("collider", []):
        for key in ("file", "mesh"):
            if key in o:
                o[key] = str((src.parent / o[key]).resolve())
    path = folder / f"{example}_{device}.toml"
    path.write_text(tomli_w.dumps(data))
    return path


def run_scene(example: str, device: str, frames: int, timeout: float, engine: str | None = None) -> dict:
    """One ``gasp simulate`` of ``example`` on ``device``: the figures of its ``run.json`` (module notes)."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        toml = scene_file(example, device, Path(tmp), engine)
        out = Path(tmp) / "out"
        cmd = [sys.executable, "-m", "gasp_core", "simulate", str(toml), "-o", str(out), "--frames", str(frames),
               "--yes", "-q"]
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=max(timeout, 1.0))
        except subprocess.TimeoutExpired:
            return {"error": f"past its {timeout:.0f} s"}
        if r.returncode != 0:
            return {"error": f"exit {r.returncode}: " + " | ".join(r.stderr.strip().splitlines()[-4:])}
        doc = json.loads((out / "run.json").read_text())
    rows = [f for f in doc["frames"] if f.get("frame", 0) >= 2]
    med = {k: float(np.median([f[k] for f in rows if k in f])) if rows else None
           for k in ("wall_s", "sim_s", "write_s")}
    last = doc["frames"][-1]
    return {"points": doc["n_points"], "n_substeps": doc["engine_stats"].get("n_substeps"),
            "schedule": doc["engine_stats"].get("schedule"), "device": doc["engine_stats"].get("device", device),
            "frames": len(doc["frames"]) - 1, "frame1_s": doc["frames"][1].get("wall_s"),
            **{f"{k}_median": v for k, v in med.items()}, "pieces_last": last.get("pieces"),
            "run_s": round(time.perf_counter() - t0, 1)}


def markdown(doc: dict) -> str:
    lines = [f"# gpu_scenes.py: bundled examples through `gasp simulate`, {doc['gpu']}, {doc['date']}", "",
             f"Host: {doc['cpu_count']} CPU threads. Medians after frame 1 (which compiles), s a frame.", "",
             "| scene | device | points | substeps | frame | engine | writing | frame 1 | pieces (last) |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in doc["cases"]:
        if "error" in r:
            lines.append(f"| {r['scene']} | {r['device_asked']} | | | | | | | {r['error'][:100]} |")
            continue
        lines.append(f"| {r['scene']} | {r['device_asked']} | {r['points']} | {r['n_substeps']} | "
                     f"{r['wall_s_median']:.3f} | {r['sim_s_median']:.3f} | {r['write_s_median']:.3f} | "
                     f"{r['frame1_s']:.1f} | {r['pieces_last']} |")
    by = {(r["scene"], r["device_asked"]): r for r in doc["cases"] if "error" not in r}
    for scene in dict.fromkeys(r["scene"] for r in doc["cases"]):
        c, p = by.get((scene, "cuda")), by.get((scene, "cpu"))
        if c and p:
            lines.append(f"\n{scene}: CUDA against this machine's CPU cores, the whole frame "
                         f"{p['wall_s_median'] / c['wall_s_median']:.1f}x, the engine "
                         f"{p['sim_s_median'] / c['sim_s_median']:.1f}x")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--scenes", default="donut_shatter:10,donut_jelly:20",
                    help="example:frames or example:frames:device, comma-separated")
    ap.add_argument("--devices", default="cuda,cpu")
    ap.add_argument("--engine", default=None, help="run every scene on this engine (default: each example's own)")
    ap.add_argument("--budget", type=float, default=300.0, help="seconds for all the runs")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    try:
        gpu = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True).stdout.strip() or "no GPU"
    except OSError:
        gpu = "no GPU"
    doc = {"gpu": gpu, "date": datetime.date.today().isoformat(), "cpu_count": os.cpu_count(), "cases": []}
    end = time.perf_counter() + a.budget
    for item in a.scenes.split(","):
        example, frames, *only = item.split(":")   # example:frames[:device]
        for device in only or a.devices.split(","):
            left = end - time.perf_counter()
            rec = (run_scene(example, device, int(frames), left, a.engine) if left > 20
                   else {"error": "not run: budget spent"})
            rec.update(scene=example, device_asked=device, engine=a.engine or "the example's")
            print(json.dumps(rec), flush=True)
            doc["cases"].append(rec)
            (a.out / "gpu_scenes.json").write_text(json.dumps(doc, indent=1))
    (a.out / "gpu_scenes.md").write_text(markdown(doc))
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
