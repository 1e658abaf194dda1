"""Throughput of the installed grid-based (MPM) engines, in particle-substeps per second.

Scene: a cube of jelly (or neo-Hookean) points sampled at 8 points per grid cell (2 per axis),
released 1 cell above a ground plane at 1 m/s downwards, in a 1 m box with ``n_grid = 64``,
f32, CPU. Every engine runs the same substep ``dt = gasp_core.mpm.substeps.mpm_stable_dt(...)``:
``frame_dt = SUBSTEPS * dt`` and the option ``n_substeps = SUBSTEPS``.

Each engine runs in its own subprocess (Taichi and Warp keep process-global state), one after
another in this run, so the ratios compare engines measured under the same machine load.
Build and the first frame (kernel compilation) are excluded; then ``--frames`` frames are timed
with the wall clock (``time.perf_counter``) and the process CPU time.

Usage::

    python benchmarks/bench_mpm.py                       # all installed grid engines
    python benchmarks/bench_mpm.py --engines taichi_mpm,warp_mpm --sizes 50000

Writes ``benchmarks/results/bench_mpm.json`` and ``benchmarks/results/bench_mpm.md``.
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

SUBSTEPS = 10
N_GRID = 64
GROUND = 0.1
RESULTS = Path(__file__).resolve().parent / "results"


def make_setup(n_target: int, material: str):
    """The benchmark scene: a block of about ``n_target`` points, 8 per cell, above the ground.

    Returns
    -------
    SimSetup
        World frame, z up; ``options`` ask for CPU, f32 and ``SUBSTEPS`` substeps per frame.
    """
    from gasp_core.seam.setup import Boundary, Material, SimSetup
    from gasp_core.mpm.substeps import mpm_stable_dt

    dx = 1.0 / N_GRID
    cells = max(1, int(round((n_target / 8) ** (1 / 3))))
    h = dx / 2
    side = cells * dx
    g = (np.arange(2 * cells) + 0.5) * h
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    x += np.array([0.5 - side / 2, 0.5 - side / 2, GROUND + dx])
    mat = Material(material, E=1e5, nu=0.3, rho=1000.0)
    v0 = np.array([0.0, 0.0, -1.0])
    gravity = np.array([0.0, 0.0, -9.81])
    dt = mpm_stable_dt([mat], dx, gravity, height=1.0, v0_max=1.0)
    return SimSetup(x=x, v=v0, p_vol=h ** 3, body_id=0, materials=[mat], gravity=gravity,
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=N_GRID,
                    boundaries=[Boundary("ground", height=GROUND, friction=0.5)],
                    frame_dt=SUBSTEPS * dt,
                    options={"device": "cpu", "precision": "f32", "n_substeps": SUBSTEPS})


def worker(engine: str, sizes: list[int], materials: list[str], frames: int,
           with_donut: bool = True) -> list[dict]:
    """Time one engine on every (size, material); runs inside the subprocess."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine

    info = get_engine(engine)
    out = []
    for n in sizes:
        for mat in materials:
            setup = make_setup(n, mat)
            rec = {"engine": engine, "material": mat, "n_target": n, "n_points": len(setup.x)}
            try:
                t0 = time.perf_counter()
                eng = build_engine(info, setup)
                rec["build_s"] = time.perf_counter() - t0
                t0 = time.perf_counter()
                eng.step_frame()
                eng.positions()
                rec["first_frame_s"] = time.perf_counter() - t0
                st = eng.stats()
                n_sub = int(st.get("n_substeps", SUBSTEPS))
                w0, c0 = time.perf_counter(), time.process_time()
                for _ in range(frames):
                    eng.step_frame()
                    x = eng.positions()
                wall, cpu = time.perf_counter() - w0, time.process_time() - c0
                eng.close()
                work = len(setup.x) * n_sub * frames
                rec.update(n_substeps_per_frame=n_sub, frames=frames, wall_s=wall, cpu_s=cpu,
                           M_per_s=work / wall / 1e6, M_per_cpu_s=work / cpu / 1e6,
                           finite=bool(np.isfinite(x).all()), threads=st.get("threads"),
                           stats={k: v for k, v in st.items() if isinstance(v, (int, float, str))})
            except Exception as e:  # an engine that cannot run a case is reported, not fatal
                rec["error"] = f"{type(e).__name__}: {e}"
            out.append(rec)
            print(json.dumps(rec), file=sys.stderr, flush=True)
    if with_donut:
        try:
            rec = donut_frame(engine)
        except Exception as e:
            rec = {"engine": engine, "material": "donut (jelly)", "n_points": 0, "error": f"{type(e).__name__}: {e}"}
        out.append(rec)
        print(json.dumps(rec), file=sys.stderr, flush=True)
    return out


