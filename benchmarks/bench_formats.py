"""Size and precision of each output format and layout on the donut and the kitchen (docs/formats.md).

Runs each scene once per (format, layout) with the same deterministic engine settings, then compares every
frame, read back through gasp_core.run.layout.open_frames, with the lossless PLY run of the same scene.
Writes the table to benchmarks/results/bench_formats.md (or the path given) and prints it.

    python benchmarks/bench_formats.py [--frames 4] [--n-grid 24] [--engine warp_mpm] [-o results.md]
"""
from __future__ import annotations

import argparse
import tempfile
import tomllib
from pathlib import Path

import numpy as np

from gasp_core.gs.ply import SH_C0
from gasp_core.run.layout import open_frames
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import parse_scene

ROOT = Path(__file__).resolve().parents[1]
SCENES = {"donut": ROOT / "examples" / "donut_jelly.toml", "kitchen": ROOT / "examples" / "kitchen_spinach.toml"}
RUNS = [("ply", "frames"), ("ply", "split"), ("compressed_ply", "split"), ("spz", "split"), ("sog", "split"),
        ("spz", "frames")]


def scene(path: Path, n_grid: int, engine: str):
    data = tomllib.loads(path.read_text())
    data["domain"]["n_grid"] = n_grid
    data["engine"] = {"name": engine, "options": {"threads": 1} if engine == "taichi_mpm" else {}}
    return parse_scene(data, path)


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file() and p.name not in ("run.json",))


def errors(ref, run) -> dict:
    """Largest errors over all frames and objects against the lossless run (file units)."""
    out = {"pos_max": 0.0, "pos_rel": 0.0, "rot_max": 0.0, "logscale_p99": 0.0, "rgb_p99": 0.0, "alpha_max": 0.0}
    for f in range(ref.n_frames):
        for k in range(len(ref.manifest["objects"])):
            a, b = ref.gaussians(f, k), run.gaussians(f, k)
            d = np.abs(a.means - b.means).max()
            ext = np.ptp(a.means, axis=0).max()
            q = np.minimum(np.abs(a.rotations - b.rotations).max(1), np.abs(a.rotations + b.rotations).max(1))
            with np.errstate(divide="ignore", invalid="ignore"):
                ls = np.abs(np.log(np.maximum(a.scales, 1e-30)) - np.log(np.maximum(b.scales, 1e-30)))
            rgb = np.abs(np.clip(0.5 + SH_C0 * a.sh_dc, 0, 1) - np.clip(0.5 + SH_C0 * b.sh_dc, 0, 1))
            al = np.abs(1 / (1 + np.exp(-a.opacities.astype(float))) - 1 / (1 + np.exp(-b.opacities.astype(float))))
            for key, val in (("pos_max", d), ("pos_rel", d / ext), ("rot_max", q.max()),
                             ("logscale_p99", np.quantile(ls, 0.99)), ("rgb_p99", np.quantile(rgb, 0.99)),
                             ("alpha_max", al.max())):
                out[key] = max(out[key], float(val))
    return out


def measure(name: str, path: Path, frames: int, n_grid: int, engine: str, tmp: Path) -> list[str]:
    sc = scene(path, n_grid, engine)
    folders = {}
    for fmt, layout in RUNS:
        out = tmp / f"{name}_{fmt}_{layout}"
        simulate_scene(sc, out, quiet=True, n_frames=frames, fmt=fmt, layout=layout)
        folders[fmt, layout] = out
    ref = open_frames(folders["ply", "frames"])
    base = folder_bytes(folders["ply", "frames"])
    rows = []
    for (fmt, layout), out in folders.items():
        size = folder_bytes(out)
        e = errors(ref, open_frames(out))
        rows.append(f"| {name} | {fmt} | {layout} | {size / 1e6:.2f} | {base / size:.1f}x | {e['pos_max']:.2e} | "
                    f"{e['pos_rel']:.1e} | {e['rot_max']:.4f} | {e['logscale_p99']:.4f} | {e['rgb_p99']:.4f} | "
                    f"{e['alpha_max']:.4f} |")
    return rows


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--frames", type=int, default=4)
    p.add_argument("--n-grid", type=int, default=24)
    p.add_argument("--engine", default="warp_mpm")
    p.add_argument("-o", "--output", type=Path, default=ROOT / "benchmarks" / "results" / "bench_formats.md")
    a = p.parse_args()
    head = ["| scene | format | layout | MB | smaller than PLY frames | position max (file units) | "
            "position max / extent | rotation max | log-scale p99 | colour p99 | opacity max |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        rows = [r for name, path in SCENES.items() for r in measure(name, path, a.frames, a.n_grid, a.engine,
                                                                     Path(tmp))]
    text = (f"{a.frames + 1} frames (frame 0 = the input), n_grid {a.n_grid}, engine {a.engine}; errors against "
            f"the lossless PLY run, every frame and object.\n\n" + "\n".join(head + rows) + "\n")
    a.output.parent.mkdir(parents=True, exist_ok=True)
    a.output.write_text(text)
    print(text)


if __name__ == "__main__":
    main()
