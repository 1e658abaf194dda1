"""Issue 53 items 1-2: the rigid route's bounce against the restitution asked, and a rigid body at rest.

``drop``: a 10 cm ball (``bench_rigid.ball_ply``: 600 flat Gaussians on a sphere) of steel (E 2e11, rho 7850) or
hardwood (E 1e10, rho 700), ``model = "auto"`` (the rigid route), its bottom 0.2 m over a ground (friction 0.5),
30 fps; the restitution read from the free flights around the first bounce
(``gasp_studies.accuracy.first_bounce``) against the one the materials give
(``gasp_core.mpm.restitution``). Per engine and ``n_grid``. Also the last frame's lowest Gaussian over the
ground (``rest_gap_dx``, in cells) after ``--rest-frames`` more frames.

``donut``: ``examples/donut_wood.toml`` (dropped 5 cm) and the same donut set down flat (its lowest Gaussian on the
ground), 3 s: the travel of its centroid and its rotation from frame 0 (set down) or 1 s (dropped) to the end, and
from 0.5 s later (once settled), its lowest Gaussians over the ground (cells).

    python benchmarks/bench_restitution.py --parts drop --engines taichi_mpm,warp_mpm --grids 24,40
    python benchmarks/bench_restitution.py --parts donut --engines taichi_mpm,warp_mpm

Writes ``benchmarks/results/restitution.json`` (or ``--out``), a JSON line per run, as each run ends.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import tomli_w

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from bench_rigid import ball_ply  # noqa: E402

MATERIALS = {"steel": {"name": "jelly", "E": 2.0e11, "nu": 0.3, "rho": 7850.0},
             "wood": {"name": "jelly", "E": 1.0e10, "nu": 0.3, "rho": 700.0}}
DROP = 0.2
#: Engine options every run takes (``--options``, JSON).
OPTIONS: dict = {}


def run_frames(scene: Path, n_frames: int):
    """(track means per frame (n_frames + 1, n, 3), setup, prepared scene, engine)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam import build_engine
    prep = prepare_scene(load_scene(scene))
    s = prep.setup
    eng = build_engine(prep.info, s)
    frames = [np.asarray(s.x[:s.n_render], np.float64)]
    for _ in range(n_frames):
        eng.step_frame()
        frames.append(eng.positions()[:s.n_render].astype(np.float64))
    return np.stack(frames), s, prep, eng


def track_of(means, s, dt):
    from gasp_studies.accuracy import Track
    return Track(means=means, obj_start=np.array([0, means.shape[1]]), names=["body"], frame_dt=dt,
                 ground_z=0.0, dx=float(s.dx))


def drop(engine: str, mat: str, n_grid: int, frames: int, work: Path) -> dict:
    from gasp_studies.accuracy import events, first_bounce
    doc = {"frame_dt": 1.0 / 30.0, "n_frames": frames,
           "engine": {"name": engine, "options": {**({"threads": 1} if engine == "taichi_mpm" else {}), **OPTIONS}},
           "domain": {"n_grid": n_grid}, "boundary": [{"kind": "ground", "height": 0.0, "friction": 0.5}],
           "object": [{"file": str(ball_ply(work / "ball.ply")), "up_axis": "+z", "position": [0.0, 0.0, DROP],
                       "material": {**MATERIALS[mat], "model": "auto"}}]}
    path = work / f"{engine}_{mat}_{n_grid}.toml"
    path.write_text(tomli_w.dumps(doc))
    cpu = time.process_time()
    means, s, prep, eng = run_frames(path, frames)
    ev = events(track_of(means, s, 1.0 / 30.0), 0, 0.25 * float(s.dx))
    bottom = means[:, :, 2].min(axis=1)
    ev["restitution_ballistic"] = first_bounce(means[:, :, 2].mean(axis=1), bottom, 1.0 / 30.0, float(s.dx))
    tail = means[-30:].mean(axis=1)
    from gasp_core.mpm.restitution import body_restitution
    return {"engine": engine, "material": mat, "n_grid": n_grid, "dx": float(s.dx),
            "model": prep.objects[0].body_model.get("model"), "asked": body_restitution(s.materials[0]),
            "restitution_ballistic": ev["restitution_ballistic"], "restitution_frames": ev["restitution"],
            "last_bottom_over_ground_dx": float(bottom[-1] / s.dx),
            "last_second_bottom_range_mm": float(1e3 * np.ptp(bottom[-30:])),
            "last_second_travel_mm": float(1e3 * np.linalg.norm(tail[-1, :2] - tail[0, :2])),
            "n_substeps": eng.stats().get("n_substeps"), "cpu_s": time.process_time() - cpu,
            "load": os.getloadavg()[0]}


