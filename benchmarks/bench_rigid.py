"""Issue 40's must-shows: the rigid limit of a stiff body (``material.model = "rigid"``, ``docs/rigid.md``) on taichi_mpm.

Parts (``--parts``, each one ``gasp simulate`` process per run, one after another, one engine thread):

* ``stiff``: the stiff block of ``bench_newton_stiff.py`` (the README donut cut to every 4th Gaussian, jelly
  E 1e7, no viscosity, dropped 5 cm, ``n_grid`` 32, 8 frames): the explicit elastic model (``model =
  "elastic"``) on ``n_grid`` and on its twin ``3/4 n_grid`` (U), and the rigid limit on ``n_grid``. Figures: each
  process's CPU seconds, the rigid run's split error against the explicit one
  (:func:`gasp_studies.trade.accuracy_report`: centroid, rotation, events; in U of the twin) and both restitutions,
  by frame differences and from the free flights around the bounce (:func:`gasp_studies.accuracy.ballistic_restitution`).
* ``steel``: a 10 cm ball of 600 flat Gaussians (steel: E 2e11, nu 0.3, rho 7850, ``model = "auto"``) dropped 5 cm
  onto the ground (friction 0.5), ``n_grid`` 32, 30 frames, run in this process to read the engine's points each
  frame: CPU seconds (prepare, build and frames), the model chosen, restitution (frame differences of the
  Gaussians' centroid), and the mechanical energy ``sum m (g z + |v|^2 / 2)`` of the material points per frame
  against the start (its largest rise above it, J).
* ``figure``: the scanned-figure case, ``tests/test_stand.py``'s figure on two legs at E 2e7 with ``model = "auto"``,
  30 frames on warp_mpm: the model taken, CPU seconds, lean and height per frame (:func:`part_figure`).
* ``mixed``: a soft donut (the cut donut, E 2e4) and the steel ball 0.45 m apart (0.24 m between them) in one domain (not touching): the
  donut alone, the donut with the ball (each takes its route), and the donut alone on the twin grid (U); the
  donut's centroid, rotation and shape with the ball against without, in U.

Run: ``python benchmarks/bench_rigid.py`` (all parts; writes ``benchmarks/results/rigid.{json,md}``).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import tomli_w

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_newton_stiff import stiff_scene  # noqa: E402
from bench_trade import run_variant  # noqa: E402

from gasp_studies.accuracy import track_from_run_dir  # noqa: E402
from gasp_studies.trade import accuracy_report  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
N_BALL, RADIUS, DROP = 600, 0.05, 0.05
STEEL = {"name": "jelly", "E": 2.0e11, "nu": 0.3, "rho": 7850.0}


def with_model(path: Path, model: str, out: Path, contact: str | None = None, fps: float | None = None) -> Path:
    """The scene at ``path`` with its object's ``material.model`` (and the engine option ``contact``; with ``fps``,
    its frames at that rate over the same time), to ``out``."""
    doc = tomllib.loads(path.read_text())
    doc["object"][0]["material"]["model"] = model
    if contact:
        doc["engine"]["options"]["contact"] = contact
    if fps:
        doc["n_frames"] = int(round(doc["n_frames"] * doc.get("frame_dt", 1 / 30) * fps))
        doc["frame_dt"] = 1.0 / fps
    out.write_text(tomli_w.dumps(doc))
    return out


def timed(name: str, scene: Path, out: Path) -> dict:
    print(f"[rigid] {name} ...", flush=True)
    r = run_variant(scene, out, 7200.0)
    r["load_avg_1min"] = os.getloadavg()[0]
    if r["returncode"] == 0:
        r["model"] = [o.get("model") for o in json.loads((out / "run.json").read_text())["objects"]]
    print(f"[rigid]   {json.dumps({k: v for k, v in r.items() if k not in ('domain', 'model')})[:300]}", flush=True)
    return r


def figures(report: dict, k: int = 0) -> dict:
    """The figures the must-show reads from an accuracy report (object ``k``)."""
    f = list(report["objects"].values())[k]
    return {"centroid": f["worst"]["centroid"], "rotation_deg": f["worst"]["rotation_deg"],
            "shape": f["worst"]["shape"], "in_u": {k: f.get("in_u", {}).get(k) for k in
                                                   ("centroid", "rotation_deg", "shape")},
            "restitution_run": f["events_run"]["restitution"], "restitution_ref": f["events_ref"]["restitution"],
            "restitution_ballistic_run": f["events_run"]["restitution_ballistic"],
            "restitution_ballistic_ref": f["events_ref"]["restitution_ballistic"],
            "impact_run_s": f["events_run"]["impact_s"], "impact_ref_s": f["events_ref"]["impact_s"]}


def part_stiff(work: Path, args) -> dict:
    """The explicit model with the scene's contact (``auto``: the particle contact since issue 38's balance, the
    rigid body's law) and its twin, and the rigid limit; the rigid run against it."""
    twin = int(round(0.75 * args.n_grid))
    runs = {"explicit": ("elastic", args.n_grid, None), "explicit_twin": ("elastic", twin, None),
            "rigid": ("rigid", args.n_grid, None)}
    rec, tracks = {}, {}
    for name, (model, n, contact) in runs.items():
        scene = with_model(stiff_scene(work, 4, args.E, n, args.frames, "taichi_mpm"), model, work / f"stiff_{name}.toml",
                           contact, args.fps)
        rec[name] = timed(f"stiff {name} (n_grid {n})", scene, work / name)
        if rec[name]["returncode"] == 0:
            tracks[name] = track_from_run_dir(work / name, name)
    out = {"runs": rec, "n_grid": args.n_grid, "twin_grid": twin}
    for ref in ("explicit",):
        if {ref, "rigid", f"{ref}_twin"} <= set(tracks):
            out[f"rigid_vs_{ref}"] = figures(accuracy_report(tracks["rigid"], tracks[ref], tracks[f"{ref}_twin"]))
            out[f"twin_vs_{ref}"] = figures(accuracy_report(tracks[f"{ref}_twin"], tracks[ref]))
            out[f"cpu_ratio_{ref}"] = rec[ref]["process_cpu_s"] / rec["rigid"]["process_cpu_s"]
    return out


