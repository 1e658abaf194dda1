"""Numerical dissipation of the engines: restitution of an elastic ball and free vibration of a bar, against
``cfl`` and ``n_grid``, with APIC and with the AFLIP transfer (engine option ``flip``), and the stability of
AFLIP at the extremes.

Scenes (``gasp_core/testing``), all elastic, so every joule lost is lost by the numerics:

- ``bounce``: the ``bounce_hertz`` conformance scene (jelly ball R 0.12 m, E 2e5 Pa, nu 0.3, dropped 0.14 m on
  a frictionless ground; 1.6k points at n_grid 32): restitution ``v_out / v_in`` (elastic: 1), and the contact
  duration against Hertz. Other grids keep the ball's size (points at dx / 2).
- ``bar``: the ``bar_viscous_decay`` bar (free-free, L 0.5 m, nu 0, 2 x 2 dx section) with viscosity 0, in its
  first longitudinal mode (10 Hz), 0.4 s = 4 periods: the log decrement per period of the fitted mode and the
  kinetic energy kept after 4 periods ``exp(-8 delta)`` (elastic: 0 and 1).
- ``stiff`` (``--stiff``, slow): the bounce with E 1e9 Pa.
- ``extremes``: the four impact cases of ``conformance_tests/test_extremes.py`` (E 1e9, nu 0.49, rho 10, a
  20 m/s drop) with each transfer: ``ok`` (no NaN, no energy gain over 5 %, no point deeper than 0.5 dx) or
  the clear error, as that test asks.

Engines: ``taichi_mpm`` (threads 1) and ``warp_mpm`` run everything; other engines with a ``cfl`` option
(``mujoco_flex``, ``genesis``) run the ball and the bar with their defaults (``mujoco_flex`` also with its
Rayleigh ``damping`` option at 0; its lattice diverges at the ball's impact, a declared known failure, which
the table shows); engines that cannot run are listed with the reason.

Usage::

    python benchmarks/bench_dissipation.py                          # all installed engines
    python benchmarks/bench_dissipation.py --engines warp_mpm --stiff

Writes ``benchmarks/results/bench_dissipation.json`` and ``.md`` (the tables ``docs/dissipation.md`` quotes).
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from gasp_core.errors import GaspError
from gasp_core.fsutil import atomic_json, atomic_write
from gasp_core.seam.plugins import engines as installed_engines
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing import scenes_analytic as sa
from gasp_core.testing.helpers import make_setup, sphere_points
from gasp_core.testing.kit import run_trace
from gasp_core.testing.scenes_damping import bar_mode_decay, bar_mode_setup

RESULTS = Path(__file__).resolve().parent / "results"
CFLS = (0.8, 0.4, 0.2, 0.1)
GRIDS = (16, 32, 48)
FLIPS = (0.0, 0.99)
BAR_FRAMES = 80            # 0.4 s at 200 fps: 4 periods of the 10 Hz mode
MPM = ("taichi_mpm", "warp_mpm")


def bounce_setup(n_grid: int = sa.BOUNCE_NGRID, mat: Material = sa.BOUNCE_MAT, options: dict | None = None):
    """The ``bounce_hertz`` ball at any grid (same ball, ground 3 dx above the floor, points at dx / 2)."""
    dx = 1.0 / n_grid
    ground = 3 * dx
    x, p_vol = sphere_points((0.5, 0.5, ground + sa.BOUNCE_R + sa.BOUNCE_DROP), sa.BOUNCE_R, dx / 2)
    return make_setup(x, p_vol, mat, n_grid=n_grid, frame_dt=1.0 / sa.BOUNCE_FPS,
                      boundaries=[Boundary("ground", height=ground, friction=0.0)], options=options)


def run_bounce(info, n_grid, options, mat=sa.BOUNCE_MAT) -> dict:
    t0 = time.perf_counter()
    try:
        tr = run_trace(info, bounce_setup(n_grid, mat, options), sa._bounce_frames())
        checks = {c.name: c for c in sa._eval_bounce(info, tr)}
    except GaspError as e:
        return {"status": f"{type(e).__name__}: {str(e)[:160]}", "wall_s": time.perf_counter() - t0}
    if "restitution" not in checks:
        return {"status": next(iter(checks.values())).message, "wall_s": time.perf_counter() - t0}
    return {"status": "ok", "restitution": checks["restitution"].figures["value"],
            "hertz_rel": checks["hertz_duration"].figures["signed"], "n_substeps": tr.stats.engine.get("n_substeps"),
            "n_points": len(tr.setup.x), "wall_s": time.perf_counter() - t0}


def run_bar(info, n_grid, options) -> dict:
    t0 = time.perf_counter()
    try:
        tr = run_trace(info, bar_mode_setup(0.0, n_grid=n_grid, options=options), BAR_FRAMES)
    except GaspError as e:
        return {"status": f"{type(e).__name__}: {str(e)[:160]}", "wall_s": time.perf_counter() - t0}
    fit = bar_mode_decay(tr)
    return {"status": "ok", "delta": fit["delta"], "ke_kept_4_periods": math.exp(-8.0 * fit["delta"]),
            "omega": fit["omega"], "n_substeps": tr.stats.engine.get("n_substeps"), "n_points": len(tr.setup.x),
            "wall_s": time.perf_counter() - t0}


def run_extremes(info, flip) -> dict:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "conformance_tests"))
    from test_extremes import IMPACT_CASES, IMPACT_FRAMES, impact_verdict
    out = {}
    for case, build in IMPACT_CASES.items():
        s = build(info)
        s = s.replace(options={**s.options, **base_options(info.name), "flip": flip})
        try:
            problem = impact_verdict(run_trace(info, s, IMPACT_FRAMES))
            out[case] = "ok" if problem is None else f"WRONG: {problem}"
        except GaspError as e:
            out[case] = f"clear error {type(e).__name__}"
    return out


def base_options(name: str) -> dict:
    return {"threads": 1} if name == "taichi_mpm" else {}


def bench_engine(info, stiff: bool) -> dict:
    """Every table of one engine (MPM engines: both transfers; others: the bar with their own damping)."""
    name, res = info.name, {"bounce_cfl": [], "bounce_grid": [], "bar_cfl": [], "bar_grid": [], "stiff": [],
                            "extremes": {}}
    opts0 = base_options(name)
    if name in MPM:
        for flip in FLIPS:
            for cfl in CFLS:
                o = {**opts0, "cfl": cfl, "flip": flip}
                res["bounce_cfl"].append({"cfl": cfl, "flip": flip, **run_bounce(info, 32, o)})
                res["bar_cfl"].append({"cfl": cfl, "flip": flip, **run_bar(info, 32, o)})
                print(name, res["bounce_cfl"][-1], res["bar_cfl"][-1], flush=True)
            for ng in GRIDS:
                o = {**opts0, "cfl": 0.4, "flip": flip}
                res["bounce_grid"].append({"n_grid": ng, "flip": flip, **run_bounce(info, ng, o)})
                res["bar_grid"].append({"n_grid": ng, "flip": flip, **run_bar(info, ng, o)})
                print(name, res["bounce_grid"][-1], res["bar_grid"][-1], flush=True)
            if stiff:
                for cfl in (0.8, 0.4):
                    o = {**opts0, "cfl": cfl, "flip": flip}
                    res["stiff"].append({"cfl": cfl, "flip": flip, **run_bounce(
                        info, 32, o, Material("jelly", E=1e9, nu=0.3, rho=1000.0))})
            res["extremes"][str(flip)] = run_extremes(info, flip)
            print(name, flip, res["extremes"][str(flip)], flush=True)
    else:
        for cfl in CFLS:
            res["other_bounce"] = res.get("other_bounce", []) + [{"cfl": cfl, **run_bounce(info, 32, {**opts0, "cfl": cfl})}]
            print(name, res["other_bounce"][-1], flush=True)
        damping = next((o.default for o in info.options if o.name == "damping"), None)
        for d in ([damping, 0.0] if damping is not None else [None]):
            for cfl in CFLS:
                o = {**opts0, "cfl": cfl, **({"damping": d} if d is not None else {})}
                res["bar_cfl"].append({"cfl": cfl, "damping": d, **run_bar(info, 32, o)})
                print(name, res["bar_cfl"][-1], flush=True)
    return res


def _f(v, fmt=".3f"):
    return "-" if v is None or (isinstance(v, float) and not np.isfinite(v)) else format(v, fmt)


def markdown(results: dict, meta: dict) -> str:
    lines = ["# Numerical dissipation (benchmarks/bench_dissipation.py)", "",
             f"Machine: {meta['machine']}; load average at start {meta['load']}; {meta['date']}.", ""]
    for name, r in results.items():
        if "not_run" in r:
            lines += [f"## {name}: not run ({r['not_run']})", ""]
            continue
        lines += [f"## {name}", ""]
        if r["bounce_cfl"]:
            lines += ["Restitution of the elastic ball (`bounce_hertz`, n_grid 32; elastic: 1) and contact duration vs "
                      "Hertz, against cfl:", "", "| cfl | APIC e | AFLIP 0.99 e | APIC t_c err | AFLIP t_c err | substeps |",
                      "|---|---|---|---|---|---|"]
            for cfl in CFLS:
                a = next(x for x in r["bounce_cfl"] if x["cfl"] == cfl and x["flip"] == 0.0)
                b = next(x for x in r["bounce_cfl"] if x["cfl"] == cfl and x["flip"] > 0)
                lines.append(f"| {cfl} | {_f(a.get('restitution'))} | {_f(b.get('restitution'))} | "
                             f"{_f(a.get('hertz_rel'), '+.3f')} | {_f(b.get('hertz_rel'), '+.3f')} | {a.get('n_substeps', '-')} |")
            lines += ["", "Against n_grid (cfl 0.4; the ball is R = 0.12 m):", "",
                      "| n_grid | R / dx | points | APIC e | AFLIP 0.99 e |", "|---|---|---|---|---|"]
            for ng in GRIDS:
                a = next(x for x in r["bounce_grid"] if x["n_grid"] == ng and x["flip"] == 0.0)
                b = next(x for x in r["bounce_grid"] if x["n_grid"] == ng and x["flip"] > 0)
                lines.append(f"| {ng} | {sa.BOUNCE_R * ng:.1f} | {a.get('n_points', '-')} | {_f(a.get('restitution'))} | "
                             f"{_f(b.get('restitution'))} |")
            lines.append("")
        if r.get("other_bounce"):
            lines += ["Restitution of the elastic ball (`bounce_hertz`, n_grid 32; elastic: 1), the engine's defaults:", "",
                      "| cfl | e | contact time vs Hertz | status |", "|---|---|---|---|"]
            for x in r["other_bounce"]:
                lines.append(f"| {x['cfl']} | {_f(x.get('restitution'))} | {_f(x.get('hertz_rel'), '+.3f')} | "
                             f"{x['status'][:90]} |")
            lines.append("")
        if r["bar_cfl"]:
            key = "flip" if name in MPM else "damping"
            vals = sorted({x[key] for x in r["bar_cfl"]}, key=lambda v: -1 if v is None else v)
            lines += ["Free-free bar, first longitudinal mode (10 Hz, L 0.5 m, nu 0, viscosity 0), n_grid 32: log "
                      "decrement per period (elastic: 0) / kinetic energy kept after 4 periods, against cfl:", "",
                      "| cfl | " + " | ".join(f"{key} {'default' if v is None else v}" for v in vals) + " |", "|---|" + "---|" * len(vals)]
            for cfl in CFLS:
                cells = []
                for v in vals:
                    x = next(y for y in r["bar_cfl"] if y["cfl"] == cfl and y[key] == v)
                    cells.append(f"{_f(x.get('delta'), '.4f')} / {_f(x.get('ke_kept_4_periods'))}" if x["status"] == "ok"
                                 else x["status"][:60])
                lines.append(f"| {cfl} | " + " | ".join(cells) + " |")
            lines.append("")
        if r["bar_grid"]:
            lines += ["Against n_grid (cfl 0.4; the bar is 0.5 m):", "",
                      "| n_grid | L / dx | APIC delta / KE kept | AFLIP 0.99 delta / KE kept |", "|---|---|---|---|"]
            for ng in GRIDS:
                c = [next(x for x in r["bar_grid"] if x["n_grid"] == ng and (x["flip"] > 0) == f) for f in (False, True)]
                lines.append(f"| {ng} | {0.5 * ng:.0f} | " + " | ".join(
                    f"{_f(x.get('delta'), '.4f')} / {_f(x.get('ke_kept_4_periods'))}" for x in c) + " |")
            lines.append("")
        if r["stiff"]:
            lines += ["Ball with E 1e9 Pa (n_grid 32):", "", "| cfl | transfer | e | substeps |", "|---|---|---|---|"]
            for x in r["stiff"]:
                lines.append(f"| {x['cfl']} | {'AFLIP' if x['flip'] else 'APIC'} | {_f(x.get('restitution'))} | "
                             f"{x.get('n_substeps', '-')} |")
            lines.append("")
        if r["extremes"]:
            lines += ["Stability at the extremes (`test_extreme_impact` cases, 0.2 s):", "",
                      "| transfer | " + " | ".join(next(iter(r["extremes"].values()))) + " |",
                      "|---|" + "---|" * len(next(iter(r["extremes"].values())))]
            for flip, cases in r["extremes"].items():
                lines.append(f"| {'APIC' if float(flip) == 0 else f'AFLIP {flip}'} | " + " | ".join(cases.values()) + " |")
            lines.append("")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engines", help="comma-separated engine names (default: every installed engine)")
    ap.add_argument("--stiff", action="store_true", help="also the E 1e9 ball (slow: ~40k substeps per run)")
    ap.add_argument("--out", type=Path, default=RESULTS / "bench_dissipation")
    args = ap.parse_args(argv)
    found = installed_engines()
    names = args.engines.split(",") if args.engines else sorted(found)
    meta = {"machine": f"{platform.node()} {os.cpu_count()} cores", "load": os.getloadavg()[0],
            "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    results = {}
    for name in names:
        info = found.get(name)
        reason = "not installed" if info is None else info.unavailable_reason()
        if reason is None and name not in MPM and "jelly" not in info.capabilities.materials:
            reason = "no jelly material"
        if reason is None and name not in MPM and "cfl" not in {o.name for o in info.options}:
            reason = "no cfl option to sweep"
        results[name] = {"not_run": reason} if reason else bench_engine(info, args.stiff)
    atomic_json(args.out.with_suffix(".json"), {"meta": meta, "results": results})
    text = markdown(results, meta)
    atomic_write(args.out.with_suffix(".md"), lambda f: f.write(text), binary=False)
    print(f"wrote {args.out}.md and .json")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
