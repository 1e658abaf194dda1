"""A set impulse's scenes, bit for bit across a code change (round 44, the ``constrain`` key): sha1 of x, v, F, C after
a few frames of (1) the oblique 2:1 dog-bone at 45 deg built through the scene (``benchmarks/user_oblique.py``: a
``fixed_region``, a ramped set box, a brittle body under the held rule, passive vertices; n_grid 24, f64) and (2)
``tests/test_impulse_ramp.py``'s free block in a ramped set box (jelly, brittle) and sphere (jelly).

Run it on two trees and compare the lines:
``PYTHONPATH=<tree>:<tree>/plugins/taichi_mpm:<tree>/plugins/warp_mpm python benchmarks/studies/set_box_bits.py
--engine taichi_mpm`` (and ``warp_mpm``; ``--schedule gpu`` for warp_mpm's gpu schedule, on this CPU).
"""
import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

import gasp_core  # noqa: E402

ROOT = Path(gasp_core.__file__).resolve().parents[1]   # the tree on PYTHONPATH: its own benchmarks and tests
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))

FRAMES = 40


def digest(e) -> str:
    """sha1 of the engine's x, v, F, C (float64, setup order)."""
    s = e.get_state()
    h = hashlib.sha1()
    for k in ("x", "v", "F", "C"):
        h.update(np.ascontiguousarray(np.asarray(e.to_setup_order(s[k]), np.float64)).tobytes())
    return h.hexdigest()


def run(setup, info, frames: int) -> str:
    from gasp_core.seam.build import build_engine
    e = build_engine(info, setup)
    try:
        for _ in range(frames):
            e.step_frame()
        return digest(e)
    finally:
        e.close()


def oblique(engine: str, schedule: str | None):
    import tension_family as tf
    import user_oblique as uo
    ps, _mesh = uo.prepare(uo.SPECIMENS["dogbone_2to1"], 24, engine, "45")
    if schedule:
        ps.setup.options["schedule"] = schedule
    return ps.setup, ps.info, tf


def blocks(engine: str, schedule: str | None):
    """test_impulse_ramp's block scenes: (name, setup)."""
    import test_impulse_ramp as tr
    from gasp_core.colliders.model import Impulse
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import box_points, make_setup
    out = []
    for shape, material in tr.CASES:
        x, p_vol = box_points((0.4, 0.4, 0.4), (0.55, 0.55, 0.55), 1.0 / 48)
        m = Material("jelly", E=5e4, nu=0.3, rho=1000.0) if material == "jelly" else \
            Material("brittle", E=5e4, nu=0.0, rho=1000.0, tensile_strength=1e4, fracture_energy=1e3)
        opts = {"precision": "f64", **({"schedule": schedule} if schedule else {})}
        st = make_setup(x, p_vol, m, v=np.tile([-0.5, 0.2, 0.0], (len(x), 1)), gravity=(0, 0, 0), n_grid=16,
                        frame_dt=tr.FRAME_DT, options=opts)
        region = {"lo": (0.2, 0.2, 0.2), "hi": (0.8, 0.8, 0.8)} if shape == "box" else \
            {"centre": (0.475, 0.475, 0.475), "radius": 0.32}
        st.impulses = [Impulse(shape, tr.DV, t0=tr.T0, t1=tr.T1, mode="set", ramp=tr.RAMP, **region)]
        out.append((f"{shape}_{material}", st))
    return out


def main() -> None:
    from gasp_core.seam.plugins import engines
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--schedule", default=None, help="warp_mpm's schedule (cpu, gpu)")
    a = ap.parse_args()
    st, info, _ = oblique(a.engine, a.schedule)
    print(f"{a.engine} {a.schedule or '-'} oblique_2to1_45_n24 {FRAMES} frames {run(st, info, FRAMES)}", flush=True)
    for name, st in blocks(a.engine, a.schedule):
        print(f"{a.engine} {a.schedule or '-'} {name} 6 frames {run(st, engines()[a.engine], 6)}", flush=True)


if __name__ == "__main__":
    main()
