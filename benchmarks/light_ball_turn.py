"""Why the light ball keeps turning (issue 53, ``docs/contact.md`` "The light ball"): the column of
``gasp_core.testing.sand_ball`` against its light ball (``pair_setup(light=True)``, the fill, two fields, 60 frames),
run as it is and with one thing changed each time, to see what drives the ball's steady turn and what fails to hold
it:

- ``base``: the scene as it stands;
- ``ground1``: the ground's friction 1.0 instead of 0.5 (a rigid ball could not turn in place then);
- ``mu0``: no friction between the sand and the ball (``gasp_core.mpm.fields.field_friction`` 0).

Per case: the ball's turn (Kabsch, degrees) and the horizontal travel of its centre (mm) every 6 frames, and the mean
x travel of its bottom 4 mm of points every 12 frames (mm); for ``base`` also the sand's speeds at frames 30, 45 and
59 (median and 99th percentile, mm/s).

    python benchmarks/light_ball_turn.py [--engine warp_mpm] [--cases base,ground1,mu0]

Appends a JSON line per case to ``benchmarks/results/light_ball_turn.json`` (or ``--out``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
CASES = ("base", "ground1", "mu0")


def run(engine: str, case: str, frames: int) -> dict:
    """One case's figures (module notes)."""
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    import gasp_core.mpm.fields as F
    setup = S.pair_setup(ball=True, surface=False, options={"threads": 1, "contact_fields": True}, light=True)
    if case == "ground1":
        setup = replace(setup, boundaries=[replace(b, friction=1.0) for b in setup.boundaries])
    eng = get_engine(engine)
    saved = F.field_friction
    # every module that holds the function (the core's and an engine's own import of it)
    holders = [m for m in list(sys.modules.values()) if getattr(m, "field_friction", None) is saved]
    if case == "mu0":
        for m in holders:
            m.field_friction = lambda s: 0.0
    try:
        x = run_trace(eng, setup, frames).x
    finally:
        for m in holders:
            m.field_friction = saved
    ball = np.asarray(setup.body_id) == max(setup.body_id)
    c0 = x[0][ball].mean(0)
    bottom = ball & (x[0][:, 2] < x[0][ball][:, 2].min() + 0.004)
    rec = {"engine": engine, "case": case, "frames": frames,
           "turn_deg": [round(S.rotation_deg(x[0][ball], x[k][ball]), 3) for k in range(0, frames + 1, 6)],
           "travel_mm": [round(1e3 * float(np.linalg.norm((x[k][ball].mean(0) - c0)[:2])), 3)
                         for k in range(0, frames + 1, 6)],
           "bottom_dx_mm": [round(1e3 * float((x[k][bottom, 0] - x[0][bottom, 0]).mean()), 3)
                            for k in range(0, frames + 1, 12)]}
    if case == "base":
        speeds = {k: np.linalg.norm(x[k + 1][~ball] - x[k][~ball], axis=1) * 1e3 / setup.frame_dt
                  for k in (frames // 2, 3 * frames // 4, frames - 1)}
        rec["sand_mm_s_p50_p99"] = {k: [round(float(np.percentile(s, q)), 3) for q in (50, 99)]
                                    for k, s in speeds.items()}
    return rec


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--out", default=str(HERE / "results" / "light_ball_turn.json"))
    args = ap.parse_args()
    for case in args.cases.split(","):
        t0 = time.perf_counter()
        rec = {**run(args.engine, case, args.frames), "seconds": round(time.perf_counter() - t0, 1),
               "load": round(os.getloadavg()[0], 2)}
        print(json.dumps(rec), flush=True)
        with open(args.out, "a") as fh:
            fh.write(json.dumps(rec) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
