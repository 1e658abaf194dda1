"""How far passive surface points drift from their body as ``passive_every`` grows (issue 41).

The README donut at the ``draft`` level (passive surface, 2 fill points per cell), its first ``--frames`` frames,
one engine, once per value of ``passive_every``: the passive points' largest distance (in cells ``dx``) from where
the run with ``passive_every = 1`` (a gather every substep) puts them, at the last frame, and the body's own
largest displacement for scale. The engine option's upper bound (``gasp_core.mpm.substeps.MAX_PASSIVE_EVERY``)
comes from this table.

Run: ``python benchmarks/passive_every_drift.py [--engine warp_mpm] [--frames 12] [--values 1 8 16 32 64 128]``;
the table goes to stdout and ``benchmarks/results/passive_every_drift.md``.
"""
from __future__ import annotations

import argparse
import time
import warnings
from pathlib import Path

import numpy as np

SCENE = Path(__file__).resolve().parents[1] / "examples" / "donut_jelly.toml"


def _beyond_the_bound() -> None:
    """Lift the option's upper bound in this process only, to measure the values past it."""
    from gasp_core.mpm.substeps import PASSIVE_EVERY
    object.__setattr__(PASSIVE_EVERY, "hi", 10 ** 6)


def run(engine: str, frames: int, every: int) -> tuple[np.ndarray, np.ndarray, float, int]:
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(load_scene(SCENE, quality="draft"), engine=engine)
        ps.setup.options["passive_every"] = every
        e = build_engine(ps.info, ps.setup)
    passive = np.asarray(ps.setup.passive)
    x0 = e.positions()[passive].astype(np.float64)
    for _ in range(frames):
        e.step_frame()
    x = e.positions().astype(np.float64)
    n_sub = e.n_substeps
    e.close()
    return x0, x[passive], float(ps.setup.dx), n_sub


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--values", type=int, nargs="+", default=[1, 8, 16, 32, 64, 128])
    a = ap.parse_args()
    _beyond_the_bound()
    t0 = time.perf_counter()
    ref = None
    rows = ["| passive_every | passive points' largest distance from the every-substep run (dx) | mean (dx) |",
            "|---|---|---|"]
    for every in a.values:
        try:
            x0, xp, dx, n_sub = run(a.engine, a.frames, every)
        except Exception as exc:   # a divergence is a row of the table
            rows.append(f"| {every} | {type(exc).__name__}: {str(exc)[:90]} | |")
            print(rows[-1], flush=True)
            continue
        if ref is None:
            ref = xp
            moved = float(np.linalg.norm(xp - x0, axis=1).max()) / dx
        d = np.linalg.norm(xp - ref, axis=1) / dx
        rows.append(f"| {every} | {d.max():.3f} | {d.mean():.4f} |")
        print(rows[-1], flush=True)
    head = (f"`python benchmarks/passive_every_drift.py --engine {a.engine} --frames {a.frames}` (the README donut at "
            f"draft, {n_sub} substeps a frame, dx = {dx * 1e3:.2f} mm; the passive points moved up to {moved:.1f} dx by "
            f"frame {a.frames}; {time.perf_counter() - t0:.0f} s wall)\n\n")
    res = Path(__file__).parent / "results"
    res.mkdir(exist_ok=True)
    (res / "passive_every_drift.md").write_text(head + "\n".join(rows) + "\n")
    print(head + "\n".join(rows))


if __name__ == "__main__":
    main()
