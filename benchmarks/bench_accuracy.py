"""The split accuracy report of kept ``bench_trade.py`` runs, and the ``default`` rule applied to it.

Reads run folders kept by ``benchmarks/bench_trade.py --keep K`` (one sub-folder per variant) and their
timings (the ``bench_trade`` results files), measures every candidate against the reference run with
:func:`gasp_studies.trade.accuracy_report` (centroid, rotation, shape, events, renders: PSNR and SSIM from
the capture's cameras or a fixed orbit of 4 views), each figure also in units of U = the reference's twin
(the same model on the next coarser grid), and applies the rule of ``docs/speed_accuracy.md`` ("Choosing
the default"): the cheapest candidate whose shape residual is within 1.5 U, whose events are in their bands
and whose renders are at least as close to the reference as the twin's.

Usage (the donut, 12 frames; the runs of the first two lines may run side by side)::

    python benchmarks/bench_trade.py --variants full,draft,passive_every8_ppc4 --frames 12 --threads 1 --keep out/trade --tag f12_a30
    python benchmarks/bench_trade.py --variants full_g48,default --frames 12 --threads 1 --keep out/trade --tag f12_b30
    python benchmarks/bench_accuracy.py --runs out/trade --reference full --twin full_g48 \\
        --candidates default,draft,passive_every8_ppc4,full_g48 \\
        --timings benchmarks/results/bench_trade_donut_f12_a30.json benchmarks/results/bench_trade_donut_f12_b30.json

Writes ``benchmarks/results/accuracy_<tag>.{json,md}`` (default tag ``donut_f12``).
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from gasp_studies.accuracy import track_from_run_dir
from gasp_studies.images import cameras_for, image_scores, render_frames
from gasp_studies.strips import strip_frames
from gasp_studies.trade import BANDS, accuracy_report, choose_default, rule_checks

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"


def timings(files: list[Path]) -> dict[str, dict]:
    """``{variant: record}`` from ``bench_trade`` results files (later files win)."""
    out: dict[str, dict] = {}
    for f in files:
        out.update(json.loads(Path(f).read_text())["runs"])
    return out


def measure(runs: Path, ref_name: str, twin_name: str, names: list[str], n_images: int) -> dict:
    """Reports of every candidate (and of the twin against the reference, for U) with renders."""
    ref = track_from_run_dir(runs / ref_name, ref_name)
    twin = track_from_run_dir(runs / twin_name, twin_name)
    n = len(ref.means) - 1
    frames = [f for f in strip_frames(n, n_images + 1) if f > 0]
    cams, views = cameras_for(ref, frames)
    t0 = time.perf_counter()
    ref_img = render_frames(ref, frames, cams)
    twin_scores = image_scores(ref_img, render_frames(twin, frames, cams))
    out = {}
    for name in dict.fromkeys([twin_name] + names):
        tr = twin if name == twin_name else track_from_run_dir(runs / name, name)
        sc = twin_scores if name == twin_name else image_scores(ref_img, render_frames(tr, frames, cams))
        rep = accuracy_report(tr, ref, twin, images={"run": sc, "twin": twin_scores, "views": views,
                                                      "frames": frames})
        out[name] = rep
        print(f"[bench_accuracy] {name}: done ({time.perf_counter() - t0:.0f} s)", flush=True)
    return out


def _f(x, fmt=".3g"):
    return "-" if x is None or (isinstance(x, float) and np.isnan(x)) else format(x, fmt)


def markdown(doc: dict) -> str:
    """The report as Markdown tables: one per object (split, events, images), then the rule."""
    out = [f"# Accuracy report: `{doc['reference']}` as the reference, `{doc['twin']}` its twin (U)", "",
           f"Runs: `{doc['runs']}`; {doc['n_frames']} frames; images: {doc['views']}, frames {doc['image_frames']}, "
           f"{doc['image_size']} px; U: {doc['u_method']}. Costs are the whole `gasp simulate` process's CPU "
           "seconds (user + system), from the bench_trade records. Errors are worst frames, / object size.", "",
           "| run | CPU s | speed-up | position | centroid | rotation, deg | shape | shape, U | impact, ms (ref) | "
           "restitution (ref) | contact, % (ref ms) | rest height, dx | drift, mm | final rotation, deg | PSNR, dB | SSIM |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, r in doc["reports"].items():
        for obj, f in r["objects"].items():
            w, d, u = f["worst"], f["event_diff"], f.get("in_u", {})
            im = (r.get("images") or {}).get("run") or {}
            out.append(f"| {name} | {_f(doc['cost'].get(name), '.1f')} | {_f(doc['speedup'].get(name), '.2f')} | "
                       f"{100 * w['position']:.2f} % | {100 * w['centroid']:.2f} % | {w['rotation_deg']:.2f} | "
                       f"{100 * w['shape']:.2f} % | {_f(u.get('shape'), '.2f')} | {1e3 * d['impact_s']:.1f} "
                       f"({_f(1e3 * f['events_ref']['impact_s'], '.1f')}) | "
                       f"{_f(f['events_run']['restitution'], '.3f')} ({_f(f['events_ref']['restitution'], '.3f')}) | "
                       f"{_f(100 * d['contact_rel'], '.1f')} ({_f(1e3 * f['events_ref']['contact_s'], '.0f')}) | "
                       f"{d['rest_height_m'] / r['dx_ref_m']:.2f} | "
                       f"{1e3 * d['drift_m']:.2f} | {d['rotation_deg']:.2f} | {_f(im.get('psnr_db'), '.2f')} | "
                       f"{_f(im.get('ssim'), '.4f')} |")
    out += ["", "U per figure (the twin against the reference; the unit of the 'in U' figures): "
            + ", ".join(f"{k} {_f(v)}" for k, v in next(iter(doc["reports"][doc["twin"]]["objects"].values()))
                        .get("u", {}).items()), "",
            f"Rule (docs/speed_accuracy.md): shape <= {BANDS['shape_u']} U, restitution +-{BANDS['restitution']}, "
            f"contact time +-{100 * BANDS['contact_rel']:g} %, rest height +-{BANDS['rest_height_dx']} dx, drift <= "
            f"{1e3 * BANDS['drift_m']:g} mm, rotation <= {BANDS['rotation_deg']:g} deg, PSNR >= the twin's.", ""]
    for line in doc["rule"]["why"]:
        out.append(f"* misses: {line}")
    ch = doc["rule"]["chosen"]
    out.append(f"* **chosen: `{ch}`**" if ch else "* **no candidate meets every check**")
    out.append(f"* must-show (default >= 2.5x faster than the reference run with every check met): "
               f"{doc['rule']['must_show']}")
    return "\n".join(out) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=Path, required=True, help="folder of kept runs, one sub-folder per variant")
    ap.add_argument("--reference", default="full")
    ap.add_argument("--twin", default="full_g48", help="the reference's model on the next coarser grid (U)")
    ap.add_argument("--candidates", default="default,draft")
    ap.add_argument("--default-level", default="default", help="the candidate that is the 'default' level")
    ap.add_argument("--timings", type=Path, nargs="*", default=[])
    ap.add_argument("--images", type=int, default=4, help="frames rendered (evenly spaced, frame 0 left out)")
    ap.add_argument("--tag", default="donut_f12")
    args = ap.parse_args(argv)
    names = [c.strip() for c in args.candidates.split(",") if c.strip()]
    reports = measure(args.runs, args.reference, args.twin, names, args.images)
    rec = timings(args.timings)
    cost = {n: rec[n].get("process_cpu_s") for n in [args.reference, *reports] if n in rec}
    base = cost.get(args.reference)
    speedup = {n: base / c for n, c in cost.items() if base and c}
    checks = {n: rule_checks(r) for n, r in reports.items()}
    cands = [{"name": n, "cost": cost.get(n, np.inf), "checks": checks[n]} for n in names]
    chosen, why = choose_default(cands)
    d = args.default_level
    all_ok = d in checks and all(c["ok"] for c in checks[d].values())
    must = (f"`{d}` {speedup.get(d, float('nan')):.2f}x, checks "
            + ("all met" if all_ok else "missed: " + ", ".join(k for k, c in checks.get(d, {}).items() if not c["ok"]))
            + (": **met**" if all_ok and speedup.get(d, 0) >= 2.5 else ": **not met**"))
    any_r = next(iter(reports.values()))
    doc = {"runs": str(args.runs), "reference": args.reference, "twin": args.twin,
           "n_frames": len(any_r["objects"][next(iter(any_r["objects"]))]["per_frame"]["shape"]) - 1,
           "views": any_r["images"]["views"], "image_frames": any_r["images"]["frames"], "image_size": "256x192",
           "u_method": reports[names[0]]["u_method"], "cost": cost, "speedup": speedup,
           "load_avg_1min": os.getloadavg()[0], "reports": reports, "checks": checks,
           "rule": {"chosen": chosen["name"] if chosen else None, "why": why, "must_show": must}}
    RESULTS.mkdir(parents=True, exist_ok=True)
    stem = RESULTS / f"accuracy_{args.tag}"
    stem.with_suffix(".json").write_text(json.dumps(doc, indent=1, default=float))
    stem.with_suffix(".md").write_text(markdown(doc))
    print(markdown(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
