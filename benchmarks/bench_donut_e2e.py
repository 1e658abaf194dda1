"""The README donut end to end (issue 29): ``gasp simulate examples/donut_jelly.toml --frames N`` on this checkout
and on a base checkout, alternating in one run, with wall time, CPU time (user + system of the child) and cores
used, and the engine's substeps per frame and P2G mode from the run's ``run.json``.

Usage (the lead's re-measurement on a quiet machine; base = main before issue 29)::

    git worktree add --detach /tmp/gasp-base f2a503c && \\
      python benchmarks/bench_donut_e2e.py --base /tmp/gasp-base --frames 36 --rounds 1

Each checkout first runs one untimed frame (Taichi compiles its kernels into the offline cache), so the timed
runs do not include compilation. Writes ``benchmarks/results/bench_donut_e2e.{json,md}``. Both checkouts read this checkout's scene file (the same
donut, viscosity 4 Pa s) unless ``--scene`` says otherwise.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
PLUGINS = ("taichi_mpm", "warp_mpm", "mujoco_flex", "newton", "genesis", "blender", "render_gsplat")


def _env(src: Path, threads: int | None) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(src)] + [str(src / "plugins" / p) for p in PLUGINS])
    return env


def simulate(src: Path, scene: Path, frames: int) -> dict:
    """One ``gasp simulate`` of ``scene`` with checkout ``src``: wall, CPU, cores, substeps per frame."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out),
                            "--frames", str(frames), "-q"], capture_output=True, text=True, env=_env(src, None))
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        rec = {"frames": frames, "wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "cores": round(cpu / wall, 3),
               "exit": p.returncode}
        run = next(out.rglob("run.json"), None)
        if run is not None:
            doc = json.loads(run.read_text())
            eng = doc.get("engine_stats") or {}
            if isinstance(eng, dict):
                rec.update({k: eng[k] for k in ("n_substeps", "p2g", "threads", "late_points",
                                                "viscous_cg_iterations") if k in eng})
        if p.returncode:
            rec["error"] = (p.stderr.strip().splitlines() or [""])[-1]
        return rec


def _markdown(doc: dict) -> str:
    lines = ["# README donut end to end (bench_donut_e2e.py)", "",
             f"Machine: {doc['cpu_count']} cores, load average at start {doc['load_start']}, at end {doc['load_end']}"
             f" ({'loaded: wall times are the machine' + chr(39) + 's' if max(doc['load_start']) > doc['cpu_count'] else 'quiet'})."
             f" Scene: `{doc['scene']}`, {doc['frames']} frames, `gasp simulate` end to end.", "",
             "| checkout | round | wall s | CPU s | cores used | substeps/frame | P2G |", "|---|---:|---:|---:|---:|---:|---|"]
    for r in doc["rows"]:
        lines.append(f"| {r['checkout']} | {r['round']} | {r['wall_s']} | {r['cpu_s']} | {r['cores']} | "
                     f"{r.get('n_substeps', '?')} | {r.get('p2g', '?')} |")
    if doc.get("ratio_wall"):
        lines += ["", f"base / this, wall (median over rounds): **{doc['ratio_wall']:.2f}x**; CPU: {doc['ratio_cpu']:.2f}x."]
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--base", type=Path, default=None, help="a checkout of the base commit (f2a503c)")
    ap.add_argument("--frames", type=int, default=36)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--scene", type=Path, default=ROOT / "examples" / "donut_jelly.toml")
    ap.add_argument("--out", type=Path, default=RESULTS)
    a = ap.parse_args(argv)
    srcs = {"this": ROOT}
    if a.base:
        srcs["base"] = a.base.resolve()
    doc = {"cpu_count": os.cpu_count(), "platform": platform.platform(), "scene": str(a.scene), "frames": a.frames,
           "load_start": [round(x, 2) for x in os.getloadavg()], "rows": []}
    for name, src in srcs.items():   # warm Taichi's offline kernel cache, so neither timed run compiles
        simulate(src, a.scene, 1)
    for r in range(a.rounds):
        for name, src in srcs.items():
            rec = {"checkout": name, "round": r, **simulate(src, a.scene, a.frames)}
            doc["rows"].append(rec)
            print(json.dumps(rec), file=sys.stderr, flush=True)
    doc["load_end"] = [round(x, 2) for x in os.getloadavg()]
    if a.base:
        import statistics
        per = [(b["wall_s"] / t["wall_s"], b["cpu_s"] / t["cpu_s"]) for t, b in
               zip([x for x in doc["rows"] if x["checkout"] == "this"], [x for x in doc["rows"] if x["checkout"] == "base"])]
        doc["ratio_wall"] = statistics.median(p[0] for p in per)
        doc["ratio_cpu"] = statistics.median(p[1] for p in per)
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "bench_donut_e2e.json").write_text(json.dumps(doc, indent=2) + "\n")
    (a.out / "bench_donut_e2e.md").write_text(_markdown(doc))
    print(_markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
