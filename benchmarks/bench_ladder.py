"""Issue 40, item 4: the same drop from E 1e4 to 2e11 Pa on every engine (:mod:`gasp_studies.ladder`).

Parts (``--parts``, one after another in this process):

* ``ladder``: per engine and E, ``model = "auto"`` (the route ``gasp simulate`` takes) and, on the engines with the
  feature ``rigid_limit``, the explicit elastic model too (``model = "elastic"``, at every E: 136 points are cheap
  even at 2,343 substeps a frame). Per run: the model, substeps per frame, CPU and wall seconds, the restitution from
  the free flights (and by frame differences) and ``K + P``'s largest rise over the start in units of ``M g h``.
  mujoco_flex above E 1e7 is not run (about 1,100 and 5,400 substeps a frame at ~10 ms each).
* ``block``: the 1.089 of issue 40 explained. The stiff block of ``bench_newton_stiff.py`` (the donut cut to every
  4th Gaussian, E 1e7, ``n_grid`` 32, 8 frames, taichi_mpm explicit, ``contact = "grid"``: the contact its 1.089
  was measured with) run in this process: per frame the material points' ``K + P`` against the start, the rendered
  points' centroid height, and both restitutions (:func:`gasp_studies.accuracy.events`, the gap of the accuracy
  reports: half a cell).
* ``units``: the error of ``model = "auto"`` in units of U, per E of the ladder, on one engine (``--units-engine``,
  warp_mpm: its explicit runs take 0.1-24 s of CPU) at ``--units-grid`` (16, the ladder's). Per E three runs of the
  same points: the explicit elastic model (the reference), the same on the twin grid ``round(3/4 n_grid)`` (U, as
  ``bench_rigid.py --parts stiff`` takes it), and ``auto``; the ``auto`` run against the reference through
  :func:`gasp_studies.trade.accuracy_report` with the twin (``bench_rigid.figures``: centroid, rotation, shape, each
  in U, and both restitutions; gap half a cell), and the twin against the reference (= 1 U). Where ``auto`` takes
  the elastic model it is the reference's own run: its error is 0 by construction, and ``identical`` says whether
  the two runs agree to the last bit. Run as ``--parts units --name ladder_units``.

Run: ``python benchmarks/bench_ladder.py`` (writes ``benchmarks/results/ladder.{json,md}``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

RESULTS = Path(__file__).resolve().parent / "results"
ENGINES = ("taichi_mpm", "warp_mpm", "mujoco_flex", "newton")
NOT_RUN = {("mujoco_flex", 1e9), ("mujoco_flex", 2e11)}


def part_ladder(args) -> list[dict]:
    from gasp_core.seam.plugins import engines
    from gasp_studies.ladder import LADDER, run_case
    found = engines()
    rows = []
    for name in ENGINES:
        if name not in found or found[name].unavailable_reason():
            continue
        info = found[name]
        models = ("auto", "elastic") if "rigid_limit" in info.capabilities.features else ("auto",)
        for E, rho, what in LADDER:
            for model in models:
                if (name, E) in NOT_RUN:
                    rows.append({"engine": name, "E": E, "rho": rho, "asked": model, "outcome": "not run"})
                    continue
                t0 = time.process_time()
                r = run_case(info, E, rho, model)
                r.update(asked=model, what=what, load_avg_1min=os.getloadavg()[0], cpu_to_outcome_s=time.process_time() - t0)
                r.pop("energy_J", None)
                print(f"[ladder] {name} E {E:.0e} {model}: {r['outcome']} {r.get('model')} "
                      f"{r.get('n_substeps')} substeps, {r.get('cpu_s', r['cpu_to_outcome_s']):.2f} s, "
                      f"e {r.get('restitution', float('nan')):.3f}, peak {r.get('energy_peak', float('nan')):+.4f}",
                      flush=True)
                rows.append(r)
    return rows


def _timed_track(info, setup, label):
    from gasp_core.testing import run_trace
    from gasp_studies.ladder import N_FRAMES, track
    cpu0 = time.process_time()
    tr = run_trace(info, setup, N_FRAMES)
    return track(tr, label), {"cpu_s": time.process_time() - cpu0, "n_substeps": tr.stats.engine.get("n_substeps"),
                              "load_avg_1min": os.getloadavg()[0]}


def part_units(args) -> list[dict]:
    """Per E: ``auto`` against the explicit reference in U of the reference's twin (see the module)."""
    import dataclasses
    from bench_rigid import figures
    from gasp_core.seam.plugins import engines
    from gasp_studies.ladder import LADDER, ball_setup, resolve
    from gasp_studies.trade import accuracy_report
    info, n, twin = engines()[args.units_engine], args.units_grid, int(round(0.75 * args.units_grid))
    rows = []
    for E, rho, what in LADDER:
        ref = ball_setup(E, rho, "elastic", n_grid=n)
        auto = ball_setup(E, rho, "auto", n_grid=n)
        choice = resolve(info, auto)
        t_ref, r_ref = _timed_track(info, ref, "explicit")
        t_twin, r_twin = _timed_track(info, dataclasses.replace(ref, n_grid=twin), "explicit_twin")
        t_auto, r_auto = _timed_track(info, auto, "auto")
        row = {"engine": info.name, "E": E, "rho": rho, "what": what, "n_grid": n, "twin_grid": twin,
               "n_points": len(ref.x), "auto_model": choice["model"], "why": choice.get("why", ""),
               "runs": {"explicit": r_ref, "explicit_twin": r_twin, "auto": r_auto},
               "identical": bool(np.array_equal(t_auto.means, t_ref.means)),
               "auto_vs_explicit": figures(accuracy_report(t_auto, t_ref, t_twin)),
               "twin_vs_explicit": figures(accuracy_report(t_twin, t_ref))}
        a = row["auto_vs_explicit"]
        print(f"[units] E {E:.0e} auto {choice['model']}: centroid {a['in_u']['centroid']:.2f} U, rotation "
              f"{a['rotation_deg']:.2e} deg ({a['in_u']['rotation_deg']:.2f} U), e {a['restitution_ballistic_run']:.3f} "
              f"vs {a['restitution_ballistic_ref']:.3f}, identical {row['identical']}", flush=True)
        rows.append(row)
    return rows


