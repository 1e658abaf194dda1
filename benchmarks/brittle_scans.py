"""Every bundled scan made brittle (issue 66, "Every bundled scan breaks"): the donut (``examples/donut_shatter.toml``),
the guitar (dropped from 0.3 m) and the kitchen's spinach (let go in its pan, walls around the domain), each as a
brittle body, at the quality levels' grids.

For each scan and level: the points, ``n_grid``, the piece labelling's peak memory (``tracemalloc`` around building
:class:`gasp_core.run.pieces.PieceTracker` and labelling a frame, against the points: bounded by the input, not by one
point's volume as when the guitar died in ``cKDTree.query_pairs``), and, with ``--frames`` > 0, a run of that many
frames: whether it reached its last frame, the pieces at the end and the wall time. Writes
``benchmarks/results/brittle_scans.{json,md}``::

    python benchmarks/brittle_scans.py --frames auto --levels draft,default

``--frames auto`` runs each scan past its landing (:data:`FRAMES`: the guitar, dropped from 0.3 m, lands at frame 7,
so 8 frames no longer reach its break; round 77). ``tests/test_brittle_scans.py`` checks the same (slow tier).
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "examples"
BRITTLE = ('[object.material]\nname = "brittle"\nE = 1.0e6\nnu = 0.25\nrho = 300.0\ntensile_strength = 2.7e4\n'
           'fracture_energy = 60.0\n')   # above the snap-back limit at the draft grid of a 1.1 m guitar (25.7 J/m^2)


#: Frames each scan runs with ``--frames auto``: past its landing and break.
FRAMES = {"donut": 8, "guitar": 16, "spinach": 8}


def scene_text(scan: str) -> str:
    """The scan's scene, brittle (the donut shatter's material), file paths absolute."""
    if scan == "donut":
        text = (EX / "donut_shatter.toml").read_text()
    else:
        text = (EX / ("guitar_sand.toml" if scan == "guitar" else "kitchen_spinach.toml")).read_text()
        text = text[:text.index("[object.material]")] + BRITTLE
        if scan == "guitar":   # dropped from 0.3 m onto the ground, as the donut from 1 m
            text = text.replace("position = [0.0, 0.0, 0.0]", "position = [0.0, 0.0, 0.3]")
        else:                  # walls around the domain: debris that leaves the pan stops there (else the run stops)
            text = text.replace("[[object]]", '[[boundary]]\nkind = "walls"\nfriction = 0.5\n\n[[object]]', 1)
    text = re.sub(r"^n_frames = \d+", "n_frames = 30", text, flags=re.M)
    return text.replace('file = "data/', f'file = "{EX}/data/')


def labelling_memory(toml: Path, level: str) -> dict:
    """Peak memory (MB) of the piece tracker's build and of one labelling with a third of the points broken."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.run.pieces import tracker_for
    from gasp_core.scene.spec import load_scene
    prep = prepare_scene(load_scene(toml, quality=level))
    s = prep.setup
    rng = np.random.default_rng(0)
    tracemalloc.start()
    tr = tracker_for(s)
    build = tracemalloc.get_traced_memory()[1]
    tracemalloc.reset_peak()
    damage = np.where(rng.random(len(s.x)) < 1 / 3, 1.0, 0.0)
    row, _ = tr.row(s.x + rng.normal(0, s.dx / 4, s.x.shape), damage)
    label = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return {"points": len(s.x), "n_grid": s.n_grid, "links": len(tr.pairs), "build_MB": build / 1e6,
            "label_MB": label / 1e6, "input_MB": s.x.nbytes / 1e6, "pieces_random": row["pieces"]}


def run_frames(toml: Path, level: str, frames: int, out: Path) -> dict:
    text = re.sub(r"^n_frames = \d+", f"n_frames = {frames}", toml.read_text(), flags=re.M)
    scene = out / f"{toml.stem}_{level}.toml"
    scene.write_text(text)
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "gasp_core", "simulate", str(scene), "-o", str(out / scene.stem),
                        "--quality", level], capture_output=True, text=True, timeout=3600)
    wall = time.perf_counter() - t0
    rec = {"exit": r.returncode, "wall_s": wall}
    run = out / scene.stem / "run.json"
    if run.is_file():
        rows = json.loads(run.read_text()).get("frames", [])
        rec["pieces"] = [row.get("pieces") for row in rows]
        rec["last_frame"] = rows[-1]["frame"] if rows else 0
    if r.returncode:
        rec["error"] = r.stderr.strip().splitlines()[-1:]
    return rec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", default="draft,default,reference")
    ap.add_argument("--scans", default="donut,guitar,spinach")
    ap.add_argument("--frames", default="0", help="frames to run each scan (0: none; auto: FRAMES)")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for scan in a.scans.split(","):
            toml = tmp / f"{scan}_brittle.toml"
            toml.write_text(scene_text(scan))
            for level in a.levels.split(","):
                rec = {"scan": scan, "level": level, **labelling_memory(toml, level)}
                frames = FRAMES[scan] if a.frames == "auto" else int(a.frames)
                if frames:
                    rec.update(run_frames(toml, level, frames, tmp))
                rows.append(rec)
                print(json.dumps(rec), flush=True)
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "brittle_scans.json").write_text(json.dumps(rows, indent=1))
    lines = ["# brittle_scans.py: every bundled scan made brittle", "",
             "| scan | level | points | n_grid | links | labelling peak MB (build / a frame) | points MB | frames run | "
             "pieces at the end | wall s |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        end = (r.get("pieces") or [None])[-1]
        lines.append(f"| {r['scan']} | {r['level']} | {r['points']} | {r['n_grid']} | {r['links']} | "
                     f"{r['build_MB']:.0f} / {r['label_MB']:.0f} | {r['input_MB']:.1f} | {r.get('last_frame', '-')} | "
                     f"{end if end is not None else '-'} | {r.get('wall_s', 0):.0f} |")
    (a.out / "brittle_scans.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
