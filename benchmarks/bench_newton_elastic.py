"""Newton's implicit MPM on elastic bodies: creep (static sag at one step per frame) and restitution.

Two conformance-kit scenes (``gasp_core.testing``), each with a few of the newton engine's options:

- ``self_weight_sag`` (a jelly column standing on the ground; analytic shortening ``rho g (...)/(2E)``)
  at one implicit step per 1/30 s frame for 0.6 s, with ``max_iterations`` 50 and 250: the shortening
  level (least-squares fit of the axial oscillation, as the kit's check) and the final shortening, mm. A
  solve stopped early drops the strain it did not reach, so an elastic body creeps flat (docs/newton.md).
- ``bounce_hertz`` (a jelly ball dropped on a frictionless ground) at 1 and 4 steps per 1/240 s frame:
  restitution ``v_out / v_in`` of the mass-weighted mean vertical velocity (largest after the lowest).

Usage::

    python benchmarks/bench_newton_elastic.py

Writes ``benchmarks/results/newton_elastic.json`` (atomically).
"""
from __future__ import annotations

import dataclasses
import json
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from gasp_core.testing.kit import resolve_engine, run_trace
from gasp_core.testing.scenes import scene_by_name
from gasp_core.testing.scenes_analytic import ground_force

OUT = Path(__file__).resolve().parent / "results" / "newton_elastic.json"


def run(scene_name: str, options: dict, frame_dt: float | None = None, n_frames: int | None = None):
    info, scene = resolve_engine("newton"), scene_by_name(scene_name)
    setup = scene.build(info)
    setup = dataclasses.replace(setup, options={**setup.options, **options}, frame_dt=frame_dt or setup.frame_dt)
    t0 = time.perf_counter()
    tr = run_trace(info, setup, n_frames or scene.n_frames)
    return info, scene, tr, time.perf_counter() - t0


def sag(options: dict) -> dict:
    info, scene, tr, wall = run("self_weight_sag", {"n_substeps": 1, **options}, 1.0 / 30.0, 18)
    (check,) = scene.evaluate(info, tr)
    z0 = tr.x[0, :, 2]
    top, bot = z0 > z0.max() - 1e-9, z0 < z0.min() + 1e-9
    length = tr.x[:, top, 2].mean(axis=1) - tr.x[:, bot, 2].mean(axis=1)
    return {"options": options, "level_mm": check.figures["measured"] * 1e3,
            "expected_mm": check.figures["expected"] * 1e3, "signed_error": check.figures["signed"],
            "final_mm": float(length[0] - length[-1]) * 1e3, "wall_s": wall}


def restitution(options: dict) -> dict:
    _, _, tr, wall = run("bounce_hertz", options)
    _, F, vz = ground_force(tr)
    i = int(np.argmin(vz))
    return {"options": options, "v_in": float(-vz[i]), "v_out": float(vz[i:].max()),
            "restitution": float(vz[i:].max() / -vz[i]), "wall_s": wall}


def main() -> None:
    out = {"machine": os.uname().nodename, "load_average": os.getloadavg(),
           "sag_one_step_per_frame": [sag({"max_iterations": n}) for n in (50, 250)],
           "bounce_hertz": [restitution({"n_substeps": n}) for n in (1, 4)]}
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.NamedTemporaryFile("w", dir=OUT.parent, delete=False, suffix=".tmp") as f:
        json.dump(out, f, indent=1)
    os.replace(f.name, OUT)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
