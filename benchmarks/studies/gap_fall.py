"""Round 60 (issue 67/66, ``docs/contact.md`` "Round 60: a touch by geometry"): the upper body of a pair that does not
land in the frame falls freely across the gap, under the touch by geometry and under the rule before.

A jelly box (half-width ``half``, 6 cm tall, E 1e5, rho 700) on the ground and a jelly ball (R 5 cm) or cube (8 cm)
``gap`` above it at rest (``tests/test_contact_fine_step.py``'s scene), one frame (1/30 s) at ``factor`` times the
default substeps; prints per case the upper body's mean v_z (m/s) against ``-g t`` (-0.327) and the box's mean speed.
``--rule old`` sets ``gasp_core.mpm.fields.GAP_TOUCH = False`` (the volume-fraction touch, ``SOFT_TOUCH_FRACTION``).

Usage: ``python benchmarks/studies/gap_fall.py --engine taichi_mpm --shape ball --gap 0.53 --factors 1,2,4,8
--rule new`` (``--curvature``: round 61's level, ``gasp_core.mpm.gap_touch.CURVATURE``; ``--gap`` in cells of the
grid, ``--n-grid`` 32 by default); ``--land``: the body dropped from ``--gap``,
its gap at rest after 20 frames (``landed``).
"""
import argparse
import time

import numpy as np

from gasp_core.mpm import fields as core_fields
from gasp_core.mpm.grid_engine import grid_substeps
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.testing.helpers import body_over_box

SIDE, FRAME = 0.6, 1.0 / 30.0


def scene(shape="ball", half=0.06, n_grid=32, gap_cells=0.53, n_substeps=None):
    """``(setup, n_box)``: the box's points first (the scene of ``tests/test_contact_fine_step.py``,
    :func:`gasp_core.testing.helpers.body_over_box`, its gap in cells)."""
    return body_over_box(shape, half, n_grid, gap_cells * SIDE / n_grid, n_substeps)


def run(engine, shape, half, n_grid, gap_cells, factor):
    """``(upper body's mean v_z, box's mean speed, n_substeps)`` after one frame."""
    setup, nb = scene(shape, half, n_grid, gap_cells)
    n = grid_substeps(setup) * factor
    setup, nb = scene(shape, half, n_grid, gap_cells, n)
    eng = build_engine(engines()[engine], setup)
    try:
        eng.step_frame()
        v = np.asarray(eng.velocities(), np.float64)
        return float(v[nb:, 2].mean()), float(np.linalg.norm(v[:nb].mean(0))), n
    finally:
        eng.close()


def landed(engine, shape, half, n_grid, gap_cells, frames=20, stress_at=None):
    """The body dropped ``gap_cells`` dx above the box, after ``frames`` frames: ``(gap at rest in dx, the deepest gap
    over the run in dx)``, the gap ``gasp_core.testing.scenes_pairs.surface_gap`` (nearest points less half of each
    one's spacing; the mean of the last 5 frames). ``stress_at``: the engines' option (None: the default, round 70's
    "trapezoid")."""
    from gasp_core.testing.scenes_pairs import surface_gap
    setup, nb = scene(shape, half, n_grid, gap_cells)
    if stress_at is not None:
        setup.options["stress_at"] = stress_at
    dx = SIDE / n_grid
    eng = build_engine(engines()[engine], setup)
    gaps = []
    try:
        for _ in range(frames):
            eng.step_frame()
            gaps.append(surface_gap(np.asarray(eng.positions(), np.float64), setup.body_id, setup.p_vol) / dx)
    finally:
        eng.close()
    return float(np.mean(gaps[-5:])), float(np.min(gaps))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--shape", default="ball")
    ap.add_argument("--half", type=float, default=0.06)
    ap.add_argument("--n-grid", type=int, default=32)
    ap.add_argument("--gap", default="0.53", help="gaps in cells, comma separated")
    ap.add_argument("--factors", default="1,8")
    ap.add_argument("--rule", default="new", choices=("new", "old"))
    ap.add_argument("--curvature", action="store_true", help="round 61: gasp_core.mpm.gap_touch.CURVATURE on")
    ap.add_argument("--land", action="store_true", help="drop the body from --gap and report its gap at rest")
    ap.add_argument("--frames", type=int, default=20, help="with --land: the frames run (the mean of the last 5)")
    ap.add_argument("--stress-at", default=None, help="with --land: the engines' stress_at (default: theirs)")
    a = ap.parse_args()
    core_fields.GAP_TOUCH = a.rule == "new"
    if a.curvature:
        from gasp_core.mpm import gap_touch
        gap_touch.CURVATURE = True
    fall = -9.81 * FRAME
    if a.land:
        for gap in [float(g) for g in a.gap.split(",")]:
            rest, deep = landed(a.engine, a.shape, a.half, a.n_grid, gap, a.frames, a.stress_at)
            print(f"{a.engine} {a.shape} n_grid {a.n_grid} dropped {gap:.2f} dx rule {a.rule} stress_at "
                  f"{a.stress_at or 'default'}: gap at rest "
                  f"{rest:+.3f} dx (deepest {deep:+.3f} dx)", flush=True)
        return
    for gap in [float(g) for g in a.gap.split(",")]:
        for f in [int(c) for c in a.factors.split(",")]:
            t0 = time.time()
            vz, box, n = run(a.engine, a.shape, a.half, a.n_grid, gap, f)
            print(f"{a.engine} {a.shape} n_grid {a.n_grid} gap {gap:.2f} dx rule {a.rule} x{f} ({n} substeps): "
                  f"v_z {vz:+.4f} m/s ({(vz - fall) / abs(fall) * 100:+.1f} % of g t), box {box:.4f} m/s "
                  f"[{time.time() - t0:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
