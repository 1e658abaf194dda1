"""taichi_mpm on 1 and N threads (issue 29): jelly and sand blocks at 46,656 and 195,112 points, interleaved, in one run.

``bench_mpm``'s scene (``make_setup``: 8 points per cell, n_grid 64, f32, 10 substeps per frame, CPU). Each case is a
fresh subprocess: build, one warm-up frame (compiles), then ``--frames`` timed frames. Reported per case: M
particle-substeps per wall second, cores used (process user + system CPU / wall), and the CPU seconds of each
thread (``/proc/self/task``): on a shared machine the wall ratio says little, but two worker threads with the same
CPU time show that the work is split evenly (what the quiet-machine speed-up then follows). The ratio N / 1 is the
median over rounds of the per-round wall-throughput ratios.

Usage::

    python benchmarks/bench_p2g_threads.py --threads 2 --rounds 3 --frames 5

Writes ``benchmarks/results/bench_p2g_threads.{json,md}``.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"


def per_thread_cpu() -> dict[str, float]:
    """CPU seconds of each thread of this process, by thread id."""
    tick = os.sysconf("SC_CLK_TCK")
    out = {}
    for t in Path("/proc/self/task").iterdir():
        f = (t / "stat").read_text().rsplit(")", 1)[1].split()
        out[t.name] = (int(f[11]) + int(f[12])) / tick
    return out


def worker(n: int, material: str, threads: int, frames: int) -> dict:
    sys.path.insert(0, str(HERE))
    from bench_mpm import make_setup
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    setup = make_setup(n, material)
    setup.options["threads"] = threads
    eng = build_engine(get_engine("taichi_mpm"), setup)
    eng.step_frame()
    c0, w0, p0 = per_thread_cpu(), time.perf_counter(), time.process_time()
    for _ in range(frames):
        eng.step_frame()
    wall, cpu, c1 = time.perf_counter() - w0, time.process_time() - p0, per_thread_cpu()
    st = eng.stats()
    work = len(setup.x) * st["n_substeps"] * frames
    main = str(os.getpid())
    workers = sorted((round(v - c0.get(k, 0.0), 2) for k, v in c1.items() if k != main), reverse=True)
    return {"n_points": len(setup.x), "material": material, "threads": threads, "p2g": st["p2g"],
            "wall_s": round(wall, 3), "cpu_s": round(cpu, 3), "cores": round(cpu / wall, 3),
            "M_per_s": round(work / wall / 1e6, 3), "M_per_cpu_s": round(work / cpu / 1e6, 3),
            "main_thread_cpu_s": round(c1.get(main, 0.0) - c0.get(main, 0.0), 2), "worker_threads_cpu_s": workers[:4],
            "late_points": st.get("late_points")}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="46656,195112")
    ap.add_argument("--materials", default="jelly,sand")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--frames", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", type=Path, default=RESULTS)
    ap.add_argument("--worker", nargs=4, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        n, mat, thr, fr = a.worker
        print(json.dumps(worker(int(n), mat, int(thr), int(fr))))
        return 0
    doc = {"cpu_count": os.cpu_count(), "load_start": [round(x, 2) for x in os.getloadavg()], "rows": []}
    for r in range(a.rounds):
        for n in [int(s) for s in a.sizes.split(",")]:
            for mat in a.materials.split(","):
                for thr in (1, a.threads):
                    p = subprocess.run([sys.executable, __file__, "--worker", str(n), mat, str(thr), str(a.frames)],
                                       capture_output=True, text=True)
                    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("{")]
                    rec = json.loads(lines[-1]) if lines else {"error": (p.stderr.strip().splitlines() or ["?"])[-1]}
                    rec.update(round=r, n_target=n, material=mat, threads=thr)
                    doc["rows"].append(rec)
                    print(json.dumps(rec), file=sys.stderr, flush=True)
    doc["load_end"] = [round(x, 2) for x in os.getloadavg()]
    ratios = []
    for n in {r["n_target"] for r in doc["rows"]}:
        for mat in a.materials.split(","):
            per = []
            for r in range(a.rounds):
                one = [x for x in doc["rows"] if (x["n_target"], x["material"], x["round"], x["threads"]) == (n, mat, r, 1)]
                many = [x for x in doc["rows"] if (x["n_target"], x["material"], x["round"], x["threads"]) ==
                        (n, mat, r, a.threads)]
                if one and many and "M_per_s" in one[0] and "M_per_s" in many[0]:
                    per.append(many[0]["M_per_s"] / one[0]["M_per_s"])
            if per:
                ratios.append({"n_target": n, "material": mat, "speedup": round(statistics.median(per), 3),
                               "per_round": [round(x, 3) for x in per]})
    doc["ratios"] = sorted(ratios, key=lambda d: (d["material"], d["n_target"]))
    lines = ["# taichi_mpm, 1 vs N threads (bench_p2g_threads.py)", "",
             f"{doc['cpu_count']} cores; load average at start {doc['load_start']}, at end {doc['load_end']} "
             f"(above the core count: loaded, wall figures are the machine's).", "",
             "| material | points | threads | M/s wall | cores used | main thread CPU s | worker threads CPU s | late points |",
             "|---|---:|---:|---:|---:|---:|---|---:|"]
    for x in doc["rows"]:
        if "error" in x:
            lines.append(f"| {x['material']} | {x['n_target']} | {x['threads']} | error: {x['error'][:60]} | | | | |")
        else:
            lines.append(f"| {x['material']} | {x['n_points']} | {x['threads']} | {x['M_per_s']} | {x['cores']} | "
                         f"{x['main_thread_cpu_s']} | {x['worker_threads_cpu_s']} | {x['late_points']} |")
    lines += ["", f"Speed-up, {a.threads} threads / 1 (median over rounds of the wall-throughput ratio):", "",
              "| material | points | speed-up | per round |", "|---|---:|---:|---|"]
    lines += [f"| {x['material']} | {x['n_target']} | {x['speedup']} | {x['per_round']} |" for x in doc["ratios"]]
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "bench_p2g_threads.json").write_text(json.dumps(doc, indent=2) + "\n")
    (a.out / "bench_p2g_threads.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
