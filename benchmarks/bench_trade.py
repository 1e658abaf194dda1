"""What "model only what a scene requires" buys, end to end, on the full real scenes.

Each variant is the bundled scene with a few keys changed, run as a user runs it: a fresh
``gasp simulate SCENE -o OUT -q`` process, timed from its start to its exit (Python start-up,
reading, flattening, fill, hierarchy, engine build and JIT compiles, every frame, the PLY writes).
Its frames are then read back and compared, Gaussian by Gaussian, with a chosen run of the same
script:

* ``err_vs_full``: the worst frame's mean distance between the same Gaussian's means in this run and
  in the ``full`` run (every triangle vertex simulated as material: the baseline), world frame,
  divided by the object size (diagonal of the bounding box of the frame-0 means);
* ``err_vs_converged`` and ``verdict``: the same against the **converged reference**
  (:mod:`gasp_studies.convergence`): a Richardson estimate from the ``--reference-model``'s runs on three
  grids (or, failing that, the finest of them with its distance to the next coarser one), whose own
  uncertainty is stated; a run is ranked against it only where that uncertainty is below
  ``--tolerance``. Timings: ``process_wall_s`` and ``process_cpu_s`` (the process's CPU time, what it
  costs whatever else the machine runs), both from process start to exit, build and JIT included.

Variants (donut, ``examples/donut_jelly.toml``; the guitar, ``examples/guitar_sand.toml``, takes
the same keys)::

    full        surface = "material", core_fraction = 1      (every vertex simulated)
    passive     surface = "passive"                          (the fill is the material, vertices advected)
    core0.2     core_fraction = 0.2                          (hierarchy: 20 % of the Gaussians as cores)
    centres     surface_points = "centres", rebuild = "covariance"  (PhysGaussian's layout: one point per Gaussian)
    ...

Usage::

    sh benchmarks/bench_levels.sh                           # the quality levels on the README scenes against each
                                                            # scene's converged reference (issue 18), one command
    python benchmarks/bench_trade.py --variants verdict --frames 12 --threads 1
    python benchmarks/bench_trade.py --variants full,full_g48,default,draft --frames 12 --threads 1 --keep K \
        --accuracy-twin full_g48            # and the split accuracy report (benchmarks/bench_accuracy.py)
                                                            # the same on the donut's first 12 frames only
    python benchmarks/bench_trade.py --variants default,full_g32,full_g48 --keep K --tag a &
    python benchmarks/bench_trade.py --variants full --keep K --tag b &    # two at once on a shared machine, then:
    python benchmarks/bench_trade.py --variants verdict --keep K --reuse benchmarks/results/bench_trade_donut_{a,b}.json
    python benchmarks/bench_trade.py --threads 1 --window 18 --compare out/full_g96 out/passive_every4_g96
                                                            # donut: the 'trade' set, 36 frames, and the
                                                            # n_grid 96 runs of --variants full_g96,passive_every4_g96 --keep out
    python benchmarks/bench_trade.py --variants convergence --frames 12
    python benchmarks/bench_trade.py --scene guitar --frames 10
    python benchmarks/bench_trade.py --variants full,passive --frames 10

Writes ``benchmarks/results/bench_trade_<scene>_<set>.{json,md}``. All variants of one call run one
after another on the same machine, so their ratios come from one run; the machine's load is
recorded before and after.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import numpy as np
import tomli_w  # pip install -e ".[studies]"

from gasp_studies.convergence import frame_distance, reference, verdict

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
SCENES = {"donut": ROOT / "examples" / "donut_jelly.toml", "guitar": ROOT / "examples" / "guitar_sand.toml",
          "kitchen": ROOT / "examples" / "kitchen_spinach.toml"}

#: variant name -> (object keys, domain keys, engine options). The domain key ``shift_cells`` (cells
#: along x, y, z) moves the ``full`` run's grid by that much: the same physics on a shifted grid, which
#: shows how far the full run itself moves with its grid's alignment (the floor of any comparison).
VARIANTS: dict[str, tuple[dict, dict, dict]] = {
    "full": ({"surface": "material", "core_fraction": 1.0}, {}, {}),
    "full_shift": ({"surface": "material", "core_fraction": 1.0}, {"shift_cells": [0.5, 0.5, 0.0]}, {}),
    "passive": ({"surface": "passive"}, {}, {}),
    "passive_every4": ({"surface": "passive"}, {}, {"passive_every": 4}),
    "passive_every8": ({"surface": "passive"}, {}, {"passive_every": 8}),
    "core0.5": ({"surface": "material", "core_fraction": 0.5}, {}, {}),
    "core0.2": ({"surface": "material", "core_fraction": 0.2}, {}, {}),
    "passive_core0.2": ({"surface": "passive", "core_fraction": 0.2}, {}, {}),
    "passive_every4_core0.5": ({"surface": "passive", "core_fraction": 0.5}, {}, {"passive_every": 4}),
    # the grid sequence of one model, for the convergence check (errors against the finest)
    "passive_core0.2_g48": ({"surface": "passive", "core_fraction": 0.2}, {"n_grid": 48}, {}),
    "passive_core0.2_g96": ({"surface": "passive", "core_fraction": 0.2}, {"n_grid": 96}, {}),
    "passive_core0.2_g128": ({"surface": "passive", "core_fraction": 0.2}, {"n_grid": 128}, {}),
    "full_g96": ({"surface": "material", "core_fraction": 1.0}, {"n_grid": 96}, {}),
    "passive_every4_g96": ({"surface": "passive"}, {"n_grid": 96}, {"passive_every": 4}),
    "passive_every4_g128": ({"surface": "passive"}, {"n_grid": 128}, {"passive_every": 4}),
    "full_g48": ({"surface": "material", "core_fraction": 1.0}, {"n_grid": 48}, {}),
    "full_g32": ({"surface": "material", "core_fraction": 1.0}, {"n_grid": 32}, {}),
    # the time step: the full model at cfl 0.8 (the engines' default is 0.4; the contact's own stable step may
    # bind first, gasp_core.mpm.contact.contact_dt)
    "full_cfl0.8": ({"surface": "material", "core_fraction": 1.0}, {}, {"cfl": 0.8}),
    "draft_cfl0.4": ({}, {}, {"cfl": 0.4}),
    # the full model with the fill at 8 points per cell (the 'reference' level's model) on three grids:
    # the Richardson reference of every other run (gasp_studies.convergence)
    "full_ppc8_g32": ({"surface": "material", "core_fraction": 1.0}, {"n_grid": 32, "particles_per_cell": 8}, {}),
    "full_ppc8_g48": ({"surface": "material", "core_fraction": 1.0}, {"n_grid": 48, "particles_per_cell": 8}, {}),
    "full_ppc8": ({"surface": "material", "core_fraction": 1.0}, {"particles_per_cell": 8}, {}),
    "full_ppc8_g96": ({"surface": "material", "core_fraction": 1.0}, {"n_grid": 96, "particles_per_cell": 8}, {}),
    # the quality levels as a user runs them (gasp_core.scene.quality): the scene file as it is
    "draft": ({}, {}, {}),
    "default": ({}, {}, {}),
    "reference": ({}, {}, {}),
    # fill density: the passive model's material is the fill alone, so its points per cell set its cost
    "passive_every8_ppc4": ({"surface": "passive"}, {"particles_per_cell": 4}, {"passive_every": 8}),
    "passive_every8_ppc2": ({"surface": "passive"}, {"particles_per_cell": 2}, {"passive_every": 8}),
    "passive_every16_ppc2": ({"surface": "passive"}, {"particles_per_cell": 2}, {"passive_every": 16}),
    "passive_every16_ppc4": ({"surface": "passive"}, {"particles_per_cell": 4}, {"passive_every": 16}),
    # PhysGaussian's layout (issue 39 item 5): one point per Gaussian, its centre; F from its neighbours'
    # motion, rebuilt as F Sigma F^T (gasp_core.maps.centres)
    "centres": ({"surface": "material", "core_fraction": 1.0, "surface_points": "centres", "rebuild": "covariance"},
                {}, {}),
    "centres_passive_every8_ppc4": ({"surface": "passive", "surface_points": "centres", "rebuild": "covariance"},
                                    {"particles_per_cell": 4}, {"passive_every": 8}),
}
#: variants that set the scene's top-level ``quality`` key
QUALITY = {"draft": "draft", "default": "default", "reference": "reference", "draft_cfl0.4": "draft"}
#: what a call runs unless ``--variants`` says otherwise
SETS = {
    "trade": ["full", "full_shift", "passive", "passive_every4", "passive_every8", "passive_every4_core0.5",
              "core0.2"],
    "levels": ["full", "default", "draft"],
    "grids": ["full_g32", "full_g48"],
    # one call: the levels, timed, against the full model's Richardson reference (n_grid 32, 48, 64) ...
    "verdict": ["full", "default", "draft", "full_g32", "full_g48"],
    # ... or (n_grid 48, 64, 96) on a machine with the time for the n_grid 96 run
    "verdict96": ["full", "default", "draft", "full_g48", "full_g96"],
    "convergence": ["passive_core0.2_g48", "passive_core0.2", "passive_core0.2_g96", "passive_core0.2_g128",
                    "full", "passive", "core0.2"],
}


def variant_scene(src: Path, obj_keys: dict, domain_keys: dict, n_frames: int, dst: Path,
                  options: dict | None = None, full_domain: dict | None = None, quality: str | None = None) -> Path:
    """Write the scene ``src`` with the variant's keys to ``dst`` (object files made absolute).

    ``shift_cells`` in ``domain_keys`` becomes an explicit ``lo``/``hi``: ``full_domain`` (the
    ``full`` run's ``run.json`` domain) moved by that many cells.
    """
    doc = tomllib.loads(src.read_text())
    doc["n_frames"] = n_frames
    if quality:
        doc["quality"] = quality
    if options:
        doc.setdefault("engine", {}).setdefault("options", {}).update(options)
    domain_keys = dict(domain_keys)
    shift = domain_keys.pop("shift_cells", None)
    if shift is not None:
        if full_domain is None:
            raise SystemExit("bench_trade: a 'shift_cells' variant needs the 'full' run before it")
        d = np.asarray(shift, float) * full_domain["dx"]
        domain_keys.update(lo=(np.asarray(full_domain["lo"]) + d).tolist(), hi=(np.asarray(full_domain["hi"]) + d).tolist())
    doc.setdefault("domain", {}).update(domain_keys)
    if "surface" in obj_keys and "surface_points" not in obj_keys:   # a named surface model: the vertex layout
        obj_keys = {**obj_keys, "surface_points": "vertices"}        # (the levels carry a passive one by centres)
    for o in doc.get("object", []):
        o["file"] = str((src.parent / o["file"]).resolve())
        o.update(obj_keys)
    dst.write_text(tomli_w.dumps(doc))
    return dst


def read_means(run_dir: Path) -> tuple[np.ndarray, float]:
    """Means of every frame, shape (n_frames + 1, n, 3), world metres, and the object size, m."""
    from gasp_core.gs.io import read_gaussians
    summary = json.loads((run_dir / "run.json").read_text())
    per_obj = []
    for o in summary["objects"]:
        files = sorted((run_dir / o["name"]).glob("frame_*.ply"))
        pl = o["placement"]   # file frame -> world: scale x R^T + t
        R, t = np.asarray(pl["R"], float), np.asarray(pl["t"], float)
        per_obj.append(pl["scale"] * np.stack([read_gaussians(f).means.astype(np.float64) for f in files]) @ R.T + t)
    means = np.concatenate(per_obj, axis=1)
    size = float(np.linalg.norm(np.ptp(means[0], axis=0)))
    return means, size


def error(a: np.ndarray, b: np.ndarray, size: float, window: int | None = None) -> dict:
    """Worst frame's mean / max distance between the same Gaussians, as fractions of ``size``;
    with ``window`` also the worst frame's mean over frames 0..window (``window_mean``)."""
    n = min(len(a), len(b))
    d = np.linalg.norm(a[:n] - b[:n], axis=2)
    per_frame = d.mean(axis=1) / size
    out = {"mean": float(per_frame.max()), "max": float(d.max() / size), "frames": n,
           "per_frame_mean": [round(float(e), 6) for e in per_frame]}
    if window is not None:
        out["window_mean"] = max(out["per_frame_mean"][:window + 1])
    return out


def run_variant(scene: Path, out: Path, timeout_s: float) -> dict:
    """Run ``gasp simulate`` on ``scene`` in a fresh process: its wall time and its CPU time (user + system,
    the process and its children: what it costs whatever else the machine runs) and its run.json figures."""
    t0 = time.perf_counter()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    p = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "-q"],
                       capture_output=True, text=True, timeout=timeout_s)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    rec = {"returncode": p.returncode, "process_wall_s": wall,
           "process_cpu_s": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)}
    if p.returncode != 0:
        rec["stderr"] = p.stderr[-2000:]
        return rec
    s = json.loads((out / "run.json").read_text())
    rec.update(prepare_s=s["prepare_s"], build_s=s["build_s"], run_wall_s=s["wall_s"],
               n_points=s["n_points"], n_render_points=s["n_render_points"],
               n_substeps=s["engine_stats"].get("n_substeps"), n_grid=s["domain"]["n_grid"],
               mass_kg=s["engine_stats"].get("mass"), quality=s.get("quality"),
               surface_rule=[o.get("surface_rule") for o in s["objects"]],
               n_fill_points=sum(o["n_fill_points"] for o in s["objects"]), domain=s["domain"],
               n_gaussians=sum(o["n_gaussians"] for o in s["objects"]))
    return rec


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="donut")
    ap.add_argument("--frames", type=int, default=None, help="frames per run (default: the scene's)")
    ap.add_argument("--variants", default="trade", help=f"a set ({', '.join(SETS)}) or comma-separated names from "
                    + ", ".join(VARIANTS))
    ap.add_argument("--tag", default=None, help="results file suffix (default: the set's name, or 'custom')")
    ap.add_argument("--threads", type=int, default=None, help="engine option 'threads' for every run "
                    "(default: the engine's; 1 keeps runs comparable on a machine shared with other work)")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per run")
    ap.add_argument("--keep", type=Path, default=None, help="keep the run folders here")
    ap.add_argument("--compare", type=Path, nargs="*", default=[], metavar="RUN_DIR",
                    help="finished `gasp simulate` outputs of the same scene (e.g. finer grids, too slow to "
                    "repeat): every variant's error against each is reported as err_vs_<folder name>; not timed")
    ap.add_argument("--window", type=int, default=None, metavar="K",
                    help="also report each error's worst frame over frames 0..K")
    ap.add_argument("--reuse", type=Path, nargs="*", default=[], metavar="RESULTS_JSON",
                    help="results files of earlier calls: a variant recorded there (and kept in --keep/<variant>) is "
                    "not run again; its record (timings) and frames are taken from there")
    ap.add_argument("--reference-model", default="full", metavar="VARIANT",
                    help="the model whose runs on several grids (variants with the same keys but n_grid) give the "
                    "converged reference (default full: every vertex simulated, the scene's fill)")
    ap.add_argument("--tolerance", type=float, default=0.01,
                    help="error asked for, fraction of the object size (default 0.01)")
    ap.add_argument("--accuracy-twin", default=None, metavar="VARIANT",
                    help="with --keep: also write the split accuracy report (benchmarks/bench_accuracy.py) of every "
                    "variant against --reference-model's run, U from this variant (its model on a coarser grid)")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw the figure of an existing results file (--tag); centroid heights are "
                    "(re)read from the run folders in --keep, where there, and from --compare")
    args = ap.parse_args(argv)
    src = SCENES[args.scene]
    if args.replot:
        return replot(RESULTS / f"bench_trade_{args.scene}_{args.tag or args.variants}.json", args.keep, args.compare)
    n_frames = args.frames or tomllib.loads(src.read_text())["n_frames"]
    names = SETS.get(args.variants) or [v.strip() for v in args.variants.split(",") if v.strip()]
    tag = args.tag or (args.variants if args.variants in SETS else "custom")
    bad = [v for v in names if v not in VARIANTS]
    if bad:
        ap.error(f"--variants: unknown {bad}; known: {list(VARIANTS)}")
    work = Path(tempfile.mkdtemp(prefix="gasp_trade_"))
    rows: dict[str, dict] = {}
    means: dict[str, np.ndarray] = {}
    size = None
    load = [os.getloadavg()[0]]
    reused = {}
    for f in args.reuse:
        reused.update(json.loads(f.read_text())["runs"])
    try:
        for name in names:
            if name in reused and args.keep is not None and (args.keep / name / "run.json").exists():
                rows[name] = reused[name]
                if rows[name]["returncode"] == 0:
                    means[name], size = read_means(args.keep / name)
                print(f"[bench_trade] {args.scene} {name}: reused", flush=True)
                continue
            obj_keys, dom_keys, opts = VARIANTS[name]
            opts = {**({"threads": args.threads} if args.threads else {}), **opts}
            scene = variant_scene(src, obj_keys, dom_keys, n_frames, work / f"{name}.toml", opts,
                                  rows.get("full", {}).get("domain"), QUALITY.get(name))
            out = (args.keep or work) / name
            print(f"[bench_trade] {args.scene} {name} ...", flush=True)
            rec = run_variant(scene, out, args.timeout)
            rec["keys"] = {**obj_keys, **dom_keys, **VARIANTS[name][2]}
            rows[name] = rec
            if rec["returncode"] == 0:
                means[name], size = read_means(out)
                rec["centroid_dz_m"] = centroid_dz(means[name])
                if args.keep is None:
                    shutil.rmtree(out)
            print(f"[bench_trade]   {json.dumps({k: v for k, v in rec.items() if k != 'stderr'})}", flush=True)
            load.append(os.getloadavg()[0])
    finally:
        shutil.rmtree(work, ignore_errors=True)
    # the converged reference: the reference model's runs on several grids (gasp_studies.convergence)
    model = {k: v for k, v in VARIANTS[args.reference_model][0].items()}
    model_dom = {k: v for k, v in VARIANTS[args.reference_model][1].items() if k != "n_grid"}
    seq = {rows[n]["n_grid"]: means[n] for n in names if n in means and VARIANTS[n][0] == model
           and {k: v for k, v in VARIANTS[n][1].items() if k != "n_grid"} == model_dom and not VARIANTS[n][2]}
    conv = reference(seq, size) if seq else None
    others = {d.name: read_means(d)[0] for d in args.compare}
    compared_dz = {name: centroid_dz(m) for name, m in others.items()}
    for name, rec in rows.items():
        if name not in means:
            continue
        if "full" in means:
            rec["err_vs_full"] = error(means[name], means["full"], size, args.window)
            rec["speedup_vs_full"] = rows["full"]["process_wall_s"] / rec["process_wall_s"]
            if "process_cpu_s" in rows["full"] and "process_cpu_s" in rec:
                rec["speedup_vs_full_cpu"] = rows["full"]["process_cpu_s"] / rec["process_cpu_s"]
        for other, m in others.items():
            rec[f"err_vs_{other}"] = error(means[name], m, size, args.window)
        if conv is not None:
            e = frame_distance(means[name], conv.means, size)
            own = frame_distance(means["full"], conv.means, size) if "full" in means else None
            rec["err_vs_converged"] = {"mean": float(e.max()), "per_frame_mean": [round(float(x), 6) for x in e]}
            rec["verdict"] = verdict(e, conv, args.tolerance, own=own)
    doc = {"scene": str(src.relative_to(ROOT)), "n_frames": n_frames, "threads": args.threads, "object_size_m": size,
           "converged_reference": conv.summary() if conv is not None else None, "tolerance": args.tolerance,
           "machine": f"{platform.platform()}, {os.cpu_count()} CPUs, Python {platform.python_version()}",
           "load_avg_1min": load, "window": args.window, "compared": [d.name for d in args.compare],
           "compared_centroid_dz_m": compared_dz, "runs": rows}
    RESULTS.mkdir(parents=True, exist_ok=True)
    stem = RESULTS / f"bench_trade_{args.scene}_{tag}"
    tmp = stem.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(doc, indent=1))
    os.replace(tmp, stem.with_suffix(".json"))
    tmp = stem.with_suffix(".md.tmp")
    tmp.write_text(report(doc))
    os.replace(tmp, stem.with_suffix(".md"))
    plot(doc, stem.with_suffix(".png"))
    print(report(doc))
    if args.accuracy_twin and args.keep is not None:
        import bench_accuracy
        others = [n for n in names if n not in (args.reference_model, args.accuracy_twin) and n in means]
        bench_accuracy.main(["--runs", str(args.keep), "--reference", args.reference_model, "--twin",
                             args.accuracy_twin, "--candidates", ",".join(others + [args.accuracy_twin]),
                             "--timings", str(stem.with_suffix(".json")), *[str(f) for f in args.reuse],
                             "--tag", f"{args.scene}_{tag}"])
    return 0


