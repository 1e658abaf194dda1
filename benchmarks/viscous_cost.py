"""Round 49 (issue 67): the viscous step's cost under its rules, a scene run by ``gasp simulate`` in this process
(docs/contact.md "Round 49: the viscous step's momentum, a uniform correction").

    python benchmarks/viscous_cost.py --scene examples/donut_jelly.toml --engine taichi_mpm --frames 12

Variants (``--variants``, comma-separated): ``conserve`` (round 49's rule: the CG to ``TOL`` 1e-2, then the uniform
correction ``du = sum r / sum m``), ``iterate`` (``conserve`` off: the CG's iterate ``m u``, the rule before),
``tol1e-6`` (``conserve`` off, the CG to ``TOL`` 1e-6: option b). Each variant runs in a fresh Python process (taichi
reads ``TOL`` when it compiles); a line per variant: the frames' mean wall time after the first (its build and
kernels left out), the mean CG iterations per viscous solve, and whether the run finished (rc, non-finite points
reported by the CLI). Lines are printed and appended to ``--out`` (``benchmarks/results/viscous_cost.md``).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = {"conserve": (1, None), "iterate": (0, None), "tol1e-6": (0, 1e-6)}

CHILD = r"""
import sys
import gasp_taichi_mpm.viscosity as tv, gasp_warp_mpm.viscosity as wv
import gasp_warp_mpm.schedule.gpu as wg, gasp_warp_mpm.schedule.ordered as wo
conserve, tol = int(sys.argv[1]), sys.argv[2]
tv.ImplicitViscosity.conserve = wv.ImplicitViscosity.conserve = bool(conserve)
if tol != "None":
    for mod in (tv, wv, wg, wo):
        mod.TOL = float(tol)
from gasp_core.cli.main import main
sys.argv = ["gasp"] + sys.argv[3:]
sys.exit(main())
"""


def run_variant(scene: str, engine: str, frames: int, name: str) -> str:
    """One variant's line (markdown table row)."""
    conserve, tol = VARIANTS[name]
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, "-c", CHILD, str(conserve), str(tol), "simulate", scene, "-o", out + "/run",
               "--engine", engine, "--frames", str(frames), "-q"]
        p = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
        run = Path(out) / "run" / "run.json"
        info = json.loads(run.read_text()) if run.exists() else {}
    walls = _walls(info)
    mean = sum(walls[1:]) / max(len(walls) - 1, 1) if walls else float("nan")
    iters = _find(info, "viscous_cg_iterations")
    tail = (p.stderr.strip().splitlines() or [""])[-1][:80]
    return (f"| {Path(scene).name} | {engine} | {name} | {frames} frames | {mean:.3f} s/frame | "
            f"{iters if iters is None else f'{iters:.2f}'} CG iterations/solve | rc {p.returncode} | {tail} |")


def _walls(info) -> list:
    frames = info.get("frames") or []
    return [f["wall_s"] for f in frames if isinstance(f, dict) and "wall_s" in f]


def _find(obj, key):
    if isinstance(obj, dict):
        if key in obj:
            return obj[key]
        obj = list(obj.values())
    if isinstance(obj, list):
        for v in obj:
            hit = _find(v, key)
            if hit is not None:
                return hit
    return None


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", default=str(ROOT / "examples/donut_jelly.toml"))
    p.add_argument("--engine", default="taichi_mpm")
    p.add_argument("--frames", type=int, default=12)
    p.add_argument("--variants", default="conserve,iterate,tol1e-6")
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/viscous_cost.md"))
    a = p.parse_args()
    for name in a.variants.split(","):
        line = run_variant(a.scene, a.engine, a.frames, name)
        print(line, flush=True)
        with open(a.out, "a") as fh:
            fh.write(line + "\n")


if __name__ == "__main__":
    main()
