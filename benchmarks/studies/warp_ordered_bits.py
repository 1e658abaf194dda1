"""warp_mpm's CPU schedule, bit for bit across a code change (issue 65's layout: the ordered launches moved to
``gasp_warp_mpm/schedule/ordered.py``): sha1 of x, v, F, C after a few frames of a viscous scene and of two contact
scenes whose balance launches ``contact_fix``, on ``schedule = "cpu"`` (f32, the default precision; the viscous scene
also in f64).

Run it on two trees and compare the lines:
``PYTHONPATH=<tree>:<tree>/plugins/warp_mpm python benchmarks/studies/warp_ordered_bits.py`` (the scenes are those of
``<tree>/plugins/warp_mpm/tests/test_warp_schedule.py`` and ``gasp_core.testing.sand_ball.slide_setup``). Each
line also counts the launches of ``lists``, ``dot`` and ``contact_fix`` in the last frame, so that a scene which never
reached the ordered kernels is seen. ``--schedule gpu`` runs the same scenes on the gpu schedule (on this CPU), whose
bits a change to the kernels both schedules share must keep too.
"""
import hashlib
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import warp as wp

from gasp_core.seam import build_engine
from gasp_core.seam.plugins import engines

import gasp_core  # noqa: E402

ROOT = Path(gasp_core.__file__).resolve().parents[1]   # the tree on PYTHONPATH: its own test scenes
sys.path.insert(0, str(ROOT / "plugins" / "warp_mpm" / "tests"))

FRAMES = 3


def scenes(schedule: str) -> dict:
    from test_warp_schedule import contact_scene, viscous_scene
    from gasp_core.testing import sand_ball as S
    mixed = S.slide_setup(1.2, {"threads": 1, "schedule": schedule}, slab_h=2 * S.SIDE / S.N_GRID)
    v64 = viscous_scene(schedule)
    v64.options["precision"] = "f64"
    return {"viscous_on_ground": viscous_scene(schedule), "viscous_on_ground_f64": v64,
            "two_bodies_walls": contact_scene(schedule), "thin_support_mixed": mixed}


def counting():
    """Patch wp.launch and wp.Launch.launch to count kernels by name; return the Counter."""
    seen = Counter()
    launch, cmd = wp.launch, wp.Launch.launch

    def launch_(kernel, dim=None, *a, **kw):
        if not kw.get("record_cmd"):
            seen[kernel.key.rpartition("__")[2]] += 1
        return launch(kernel, dim, *a, **kw)

    def cmd_(self, *a, **kw):
        seen[self.kernel.key.rpartition("__")[2]] += 1
        return cmd(self, *a, **kw)

    wp.launch, wp.Launch.launch = launch_, cmd_
    return seen


def main(schedule: str = "cpu") -> None:
    import gasp_warp_mpm
    print("gasp_warp_mpm:", gasp_warp_mpm.__file__)
    seen = counting()
    for name, setup in scenes(schedule).items():
        e = build_engine(engines()["warp_mpm"], setup)
        try:
            assert e.schedule == schedule
            for f in range(FRAMES):
                seen.clear()
                e.step_frame()
            h = hashlib.sha1()
            for a in (e.x, e.v, e.F, e.C):
                h.update(np.ascontiguousarray(a.numpy()).tobytes())
            n = {k: seen[k] for k in ("lists", "dot", "contact_fix", "fix_nodes")}
            print(f"{name}: {len(setup.x)} points, {FRAMES} frames, sha1(x, v, F, C) = {h.hexdigest()}; "
                  f"last frame's launches {n}")
        finally:
            e.close()


if __name__ == "__main__":
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--schedule", choices=("cpu", "gpu"), default="cpu")
    main(ap.parse_args().schedule)