def replot(path: Path, keep: Path | None, compare: list[Path]) -> int:
    """Redraw ``path``'s figure and report: centroid heights (re)read from the ``keep/<variant>``
    folders, where there, and from the ``compare`` runs, and each kept variant's errors against the
    ``compare`` runs (``err_vs_<folder name>``) added."""
    doc = json.loads(path.read_text())
    cdz = doc.setdefault("compared_centroid_dz_m", {})
    others = {d.name: read_means(d)[0] for d in compare}
    for name, m in others.items():
        cdz[name] = centroid_dz(m)
        if name not in doc.setdefault("compared", []):
            doc["compared"].append(name)
    for name, r in doc["runs"].items():
        if keep is not None and (keep / name / "run.json").exists():
            mine, size = read_means(keep / name)
            r["centroid_dz_m"] = centroid_dz(mine)
            for other, m in others.items():
                r[f"err_vs_{other}"] = error(mine, m, size, doc.get("window"))
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(doc, indent=1))
    os.replace(tmp, path)
    tmp = path.with_suffix(".md.tmp")
    tmp.write_text(report(doc))
    os.replace(tmp, path.with_suffix(".md"))
    return 0 if plot(doc, path.with_suffix(".png")) else 1


def centroid_dz(means: np.ndarray) -> list[float]:
    """Height of the Gaussians' centroid relative to frame 0, per frame, metres."""
    z = means[:, :, 2].mean(axis=1)
    return [round(float(v), 7) for v in z - z[0]]


