"""Issue 38 item 2 on `examples/donut_on_guitar.toml`: how the donut rests on the guitar's collider, and the cost of
the contact per substep. The engine stepped directly (CPU), 30 frames: the substeps of frames 3-8 timed (frames 1-2
compile the kernels), the load average beside them; at frames 10, 20 and 30 the donut's points' signed distance to
the guitar's collider (``Collider.distance``: the same field the engines read), in dx: the median over the donut's
lowest 1 % of points by height (as ``tests/test_example_donut_on_guitar.py`` takes its Gaussians': 0 when it rests
on the surface, positive when it floats), the mean of the smallest 1 % of distances, and the smallest.

Run from a tree: ``python benchmarks/donut_guitar_contact.py --engine warp_mpm --tag after``; one line goes to stdout
and is appended to ``benchmarks/results/donut_guitar_contact.md``. ``--motion FILE`` also writes, per frame, how far
the donut moved since the last frame (largest point move, centroid, rotation of the best rigid fit) and the mean of
its smallest 1 % of collider distances: when it comes to rest (``benchmarks/results/donut_guitar_rest.md``).
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
    ap.add_argument("--motion", default=None, help="also write the per-frame motion table here")
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
    gaps, t_sub, loads, motion = [], 0.0, [], []
    x_prev = np.asarray(e.positions(), float)
    for f in range(1, a.frames + 1):
        if 3 <= f <= 8:
            loads.append(os.getloadavg()[0])
            t0 = time.perf_counter()
        e.step_frame()
        if 3 <= f <= 8:
            t_sub += time.perf_counter() - t0
        if a.motion:
            x = np.asarray(e.positions(), float)
            motion.append((f, *frame_motion(x_prev, x, dx), float(np.sort(col.distance(x, f * setup.frame_dt))[
                :max(1, len(x) // 100)].mean()) / dx))
            x_prev = x
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
    if a.motion:
        Path(a.motion).write_text(
            f"`python benchmarks/donut_guitar_contact.py --engine {a.engine} --frames {a.frames} --motion ...` "
            f"({n_sub} substeps a frame, dx = {dx * 1e3:.2f} mm): the donut's motion since the previous frame\n\n"
            "| frame | largest point move, dx | centroid move, mm | rotation, deg | nearest 1 % to the guitar, dx |\n"
            "|---:|---:|---:|---:|---:|\n"
            + "".join(f"| {f} | {m:.3f} | {c * 1e3:.3f} | {r:.3f} | {g:+.3f} |\n" for f, m, c, r, g in motion))


def frame_motion(x_prev: np.ndarray, x: np.ndarray, dx: float) -> tuple[float, float, float]:
    """Largest point move (dx), centroid move (m) and the angle (degrees) of the best rigid rotation (Kabsch)
    between two frames' points, shape (n, 3)."""
    c_prev, c = x_prev.mean(axis=0), x.mean(axis=0)
    u, _, vt = np.linalg.svd((x_prev - c_prev).T @ (x - c))
    cos = (np.trace(vt.T @ u.T) - 1.0) / 2.0
    return (float(np.abs(x - x_prev).max()) / dx, float(np.linalg.norm(c - c_prev)),
            float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))))


if __name__ == "__main__":
    main()