def ball_ply(path: Path, centre=(0.0, 0.0, 0.0)) -> Path:
    """``N_BALL`` flat Gaussians tangent to a sphere of ``RADIUS`` (Fibonacci points, thin axis along the normal)."""
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    from gasp_core.testing.scenes_passive import fibonacci_sphere
    d = fibonacci_sphere(N_BALL)
    q = np.array([Rotation.align_vectors([v], [[1.0, 0.0, 0.0]])[0].as_quat() for v in d])
    g = Gaussians(means=RADIUS * d + np.asarray(centre), scales=np.tile([1e-8, 0.006, 0.006], (N_BALL, 1)),
                  rotations=q[:, [3, 0, 1, 2]], opacities=np.full(N_BALL, 3.0, np.float32),
                  sh_dc=np.full((N_BALL, 3), 0.5, np.float32))
    return write_gaussians(path, g, overwrite=True)


def ball_object(ply: Path, position, model: str = "auto") -> dict:
    return {"file": str(ply), "up_axis": "+z", "position": list(position), "material": {**STEEL, "model": model}}


def steel_scene(work: Path, frames: int, n_grid: int) -> Path:
    doc = {"frame_dt": 1.0 / 30.0, "n_frames": frames, "engine": {"name": "taichi_mpm", "options": {"threads": 1}},
           "domain": {"n_grid": n_grid}, "boundary": [{"kind": "ground", "height": 0.0, "friction": 0.5}],
           "object": [ball_object(ball_ply(work / "ball.ply"), (0.0, 0.0, DROP))]}
    path = work / "steel.toml"
    path.write_text(tomli_w.dumps(doc))
    return path


def apex_rise(cz) -> float:
    """The highest apex (a frame higher than both neighbours) of a centroid height series over its start, m."""
    c = np.asarray(cz)
    i = np.flatnonzero((c[1:-1] >= c[:-2]) & (c[1:-1] >= c[2:])) + 1
    return float(c[i].max() - c[0]) if len(i) else float("nan")


