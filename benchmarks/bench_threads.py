"""How well taichi_mpm uses the CPU cores: 1 thread vs all cores, a per-kernel profile, and the README donut.

Three measurements, each written to ``benchmarks/results/`` (``bench_threads.json``, ``bench_threads.md`` and,
with matplotlib, ``bench_threads_profile.png``):

* **scaling** - ``bench_mpm``'s jelly block (``make_setup``: 8 points per cell, n_grid 64, f32, 10 substeps per
  frame) at each ``--sizes``, with ``threads = 1``, ``threads = <all cores>`` (each worker pinned to its own
  core, the engine's default), the same left to the scheduler (``pin_threads = false``) and all cores' threads
  on one core (``taskset -c 0``: the cost of the threading itself). Each case is a fresh subprocess; the cases
  are interleaved (``1, N, pinned, 1, N, pinned, ...``) so that each ratio N / 1 compares runs measured
  next to each other under the same machine load. Reported: M particle-substeps per wall second, cores
  used (process user + system CPU / wall) and the median of the per-round ratios.
* **profile** - the time of each taichi_mpm kernel per substep (each launch followed by ``ti.sync()``),
  the Python and launch time between kernels (a frame's ``substeps()`` minus its kernels) and the host
  work per frame (``step_frame`` minus ``substeps``), on 1 and all threads; with ``--base DIR`` also for
  the checkout in DIR (the figure puts the two side by side).
* **donut** (``--donut-frames N``) - ``gasp simulate examples/donut_jelly.toml --frames N`` end to end:
  wall time and cores used, alternating this checkout and ``--base DIR`` when given.

The machine's load at the start and end is recorded; on a shared machine only the ratios mean much.

Usage (the lead's one-line re-measurement on a quiet machine, base = a checkout of the older main)::

    git worktree add --detach /tmp/gasp-base ad32b61 && \\
      python benchmarks/bench_threads.py --base /tmp/gasp-base --rounds 3 --donut-frames 36
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
RESULTS = HERE / "results"
PLUGINS = ("taichi_mpm", "warp_mpm", "mujoco_flex", "genesis", "blender", "render_gsplat")


def _env(src: Path) -> dict:
    """Environment running the checkout ``src`` (its core and plugins first on ``PYTHONPATH``)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(src)] + [str(src / "plugins" / p) for p in PLUGINS])
    return env


# ---------------------------------------------------------------- inside the subprocess
def _engine(n: int, threads: int, pin: bool = True):
    sys.path.insert(0, str(HERE))
    from bench_mpm import make_setup
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    setup = make_setup(n, "jelly")
    setup.options["threads"] = threads
    setup.options["pin_threads"] = pin
    eng = build_engine(get_engine("taichi_mpm"), setup)
    eng.step_frame()                                   # compiles
    return eng, len(setup.x)


def worker_scaling(n: int, threads: int, frames: int, pin: bool = True) -> dict:
    """Throughput of ``frames`` frames after a warm-up frame (``pin``: taichi_mpm's ``pin_threads``)."""
    eng, n_points = _engine(n, threads, pin)
    st = eng.stats()
    w0, c0 = time.perf_counter(), time.process_time()
    for _ in range(frames):
        eng.step_frame()
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    work = n_points * st["n_substeps"] * frames
    return {"n_points": n_points, "threads": threads, "p2g": st["p2g"], "wall_s": wall, "cpu_s": cpu,
            "M_per_s": work / wall / 1e6, "cores": cpu / wall, "pinned_cores": st.get("pinned_cores")}


