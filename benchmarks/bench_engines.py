"""Every installed engine on the same two scenes, in one run: frames per second and MPM throughput.

Scenes (CPU, f32 where the engine offers it, the engine's own automatic substeps):

* ``block``: a jelly cube of 46,656 points (36^3, 8 points per grid cell) in a 1 m box with
  ``n_grid = 64``, dropped from 1 cell above a ground plane at 1 m/s, ``frame_dt = 1/30`` s;
* ``donut``: ``examples/donut_jelly.toml`` (the real 45,624-Gaussian donut, 146k simulated points
  with the interior fill, ``n_grid = 64``) through :func:`gasp_core.prepare.scene.prepare_scene`.

Each (scene, engine) runs in its own subprocess (Taichi and Genesis keep process-global state),
one after another in this run, so the ratios compare engines under the same machine load. The
engine is built and frame 1 (which holds the JIT compile) is run untimed; then ``--frames``
frames are timed with the wall clock and the process CPU time (``step_frame`` plus read-back;
the Gaussian rebuild is not included). Figures:

* ``fps``: frames per wall-clock second (all engines);
* ``Mpss``: million particle-substeps per wall-clock second, ``n_points * n_substeps / s_per_frame``
  (grid engines: every substep touches every particle; ``mujoco_flex`` steps a lattice, not the
  points, so it has no such figure);
* ratios of ``Mpss`` taichi_mpm / genesis and warp_mpm / genesis (and taichi_mpm / warp_mpm).

Usage::

    python benchmarks/bench_engines.py                      # all installed engines, both scenes
    python benchmarks/bench_engines.py --engines taichi_mpm,warp_mpm --scenes block --frames 3

Writes ``benchmarks/results/bench_engines.json`` and ``benchmarks/results/bench_engines.md``.
"""
from __future__ import annotations

import argparse
import importlib.metadata as md
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
DONUT = ROOT / "examples" / "donut_jelly.toml"
N_GRID = 64
GROUND = 0.1


def block_setup(engine: str):
    """The ``block`` scene as a :class:`gasp_core.seam.engine.SimSetup` (world frame, z up, metres)."""
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    dx = 1.0 / N_GRID
    cells = 18                                   # 36^3 = 46,656 points at 2 per axis per cell
    h = dx / 2
    side = cells * dx
    g = (np.arange(2 * cells) + 0.5) * h
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    x += np.array([0.5 - side / 2, 0.5 - side / 2, GROUND + dx])
    return SimSetup(x=x, v=np.array([0.0, 0.0, -1.0]), p_vol=h ** 3, body_id=0,
                    materials=[Material("jelly", E=1e5, nu=0.3, rho=1000.0)],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=N_GRID, boundaries=[Boundary("ground", height=GROUND, friction=0.5)],
                    frame_dt=1.0 / 30.0, options=_options(engine))


def _options(engine: str) -> dict:
    from gasp_core.seam.plugins import get_engine
    caps = get_engine(engine).capabilities
    return {"device": "cpu", "precision": "f32"} if "f32" in caps.precisions else {"device": "cpu"}


