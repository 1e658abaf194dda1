"""A device check of warp_mpm's gpu schedule (issue 65), to run where a CUDA GPU and warp-lang are present; not a
pytest file (no ``test_`` prefix): it has not run yet, since none was at hand where the schedule was written.

    PYTHONPATH=.:plugins/warp_mpm python plugins/warp_mpm/tests/gpu_schedule_check.py [--donut N_FRAMES]

What it checks, on ``device = "cuda"``:

1. the frame's CUDA graph captures with the gpu schedule: the viscous lists' ``wp.utils.array_scan`` and, where
   ``wp.is_conditional_graph_supported()``, the CG's ``wp.capture_while`` inside it (else 30 iterations);
2. the gpu schedule on CUDA agrees with the cpu schedule on CPU on the small viscous and contact scenes of
   ``test_warp_schedule.py`` (P2G's f32 atomics on CUDA leave the last bits to the order of the atomics, so the
   tolerance is looser than on CPU: 1e-2 dx);
3. with ``--donut N``: the README donut (``examples/donut_jelly.toml``), seconds per frame on CUDA with
   ``schedule = "cpu"`` (today's one-thread lists and dots inside the graph) and ``"gpu"``, frames 2..N.
"""
import argparse
import sys
import time
from pathlib import Path

import numpy as np
import warp as wp

sys.path.insert(0, str(Path(__file__).parent))
import test_warp_schedule as T  # noqa: E402

from gasp_core.seam import build_engine  # noqa: E402
from gasp_core.seam.plugins import engines  # noqa: E402


def run(setup, n):
    e = build_engine(engines()["warp_mpm"], setup)
    try:
        out = []
        for _ in range(n):
            e.step_frame()
            out.append(e.positions().astype(np.float64))
        return out, e.schedule, getattr(e, "_graph", None) is not None
    finally:
        e.close()


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--donut", type=int, default=0, help="frames of the README donut to time on both schedules")
    a = ap.parse_args()
    wp.init()
    print("cuda:", wp.is_cuda_available(), "conditional graphs:", wp.is_conditional_graph_supported(), flush=True)
    ok = True
    for scene, make in T.SCENES.items():
        ref, _, _ = run(make("cpu"), T.FRAMES)
        s = make("gpu")
        s.options["device"] = "cuda"
        t = time.time()
        got, sch, graph = run(s, T.FRAMES)
        diff = max(np.abs(x - y).max() for x, y in zip(ref, got)) / T.DX
        print(f"{scene}: schedule {sch}, graph {graph}, {time.time() - t:.1f} s, max |x_cuda,gpu - x_cpu,cpu| = "
              f"{diff:.3g} dx", flush=True)
        ok &= bool(diff < 1e-2)
    if a.donut:
        from gasp_core.prepare.scene import prepare_scene
        from gasp_core.scene.spec import load_scene
        sc = load_scene(Path(__file__).parents[3] / "examples" / "donut_jelly.toml")
        for sch in ("cpu", "gpu"):
            ps = prepare_scene(sc, engine="warp_mpm", options={"device": "cuda", "schedule": sch})
            e = build_engine(engines()["warp_mpm"], ps.setup)
            e.step_frame()   # the capture
            wp.synchronize()
            t = time.time()
            for _ in range(a.donut - 1):
                e.step_frame()
            wp.synchronize()
            print(f"donut, schedule {sch}: {(time.time() - t) / max(1, a.donut - 1):.3f} s/frame "
                  f"({e.n_points} points, {e.n_substeps} substeps)", flush=True)
            e.close()
    print("OK" if ok else "FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