DONUT = Path(__file__).resolve().parents[1] / "examples" / "donut_jelly.toml"


def donut_frame(engine: str) -> dict:
    """Wall time of one frame of the README's donut scene (examples/donut_jelly.toml) on ``engine``.

    Frame 1 (kernel compilation) is excluded; frame 2 is timed, then the point count and substeps.
    """
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.seam.runner import RunStats, run_engine
    from gasp_core.scene.spec import load_scene

    prep = prepare_scene(load_scene(DONUT), engine)
    stats = RunStats()
    frames = list(run_engine(prep.info, prep.setup, 2, stats))
    return {"engine": engine, "material": "donut (jelly)", "n_points": len(prep.setup.x),
            "donut_frame_s": frames[1].wall_s, "first_frame_s": frames[0].wall_s,
            "n_substeps_per_frame": stats.engine.get("n_substeps"),
            "M_per_s": len(prep.setup.x) * stats.engine.get("n_substeps", 0) / frames[1].wall_s / 1e6}


def _versions() -> dict:
    v = {"python": platform.python_version()}
    for dist in ("numpy", "gasp", "taichi", "warp-lang", "genesis-world", "gasp-taichi-mpm",
                 "gasp-warp-mpm", "gasp-genesis"):
        try:
            v[dist] = md.version(dist)
        except md.PackageNotFoundError:
            pass
    return v


