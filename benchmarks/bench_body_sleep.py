"""Sleep per body on the conformance scene ``ball_wakes_ball`` (``gasp_core/testing/scenes_sleep.py``): what a
sleeping body saves and what it costs.

For each engine the scene is run awake and with sleep, alternately, ``--reps`` times each (after a warm-up run that
fills the kernel caches), in this process. Reported: the frames ball A slept (``RunStats.bodies``), the engine's
median wall time per frame (``RunStats.frame_s``: ``step_frame`` and the read-back) over those frames in each
sleeping run and over the same frames of each awake run, their ratio, the same ratio with each run's time divided by
its own median over the frames before A slept (the same work in both: what the shared machine gave that run), the
1-minute load average before each run, and what
sleep changed: A's centroid's farthest distance from the awake run's after it fell asleep (dx) and its deepest
descent under B's impact over the awake run's (the checks ``impact_path`` and ``impact_depth``).

Run: ``python benchmarks/bench_body_sleep.py [--engines warp_mpm taichi_mpm] [--div 1]`` (``--div k``: points
``dx / (2 k)`` apart, k^3 times as many: A no longer settles within the scene's frames, so only the flag-only
table is made at k = 2 too); the table goes to stdout and ``benchmarks/results/bench_body_sleep.md``.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import get_engine
from gasp_core.testing import scenes_sleep as S

OUT = Path(__file__).resolve().parent / "results" / "bench_body_sleep.md"


def measure(engine: str, div: int, reps: int, options: dict) -> dict:
    """One engine's row (see the module docstring): ``reps`` pairs of runs, awake and asleep alternately."""
    info = get_engine(engine)
    setup = S.build(info, spacing=S.DX / (2 * div))
    setup.options = dict(options)
    S.frames(info, setup, sleep=False, n=3)   # warm-up: kernel compilation and caches
    runs = {False: [], True: []}
    for _ in range(reps):
        for sleep in (False, True):
            load = os.getloadavg()[0]
            xs, st = S.frames(info, setup, sleep=sleep)
            runs[sleep].append((load, xs, st))
    st_sleep = runs[True][0][2]
    rec = st_sleep.bodies[0]
    ks, kw = rec["slept_after_frames"][0], rec["woke_before_frames"][0]

    def per_frame(st) -> tuple[float, float]:
        """Median ms per frame while A sleeps (frames ks + 1 .. kw - 1, ``frame_s[ks:kw - 1]``), and over the
        frames before it slept (the same work in both runs: the machine's speed at that moment)."""
        f = np.array(st.frame_s) * 1e3
        return float(np.median(f[ks:kw - 1])), float(np.median(f[:ks]))
    aw = [per_frame(r[2]) for r in runs[False]]
    sl = [per_frame(r[2]) for r in runs[True]]
    checks = {c.name: c for c in S.ball_checks(setup, runs[False][0][1], runs[True][0][1], st_sleep)}
    return {"engine": engine, "n_points": len(setup.x), "ks": ks, "kw": kw,
            "loads": [r[0] for r in runs[False] + runs[True]], "awake": aw, "sleep": sl,
            "path": checks["impact_path"].figures["value"], "depth": checks["impact_depth"].figures["value"],
            "passed": all(c.passed for c in checks.values())}


def flag_only(engine: str, div: int, reps: int, options: dict, start: int = 23, frames: int = 20) -> dict:
    """The engine alone, from one state (after ``start`` frames of the awake scene), ``frames`` frames with A flagged
    asleep and with it awake, ``reps`` times each, alternately (``set_state`` back to the same state before each):
    ms per frame of each. Only the flag differs, so this is what the flag saves, free of the run-to-run drift."""
    info = get_engine(engine)
    setup = S.build(info, spacing=S.DX / (2 * div))
    setup.options = dict(options)
    eng = build_engine(info, setup)
    try:
        for _ in range(start):
            eng.step_frame()
        state = eng.get_state()
        out = {False: [], True: [], "load": os.getloadavg()[0], "n_points": len(setup.x),
               "n_substeps": eng.stats().get("n_substeps")}
        for _ in range(reps):
            for flag in (False, True):
                eng.set_state(state)
                eng.set_asleep(np.array([flag, False]))
                t0 = time.perf_counter()
                for _ in range(frames):
                    eng.step_frame()
                out[flag].append((time.perf_counter() - t0) / frames * 1e3)
        return out
    finally:
        eng.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--div", type=int, default=1)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--threads", type=int, default=0, help="taichi_mpm's option threads (0: its default)")
    args = ap.parse_args()
    head = ("| engine | points | A asleep (frames) | ms/frame over those frames, awake runs | the same, sleeping runs "
            "| sleeping / awake (median of runs) | the same, each run over its own frames before A slept "
            "| load before each run | A's path off the awake run (dx) | A's depth / awake | checks |")
    lines = [head, "|" + "---|" * 11]
    for e in args.engines:
        opts = {"threads": args.threads} if args.threads and e == "taichi_mpm" else {}
        r = measure(e, args.div, args.reps, opts)
        a_med, s_med = np.median([a for a, _ in r["awake"]]), np.median([s for s, _ in r["sleep"]])
        a_rel = np.median([a / b for a, b in r["awake"]])
        s_rel = np.median([s / b for s, b in r["sleep"]])
        lines.append(f"| {e}{' threads ' + str(args.threads) if opts else ''} | {r['n_points']} | "
                     f"{r['ks'] + 1}-{r['kw'] - 1} ({r['kw'] - 1 - r['ks']}) | "
                     f"{', '.join(f'{a:.1f}' for a, _ in r['awake'])} | {', '.join(f'{s:.1f}' for s, _ in r['sleep'])} | "
                     f"{s_med / a_med:.2f} | {s_rel / a_rel:.2f} ({s_rel:.2f} / {a_rel:.2f}) | "
                     f"{', '.join(f'{x:.2f}' for x in r['loads'])} | "
                     f"{r['path']:.3f} | {r['depth']:.4f} | {'pass' if r['passed'] else 'FAIL'} |")
        print(lines[-1], flush=True)
    lines += ["", "The flag alone (`flag_only`: one state after frame 23, 20 frames with A flagged asleep and awake, "
              "alternately; ms per frame each repetition):", "",
              "| engine | points | substeps/frame | A awake | A asleep | asleep / awake (medians) | load before |",
              "|" + "---|" * 7]
    for e in args.engines:
        opts = {"threads": args.threads} if args.threads and e == "taichi_mpm" else {}
        for div in sorted({1, args.div, 2}):
            r = flag_only(e, div, args.reps, opts)
            lines.append(f"| {e}{' threads ' + str(args.threads) if opts else ''} | {r['n_points']} | "
                         f"{r['n_substeps']} | {', '.join(f'{a:.1f}' for a in r[False])} | "
                         f"{', '.join(f'{a:.1f}' for a in r[True])} | "
                         f"{np.median(r[True]) / np.median(r[False]):.2f} | {r['load']:.2f} |")
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
