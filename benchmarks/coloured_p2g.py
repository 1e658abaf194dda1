"""Prototype (issue 29, phase A): a coloured block P2G for taichi_mpm on CPU, and what the block sort costs.

The points are sorted by grid block (``B`` nodes a side, keyed by the point's stencil base ``floor(X - 0.5)``)
with a deterministic counting sort in Taichi, then scattered in 2^3 = 8 coloured passes. Blocks of one
colour are a block apart, so with ``B = 4`` the 3-node stencils of two same-colour blocks never overlap
even when a point has drifted one cell out of its block since the sort: each pass scatters with plain
adds into one global grid, and a node's sum is the same on any thread count (fixed colour order, one
block per node and pass, the block's points in sorted order). A point that drifted further is scattered
after the 8 passes, serially, in sorted order.

Taichi 1.7.4 parallelises only a kernel's outermost loop, and its CPU backend cuts that loop into one
contiguous range per thread of at least 512 iterations (``make_cpu_multithreaded_range_for.cpp``,
``minimal_block_range = 512``): a loop over 16 or 500 blocks runs on one thread. So each pass loops over
the *points* of its colour; the iteration at a block's first point scatters the whole block, the others
do nothing. Thread ``t`` gets the blocks that start in its share of the points: balanced by point count.

The sort is redone every ``sort_every`` substeps (and at every frame's first: ``--resume`` sees the same
order). It is stable with respect to the solver's point order, so the whole run is a function of the state
at the start of a frame.

Usage::

    python benchmarks/coloured_p2g.py check            # same numbers on 1 and 2 threads, against the chunked P2G
    python benchmarks/coloured_p2g.py bench N THREADS MODE   # MODE: coloured | chunks
"""
from __future__ import annotations

import json
import resource
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def per_thread_cpu() -> dict[str, float]:
    """CPU seconds of each thread of this process (``/proc/self/task/*/stat``), by thread id."""
    import os
    tick = os.sysconf("SC_CLK_TCK")
    out = {}
    for t in Path("/proc/self/task").iterdir():
        f = (t / "stat").read_text().rsplit(")", 1)[1].split()
        out[t.name] = (int(f[11]) + int(f[12])) / tick
    return out


def build(n: int, threads: int, mode: str, material: str = "jelly", sort_every: int = 10):
    import taichi as ti
    sys.path.insert(0, str(HERE))
    from bench_mpm import make_setup
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    setup = make_setup(n, material)
    setup.options["threads"] = threads
    if mode == "coloured":
        from coloured_solver import install
        install(sort_every)
    eng = build_engine(get_engine("taichi_mpm"), setup)
    return eng, setup


def bench(n: int, threads: int, mode: str, frames: int = 10, material: str = "jelly") -> dict:
    eng, setup = build(n, threads, mode, material)
    eng.step_frame()
    if hasattr(eng.solver, "sort_stats"):
        eng.solver.n_sorts, eng.solver.sort_s, eng.solver.late_total = 0, 0.0, 0
    c_thr0 = per_thread_cpu()
    w0, r0 = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF)
    for _ in range(frames):
        eng.step_frame()
    wall, r1 = time.perf_counter() - w0, resource.getrusage(resource.RUSAGE_SELF)
    cpu = r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime
    thr = per_thread_cpu()
    work = len(setup.x) * eng.n_substeps * frames
    rec = {"mode": mode, "n_points": len(setup.x), "threads": threads, "material": material, "wall_s": wall,
           "cpu_s": cpu, "cores": cpu / wall, "M_per_s": work / wall / 1e6, "M_per_cpu_s": work / cpu / 1e6,
           "threads_cpu_s": sorted((round(v - c_thr0.get(k, 0.0), 2) for k, v in thr.items()), reverse=True)[:4]}
    s = eng.solver
    if hasattr(s, "sort_stats"):
        rec.update(s.sort_stats())
    return rec


def check() -> None:
    """Coloured on 1 and 2 threads bit-identical; coloured vs chunked within rounding."""
    import subprocess
    out = {}
    for mode, threads in (("coloured", 1), ("coloured", 2), ("chunks", 1)):
        p = subprocess.run([sys.executable, __file__, "dump", mode, str(threads)], capture_output=True, text=True)
        if p.returncode:
            print(p.stderr[-3000:])
            raise SystemExit(1)
        out[(mode, threads)] = np.load(f"/tmp/coloured_{mode}_{threads}.npy")
    a, b, c = out[("coloured", 1)], out[("coloured", 2)], out[("chunks", 1)]
    print("coloured 1 vs 2 threads bit-identical:", bool(np.array_equal(a, b)))
    print("coloured vs chunks max |dx| (m):", float(np.abs(a - c).max()))


def dump(mode: str, threads: int) -> None:
    eng, setup = build(20000, threads, mode)
    for _ in range(4):
        eng.step_frame()
    np.save(f"/tmp/coloured_{mode}_{threads}.npy", np.concatenate([eng.positions(), eng.velocities()], 1))


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "check":
        check()
    elif what == "dump":
        dump(sys.argv[2], int(sys.argv[3]))
    else:
        print(json.dumps(bench(int(sys.argv[2]), int(sys.argv[3]), sys.argv[4],
                               material=sys.argv[5] if len(sys.argv) > 5 else "jelly")))