def part_block(args) -> dict:
    """The stiff block, explicit, grid contact, in this process (see the module)."""
    from bench_newton_stiff import stiff_scene
    from bench_rigid import with_model
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam import build_engine
    from gasp_studies.accuracy import CONTACT_GAP_DX, Track, events
    work = Path(tempfile.mkdtemp(prefix="ladder_block_"))
    scene = with_model(stiff_scene(work, 4, 1e7, 32, 8, "taichi_mpm"), "elastic", work / "block.toml", "grid")
    cpu0 = time.process_time()
    prep = prepare_scene(load_scene(scene))
    s = prep.setup
    eng = build_engine(prep.info, s)
    m, g, mat, n = s.p_mass, -float(s.gravity[2]), s.material_mask, s.n_render

    def energy(x, v):
        return float((m[mat] * (g * x[mat, 2] + 0.5 * (v[mat] ** 2).sum(axis=1))).sum())
    e, means = [energy(s.x, s.v)], [s.x[:n].copy()]
    for _ in range(8):
        eng.step_frame()
        x, v = eng.positions().astype(np.float64), eng.velocities().astype(np.float64)
        e.append(energy(x, v))
        means.append(x[:n].copy())
    cpu = time.process_time() - cpu0
    ground = min(b.height for b in s.boundaries if b.kind == "ground")
    means = np.stack(means)
    tr = Track(means=means, obj_start=np.array([0, n]), names=["block"], frame_dt=s.frame_dt, ground_z=ground, dx=s.dx)
    ev = events(tr, 0, CONTACT_GAP_DX * s.dx)
    cz = means[:, :, 2].mean(axis=1)
    drop = float(cz[0] - cz.min())
    M = float(m[mat].sum())
    return {"cpu_s": cpu, "load_avg_1min": os.getloadavg()[0], "n_substeps": eng.stats().get("n_substeps"),
            "n_points": len(s.x), "energy_J": e, "energy_rel_start": [(x - e[0]) / (M * g * drop) for x in e],
            "mass_kg": M, "centroid_z": cz.tolist(), "drop_m": drop, "vz": (np.diff(cz) / s.frame_dt).tolist(),
            "restitution_frames": ev["restitution"], "restitution_ballistic": ev["restitution_ballistic"],
            "impact_s": ev["impact_s"], "contact_s": ev["contact_s"]}


def _f(x, fmt):
    return "-" if x is None or (isinstance(x, float) and not np.isfinite(x)) else format(x, fmt)


