"""Sleep on the README donut: end-to-end wall time with and without it, and what it costs in accuracy.

Runs ``gasp simulate examples/donut_jelly.toml`` twice in fresh processes, in one run of this script: with the
scene's default ``sleep = true`` and with ``sleep = false`` (the same scene otherwise), and compares every frame's
Gaussian means: the largest and mean distance between the two runs (mm, and as a share of the donut's size, the
diagonal of its frame-0 means' bounding box, as in ``docs/speed_accuracy.md``, where U, the reference's own
uncertainty, is 0.62 % of the size in shape and 2.3 % in position). ``run.json`` says after which frame the
scene fell asleep.

Run: ``python benchmarks/bench_sleep.py [--frames 36] [--engine taichi_mpm]``; the table goes to stdout and
``benchmarks/results/bench_sleep.md``. Quiet machine: the ratio is of two runs taken one after the other.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "donut_jelly.toml"


def simulate(scene: Path, out: Path, frames: int, engine: str | None) -> tuple[float, float, float]:
    """Wall and CPU seconds of one ``gasp simulate`` in a fresh process, and the 1-minute load average before it."""
    load = os.getloadavg()[0]
    cmd = [sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "-q",
           "--frames", str(frames), *(["--engine", engine] if engine else [])]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), load


def means(out: Path) -> list[np.ndarray]:
    from gasp_core.render.run import load_run
    run = load_run(out)
    return [np.asarray(run.read(f, 0).means, dtype=np.float64) for f in range(run.n_frames)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=36)
    ap.add_argument("--engine", default=None)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        text = SCENE.read_text().replace('file = "data/', f'file = "{SCENE.parent}/data/')
        on, off = d / "sleep.toml", d / "awake.toml"
        on.write_text(text)
        off.write_text("sleep = false\n" + text)
        t_on = simulate(on, d / "on", a.frames, a.engine)
        t_off = simulate(off, d / "off", a.frames, a.engine)
        rec = json.loads((d / "on" / "run.json").read_text())
        m_on, m_off = means(d / "on"), means(d / "off")
    size = float(np.linalg.norm(np.ptp(m_off[0], axis=0)))
    dist = [np.linalg.norm(x - y, axis=1) for x, y in zip(m_on, m_off)]
    worst = max(range(len(dist)), key=lambda f: float(dist[f].max()))
    after = rec["sleep"]["asleep_after_frame"]
    lines = [
        f"`python benchmarks/bench_sleep.py --frames {a.frames}` ({rec['engine']}, {os.cpu_count()} cores, "
        f"{rec['engine_stats'].get('n_substeps')} substeps a frame)",
        "",
        "| run | wall (s) | CPU (s) | load average before it (1 min) |", "|---|---|---|---|",
        f"| sleep (default; asleep after frame {after}) | {t_on[0]:.1f} | {t_on[1]:.1f} | {t_on[2]:.2f} |",
        f"| sleep = false | {t_off[0]:.1f} | {t_off[1]:.1f} | {t_off[2]:.2f} |",
        "",
        f"Wall time ratio, awake / asleep: **{t_off[0] / t_on[0]:.2f}x**.",
        f"Largest distance of a Gaussian's centre between the two runs: {1e3 * dist[worst].max():.3f} mm at frame "
        f"{worst} ({100 * dist[worst].max() / size:.3f} % of the donut's size {size:.3f} m); mean over the Gaussians "
        f"at the last frame {1e3 * dist[-1].mean():.4f} mm ({100 * dist[-1].mean() / size:.4f} %).",
    ]
    text = "\n".join(lines) + "\n"
    res = Path(__file__).parent / "results"
    res.mkdir(exist_ok=True)
    (res / "bench_sleep.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
