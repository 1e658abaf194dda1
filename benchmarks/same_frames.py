"""Bit for bit: the sha1 of every frame file of a set of real scenes, one per surface map form, on both MPM engines.

Issue 51 moved the GaMeS map ``T`` / ``T^-1`` into one home (:mod:`gasp_core.maps.surface`) and must not change a
single bit of any frame. This script runs ``gasp simulate`` on the README donut (PhysGaussian's centres), the same
donut on its GaMeS triangles (the paper's vertices), on Core Gaussians (``core_fraction``), in mesh mode, and the
kitchen's dynamic spinach (a ``.splatv`` model, a selection, velocities from the model), for taichi_mpm and
warp_mpm, and writes the sha1 of each frame file (positions, rotations, scales: every rebuilt field) to a JSON
file. Run it on two checkouts and compare the files::

    python benchmarks/same_frames.py -o benchmarks/results/same_frames.json            # this checkout
    python benchmarks/same_frames.py --compare benchmarks/results/same_frames_base_3ad98bd.json \
        benchmarks/results/same_frames.json

Issue 51 (2026-11-25): the base 3ad98bd (run from a worktree of it) and d350bf7 give the same sha1 for all 10 runs
(5 scenes x 2 engines, 4 frames each).
Round 19 (a freshly built virtual environment): the base itself then gives other frames for ``donut_cores`` on both
engines (its Core Gaussians' clustering), so the base was run again in that environment:
``benchmarks/results/same_frames_base_3ad98bd_venv2.json``; compare against the file made in the same environment.

Each scene runs a few frames (``--frames``), ``threads = 1`` for taichi_mpm (its CPU P2G is bit-repeatable only
on one thread when the contact balance is on; docs/engines.md).
"""
from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "examples" / "data"

#: name -> (scene file, lines appended to its [[object]] table, lines for its [engine.options])
SCENES = {
    "donut_centres": ("donut_jelly.toml", [], []),
    "donut_triangles": ("donut_jelly.toml", ['surface_points = "vertices"'], []),
    "donut_cores": ("donut_jelly.toml", ['surface_points = "vertices"', "core_fraction = 0.2"], []),
    "donut_mesh": ("donut_mesh.toml", [], []),
    "kitchen_dynamic": ("kitchen_spinach.toml", [], []),
}
ENGINES = ("taichi_mpm", "warp_mpm")


def variant(name: str, engine: str, folder: Path) -> Path:
    """The scene ``name`` for ``engine`` written to ``folder``: its file paths made absolute, object keys added."""
    src, object_keys, _ = SCENES[name]
    text = (ROOT / "examples" / src).read_text()
    text = text.replace('file = "data/', f'file = "{DATA}/').replace('path = "data/', f'path = "{DATA}/')
    text = text.replace('mesh = "data/', f'mesh = "{DATA}/')
    if object_keys:   # after the first [[object]] header's own keys: before its first sub-table
        head, sep, rest = text.partition("[object.material]")
        text = head + "\n".join(object_keys) + "\n" + sep + rest
    if engine == "taichi_mpm":
        text = text.replace("[engine]", "[engine.options]\nthreads = 1\n[engine]", 1) if "[engine.options]" not in \
            text else text.replace("[engine.options]", "[engine.options]\nthreads = 1", 1)
    out = folder / f"{name}_{engine}.toml"
    out.write_text(text)
    return out


def frame_hashes(run: Path) -> dict[str, str]:
    """sha1 of every frame file under ``run`` (``run.json`` and timings left out), keyed by relative path."""
    return {str(p.relative_to(run)): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(run.rglob("frame_*")) if p.is_file()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", type=Path, default=ROOT / "benchmarks" / "results" / "same_frames.json")
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--engines", default=",".join(ENGINES))
    ap.add_argument("--compare", nargs=2, type=Path, metavar=("A", "B"), help="compare two result files and exit")
    a = ap.parse_args(argv)
    if a.compare:
        one, two = (json.loads(p.read_text())["hashes"] for p in a.compare)
        keys = sorted(set(one) | set(two))
        differ = [k for k in keys if one.get(k) != two.get(k)]
        print(f"{len(keys) - len(differ)} of {len(keys)} runs the same bit for bit" +
              ("" if not differ else ": differ " + ", ".join(differ)))
        return 1 if differ else 0
    hashes = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.scenes.split(","):
            for engine in a.engines.split(","):
                toml = variant(name, engine, Path(tmp))
                out = Path(tmp) / f"out_{name}_{engine}"
                cmd = [sys.executable, "-m", "gasp_core", "simulate", str(toml), "-o", str(out), "--engine", engine,
                       "--frames", str(a.frames), "-q"]
                r = subprocess.run(cmd, capture_output=True, text=True)
                if r.returncode:
                    hashes[f"{name}/{engine}"] = f"exit {r.returncode}: {r.stderr.strip().splitlines()[-1:]}"
                else:
                    hashes[f"{name}/{engine}"] = hashlib.sha1(json.dumps(frame_hashes(out), sort_keys=True)
                                                              .encode()).hexdigest()
                print(f"{name}/{engine}: {hashes[f'{name}/{engine}']}", flush=True)
    rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    a.output.parent.mkdir(parents=True, exist_ok=True)
    a.output.write_text(json.dumps({"commit": rev.stdout.strip(), "frames": a.frames, "hashes": hashes}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
