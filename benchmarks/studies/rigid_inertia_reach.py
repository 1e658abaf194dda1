"""Round 68 (issue 67 item 2): which scenes round 67's rigid-body change reaches. ``tests/test_three_bodies.py``'s
scenes (``scenes_three``: the stack, the slide, the fall; no rigid body) and ``tests/test_bending.py``'s rod
(``benchmarks/bending_family.py``; its held region is not a rigid body) run a few frames on both grid engines with the
constants now (``gasp_core.mpm.rigid.APIC_SPIN`` 0, ``ROTATION_PASSES`` 4) and with round 66's (1, 0); the hash of
the positions at every frame is printed for both. The control, the rigid / jelly / rigid sandwich thrown
(``scenes_rigid3.slide_setup``, n_grid 32), has a turning rigid body and must differ.

    python benchmarks/studies/rigid_inertia_reach.py [--frames 4] [--engines warp_mpm,taichi_mpm]

Figures: ``docs/rigid.md`` ("Round 68: the slow tiers after the body's own inertia").
"""
from __future__ import annotations

import argparse
import hashlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import bending_family as bf  # noqa: E402
from gasp_core.mpm import rigid as R  # noqa: E402
from gasp_core.seam import build_engine, get_engine  # noqa: E402
from gasp_core.testing import scenes_rigid3 as S3  # noqa: E402
from gasp_core.testing import scenes_three as S  # noqa: E402

ROD = [c for c in bf.FAMILY if c.shape == "rod"][0]
SCENES = {
    "three_bodies stack3 cube 24": lambda e: S.stack3("cube", 24),
    "three_bodies slide3 32 mu 0.3": lambda e: S.slide3(32, 0.3),
    "three_bodies fall3 0.3 dx 32": lambda e: S.fall3(0.3, 32),
    f"bending {ROD.name}": lambda e: bf.build(ROD, e)[0],
    "CONTROL rigid sandwich slide 32": lambda e: S3.slide_setup(32, 0.5, models=("rigid", "elastic", "rigid")),
}
NOW, ROUND66 = (0.0, 4), (1.0, 0)


def positions_hash(engine: str, make, frames: int, consts) -> str:
    saved = R.APIC_SPIN, R.ROTATION_PASSES
    R.APIC_SPIN, R.ROTATION_PASSES = consts   # read when the engine is built
    try:
        e = build_engine(get_engine(engine), make(engine))
        h = hashlib.sha256()
        for _ in range(frames):
            e.step_frame()
            h.update(np.ascontiguousarray(e.positions()).tobytes())
        e.close()
    finally:
        R.APIC_SPIN, R.ROTATION_PASSES = saved
    return h.hexdigest()[:8]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=4)
    ap.add_argument("--engines", default="warp_mpm,taichi_mpm")
    args = ap.parse_args()
    for engine in args.engines.split(","):
        for name, make in SCENES.items():
            now = positions_hash(engine, make, args.frames, NOW)
            old = positions_hash(engine, make, args.frames, ROUND66)
            print(f"{engine:10s} {name:34s} now {now} round66 {old} {'SAME' if now == old else 'DIFFERENT'}",
                  flush=True)


if __name__ == "__main__":
    main()