def markdown(out: dict) -> str:
    if "ladder" not in out and "block" not in out:
        return "\n".join(["# The ladder's error in units of U (benchmarks/bench_ladder.py --parts units, issue 40 "
                          f"item 5)", "", f"Load average at the start {out['load_avg_start']:.2f}."]
                         + markdown_units(out.get("units"))[1:]) + "\n"
    lines = ["# The same drop from E 1e4 to 2e11 Pa (benchmarks/bench_ladder.py, issue 40 item 4)", "",
             "`python benchmarks/bench_ladder.py`: gasp_studies/ladder.py's drop (a 0.1 m ball of 136 points, 0.2 m onto "
             "the ground, n_grid 16, 60 frames of 0.01 s); `auto`: the route `gasp simulate` takes; `elastic`: the "
             "explicit model forced. CPU: this process's seconds for build and frames (one job at a time; load in "
             "the json). Restitution from the free flights (frame differences in brackets); energy: K + P's largest "
             "rise over the start after frame 0, in units of M g h (negative: never above the start).", "",
             "| engine | E Pa | rho | asked | model | substeps/frame | CPU s | restitution | K + P peak | load |",
             "|---|---:|---:|---|---|---:|---:|---|---:|---:|"]
    for r in out.get("ladder", []):
        if r["outcome"] != "ok":
            err = r.get("error", "")[:120]
            lines.append(f"| {r['engine']} | {r['E']:.0e} | {r['rho']:g} | {r['asked']} | {r.get('model', '-')} | - | "
                         f"{_f(r.get('cpu_to_outcome_s'), '.1f')} | {r['outcome']}{': ' + err if err else ''} | - | "
                         f"{_f(r.get('load_avg_1min'), '.1f')} |")
            continue
        lines.append(f"| {r['engine']} | {r['E']:.0e} | {r['rho']:g} | {r['asked']} | {r['model']} | {r['n_substeps']} | "
                     f"{r['cpu_s']:.2f} | {_f(r['restitution'], '.3f')} ({_f(r['restitution_frames'], '.3f')}) | "
                     f"{r['energy_peak']:+.2%} | {r['load_avg_1min']:.1f} |")
    b = out.get("block")
    if b:
        lines += ["", "## The stiff block's 1.089", "",
                  f"taichi_mpm explicit, contact grid, E 1e7, n_grid 32, 8 frames, {b['n_points']} points, "
                  f"{b['n_substeps']} substeps/frame: {b['cpu_s']:.1f} s CPU (load {b['load_avg_1min']:.1f}). "
                  f"Restitution by frame differences {_f(b['restitution_frames'], '.3f')}, from the free flights "
                  f"{_f(b['restitution_ballistic'], '.3f')}.", "",
                  "| frame | centroid z m | vz m/s (to this frame) | K + P - start, J | in M g (drop) |", "|---:|---:|---:|---:|---:|"]
        for f, (z, e, rel) in enumerate(zip(b["centroid_z"], b["energy_J"], b["energy_rel_start"])):
            vz = b["vz"][f - 1] if f else float("nan")
            lines.append(f"| {f} | {z:.4f} | {_f(vz, '+.3f')} | {e - b['energy_J'][0]:+.4f} | {rel:+.3f} |")
    lines += markdown_units(out.get("units"))
    return "\n".join(lines) + "\n"


def markdown_units(rows: list[dict] | None) -> list[str]:
    """The ``units`` part's table (empty without it)."""
    if not rows:
        return []
    r0 = rows[0]
    lines = ["", f"## The error of `auto` in units of U ({r0['engine']}, n_grid {r0['n_grid']}, {r0['n_points']} points)", "",
             f"Per E: the explicit elastic model (the reference), the same points on n_grid {r0['twin_grid']} (its twin: "
             "U), and `model = \"auto\"`; `auto` against the reference (worst frame, centroid / size, rotation in "
             "degrees), each in U of the twin's own figure; restitution from the free flights (gap half a cell, as "
             "bench_rigid's stiff part). Where `auto` is the elastic model it is the reference's run: 0 by "
             "construction (`identical`: the same to the last bit). CPU: each run's build and frames.", "",
             "| E Pa | auto | identical | centroid | centroid U | rotation deg | rotation U | shape U | restitution auto "
             "/ explicit / twin | CPU explicit / twin / auto s | substeps explicit / twin / auto | load |",
             "|---:|---|---|---:|---:|---:|---:|---:|---|---|---|---:|"]
    for r in rows:
        a, t, ru = r["auto_vs_explicit"], r["twin_vs_explicit"], r["runs"]
        lines.append(f"| {r['E']:.0e} | {r['auto_model']} | {'yes' if r['identical'] else 'no'} | "
                     f"{100 * a['centroid']:.2f} % | {_f(a['in_u']['centroid'], '.2f')} | {a['rotation_deg']:.1e} | "
                     f"{_f(a['in_u']['rotation_deg'], '.2f')} | {_f(a['in_u']['shape'], '.2f')} | "
                     f"{_f(a['restitution_ballistic_run'], '.3f')} / {_f(a['restitution_ballistic_ref'], '.3f')} / "
                     f"{_f(t['restitution_ballistic_run'], '.3f')} | "
                     + " / ".join(f"{ru[k]['cpu_s']:.2f}" for k in ("explicit", "explicit_twin", "auto")) + " | "
                     + " / ".join(str(ru[k]['n_substeps']) for k in ("explicit", "explicit_twin", "auto")) +
                     f" | {ru['auto']['load_avg_1min']:.1f} |")
    lines += ["", "U per E (the twin against the reference: centroid / size, rotation degrees): " + "; ".join(
        f"{r['E']:.0e}: {100 * r['twin_vs_explicit']['centroid']:.2f} %, {r['twin_vs_explicit']['rotation_deg']:.1e} deg"
        for r in rows) + "."]
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--parts", default="ladder,block")
    ap.add_argument("--name", default="ladder")
    ap.add_argument("--units-engine", default="warp_mpm")
    ap.add_argument("--units-grid", type=int, default=16)
    args = ap.parse_args(argv)
    out = {"load_avg_start": os.getloadavg()[0]}
    for part in args.parts.split(","):
        out[part] = {"ladder": part_ladder, "block": part_block, "units": part_units}[part](args)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{args.name}.json").write_text(json.dumps(out, indent=1, default=float))
    (RESULTS / f"{args.name}.md").write_text(markdown(out))
    print(markdown(out))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
