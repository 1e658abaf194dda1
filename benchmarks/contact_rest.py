"""Issue 38's must-show through `gasp simulate`: a ball of 600 flat Gaussians with its fill (jelly E 2e4 Pa, nu 0.3,
rho 300, R 5 cm), dropped onto ground with friction 0.5, 40 frames: the largest horizontal travel of each ball's
Gaussians' centroid (mm) per engine and case, with the contact's balance (the default) and without it
(``contact_balance = false``, the contact before issue 38).

Cases: the Fibonacci ball dropped 5 and 7 cm (n_grid 16); its Gaussians' centres jittered +-3 mm (seeded) at
n_grid 16 and 32; an E 1e6 Pa ball (``model = "elastic"``) 30 cm beside the soft one on the same ground (each
ball's travel; 14 cm apart, 1.3 cells at n_grid 16, the grid couples the two balls and they pushed each other 18 and
27 mm, with or without the balance).

Run: ``python benchmarks/contact_rest.py [--engines warp_mpm taichi_mpm]``; the table goes to stdout and
``benchmarks/results/contact_rest.md``. Wall seconds are of the whole `gasp simulate` (the machine's load average
is written beside them).
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

import contact_mustshow as cm

CASES = {  # name: (jitter m, drop m, n_grid, stiff ball beside it)
    "Fibonacci, drop 5 cm": (0.0, 0.05, 16, False),
    "Fibonacci, drop 7 cm": (0.0, 0.07, 16, False),
    "jittered, n_grid 16": (cm.JITTER, 0.05, 16, False),
    "jittered, n_grid 32": (cm.JITTER, 0.05, 32, False),
    "beside an E 1e6 ball": (0.0, 0.05, 16, True),
}


def scene(ply: Path, engine: str, balance: bool, drop: float, n_grid: int, stiff: bool) -> str:
    text = cm.scene(ply, engine, "auto").replace('options = { contact = "auto" }',
                                                 f"options = {{ contact_balance = {str(balance).lower()} }}")
    text = text.replace("n_grid = 16", f"n_grid = {n_grid}").replace(f"{cm.RADIUS + cm.DROP}", f"{cm.RADIUS + drop}")
    if stiff:
        text = text.replace("position = [0.0, 0.0,", "position = [-0.15, 0.0,") + f"""
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.15, 0.0, {cm.RADIUS + drop}]
[object.material]
name = "jelly"
E = 1.0e6
model = "elastic"
nu = 0.3
rho = 300.0
"""
    return text


def run(tmp: Path, engine: str, case: str, balance: bool) -> dict:
    from gasp_core.gs.io import read_gaussians
    jitter, drop, n_grid, stiff = CASES[case]
    ply = cm.ball(tmp / f"ball_{jitter}.ply", jitter)
    toml = tmp / f"{engine}_{abs(hash((case, balance)))}.toml"
    toml.write_text(scene(ply, engine, balance, drop, n_grid, stiff))
    out = tmp / f"out_{toml.stem}"
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(toml), "-o", str(out), "-q",
                        "--overwrite"], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode:
        return {"error": r.stderr.strip()[-300:]}
    travel = []
    for folder in sorted(p for p in out.iterdir() if p.is_dir()):
        frames = sorted(folder.glob("frame_*.ply"))
        c = np.array([read_gaussians(f).means.mean(axis=0) for f in frames])
        travel.append(1e3 * float(np.linalg.norm(c[:, :2] - c[0, :2], axis=1).max()))
    return {"travel": travel, "wall_s": wall}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--cases", nargs="+", default=list(CASES))
    a = ap.parse_args()
    rows = ["| engine | case | travel with the balance (mm) | without (mm) | wall s (with / without) | load avg |",
            "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as d:
        for engine in a.engines:
            for case in a.cases:
                load = os.getloadavg()[0]
                f = [run(Path(d), engine, case, b) for b in (True, False)]
                cells = [("error: " + x["error"][-120:]) if "error" in x else " / ".join(f"{t:.2f}" for t in x["travel"])
                         for x in f]
                walls = " / ".join(f"{x.get('wall_s', float('nan')):.0f}" for x in f)
                rows.append(f"| {engine} | {case} | {cells[0]} | {cells[1]} | {walls} | {load:.1f} |")
                print(rows[-1], flush=True)
    text = "\n".join(rows)
    res = Path(__file__).parent / "results"
    res.mkdir(exist_ok=True)
    (res / "contact_rest.md").write_text(
        "`python benchmarks/contact_rest.py` (largest horizontal travel of each ball's Gaussians' centroid over 40 "
        "frames; beside an E 1e6 ball: soft / stiff)\n\n" + text + "\n")
    print(text)


if __name__ == "__main__":
    main()
