"""The cost of ``stress_at``'s default (the trapezoid since round 70, docs/fracture.md "Round 70: the trapezoid as the
default"; ``gasp_core.mpm.stress_at``) against "start" on the README donut (``examples/donut_jelly.toml``, the scene
as the quick start runs it: its quality level, n_grid 64, the jelly's viscosity): the engine stepped directly, 2
frames of warm-up (kernels compiled), then ``FRAMES`` frames timed (wall and CPU seconds, per substep and per frame),
"start" and "trapezoid" alternating in one process, ``ROUNDS`` pairs an engine; the ratio trapezoid / start of each
pair. Round 69 measured 1.11-1.18x a frame on a jelly donut (``benchmarks/studies/stress_at_cost.py``, not quiet).

Run (quietly: nothing else on the machine): ``python benchmarks/bench_stress_at_cost.py [--engines taichi_mpm
warp_mpm] [--frames 4] [--rounds 2]``; the table goes to stdout and ``benchmarks/results/stress_at_cost.md`` (with
the load average before each pair). ``--only start|trapezoid``: one engine's run of that scheme (2 + FRAMES frames),
nothing timed or written: for a whole-process timing of the two schemes from outside (``/usr/bin/time -v`` each).
"""
from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCHEMES = ("start", "trapezoid")


def build(engine: str, at: str):
    """The README donut's engine on ``engine`` with ``stress_at = at``."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    scene = load_scene(ROOT / "examples" / "donut_jelly.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(scene, engine)
        setup = ps.setup.replace(options={**ps.setup.options, "stress_at": at})
        return build_engine(engines()[engine], setup)


def timed(engine: str, at: str, frames: int) -> dict:
    """Wall and CPU seconds of ``frames`` frames after 2 warm-up frames, and the substeps they took."""
    e = build(engine, at)
    try:
        for _ in range(2):
            e.step_frame()
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(frames):
            e.step_frame()
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        n = int(e.n_substeps)   # chosen once at the build (docs/mpm.md): the same every frame on a jelly
    finally:
        e.close()
    return {"wall": wall, "cpu": cpu, "substeps": frames * n}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["taichi_mpm", "warp_mpm"])
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--only", choices=SCHEMES, default=None)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "stress_at_cost.md")
    a = ap.parse_args(argv)
    if a.only:
        for engine in a.engines:
            e = build(engine, a.only)
            try:
                for _ in range(2 + a.frames):
                    e.step_frame()
            finally:
                e.close()
        return 0
    rows = ["| engine | pair | load avg | substeps (start / trapezoid) | wall s a frame: start | trapezoid | ratio "
            "| ms a substep: start | trapezoid | ratio | CPU s a frame: start | trapezoid | ratio |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    ratios = {}
    for engine in a.engines:
        for r in range(a.rounds):
            load = os.getloadavg()[0]
            s, t = (timed(engine, at, a.frames) for at in SCHEMES)
            ms = [1e3 * x["wall"] / x["substeps"] for x in (s, t)]
            rw, rs, rc = t["wall"] / s["wall"], ms[1] / ms[0], t["cpu"] / s["cpu"]
            ratios.setdefault(engine, []).append((rw, rs, rc))
            rows.append(f"| {engine} | {r + 1} | {load:.2f} | {s['substeps']} / {t['substeps']} | "
                        f"{s['wall'] / a.frames:.3f} | {t['wall'] / a.frames:.3f} | {rw:.3f} | {ms[0]:.2f} | "
                        f"{ms[1]:.2f} | {rs:.3f} | {s['cpu'] / a.frames:.3f} | {t['cpu'] / a.frames:.3f} | {rc:.3f} |")
            print(rows[-1], flush=True)
    summary = [f"{e}: trapezoid / start a frame, wall {min(x[0] for x in v):.3f}-{max(x[0] for x in v):.3f}, "
               f"a substep {min(x[1] for x in v):.3f}-{max(x[1] for x in v):.3f}, CPU "
               f"{min(x[2] for x in v):.3f}-{max(x[2] for x in v):.3f} ({len(v)} pairs)" for e, v in ratios.items()]
    text = "\n".join(rows) + "\n\n" + "\n".join(f"- {s}" for s in summary) + "\n"
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text(f"`python benchmarks/bench_stress_at_cost.py --engines {' '.join(a.engines)} --frames "
                     f"{a.frames} --rounds {a.rounds}` (the README donut, `examples/donut_jelly.toml`: frames 3 onward, "
                     "stress_at 'start' then 'trapezoid' in each pair, one process)\n\n" + text)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
