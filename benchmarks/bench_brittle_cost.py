"""Cost of the brittle material (issue 52) on the README donut (`examples/donut_jelly.toml`): per substep, the same
setup as ``jelly`` (its material), ``metal`` (the same SVD and Hencky stress, no yield reached) and ``brittle``
(damage criterion evaluated, never reached at this strength), the engine stepped directly, 2 frames of warm-up,
then ``FRAMES`` frames timed; and per frame, the core's piece labelling (:class:`gasp_core.run.pieces.PieceTracker` on the donut's points:
on a frame where the set of broken points changed, and on one where nothing new broke) and the engine's
``damage()`` read, against the brittle frame.

Run: ``python benchmarks/bench_brittle_cost.py [--engines warp_mpm taichi_mpm] [--frames 3]``; the table goes to
stdout and ``benchmarks/results/brittle_cost.md`` (with the load average before each measurement).
"""
from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
MATERIALS = ("jelly", "metal", "brittle")


def donut_setup(material: str):
    """The README donut's setup with its material replaced by ``material`` (E, nu, rho, viscosity kept; metal's yield
    (1e9 Pa) and brittle's strength (1e5 Pa, 5 E) out of reach, so the three run the same motion)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.setup import Material
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ps = prepare_scene(load_scene(ROOT / "examples" / "donut_jelly.toml"))
    m = ps.setup.materials[0]
    new = Material(material, E=m.E, nu=m.nu, rho=m.rho, viscosity=m.viscosity, yield_stress=1e9,
                   tensile_strength=1e5, fracture_energy=1e4)
    return ps.setup.replace(materials=[new])


def measure(engine: str, material: str, frames: int) -> dict:
    """ms per substep, substeps a frame, ms per frame, and for brittle the ms of ``damage()`` and of the labelling."""
    from gasp_core.run.pieces import tracker_for
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = donut_setup(material)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e = build_engine(engines()[engine], setup)
    for _ in range(2):
        e.step_frame()
    t0 = time.perf_counter()
    for _ in range(frames):
        e.step_frame()
    wall = time.perf_counter() - t0
    n = int(e.stats()["n_substeps"])
    out = {"substep_ms": 1e3 * wall / (frames * n), "n_substeps": n, "frame_ms": 1e3 * wall / frames}
    if material == "brittle":
        tracker = tracker_for(setup)
        t0 = time.perf_counter()
        d = e.damage()
        out["damage_ms"] = 1e3 * (time.perf_counter() - t0)
        x = e.positions()
        t0 = time.perf_counter()
        out["pieces"] = tracker.row(x, d)[0]["pieces"]
        out["label_ms"] = 1e3 * (time.perf_counter() - t0)   # a frame where the set of broken points changed
        t0 = time.perf_counter()
        tracker.row(x, d)
        out["label_same_ms"] = 1e3 * (time.perf_counter() - t0)   # a frame where nothing new broke
    e.close()
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--frames", type=int, default=3)
    a = ap.parse_args()
    rows = ["| engine | material | ms per substep | against jelly | against metal | substeps a frame | ms per frame "
            "| damage() ms | labelling ms (something broke / nothing new) | share of the brittle frame | load avg |",
            "|---" * 11 + "|"]
    for engine in a.engines:
        got = {}
        for material in MATERIALS:
            load = os.getloadavg()[0]
            got[material] = r = measure(engine, material, a.frames)
            extra = ((f"{r['damage_ms']:.1f} | {r['label_ms']:.1f} / {r['label_same_ms']:.1f} | "
                      f"{(r['damage_ms'] + r['label_ms']) / r['frame_ms']:.1%} / "
                      f"{(r['damage_ms'] + r['label_same_ms']) / r['frame_ms']:.1%}") if material == "brittle"
                     else "- | - | -")
            rows.append(f"| {engine} | {material} | {r['substep_ms']:.2f} | "
                        f"{r['substep_ms'] / got['jelly']['substep_ms']:.3f} | "
                        f"{r['substep_ms'] / got['metal']['substep_ms'] if 'metal' in got else float('nan'):.3f} | "
                        f"{r['n_substeps']} | {r['frame_ms']:.0f} | {extra} | {load:.2f} |")
            print(rows[-1], flush=True)
    out = ROOT / "benchmarks" / "results" / "brittle_cost.md"
    tmp = out.with_suffix(".md.tmp")
    tmp.write_text("# Cost of the brittle material on the README donut (bench_brittle_cost.py)\n\n"
                   + "\n".join(rows) + "\n")
    tmp.replace(out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
