"""Issue 28's must-show through `gasp simulate`: a ball of 600 flat Gaussians with its fill (jelly E 2e4,
nu 0.3, rho 300), its bottom 10 cm (``RADIUS + DROP``) above a ground with friction 0.5, n_grid 16, 40 frames: the Gaussians' centroid
travel (horizontal, mm) per engine and contact model, on the Fibonacci ball and with its Gaussians' centres
jittered (uniform, +-``JITTER`` m per axis, seeded). taichi_mpm runs on all cores (its default ``threads``), so its
sums differ from warp_mpm's in the last bits and the rolling (chaotic) motions part.

Run: ``python benchmarks/contact_mustshow.py [--engines warp_mpm taichi_mpm] [--contacts particle grid]``;
the table goes to stdout and ``benchmarks/results/contact_mustshow.md``. Times are wall seconds of the
whole `gasp simulate` (loaded machine).
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

N, RADIUS, DROP, JITTER = 600, 0.05, 0.05, 0.003   # position is the bottom centre: at RADIUS + DROP, a 10 cm fall


def ball(path: Path, jitter: float) -> Path:
    """``N`` flat Gaussians tangent to a sphere (Fibonacci points, thin axis along the outward normal)."""
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    from gasp_core.testing.scenes_passive import fibonacci_sphere
    d = fibonacci_sphere(N)
    q = np.array([Rotation.align_vectors([v], [[1.0, 0.0, 0.0]])[0].as_quat() for v in d])
    means = RADIUS * d
    if jitter:
        means = means + np.random.default_rng(28).uniform(-jitter, jitter, means.shape)
    g = Gaussians(means=means, scales=np.tile([1e-8, 0.006, 0.006], (N, 1)), rotations=q[:, [3, 0, 1, 2]],
                  opacities=np.full(N, 3.0, np.float32), sh_dc=np.full((N, 3), 0.5, np.float32))
    return write_gaussians(path, g, overwrite=True)


def scene(ply: Path, engine: str, contact: str) -> str:
    return f"""
frame_dt = 0.0333333
n_frames = 40
[engine]
name = "{engine}"
options = {{ contact = "{contact}" }}
[domain]
n_grid = 16
[[boundary]]
kind = "ground"
height = 0.0
friction = 0.5
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, {RADIUS + DROP}]
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
"""


def run(tmp: Path, engine: str, contact: str, jitter: float) -> dict:
    from gasp_core.gs.io import read_gaussians
    ply = ball(tmp / f"ball_{jitter}.ply", jitter)
    toml = tmp / f"{engine}_{contact}_{jitter}.toml"
    toml.write_text(scene(ply, engine, contact))
    out = tmp / f"out_{engine}_{contact}_{jitter}"
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(toml), "-o", str(out), "-q",
                        "--overwrite"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode:
        return {"error": r.stderr.strip()[-300:]}
    frames = sorted((out / ply.stem).glob("frame_*.ply"))
    c = np.array([read_gaussians(f).means.mean(axis=0) for f in frames])
    drift = np.linalg.norm(c[:, :2] - c[0, :2], axis=1)
    return {"drift_mm": 1e3 * float(drift.max()), "end_mm": 1e3 * float(drift[-1]), "wall_s": wall}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--contacts", nargs="+", default=["particle", "grid"])
    a = ap.parse_args()
    rows = ["| engine | contact | ball | largest drift (mm) | drift at frame 40 (mm) | wall s |",
            "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as d:
        for engine in a.engines:
            for contact in a.contacts:
                for jitter in (0.0, JITTER):
                    f = run(Path(d), engine, contact, jitter)
                    name = "jittered" if jitter else "Fibonacci"
                    if "error" in f:
                        rows.append(f"| {engine} | {contact} | {name} | {f['error']} | | |")
                    else:
                        rows.append(f"| {engine} | {contact} | {name} | {f['drift_mm']:.2f} | {f['end_mm']:.2f} | "
                                    f"{f['wall_s']:.0f} |")
                    print(rows[-1], flush=True)
    text = "\n".join(rows)
    res = Path(__file__).parent / "results"
    res.mkdir(exist_ok=True)
    (res / "contact_mustshow.md").write_text(f"`python benchmarks/contact_mustshow.py` (jitter +-{JITTER * 1e3:g} mm)\n\n"
                                             f"{text}\n")
    print(text)


if __name__ == "__main__":
    main()