def donut_setup(engine: str):
    """The ``donut`` scene's :class:`SimSetup` (the example file, engine options for CPU/f32)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    return prepare_scene(load_scene(DONUT), engine, _options(engine)).setup


def worker(engine: str, scene: str, frames: int) -> dict:
    """Time one engine on one scene; runs inside the subprocess."""
    import resource
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from gasp_core.seam.runner import check_state
    info = get_engine(engine)
    rec = {"engine": engine, "scene": scene, "version": info.version}
    try:
        setup = block_setup(engine) if scene == "block" else donut_setup(engine)
        rec["n_points"] = len(setup.x)
        t0 = time.perf_counter()
        eng = build_engine(info, setup)
        rec["build_s"] = time.perf_counter() - t0
        try:
            t0 = time.perf_counter()
            eng.step_frame()
            eng.positions()
            rec["first_frame_s"] = time.perf_counter() - t0
            wall, cpu = [], []
            for k in range(frames):
                t0, c0 = time.perf_counter(), time.process_time()
                eng.step_frame()
                x = np.asarray(eng.positions(), dtype=np.float64)
                wall.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
                check_state(x, setup, k + 2)
            st = dict(eng.stats())
        finally:
            eng.close()
        rec.update(status="ok", frame_s=wall, frame_cpu_s=cpu, s_per_frame=float(np.mean(wall)),
                   cpu_s_per_frame=float(np.mean(cpu)), fps=1.0 / float(np.mean(wall)),
                   n_substeps=st.get("n_substeps"), precision=st.get("precision"),
                   threads=st.get("threads"), grid_based="grid" in info.capabilities.features)
        if "grid" in info.capabilities.features and st.get("n_substeps"):
            rec["Mpss"] = rec["n_points"] * st["n_substeps"] / rec["s_per_frame"] / 1e6
            rec["Mpss_per_cpu_s"] = rec["n_points"] * st["n_substeps"] / rec["cpu_s_per_frame"] / 1e6
    except Exception as e:  # reported in the table, never fatal to the run
        rec.update(status="error", message=f"{type(e).__name__}: {e}")
    rec["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return rec


def _versions() -> dict:
    out = {"python": platform.python_version()}
    for d in ("numpy", "gasp", "taichi", "warp-lang", "mujoco", "genesis-world", "torch", "gasp-taichi-mpm",
              "gasp-warp-mpm", "gasp-mujoco-flex", "gasp-genesis"):
        try:
            out[d] = md.version(d)
        except md.PackageNotFoundError:
            pass
    return out


def _fmt(v, spec=".3g"):
    return "-" if v is None else format(v, spec) if isinstance(v, float) else str(v)


def write_markdown(path: Path, res: dict) -> None:
    lines = ["# All engines on the same scenes (bench_engines.py)", "",
             f"Machine: {res['machine']}, load average at start {res['load_start']}, at end {res['load_end']}; "
             f"run took {res['total_s'] / 60:.1f} min. Versions: "
             + ", ".join(f"{k} {v}" for k, v in res["versions"].items()) + ".", "",
             "Scenes: `block` = jelly cube of 46,656 points (8 per cell), n_grid 64, 1 m box, ground; "
             "`donut` = examples/donut_jelly.toml (45,624 Gaussians, interior fill, n_grid 64). CPU, f32 "
             "(mujoco_flex: f64 only), each engine's automatic substeps. Frame 1 (JIT compile) untimed, then "
             f"{res['frames']} timed frames. Mpss = million particle-substeps per wall second "
             "(grid engines); per CPU-s divides by the process CPU time instead (the machine is shared).", "",
             "| scene | engine | status | points | substeps/frame | s/frame | fps | Mpss | Mpss per CPU-s | "
             "threads | build s | frame 1 s | peak MB |", "|" + "---|" * 13]
    for r in res["runs"]:
        lines.append("| " + " | ".join([r["scene"], r["engine"], r["status"] if r["status"] == "ok" else
                                         f"{r['status']}: " + " ".join(r.get("message", "").split())[:100].replace("|", "/"),
                                         _fmt(r.get("n_points")), _fmt(r.get("n_substeps")),
                                         _fmt(r.get("s_per_frame")), _fmt(r.get("fps")), _fmt(r.get("Mpss")),
                                         _fmt(r.get("Mpss_per_cpu_s")), _fmt(r.get("threads")),
                                         _fmt(r.get("build_s")), _fmt(r.get("first_frame_s")),
                                         _fmt(r.get("peak_rss_mb"), ".0f")]) + " |")
    if res["ratios"]:
        lines += ["", "Ratios measured in this run (wall-clock particle-substeps per second, same scene):", "",
                  "| scene | ratio | value |", "|---|---|---|"]
        lines += [f"| {r['scene']} | {r['ratio']} | {r['value']:.2f} |" for r in res["ratios"]]
    path.write_text("\n".join(lines) + "\n")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--engines", help="comma-separated (default: all installed and available)")
    p.add_argument("--scenes", default="block,donut")
    p.add_argument("--frames", type=int, default=3, help="timed frames after the untimed first frame")
    p.add_argument("--out", type=Path, default=RESULTS)
    p.add_argument("--worker", nargs=2, metavar=("ENGINE", "SCENE"), help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        print("@@RESULT@@" + json.dumps(worker(args.worker[0], args.worker[1], args.frames)))
        return 0
    from gasp_core.seam.plugins import engines
    found = engines()
    names = args.engines.split(",") if args.engines else \
        [n for n, e in found.items() if e.unavailable_reason() is None]
    t_all = time.perf_counter()
    res = {"machine": f"{os.cpu_count()} logical CPUs ({platform.machine()}, {platform.processor() or 'cpu'})",
           "load_start": [round(x, 2) for x in os.getloadavg()], "versions": _versions(),
           "frames": args.frames, "runs": [], "ratios": []}
    for scene in args.scenes.split(","):
        for name in names:
            if name not in found or found[name].unavailable_reason():
                why = "not installed" if name not in found else found[name].unavailable_reason()
                res["runs"].append({"engine": name, "scene": scene, "status": "skipped", "message": why})
                continue
            print(f"bench_engines: {scene} on {name} ...", file=sys.stderr, flush=True)
            proc = subprocess.run([sys.executable, __file__, "--worker", name, scene, "--frames", str(args.frames)],
                                  capture_output=True, text=True)
            line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("@@RESULT@@")), None)
            rec = json.loads(line[len("@@RESULT@@"):]) if line else \
                {"engine": name, "scene": scene, "status": "crashed",
                 "message": f"exit code {proc.returncode}: {proc.stderr[-300:]}"}
            res["runs"].append(rec)
            print(f"bench_engines: {scene} {name}: {rec['status']} "
                  f"{_fmt(rec.get('s_per_frame'))} s/frame, Mpss {_fmt(rec.get('Mpss'))}", file=sys.stderr, flush=True)
        by = {r["engine"]: r for r in res["runs"] if r["scene"] == scene and r.get("Mpss")}
        for a, b in (("taichi_mpm", "genesis"), ("warp_mpm", "genesis"), ("taichi_mpm", "warp_mpm")):
            if a in by and b in by:
                res["ratios"].append({"scene": scene, "ratio": f"{a} / {b}", "value": by[a]["Mpss"] / by[b]["Mpss"]})
    res["load_end"] = [round(x, 2) for x in os.getloadavg()]
    res["total_s"] = time.perf_counter() - t_all
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "bench_engines.json").write_text(json.dumps(res, indent=2))
    write_markdown(args.out / "bench_engines.md", res)
    print(f"wrote {args.out / 'bench_engines.json'} and bench_engines.md", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