def plot(doc: dict, path: Path) -> bool:
    """Per-frame figures of a results ``doc``: the centroid's height (every run, the compared ones
    dashed), the error against ``full`` and against the first compared run. False without matplotlib."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    runs = {k: r for k, r in doc["runs"].items() if r.get("returncode") == 0}
    first = (doc.get("compared") or [None])[0]
    panels = [("centroid height - frame 0, mm", None), ("error vs full, % of size", "err_vs_full")]
    if first:
        panels.append((f"error vs {first}, % of size", f"err_vs_{first}"))
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 2.8 * len(panels)), sharex=True)
    compared = doc.get("compared_centroid_dz_m") or {}
    colour = {name: f"C{i % 10}" for i, name in enumerate(list(runs) + list(compared))}
    for ax, (label, key) in zip(axes, panels):
        for name, r in runs.items():
            y = [1e3 * v for v in r.get("centroid_dz_m", [])] if key is None else \
                [100 * v for v in (r.get(key) or {}).get("per_frame_mean", [])]
            if y:
                ax.plot(range(len(y)), y, label=name, lw=1.2, color=colour[name])
        if key is None:
            for name, dz in compared.items():
                ax.plot(range(len(dz)), [1e3 * v for v in dz], "--", label=f"{name} (compared)", lw=1.2,
                        color=colour[name])
        elif doc.get("window") is not None:
            ax.axvline(doc["window"], color="grey", lw=0.8, ls=":")
        if key is not None:
            ax.axhline(1.0, color="black", lw=0.8, ls="--")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for ax in axes[:2]:
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, ncol=3)
    axes[-1].set_xlabel("frame")
    fig.suptitle(f"{doc['scene']}: {doc['n_frames']} frames (benchmarks/bench_trade.py)", fontsize=9)
    fig.tight_layout()
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, path)
    return True


def _pct(e: dict | None, key: str = "mean") -> str:
    return "-" if not e else f"{100 * e[key]:.2f} %"


def report(doc: dict) -> str:
    out = [f"# End-to-end trade on `{doc['scene']}` (benchmarks/bench_trade.py)", "",
           f"{doc['n_frames']} frames; engine threads {doc.get('threads') or 'default'}; object size {doc['object_size_m'] or float('nan'):.3f} m; {doc['machine']}; "
           f"1-min load average during the runs {min(doc['load_avg_1min']):.1f}-{max(doc['load_avg_1min']):.1f}.",
           "`wall` is the whole `gasp simulate` process (start-up, read, fill, hierarchy, build, frames, writes). "
           "Errors: the worst frame's mean distance between the same Gaussians' means, / object size; "
           "against the converged reference: below" + (f"; also compared, not timed: {', '.join(f'`{c}`' for c in doc['compared'])}" if doc.get("compared") else "")
           + ".", "",
           ]
    win = doc.get("window")
    if win is not None:
        out += [f"Each error cell: worst frame over all {doc['n_frames']} frames / over frames 0..{win} only.", ""]
    cmp_keys = sorted({k for r in doc["runs"].values() for k in r if k.startswith("err_vs_")},
                      key=lambda k: (k != "err_vs_full", k != "err_vs_ref", k))
    head = ["variant", "keys", "simulated points", "n_substeps", "prepare s", "build s", "wall s", "cpu s",
            "speed-up vs full (cpu)"]
    out += ["| " + " | ".join(head + [k.replace("err_vs_", "err vs ") for k in cmp_keys]) + " |",
            "|---|---|" + "---:|" * (len(head) - 2 + len(cmp_keys))]

    def cell(e):
        if not e:
            return "-"
        return _pct(e) + (f" / {100 * e['window_mean']:.2f} %" if "window_mean" in e else "")
    for name, r in doc["runs"].items():
        keys = ", ".join(f"{k}={v}" for k, v in r["keys"].items())
        if r["returncode"] != 0:
            out.append(f"| {name} | {keys} | failed (exit {r['returncode']}): {r.get('stderr', '').strip().splitlines()[-1:]} |")
            continue
        out.append(f"| {name} | {keys} | {r['n_points']:,} | {r['n_substeps']} | {r['prepare_s']:.1f} | "
                   f"{r['build_s']:.1f} | {r['process_wall_s']:.1f} | {r.get('process_cpu_s', float('nan')):.1f} | "
                   f"{r.get('speedup_vs_full_cpu', float('nan')):.2f} |"
                   + "".join(f" {cell(r.get(k))} |" for k in cmp_keys))
    out += verdict_lines(doc)
    return "\n".join(out) + "\n"


def verdict_lines(doc: dict) -> list[str]:
    """The converged reference, its uncertainty, and which runs stay within the tolerance of it."""
    conv = doc.get("converged_reference")
    if not conv:
        return []
    tol = doc.get("tolerance", 0.01)
    how = (f"Richardson estimate from n_grid {conv['grids']} (observed order {conv['order']:.2f})"
           if conv["method"] == "richardson" else f"the single run on n_grid {conv['grids'][0]} (its uncertainty is "
           "unknown without another grid)" if len(conv["grids"]) == 1 else f"the finest run, n_grid {conv['grids'][-1]}, with its distance to "
           f"n_grid {conv['grids'][0]} as its uncertainty" + (f" ({conv['note']})" if conv.get("note") else ""))
    out = ["", f"Converged reference: {how}; its own uncertainty is {100 * conv['bound']:.2f} % of the size on its worst "
           f"frame. Tolerance asked for: {100 * tol:g} % of the size on every frame, or the `full` run's own distance to "
           "the reference + 0.5 %.", "",
           "| variant | cpu s | wall s | err vs converged, worst frame | verdict |", "|---|---:|---:|---:|---|"]
    passing = []
    for name, r in doc["runs"].items():
        v = r.get("verdict")
        if not v:
            continue
        word = ("not ranked: " + v["why"]) if not v["ranked"] else ("within" if v["within"] else "outside")
        if v.get("within"):
            passing.append((r.get("process_cpu_s", r["process_wall_s"]), name))
        out.append(f"| {name} | {r.get('process_cpu_s', float('nan')):.1f} | {r['process_wall_s']:.1f} | "
                   f"{100 * v['worst']:.2f} % (frame {v['worst_frame']}) | {word} |")
    if passing:
        out += ["", f"Cheapest run within the tolerance (CPU time): `{min(passing)[1]}`."]
    elif conv["bound"] >= tol:
        out += ["", "No run is ranked: the reference is not converged to the tolerance asked for."]
    return out


if __name__ == "__main__":
    sys.exit(main())