def worker_profile(n: int, threads: int, frames: int) -> dict:
    """Milliseconds per substep of each kernel, of Python + launches between them, and of host work per frame."""
    import taichi as ti
    from gasp_taichi_mpm.solver import SORT_EVERY
    eng, n_points = _engine(n, threads)
    s, n_sub = eng.solver, eng.n_substeps
    kern, kmin, kcpu = {}, {}, {}

    def timed(name, f, *a):
        ti.sync()
        t0, c0 = time.perf_counter(), time.process_time()
        f(*a)
        ti.sync()
        dt = time.perf_counter() - t0
        kern[name] = kern.get(name, 0.0) + dt
        kmin[name] = min(kmin.get(name, dt), dt)
        kcpu[name] = kcpu.get(name, 0.0) + time.process_time() - c0

    t_sub = t_frame = 0.0

    def p2g(with_g2p, substep):   # the solver's p2g_substep, kernel by kernel
        if not s.coloured:
            timed("g2p_p2g", s.g2p_p2g, with_g2p)
        else:
            if substep % SORT_EVERY == 0:
                timed("sort_blocks", s.sort_blocks)
            s.p2g_begin()
            for c in range(8):
                timed("g2p_p2g", s.g2p_p2g_colour, c, with_g2p)
            timed("p2g_late", s.p2g_late)
        if s.visc is not None:
            timed("viscosity", s.visc.solve)

    for _ in range(frames):
        p2g(0, 0)           # the solver's substeps(), kernel by kernel
        for _k in range(n_sub - 1):
            timed("grid_update", s.grid_update)
            p2g(1, _k + 1)
        timed("grid_update", s.grid_update)
        timed("g2p", s.g2p)
        ti.sync()
        t0 = time.perf_counter()
        s.substeps(n_sub)
        ti.sync()
        t1 = time.perf_counter()
        eng.step_frame()
        t_frame += time.perf_counter() - t1
        t_sub += t1 - t0
    per = frames * n_sub
    out = {f"{k}_ms": v / per * 1e3 for k, v in kern.items()}
    sub_ms = t_sub / per * 1e3
    out["python_launch_ms"] = max(sub_ms - sum(out.values()), 0.0)
    # least disturbed launch of each kernel, and its CPU time (all threads) per substep: robust to machine load
    out.update({f"{k}_min_ms": v * 1e3 / (n_sub if k == "g2p" else 1) for k, v in kmin.items()})   # g2p: once a frame
    out.update({f"{k}_cpu_ms": v / per * 1e3 for k, v in kcpu.items()})
    out["host_per_frame_ms"] = max((t_frame / frames - t_sub / frames) * 1e3, 0.0)
    out.update(n_points=n_points, threads=threads, p2g=eng.stats()["p2g"], substep_ms=sub_ms)
    return out


# ---------------------------------------------------------------- driver
def _run_worker(src: Path, what: str, n: int, threads: int, frames: int, one_core: bool,
                no_pin: bool = False) -> dict:
    cmd = ([] if not one_core else ["taskset", "-c", "0"]) + [
        sys.executable, __file__, "--worker", what, "--sizes", str(n), "--threads", str(threads), "--frames",
        str(frames)] + (["--no-pin"] if no_pin else [])
    p = subprocess.run(cmd, capture_output=True, text=True, env=_env(src), timeout=1800)
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
    if p.returncode != 0 or not lines:
        return {"error": (p.stderr.strip().splitlines() or [f"exit {p.returncode}"])[-1]}
    return json.loads(lines[-1])


def scaling(src: Path, sizes: list[int], frames: int, rounds: int, ncpu: int) -> list[dict]:
    """Interleaved rounds of (1 thread, all threads each pinned to its core, all threads left to the scheduler,
    all threads on one core) per size."""
    rows = []
    for n in sizes:
        for r in range(rounds):
            cases = [("1 thread", 1, False, False), (f"{ncpu} threads", ncpu, False, False),
                     (f"{ncpu} threads, unpinned", ncpu, False, True)]
            if shutil.which("taskset"):
                cases.append((f"{ncpu} threads, 1 core", ncpu, True, False))
            for label, threads, one_core, no_pin in cases:
                rec = _run_worker(src, "scaling", n, threads, frames, one_core, no_pin)
                rec.update(case=label, round=r, n_target=n)
                rows.append(rec)
                print(json.dumps(rec), file=sys.stderr, flush=True)
    return rows


def ratios(rows: list[dict], ncpu: int) -> list[dict]:
    """Per size: the median over rounds of (all threads / 1 thread) wall throughput, and of cores used."""
    out = []
    for n in sorted({r["n_target"] for r in rows}):
        per_round = []
        for r in sorted({r["round"] for r in rows}):
            one = [x for x in rows if x["n_target"] == n and x["round"] == r and x["case"] == "1 thread"]
            many = [x for x in rows if x["n_target"] == n and x["round"] == r and x["case"] == f"{ncpu} threads"]
            pinned = [x for x in rows if x["n_target"] == n and x["round"] == r and x["case"].endswith("1 core")]
            free = [x for x in rows if x["n_target"] == n and x["round"] == r and x["case"].endswith("unpinned")]
            if one and many and "error" not in one[0] and "error" not in many[0]:
                per_round.append((many[0]["M_per_s"] / one[0]["M_per_s"], many[0]["cores"],
                                  pinned[0]["M_per_s"] / one[0]["M_per_s"] if pinned and "error" not in pinned[0]
                                  else float("nan"),
                                  free[0]["M_per_s"] / one[0]["M_per_s"] if free and "error" not in free[0]
                                  else float("nan")))
        if per_round:
            a = np.array(per_round)
            out.append({"n_target": n, "speedup": float(np.median(a[:, 0])), "speedups": a[:, 0].round(3).tolist(),
                        "cores": float(np.median(a[:, 1])), "pinned_vs_1": float(np.nanmedian(a[:, 2])),
                        "unpinned_vs_1": float(np.nanmedian(a[:, 3])), "unpinned": a[:, 3].round(3).tolist()})
    return out


