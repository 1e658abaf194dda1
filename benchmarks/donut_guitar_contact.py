"""Issue 38 item 2 on `examples/donut_on_guitar.toml`: how the donut rests on the guitar's collider, and the cost of
the contact per substep. The engine stepped directly (CPU), 30 frames: the substeps of frames 3-8 timed (frames 1-2
compile the kernels), the load average beside them; at frames 10, 20 and 30 the donut's points' signed distance to
the guitar's collider (``Collider.distance``: the same field the engines read), in dx: the median over the donut's
lowest 1 % of points by height (as ``tests/test_example_donut_on_guitar.py`` takes its Gaussians': 0 when it rests
on the surface, positive when it floats), the mean of the smallest 1 % of distances, and the smallest.

Run from a tree: ``python benchmarks/donut_guitar_contact.py --engine warp_mpm --tag after``; one line goes to stdout
and is appended to ``benchmarks/results/donut_guitar_contact.md``.
"""
from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--tag", default="")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "donut_guitar_contact.md"))
    a = ap.parse_args()
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    scene = load_scene(ROOT / "examples" / "donut_on_guitar.toml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        setup = prepare_scene(scene).setup
        e = build_engine(engines()[a.engine], setup)
    col, dx = setup.colliders[0], float(setup.dx)
    gaps, t_sub, loads = [], 0.0, []
    for f in range(1, a.frames + 1):
        if 3 <= f <= 8:
            loads.append(os.getloadavg()[0])
            t0 = time.perf_counter()
        e.step_frame()
        if 3 <= f <= 8:
            t_sub += time.perf_counter() - t0
        if f % 10 == 0:
            x = np.asarray(e.positions(), float)
            d = col.distance(x, f * setup.frame_dt)
            low = x[:, 2] <= np.quantile(x[:, 2], 0.01)
            s = np.sort(d)
            gaps.append((f, float(np.median(d[low])) / dx, float(s[:max(1, len(s) // 100)].mean()) / dx,
                         float(s[0]) / dx))
    n_sub = int(e.stats()["n_substeps"])
    e.close()
    ms = 1e3 * t_sub / (6 * n_sub)
    line = (f"| {a.tag} | {a.engine} | {ms:.1f} | {n_sub} | {np.mean(loads):.1f} | "
            + " | ".join(f"{g:+.3f} / {q:+.3f} / {m:+.3f}" for _, g, q, m in gaps) + " |")
    out = Path(a.out)
    if not out.exists():
        out.parent.mkdir(exist_ok=True)
        out.write_text("`python benchmarks/donut_guitar_contact.py` (`examples/donut_on_guitar.toml`, CPU, "
                       f"{len(setup.x)} points; gap: the donut's points' signed distance to the guitar's collider, dx: "
                       "median of the lowest 1 % by height / mean of the smallest 1 % / smallest)\n\n| tree | engine | ms per substep (frames 3-8) | "
                       "substeps a frame | load avg | gap frame 10 | gap frame 20 | gap frame 30 |\n"
                       "|---|---|---|---|---|---|---|---|\n")
    with out.open("a") as fh:
        fh.write(line + "\n")
    print(line)


if __name__ == "__main__":
    main()
