"""The passive G2P of taichi_mpm on the CPU, by variant (issue 65, round 39: docs/performance.md).

One scene (default ``examples/donut_shatter.toml``) is run to frame ``--frames`` on the CPU with Taichi's kernel
profiler; then its passive G2P kernel (``Transfers.g2p_passive``, weight pair 0) is launched ``--reps`` times on
that frame's grid, the passive rows' x, v and C restored before each launch (the same inputs every time), and the
kernel's loops' times (ms) printed: the gather (``kernel_1``) and the node box (``kernel_4``). Variants (each a
process: the switches are read when the kernels are built): ``fast`` (``Transfers.PASSIVE_FAST_INVERSE``),
``span`` (``grid_tables.PASSIVE_SPANNED``).

Each run appends its line to ``benchmarks/results/passive_g2p.md`` (``--out``); that file's table is the round-39
comparison (main's checkout run with ``PYTHONPATH`` for the "before").
Run:  python benchmarks/bench_passive_g2p.py --fast 1 [--threads 2]
"""
import argparse
import contextlib
import io
import sys
import time
import warnings

sys.path.insert(0, "benchmarks")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default="donut_shatter")
    ap.add_argument("--fast", type=int, default=1)
    ap.add_argument("--out", default="benchmarks/results/passive_g2p.md")
    ap.add_argument("--span", type=int, default=1)
    ap.add_argument("--frames", type=int, default=1)
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--threads", type=int, default=2)
    a = ap.parse_args()
    import bench_gpu as bg
    import taichi as ti
    import gasp_core.mpm.grid_tables as gt
    from gasp_taichi_mpm.transfers import Transfers
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import EngineRun, RunStats
    gt.PASSIVE_SPANNED = bool(a.span)
    Transfers.PASSIVE_FAST_INVERSE = bool(a.fast)
    bg.profiled(True)
    sc = load_scene(f"examples/{a.scene}.toml")
    opts = dict(sc.engine.options)
    opts.update(device="cpu", threads=a.threads)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(sc, "taichi_mpm", options=opts)
    with EngineRun(prep.info, prep.setup, RunStats()) as run:
        for rec in run.frames(a.frames):
            print(f"frame {rec.frame}: {rec.wall_s:.2f} s", flush=True)
        s = run.engine.solver
        n0, n1 = int(s.n_points[None]), int(s.n_total[None])
        keep = [(f, f.to_numpy()) for f in (s.x, s.v, s.C)]
        ti.sync()
        ti.profiler.clear_kernel_profiler_info()
        t_wall = []
        for _ in range(a.reps):
            for f, arr in keep:
                f.from_numpy(arr)
            ti.sync()
            t0 = time.perf_counter()
            s.g2p_passive(0)
            ti.sync()
            t_wall.append(1e3 * (time.perf_counter() - t0))
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf):
            ti.profiler.print_kernel_profiler_info("count")
    t_wall.sort()
    rows = [ln for ln in buf.getvalue().splitlines()
            if "g2p_passive" in ln and ("kernel_1_" in ln or "kernel_4_" in ln)]
    line = (f"| {time.strftime('%Y-%m-%d %H:%M')} | {a.scene} frame {a.frames} | fast={a.fast} span={a.span} | "
            f"{a.threads} | {n1 - n0} | {t_wall[0]:.1f} | {t_wall[len(t_wall) // 2]:.1f} | "
            + " ; ".join(r.split("|")[1].split("]")[0].strip() for r in rows) + " |")
    print(line)
    print("\n".join(rows))
    with open(a.out, "a") as f:
        f.write(line + "\n")


if __name__ == "__main__":
    main()