def donut(srcs: dict[str, Path], frames: int, rounds: int, scene: Path | None = None) -> list[dict]:
    """``gasp simulate`` of the README donut (or ``scene``: one file both checkouts read, all else equal),
    alternating the checkouts: wall, CPU and cores used."""
    rows = []
    scene = scene or ROOT / "examples" / "donut_jelly.toml"
    for r in range(rounds):
        for name, src in srcs.items():
            with tempfile.TemporaryDirectory() as tmp:
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o",
                                    str(Path(tmp) / "out"), "--frames", str(frames), "-q"],
                                   capture_output=True, text=True, env=_env(src))
                wall = time.perf_counter() - t0
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
                rec = {"checkout": name, "round": r, "frames": frames, "wall_s": wall, "cpu_s": cpu,
                       "cores": cpu / wall, "exit": p.returncode}
                if p.returncode:
                    rec["error"] = (p.stderr.strip().splitlines() or [""])[-1]
                rows.append(rec)
                print(json.dumps(rec), file=sys.stderr, flush=True)
    return rows


def _figure(profiles: list[dict], path: Path, load: list) -> bool:
    """Stacked bars per (checkout, size, threads): wall ms per substep of each part (fastest launch of each
    kernel), and the CPU ms of all threads (the work, which the machine's load hardly changes)."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    ok = [p for p in profiles if "error" not in p]
    labels = [f"{p['checkout']}\n{p['n_points'] // 1000}k, {p['threads']} thr" for p in ok]
    fig, axes = plt.subplots(1, 2, figsize=(max(8.0, 2.0 * len(ok)), 4.2))
    for ax, kind in zip(axes, ("min", "cpu")):
        parts = [(f"g2p_p2g_{kind}_ms", "G2P + P2G (fused)"), (f"grid_update_{kind}_ms", "grid update + copy sum"),
                 (f"g2p_{kind}_ms", "last G2P")] + ([("python_launch_ms", "Python + launches (mean)")]
                                                   if kind == "min" else [])
        bottom = np.zeros(len(ok))
        for key, name in parts:
            vals = np.array([p.get(key, 0.0) for p in ok])
            ax.bar(range(len(ok)), vals, bottom=bottom, label=name)
            bottom += vals
        ax.set_xticks(range(len(ok)), labels, fontsize=7)
        ax.set_ylabel("wall ms per substep (fastest launch)" if kind == "min" else "CPU ms per substep, all threads")
        ax.legend(fontsize=7)
    axes[0].set_title(f"wall (load average {load[0]} on {os.cpu_count()} cores)", fontsize=9)
    axes[1].set_title("CPU time: the work", fontsize=9)
    fig.suptitle("taichi_mpm substep, each kernel timed with ti.sync() (benchmarks/bench_threads.py)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def _markdown(doc: dict) -> str:
    lines = ["# taichi_mpm on all CPU cores (bench_threads.py)", "",
             f"{doc['cpu_count']} CPU cores; load average at start {doc['load_start']}, at end {doc['load_end']}. "
             f"{doc['frames']} timed frames of 10 substeps a case. Scaling rows alternate 1 thread / all threads "
             "(each worker pinned to its own core, taichi_mpm's default) / all threads left to the scheduler "
             "(`pin_threads = false`) / all threads on one core (`taskset -c 0`), so each ratio compares "
             "neighbouring runs.", "",
             "| points | speed-up all threads / 1 (median) | per round | cores used | unpinned / 1 (median) | "
             "per round | one core / 1 thread |", "|---:|---:|---|---:|---:|---|---:|"]
    for r in doc["ratios"]:
        lines.append(f"| {r['n_target']} | {r['speedup']:.2f} | {r['speedups']} | {r['cores']:.2f} | "
                     f"{r.get('unpinned_vs_1', float('nan')):.2f} | {r.get('unpinned', [])} | "
                     f"{r['pinned_vs_1']:.2f} |")
    if doc["profile"]:
        lines += ["", "Profile, ms per substep (wall: mean / fastest launch; CPU: all threads):", "",
                  "| checkout | points | threads | p2g | G2P+P2G wall | G2P+P2G CPU | grid update wall | "
                  "last G2P | Python+launch | host per frame |", "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
        for p in doc["profile"]:
            if "error" in p:
                lines.append(f"| {p['checkout']} | | | error: {p['error'][:60]} | | | | | |")
                continue
            lines.append(f"| {p['checkout']} | {p['n_points']} | {p['threads']} | {p['p2g']} | "
                         f"{p.get('g2p_p2g_ms', 0):.2f} / {p.get('g2p_p2g_min_ms', 0):.2f} | "
                         f"{p.get('g2p_p2g_cpu_ms', 0):.2f} | "
                         f"{p.get('grid_update_ms', 0):.3f} / {p.get('grid_update_min_ms', 0):.3f} | "
                         f"{p.get('g2p_ms', 0):.3f} | {p['python_launch_ms']:.3f} | {p['host_per_frame_ms']:.1f} |")
    if doc["donut"]:
        lines += ["", "README donut, `gasp simulate` end to end:", "",
                  "| checkout | round | frames | wall s | CPU s | cores used |", "|---|---:|---:|---:|---:|---:|"]
        for d in doc["donut"]:
            lines.append(f"| {d['checkout']} | {d['round']} | {d['frames']} | {d['wall_s']:.1f} | {d['cpu_s']:.1f} | "
                         f"{d['cores']:.2f} |" + (f" error: {d['error'][:60]}" if "error" in d else ""))
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="50000,200000", help="target point counts (46,656 and 195,112 points)")
    ap.add_argument("--frames", type=int, default=10, help="timed frames (10 substeps each)")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds")
    ap.add_argument("--base", type=Path, help="another checkout to profile and time the donut against")
    ap.add_argument("--no-scaling", action="store_true")
    ap.add_argument("--no-profile", action="store_true")
    ap.add_argument("--donut-frames", type=int, default=0, help="also time the README donut end to end")
    ap.add_argument("--donut-scene", type=Path,
                    help="scene file for the donut timing (default: this checkout's examples/donut_jelly.toml; "
                         "give the base's when the base cannot read this one's keys)")
    ap.add_argument("--donut-rounds", type=int, help="interleaved donut rounds (default: --rounds)")
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--threads", type=int, default=1, help=argparse.SUPPRESS)
    ap.add_argument("--no-pin", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    sizes = [int(s) for s in a.sizes.split(",") if s]
    if a.worker:
        rec = (worker_scaling(sizes[0], a.threads, a.frames, not a.no_pin) if a.worker == "scaling"
               else worker_profile(sizes[0], a.threads, a.frames))
        print(json.dumps(rec))
        return 0
    ncpu = os.cpu_count() or 1
    srcs = {"this": ROOT} | ({"base": a.base.resolve()} if a.base else {})
    doc = {"cpu_count": ncpu, "load_start": [round(x, 2) for x in os.getloadavg()], "sizes": sizes,
           "frames": a.frames, "rounds": a.rounds, "scaling": [], "ratios": [], "profile": [], "donut": []}
    if not a.no_scaling:
        doc["scaling"] = scaling(ROOT, sizes, a.frames, a.rounds, ncpu)
        doc["ratios"] = ratios(doc["scaling"], ncpu)
    if not a.no_profile:
        for name, src in srcs.items():
            for n in sizes:
                for threads in (1, ncpu):
                    rec = _run_worker(src, "profile", n, threads, max(1, a.frames - 1), False)
                    rec.update(checkout=name)
                    doc["profile"].append(rec)
                    print(json.dumps(rec), file=sys.stderr, flush=True)
    if a.donut_frames:
        doc["donut"] = donut(srcs, a.donut_frames, a.donut_rounds or a.rounds, a.donut_scene)
        doc["donut_scene"] = str(a.donut_scene or "examples/donut_jelly.toml")
    doc["load_end"] = [round(x, 2) for x in os.getloadavg()]
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "bench_threads.json").write_text(json.dumps(doc, indent=2) + "\n")
    (a.out / "bench_threads.md").write_text(_markdown(doc))
    if doc["profile"]:
        _figure(doc["profile"], a.out / "bench_threads_profile.png", doc["load_start"])
    print(_markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