def _markdown(doc: dict) -> str:
    m = doc["machine"]
    lines = [
        "# MPM engine throughput (bench_mpm.py)",
        "",
        f"Machine: {m['cpu_count']} CPU cores ({m['processor']}), load average at start "
        f"{m['loadavg_start']}, at end {m['loadavg_end']}. Versions: "
        + ", ".join(f"{k} {v}" for k, v in doc["versions"].items()) + ".",
        "",
        f"Scene: jelly / neo-Hookean block at 8 points per cell, n_grid {N_GRID}, f32, CPU, "
        f"{SUBSTEPS} substeps per frame, {doc['frames']} timed frames after a warm-up frame. "
        "M/s = million particle-substeps per wall-clock second; per CPU-s divides by the process "
        "CPU time (the machine is shared, so wall figures depend on the load).",
        "",
        "| engine | material | points | M/s (wall) | M/s per CPU-s | threads | first frame s |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for r in doc["results"]:
        if "donut_frame_s" in r:
            continue
        if "error" in r:
            lines.append(f"| {r['engine']} | {r['material']} | {r['n_points']} | error: "
                         f"{r['error'][:80]} | | | |")
        else:
            lines.append(f"| {r['engine']} | {r['material']} | {r['n_points']} | {r['M_per_s']:.2f} | "
                         f"{r['M_per_cpu_s']:.2f} | {r.get('threads')} | {r['first_frame_s']:.1f} |")
    donut = [r for r in doc["results"] if "donut_frame_s" in r]
    if donut:
        lines += ["", "Wall time of one frame of the README donut (examples/donut_jelly.toml: 45,624 "
                  "Gaussians -> triangle vertices + interior fill, n_grid 64, f32, CPU), frame 2 "
                  "(frame 1 compiles):", "",
                  "| engine | points | substeps/frame | s per frame | M/s (wall) |", "|---|---:|---:|---:|---:|"]
        for r in donut:
            lines.append(f"| {r['engine']} | {r['n_points']} | {r['n_substeps_per_frame']} | "
                         f"{r['donut_frame_s']:.2f} | {r['M_per_s']:.2f} |")
    if doc["ratios"]:
        lines += ["", f"Ratios measured in this run (wall-clock throughput, engine / {doc['reference']}):", "",
                  "| engine | material | points | ratio |", "|---|---|---:|---:|"]
        for r in doc["ratios"]:
            lines.append(f"| {r['engine']} | {r['material']} | {r['n_points']} | {r['ratio']:.2f} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engines", default=None,
                    help="comma-separated engine names (default: all installed grid engines)")
    ap.add_argument("--sizes", default="50000,200000", help="target point counts")
    ap.add_argument("--materials", default="jelly,neo_hookean")
    ap.add_argument("--frames", type=int, default=3, help=f"timed frames ({SUBSTEPS} substeps each)")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per engine")
    ap.add_argument("--out", default=str(RESULTS), help="output folder")
    ap.add_argument("--no-donut", action="store_true", help="skip the donut-frame timing")
    ap.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",") if s]
    materials = [s for s in a.materials.split(",") if s]
    if a.worker:
        print(json.dumps(worker(a.worker, sizes, materials, a.frames, not a.no_donut)))
        return 0

    from gasp_core.seam.plugins import engines
    found = engines()
    if a.engines:
        names = [s.strip() for s in a.engines.split(",") if s.strip()]
        missing = [s for s in names if s not in found]
        if missing:
            ap.error(f"--engines: not installed: {missing}; installed: {sorted(found)}")
    else:
        names = [k for k, v in found.items() if "grid" in v.capabilities.features and not v.unavailable_reason()]
    doc = {"machine": {"cpu_count": os.cpu_count(), "processor": platform.processor() or platform.machine(),
                       "platform": platform.platform(), "loadavg_start": [round(x, 2) for x in os.getloadavg()]},
           "versions": _versions(), "substeps_per_frame": SUBSTEPS, "n_grid": N_GRID, "frames": a.frames,
           "results": []}
    for name in names:
        cmd = [sys.executable, __file__, "--worker", name, "--sizes", a.sizes, "--materials",
               a.materials, "--frames", str(a.frames)] + (["--no-donut"] if a.no_donut else [])
        print(f"[bench_mpm] {name} ...", file=sys.stderr, flush=True)
        try:
            p = subprocess.run(cmd, capture_output=True, text=True, timeout=a.timeout)
            lines = [ln for ln in p.stdout.splitlines() if ln.startswith("[")]
            if p.returncode != 0 or not lines:
                raise RuntimeError(f"exit {p.returncode}: {p.stderr.strip().splitlines()[-1:] }")
            doc["results"] += json.loads(lines[-1])
        except Exception as e:  # timeout or crash of one engine: record and go on
            doc["results"].append({"engine": name, "material": "*", "n_points": 0,
                                   "error": f"{type(e).__name__}: {e}"})
    doc["machine"]["loadavg_end"] = [round(x, 2) for x in os.getloadavg()]
    ok = [r for r in doc["results"] if "error" not in r and "donut_frame_s" not in r]
    ref = names[0] if names else None
    doc["reference"] = ref
    doc["ratios"] = []
    base = {(r["material"], r["n_points"]): r["M_per_s"] for r in ok if r["engine"] == ref}
    for r in ok:
        if r["engine"] != ref and (r["material"], r["n_points"]) in base:
            doc["ratios"].append({"engine": r["engine"], "material": r["material"], "n_points": r["n_points"],
                                  "ratio": r["M_per_s"] / base[(r["material"], r["n_points"])]})
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_mpm.json").write_text(json.dumps(doc, indent=2) + "\n")
    (out / "bench_mpm.md").write_text(_markdown(doc))
    print(_markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
