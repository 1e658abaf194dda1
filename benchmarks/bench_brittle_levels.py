"""The donut shatter's pieces against the quality levels, in units of U (issue 52 item 6 on a scanned body;
docs/speed_accuracy.md's rule, docs/fracture.md).

``examples/donut_shatter.toml`` (the README donut as a brittle biscuit landing at 4.43 m/s, n_grid 64) run
``--frames F`` at each level (``draft``, ``default``, ``reference``) and at the reference's **twin** (the reference
model, ``quality = "reference"``, on the next coarser grid: the file's ``n_grid`` 48, which the level scales to 72,
against the reference's 96). U of each figure is its difference between the reference and the twin; each level's
error is given in U. Figures at the last frame, from each run's ``run.json``: the piece count, the pieces of 5 % of
the mass or more, the largest piece's share of the mass and the second's; the wall and CPU seconds of the
``gasp simulate`` process (start-up and kernel compiles included).

    python benchmarks/bench_brittle_levels.py [--frames 4] [--engine taichi_mpm] [--keep out/levels]

Writes ``benchmarks/results/brittle_levels.md`` (and ``.json``); refuses to overwrite an existing ``--keep`` run.
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
SCENE = ROOT / "examples" / "donut_shatter.toml"
#: (name, quality level, the file's n_grid)
SETTINGS = (("draft", "draft", 64), ("default", "default", 64), ("reference", "reference", 64),
            ("twin", "reference", 48))
FIGURES = ("pieces", "pieces_5pct", "largest_share", "second_share")


def figures(run: Path) -> dict:
    """The last frame's piece figures of a run (its ``run.json``)."""
    rec = json.loads((run / "run.json").read_text())
    row = rec["frames"][-1]
    mass = np.sort(np.asarray(row["piece_mass"], float))[::-1]
    share = mass / (mass.sum() + row.get("debris_mass", 0.0))     # of the body's mass, crumbs included (issue 66)
    return {"frame": int(row["frame"]), "pieces": int(row["pieces"]), "pieces_5pct": int((share >= 0.05).sum()),
            "largest_share": float(share[0]), "second_share": float(share[1]) if len(share) > 1 else 0.0,
            "n_points": rec.get("n_points"), "n_grid": rec.get("n_grid", rec.get("domain", {}).get("n_grid")),
            "pieces_per_frame": [int(r["pieces"]) for r in rec["frames"]]}


def run_setting(name: str, level: str, n_grid: int, frames: int, engine: str, keep: Path) -> dict:
    text = SCENE.read_text().replace('"data/donut_v3dg.ply"', f'"{SCENE.parent / "data" / "donut_v3dg.ply"}"')
    text = text.replace("n_grid = 64 ", f"n_grid = {n_grid} ").replace('name = "taichi_mpm"', f'name = "{engine}"')
    scene = keep / f"{name}.toml"
    scene.write_text(text)
    out = keep / name
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "gasp_core", "simulate", str(scene), "-o", str(out), "--quality", level,
                    "--frames", str(frames), "--yes", "--quiet"], check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"setting": name, "level": level, "file_n_grid": n_grid, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1),
            **figures(out)}


def table(rows: list[dict]) -> str:
    ref, twin = rows[2], rows[3]
    u = {f: abs(ref[f] - twin[f]) for f in FIGURES}

    def cell(r, f):
        v = r[f]
        s = f"{v:.3f}" if isinstance(v, float) else str(v)
        if r is ref:
            return f"{s} (reference)"
        return f"{s} ({abs(v - ref[f]) / u[f]:.2f} U)" if u[f] > 0 else f"{s} (U = 0: {'=' if v == ref[f] else '!='})"
    lines = ["| setting | level | points | CPU s | wall s | pieces by frame | pieces | pieces of 5 % or more | "
             "largest share | second share |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['setting']} | {r['level']} (file n_grid {r['file_n_grid']}) | {r['n_points']} | "
                     f"{r['cpu_s']} | {r['wall_s']} | {'/'.join(map(str, r['pieces_per_frame']))} | "
                     + " | ".join(cell(r, f) for f in FIGURES) + " |")
    lines.append("")
    lines.append("U (reference against its twin): " + ", ".join(f"{f} {u[f]:.3g}" for f in FIGURES))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--keep", type=Path, default=None, help="a new folder for the runs (default: a temporary one)")
    a = ap.parse_args()
    if a.keep is not None and a.keep.exists():
        sys.exit(f"--keep {a.keep}: exists; give a new folder")
    keep = a.keep or Path(tempfile.mkdtemp(prefix="brittle_levels_"))
    keep.mkdir(parents=True, exist_ok=True)
    rows = [run_setting(n, lv, g, a.frames, a.engine, keep) for n, lv, g in SETTINGS]
    load = os.getloadavg()
    md = (f"# The donut shatter's pieces against the quality levels ({a.engine}, {a.frames} frames)\n\n"
          f"`python benchmarks/bench_brittle_levels.py --frames {a.frames} --engine {a.engine}`; load average at "
          f"the end {load[0]:.1f} / {load[1]:.1f} / {load[2]:.1f} (seconds are of a shared 2-core machine).\n\n"
          + table(rows) + "\n")
    res = ROOT / "benchmarks" / "results"
    (res / "brittle_levels.md").write_text(md)
    (res / "brittle_levels.json").write_text(json.dumps(rows, indent=1))
    print(md)


if __name__ == "__main__":
    main()
