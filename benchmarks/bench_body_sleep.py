"""Sleep per body on the conformance scene ``ball_wakes_ball`` (``gasp_core/testing/scenes_sleep.py``): what a
sleeping body saves and what it costs.

For each engine the scene is run awake and with sleep (after a warm-up run that fills the kernel caches), in this
process, one after the other. Reported: the frames ball A slept (``RunStats.bodies``), the engine's wall time per
frame (``RunStats.frame_s``: ``step_frame`` and the read-back) over those frames in the sleeping run and over the
same frames of the awake run (median and mean), their ratio, the 1-minute load average before each run, and what
sleep changed: A's centroid's farthest distance from the awake run's after it fell asleep (dx) and its deepest
descent under B's impact over the awake run's (the checks ``impact_path`` and ``impact_depth``).

Run: ``python benchmarks/bench_body_sleep.py [--engines warp_mpm taichi_mpm] [--div 1]`` (``--div k``: points
``dx / (2 k)`` apart, k^3 times as many); the table goes to stdout and ``benchmarks/results/bench_body_sleep.md``.
"""
from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from gasp_core.seam.plugins import get_engine
from gasp_core.testing import scenes_sleep as S

OUT = Path(__file__).resolve().parent / "results" / "bench_body_sleep.md"


def measure(engine: str, div: int) -> dict:
    """One engine's row (see the module docstring)."""
    info = get_engine(engine)
    setup = S.build(info, spacing=S.DX / (2 * div))
    S.frames(info, setup, sleep=False, n=3)   # warm-up: kernel compilation and caches
    load_awake = os.getloadavg()[0]
    awake, st_awake = S.frames(info, setup, sleep=False)
    load_sleep = os.getloadavg()[0]
    asleep, st_sleep = S.frames(info, setup, sleep=True)
    rec = st_sleep.bodies[0]
    ks, kw = rec["slept_after_frames"][0], rec["woke_before_frames"][0]
    # frame_s[i] is frame i + 1: A asleep during frames ks + 1 .. kw - 1
    sl = np.array(st_sleep.frame_s[ks:kw - 1]) * 1e3
    aw = np.array(st_awake.frame_s[ks:kw - 1]) * 1e3
    checks = {c.name: c for c in S.ball_checks(setup, awake, asleep, st_sleep)}
    return {"engine": engine, "n_points": len(setup.x), "ks": ks, "kw": kw, "load_awake": load_awake,
            "load_sleep": load_sleep, "awake_med": float(np.median(aw)), "sleep_med": float(np.median(sl)),
            "awake_mean": float(aw.mean()), "sleep_mean": float(sl.mean()),
            "path": checks["impact_path"].figures["value"], "depth": checks["impact_depth"].figures["value"],
            "passed": all(c.passed for c in checks.values())}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--div", type=int, default=1)
    args = ap.parse_args()
    head = ("| engine | points | A asleep (frames) | ms/frame awake (median, mean) | ms/frame A asleep (median, mean) "
            "| ratio (median) | load before (awake, sleep) | A's path off the awake run (dx) | A's depth / awake | checks |")
    lines = [head, "|" + "---|" * 10]
    for e in args.engines:
        r = measure(e, args.div)
        lines.append(f"| {e} | {r['n_points']} | {r['ks'] + 1}-{r['kw'] - 1} ({r['kw'] - 1 - r['ks']}) | "
                     f"{r['awake_med']:.2f}, {r['awake_mean']:.2f} | {r['sleep_med']:.2f}, {r['sleep_mean']:.2f} | "
                     f"{r['sleep_med'] / r['awake_med']:.2f} | {r['load_awake']:.2f}, {r['load_sleep']:.2f} | "
                     f"{r['path']:.3f} | {r['depth']:.4f} | {'pass' if r['passed'] else 'FAIL'} |")
        print(lines[-1], flush=True)
    text = "\n".join([f"# Sleep per body: ball_wakes_ball (--div {args.div})", "",
                      "`python benchmarks/bench_body_sleep.py` (see its docstring). 2-core machine shared with "
                      "other work: the load average is beside each run.", "", *lines, ""])
    OUT.parent.mkdir(exist_ok=True)
    mode = "a" if OUT.exists() else "w"
    with OUT.open(mode) as f:
        f.write(("\n" if mode == "a" else "") + text)
    print(text)


if __name__ == "__main__":
    main()