def donut(engine: str, flat: bool, seconds: float, work: Path) -> dict:
    from gasp_studies.accuracy import kabsch, rotation_angle_deg
    from gasp_core.mpm.rigid import touch_rows
    doc = tomllib.loads((HERE.parent / "examples" / "donut_wood.toml").read_text())
    doc["engine"] = {"name": engine, "options": {**({"threads": 1} if engine == "taichi_mpm" else {}), **OPTIONS}}
    doc["object"][0]["file"] = str(HERE.parent / "examples" / doc["object"][0]["file"])
    if flat:
        doc["object"][0]["position"] = [0.0, 0.0, 0.0]
    n = int(round(seconds / doc["frame_dt"]))
    doc["n_frames"] = n
    path = work / f"donut_{engine}_{int(flat)}.toml"
    path.write_text(tomli_w.dumps(doc))
    cpu = time.process_time()
    means, s, prep, eng = run_frames(path, n)
    # from the frame the drop has settled (1 s in for the dropped one, frame 0 set down) to the end
    f0 = 0 if flat else int(round(1.0 / doc["frame_dt"]))
    c = means.mean(axis=1)
    R, _, _ = kabsch(means[f0], means[-1])
    low = np.percentile(means[-1, :, 2], 0.5)
    # the points of the Gaussians a render shows (opacity min_opacity or more; a capture's floaters hang under a
    # rigid body that does not rest on them: gasp_core.mpm.rigid.touch_rows)
    seen = touch_rows(s)[:s.n_render]
    f1 = f0 + int(round(0.5 / doc["frame_dt"]))   # once settled: from 0.5 s on
    R1, _, _ = kabsch(means[f1], means[-1])
    return {"travel_after_settling_mm": float(1e3 * np.linalg.norm(c[-1, :2] - c[f1, :2])),
            "turn_after_settling_deg": float(rotation_angle_deg(R1)), "settled_from_frame": f1,
            "engine": engine, "scene": "set down flat" if flat else "donut_wood.toml", "seconds": seconds,
            "from_frame": f0, "travel_mm": float(1e3 * np.linalg.norm(c[-1, :2] - c[f0, :2])),
            "max_travel_mm": float(1e3 * np.linalg.norm(c[f0:, :2] - c[f0, :2], axis=1).max()),
            "turn_deg": float(rotation_angle_deg(R)), "dx": float(s.dx),
            "lowest_0.5pct_over_ground_dx": float(low / s.dx),
            "lowest_over_ground_dx": float(means[-1, :, 2].min() / s.dx),
            "lowest_seen_over_ground_dx": float(means[-1, seen, 2].min() / s.dx),
            "lowest_0.5pct_seen_over_ground_dx": float(np.percentile(means[-1, seen, 2], 0.5) / s.dx),
            "n_substeps": eng.stats().get("n_substeps"), "cpu_s": time.process_time() - cpu}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", type=lambda s: s.split(","), default=["drop", "donut"])
    ap.add_argument("--engines", type=lambda s: s.split(","), default=["taichi_mpm", "warp_mpm"])
    ap.add_argument("--materials", type=lambda s: s.split(","), default=["steel", "wood"])
    ap.add_argument("--grids", type=lambda s: [int(g) for g in s.split(",")], default=[24, 40])
    ap.add_argument("--frames", type=int, default=45)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--flat", type=lambda s: [bool(int(f)) for f in s.split(",")], default=[True, False])
    ap.add_argument("--out", type=Path, default=HERE / "results" / "restitution.json")
    ap.add_argument("--options", type=json.loads, default={}, help="engine options of every run (JSON)")
    args = ap.parse_args(argv)
    OPTIONS.update(args.options)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        for engine in args.engines:
            runs = []
            if "drop" in args.parts:
                runs += [(drop, (engine, m, g, args.frames, Path(tmp))) for m in args.materials for g in args.grids]
            if "donut" in args.parts:
                runs += [(donut, (engine, f, args.seconds, Path(tmp))) for f in args.flat]
            for fn, a in runs:
                rec = {**fn(*a), "options": args.options}
                print(json.dumps(rec), flush=True)
                with open(args.out, "a") as fh:
                    fh.write(json.dumps(rec) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
