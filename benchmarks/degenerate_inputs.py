"""Wall time of ``gasp simulate`` on degenerate inputs (issue 19: "10 identical Gaussians end within 10 s").

Inputs: 10 and 600 identical Gaussians (copies of one flat splat of ``sphere_of_flat_gaussians``), 600
collinear and 600 coplanar ones; 2 frames, n_grid 16, warp_mpm (the engine that starts fastest) or the
engine given. Each run is a fresh ``python -m gasp_core.cli.main`` process, so import time counts, as a
user sees it. Writes ``benchmarks/results/degenerate_inputs.json`` (or the path given): exit status, wall
seconds, the run's ``prepare_s`` and the stderr lines.

Run:  python benchmarks/degenerate_inputs.py [out.json] [engine]
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from gasp_core.gs.io import write_gaussians  # noqa: E402
from test_freefall_e2e import sphere_of_flat_gaussians  # noqa: E402


def inputs():
    base = sphere_of_flat_gaussians(600)
    for n in (10, 600):
        yield f"identical{n}", base.subset(np.zeros(n, int))
    for kind in ("collinear", "coplanar"):
        g = base.subset(np.arange(600))
        g.means[:] = 0.0
        g.means[:, 0] = np.linspace(-0.05, 0.05, 600)
        if kind == "coplanar":
            g.means[:, 1] = np.random.default_rng(0).uniform(-0.05, 0.05, 600)
        yield kind, g


def main(out: Path, engine: str = "warp_mpm") -> list[dict]:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, g in inputs():
            write_gaussians(tmp / f"{name}.ply", g)
            scene = tmp / f"{name}.toml"
            scene.write_text(f"""frame_dt = 0.0333333
n_frames = 2
[engine]
name = "{engine}"
[domain]
n_grid = 16
[[boundary]]
kind = "ground"
height = 0.0
[[object]]
file = "{name}.ply"
position = [0.0, 0.0, 0.1]
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
""")
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o",
                                str(tmp / f"out_{name}"), "-q"], capture_output=True, text=True, timeout=600)
            wall = time.perf_counter() - t0
            run = tmp / f"out_{name}" / "run.json"
            prep = json.loads(run.read_text()).get("prepare_s") if run.exists() else None
            rows.append({"input": name, "exit": p.returncode, "wall_s": round(wall, 2), "prepare_s": prep,
                         "stderr": p.stderr.strip().splitlines()})
            print(f"{name:12s} exit {p.returncode}  wall {wall:6.2f} s  prepare {prep}", flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "benchmarks" / "results" / "degenerate_inputs.json",
         *sys.argv[2:3])
