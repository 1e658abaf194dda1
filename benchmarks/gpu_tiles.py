"""The tiled P2G on CUDA against the atomic P2G (issue 65, :mod:`gasp_taichi_mpm.schedule.tiles`), in one device call.

What the CPU cannot run of it (shared arrays exist on CUDA only; ``plugins/taichi_mpm/tests/test_taichi_tiles.py``
checks the rest on ``ti.cpu``): for the README donut (viscous, the contact's channels) and a 1M-point jelly block,
after two frames, one fused G2P + P2G from the same state by both P2Gs; per channel of ``grid_mv`` the largest
difference against the channel's largest value (f32 rounding: the same terms in another order), and the time of
each P2G (median of 20, synchronised).

Writes ``gpu_tiles.json`` to ``--out``. Usage on the device (``../shared/device``)::

    bash .device/setup.sh && PYTHONPATH=/tmp/site python3 benchmarks/gpu_tiles.py --out $OUT
"""
import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))


def engine_for(case: str):
    """A built taichi_mpm engine on CUDA, GPU schedule, for ``donut`` or ``block``."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from bench_gpu import block_setup, donut_scene
    if case == "block":
        return build_engine(get_engine("taichi_mpm"), block_setup(1_000_000, "jelly", "cuda"))
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    with tempfile.TemporaryDirectory() as tmp:
        prep = prepare_scene(load_scene(donut_scene("cuda", Path(tmp), "gpu")), "taichi_mpm")
    return build_engine(get_engine("taichi_mpm"), prep.setup)


def compare(case: str) -> dict:
    import taichi as ti
    e = engine_for(case)
    s = e.solver
    assert s.tiles, "the tiled P2G is not on"
    for _ in range(2):
        e.step_frame()
    fields = (s.x, s.v, s.C, s.F, s.Jp)
    saved = [f.to_numpy() for f in fields]

    def one(tiled: bool, reps: int):
        times = []
        for _ in range(reps):
            for f, a in zip(fields, saved):
                f.from_numpy(a)
            s.grid_mv.fill(0)
            ti.sync()
            t0 = time.perf_counter()
            if tiled:
                s.p2g_tiled(1)
            else:
                s.g2p_p2g(1)
            ti.sync()
            times.append(time.perf_counter() - t0)
        return s.grid_mv.to_numpy()[0], float(np.median(times[1:] if len(times) > 1 else times))

    atomic, t_atomic = one(False, 21)
    tiled, t_tiled = one(True, 21)
    scale = np.abs(atomic).max(axis=(0, 1, 2))
    rel = (np.abs(tiled - atomic).max(axis=(0, 1, 2)) / np.where(scale > 0, scale, 1)).tolist()
    out = {"points": int(s.n_points[None]), "channels": s.acc_width, "rel_diff_per_channel": rel,
           "mass_atomic": float(atomic[..., 3].sum()), "mass_tiled": float(tiled[..., 3].sum()),
           "active_blocks": int(s.t_n_active[None]), "p2g_ms_atomic": 1e3 * t_atomic,
           "p2g_ms_tiled": 1e3 * t_tiled, "speedup": t_atomic / t_tiled, "agree": bool(max(rel) < 1e-4)}
    e.close()
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--case", default=None)
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    if a.case:
        print(json.dumps(compare(a.case)))
        return 0
    import subprocess
    doc = {}
    for case in ("donut", "block"):
        r = subprocess.run([sys.executable, __file__, "--case", case], capture_output=True, text=True, timeout=240)
        lines = [ln for ln in r.stdout.splitlines() if ln.startswith("{")]
        doc[case] = json.loads(lines[-1]) if r.returncode == 0 and lines else \
            {"error": f"exit {r.returncode}: " + " | ".join(r.stderr.strip().splitlines()[-8:])}
        print(case, json.dumps(doc[case]), flush=True)
    (a.out / "gpu_tiles.json").write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