def part_steel(work: Path, args) -> dict:
    """The steel drop in this process: CPU, the model, restitution and energy per frame (material points)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam import build_engine
    print("[rigid] steel ball ...", flush=True)
    cpu0 = time.process_time()
    prep = prepare_scene(load_scene(steel_scene(work, args.steel_frames, args.steel_grid)))
    s = prep.setup
    eng = build_engine(prep.info, s)
    m, g = s.p_mass, -float(s.gravity[2])
    mat = s.material_mask

    def energy(x, v, lag=0.0):
        """sum m (g z + |v|^2 / 2), z taken ``lag`` s before (symplectic Euler's v is the last substep's)."""
        return float((m[mat] * (g * (x[mat, 2] - lag * v[mat, 2]) + 0.5 * (v[mat] ** 2).sum(axis=1))).sum())
    e = [energy(s.x, s.v)]
    e_half = [energy(s.x, s.v)]
    cz = [float(s.x[:s.n_render, 2].mean())]
    for _ in range(args.steel_frames):
        eng.step_frame()
        x, v = eng.positions().astype(np.float64), eng.velocities().astype(np.float64)
        e.append(energy(x, v))
        e_half.append(energy(x, v, 0.5 * eng.dt))
        cz.append(float(x[:s.n_render, 2].mean()))
    cpu = time.process_time() - cpu0
    vz = np.diff(cz) * 30.0
    hit = int(np.argmin(vz))            # fastest fall before the first bounce
    rise = float(vz[hit:].max())
    stats = eng.stats()
    return {"cpu_s": cpu, "load_avg_1min": os.getloadavg()[0], "model": prep.objects[0].body_model,
            "n_substeps": stats["n_substeps"], "n_points": stats["n_points"], "energy_J": e,
            "energy_max_rise_J": max(e) - e[0], "energy_start_J": e[0], "centroid_z": cz,
            "energy_half_step_J": e_half, "energy_half_step_max_rise_J": max(e_half) - e_half[0],
            "apex_max_rise_m": apex_rise(cz),
            "restitution": rise / -float(vz[hit]), "mass_kg": float(m[mat].sum())}


def mixed_scene(work: Path, stiff: bool, n_grid: int, frames: int) -> Path:
    """The soft cut donut (E 2e4) with (``stiff``) the steel ball at x = 0.45 m; one explicit domain for all."""
    doc = tomllib.loads(stiff_scene(work, 4, 2.0e4, n_grid, frames, "taichi_mpm").read_text())
    doc["domain"].update(lo=[-0.25, -0.25, -0.15], hi=[0.55, 0.25, 0.45])   # 3 cells of the twin under the ground
    doc["domain"].pop("padding", None)
    if stiff:
        doc["object"].append(ball_object(ball_ply(work / "ball.ply"), (0.45, 0.0, DROP)))
    path = work / f"mixed_{int(stiff)}_{n_grid}.toml"
    path.write_text(tomli_w.dumps(doc))
    return path


def part_mixed(work: Path, args) -> dict:
    twin = int(round(0.75 * args.n_grid))
    runs = {"soft": (False, args.n_grid), "soft_and_stiff": (True, args.n_grid), "soft_twin": (False, twin)}
    rec, tracks = {}, {}
    for name, (stiff, n) in runs.items():
        rec[name] = timed(f"mixed {name} (n_grid {n})", mixed_scene(work, stiff, n, args.frames), work / name)
        if rec[name]["returncode"] == 0:
            tracks[name] = track_from_run_dir(work / name, name)
    out = {"runs": rec}
    if "soft_and_stiff" in tracks:      # the donut alone (object 0) of the scene with the ball
        t = tracks["soft_and_stiff"]
        tracks["soft_and_stiff"] = dataclasses.replace(t, means=t.object_means(0), obj_start=t.obj_start[:2],
                                                       names=t.names[:1])
    if len(tracks) == 3:
        out["soft_with_stiff_vs_alone"] = figures(accuracy_report(tracks["soft_and_stiff"], tracks["soft"],
                                                                  tracks["soft_twin"]))
    return out


def part_figure(work: Path, args) -> dict:
    """The scanned-figure case: ``tests/test_stand.py``'s figure (a 0.25 m box on two 4 cm legs of flat Gaussians,
    filled by the pipeline; warp_mpm, n_grid 32, friction 0.8) at ``E`` 2e7 Pa with ``model = "auto"``, standing on
    the ground for ``--figure-frames`` frames through ``gasp simulate``'s pipeline in this process (sleep off, so a
    slow lean shows). Figures: the model taken and the line said, CPU seconds, substeps, per frame the lean (deg)
    and the height (the top tenth's centroid over its start)."""
    import warnings
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import test_stand as ts
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    print("[rigid] figure ...", flush=True)
    toml = ts.scene_file(ts.figure(work / "figure.ply"), args.figure_E, work, "figure", sleep=False,
                         n_frames=args.figure_frames)
    if args.figure_model != "auto":   # the material table is the file's last
        toml.write_text(toml.read_text() + f'model = "{args.figure_model}"\n')
    rows, x0 = [], []

    def on_frame(k, gs):
        m = gs[0].means.astype(np.float64)
        x0.append(m.copy()) if not x0 else None
        rows.append((k, *ts.lean_and_height(m, x0[0])))
    cpu0 = time.process_time()
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        simulate_scene(load_scene(toml), work / "figure_run", quiet=True, on_frame=on_frame)
    cpu = time.process_time() - cpu0
    run = json.loads((work / "figure_run" / "run.json").read_text())
    lean = [r[1] for r in rows]
    return {"cpu_s": cpu, "load_avg_1min": os.getloadavg()[0], "E": args.figure_E, "model": run["objects"][0].get("model"),
            "said": [str(w.message) for w in said if "rigid" in str(w.message)], "engine": run.get("engine"),
            "n_substeps": (run.get("engine_stats") or {}).get("n_substeps"), "rows": rows,
            "lean_growth_last_10_deg": lean[-1] - lean[-11] if len(lean) > 10 else float("nan"),
            "height_min": min(r[2] for r in rows), "height_max": max(r[2] for r in rows)}


TABLE_E = (1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 2e11)


def part_table(work: Path, args) -> dict:
    """Per E (the stiff block's scene, no simulation): auto's choice and why, the explicit model's substeps per frame
    and the rigid limit's (the engine's own step rules: ``choose_dt`` on the setup and on ``step_view``)."""
    import warnings
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.mpm.grid_engine import choose_dt
    from gasp_core.mpm.rigid import step_view
    rows = []
    for E in TABLE_E:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            prep = prepare_scene(load_scene(with_model(stiff_scene(work, 4, E, args.n_grid, args.frames, "taichi_mpm"),
                                                       "auto", work / f"table_{E:g}.toml")))
        s = prep.setup
        elastic = dataclasses.replace(s, materials=[dataclasses.replace(m, model="elastic") for m in s.materials])
        opts = {**s.options, "max_substeps": 10 ** 9}
        rows.append({"E": E, "auto": prep.objects[0].body_model["model"], "why": prep.objects[0].body_model["why"],
                     "explicit_substeps": choose_dt(elastic, opts, "taichi_mpm", True)[0],
                     "rigid_substeps": choose_dt(step_view(dataclasses.replace(
                         s, materials=[dataclasses.replace(m, model="rigid") for m in s.materials])), opts,
                         "taichi_mpm", True)[0]})
    return {"rows": rows}


def markdown(doc: dict, args) -> list[str]:
    lines = ["# The rigid limit of a stiff body (benchmarks/bench_rigid.py, issue 40)", "",
             f"`python benchmarks/bench_rigid.py --parts {','.join(args.parts)}"
             f"{f' --fps {args.fps:g}' if getattr(args, 'fps', None) else ''}` (taichi_mpm unless said, one thread; CPU: the "
             "process's user + system seconds; load average after each run in the json)", ""]
    for part in ("stiff", "mixed"):
        if part not in doc:
            continue
        lines += [f"## {part}", "", "| run | model | n_grid | points | substeps/frame | CPU s | wall s | load |",
                  "|---|---|---:|---:|---:|---:|---:|---:|"]
        for name, r in doc[part]["runs"].items():
            models = ", ".join(str(m.get("model")) for m in r.get("model") or [])
            lines.append(f"| {name} | {models} | {r.get('n_grid')} | {r.get('n_points')} | {r.get('n_substeps')} | "
                         f"{r.get('process_cpu_s', float('nan')):.1f} | {r.get('process_wall_s', float('nan')):.1f} | "
                         f"{r.get('load_avg_1min', float('nan')):.1f} |" if r["returncode"] == 0 else
                         f"| {name} | failed: {r.get('stderr', '')[-200:]!r} | | | | | | |")
        keys = ["rigid_vs_explicit"] if part == "stiff" else ["soft_with_stiff_vs_alone"]
        for key in (k for k in keys if k in doc[part]):
            f = doc[part][key]
            lines += ["", f"{key} (worst frames, / size): centroid {100 * f['centroid']:.3f} % ({f['in_u']['centroid']:.2f} U), "
                      f"rotation {f['rotation_deg']:.3f} deg ({f['in_u']['rotation_deg']:.2f} U), shape "
                      f"{100 * f['shape']:.3f} % ({f['in_u']['shape']:.2f} U); restitution by frame differences "
                      f"{f['restitution_run']:.3f} vs {f['restitution_ref']:.3f}, from the free flights "
                      f"{f['restitution_ballistic_run']:.3f} vs {f['restitution_ballistic_ref']:.3f}; first impact "
                      f"{1e3 * f['impact_run_s']:.0f} vs "
                      f"{1e3 * f['impact_ref_s']:.0f} ms."]
            ref = key.replace("rigid_vs_", "")
            if f"cpu_ratio_{ref}" in doc[part]:
                t = doc[part][f"twin_vs_{ref}"]
                lines += [f"CPU, {ref} over rigid: {doc[part][f'cpu_ratio_{ref}']:.1f}x. Its twin against it (= 1 U): "
                          f"centroid {100 * t['centroid']:.3f} %, rotation {t['rotation_deg']:.3f} deg, restitution "
                          f"{t['restitution_run']:.3f} vs {t['restitution_ref']:.3f} (free flights "
                          f"{t['restitution_ballistic_run']:.3f} vs {t['restitution_ballistic_ref']:.3f})."]
        lines.append("")
    if "table" in doc:
        lines += ["## table", "", "| E (Pa) | auto | explicit substeps/frame | rigid substeps/frame | why |", "|---:|---|---:|---:|---|"]
        lines += [f"| {r['E']:g} | {r['auto']} | {r['explicit_substeps']} | {r['rigid_substeps']} | {r['why']} |"
                  for r in doc["table"]["rows"]]
        lines.append("")
    if "figure" in doc:
        f = doc["figure"]
        lines += ["## figure", "", f"`tests/test_stand.py`'s figure on two legs, E {f['E']:g} Pa, model {args.figure_model!r} -> "
                  f"{(f['model'] or {}).get('model')!r} ({(f['model'] or {}).get('why')}), warp_mpm, n_grid 32, "
                  f"{len(f['rows']) - 1} frames, {f['n_substeps']} substeps/frame: **{f['cpu_s']:.1f} s CPU** (prepare, "
                  f"fill, frames, writing; load {f['load_avg_1min']:.1f}); lean growth over the last 10 frames "
                  f"{f['lean_growth_last_10_deg']:+.4f} deg, height / start {f['height_min']:.4f} to {f['height_max']:.4f}.",
                  "", "| frame | lean (deg) | height / start |", "|---|---:|---:|"]
        lines += [f"| {k} | {lean:.4f} | {h:.4f} |" for k, lean, h in f["rows"] if k % 5 == 0 or k == f["rows"][-1][0]]
        lines.append("")
    if "steel" in doc:
        s = doc["steel"]
        lines += ["## steel", "", f"10 cm steel ball of {N_BALL} flat Gaussians (E 2e11, nu 0.3, rho 7850, model "
                  f"'auto' -> {s['model']['model']!r}: {s['model']['why']}), dropped {100 * DROP:g} cm, n_grid "
                  f"{args.steel_grid}, {args.steel_frames} frames, {s['n_points']} points, {s['n_substeps']} "
                  f"substeps/frame: **{s['cpu_s']:.1f} s CPU** (prepare, build and frames; load {s['load_avg_1min']:.1f}), "
                  f"restitution {s['restitution']:.3f}, energy at the start {s['energy_start_J']:.4f} J, its largest "
                  f"rise above it {s['energy_max_rise_J']:+.2e} J, at the end {s['energy_J'][-1] - s['energy_start_J']:+.2e} J; "
                  f"with the height half a substep back (the time symplectic Euler's velocity belongs to) its largest "
                  f"rise {s['energy_half_step_max_rise_J']:+.2e} J; the centroid's highest apex after a bounce "
                  f"{1e3 * s['apex_max_rise_m']:+.2f} mm from the start.", ""]
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--parts", type=lambda s: s.split(","), default=["stiff", "steel", "mixed", "table"])
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--E", type=float, default=1e7)
    ap.add_argument("--n-grid", type=int, default=32)
    ap.add_argument("--steel-frames", type=int, default=30)
    ap.add_argument("--steel-grid", type=int, default=32)
    ap.add_argument("--fps", type=float, default=None, help="stiff: frames at this rate over the same time (the "
                    "frame-difference restitution resolves a contact shorter than a 30 fps frame)")
    ap.add_argument("--figure-E", type=float, default=2e7)
    ap.add_argument("--figure-frames", type=int, default=30)
    ap.add_argument("--figure-model", default="auto", choices=("auto", "elastic", "rigid"))
    ap.add_argument("--tag", default="", help="results file suffix")
    ap.add_argument("--keep", type=Path, default=None, help="run in this (new) folder and keep it")
    args = ap.parse_args(argv)
    doc = {"args": vars(args)}
    parts = {"stiff": part_stiff, "steel": part_steel, "mixed": part_mixed, "table": part_table, "figure": part_figure}
    with tempfile.TemporaryDirectory(prefix="gasp_rigid_") as tmp:
        work = Path(tmp) if args.keep is None else args.keep
        work.mkdir(parents=True, exist_ok=True)
        for name in args.parts:
            doc[name] = parts[name](work, args)
    RESULTS.mkdir(parents=True, exist_ok=True)
    stem = f"rigid{'_' + args.tag if args.tag else ''}"
    (RESULTS / f"{stem}.json").write_text(json.dumps(doc, indent=1, default=lambda o: str(o) if isinstance(o, Path) else float(o)))
    lines = markdown(doc, args)
    (RESULTS / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
