"""The GASP paper's Tables 1, 2 and 4, in their shape, on this project's data (``docs/paper_tables.md``).

* ``--table 2`` (timings): time to finish the donut and the guitar, each a fresh ``gasp simulate`` process
  (start-up, read, fill, build and JIT, every frame, the PLY writes; CPU seconds and wall), for the full
  vertices (``surface = "material"``, ``core_fraction = 1``), Core Gaussians (``core_fraction = 0.2``), the
  passive surface (``surface = "passive"``) and PhysGaussian's covariance update (``rebuild = "covariance"``:
  ``F Sigma F^T`` with each triangle's own ``F``; the core simulates a Gaussian's three triangle vertices, not
  its centre alone, so this row costs what the full row costs: see ``docs/paper_tables.md``); and PhysGaussian's
  layout itself (``surface_points = "centres"``: one point per Gaussian, ``F`` from its neighbours' motion,
  :mod:`gasp_core.maps.centres`), material and passive.
* ``--table 1`` (image similarity of the rebuild rules): one engine run on the scene's grid and one on a
  coarser grid (``--coarse``), every kept frame rebuilt both ways (``rebuild = "games"``, GASP's, and
  ``"covariance"``); PSNR and SSIM (:mod:`gasp_studies.images`, a fixed orbit of 4 views or the capture's
  cameras) of each rule against the same rule on the scene's grid (the reference), and of the two rules
  against each other.
* ``--table 4`` (the alpha rule on the sand guitar): the same two runs, rebuilt with GaMeS and the alpha rule
  at 1, 1.5, 2, 3, 5 and off; PSNR / SSIM against the same rule on the reference grid, against the reference
  grid's alpha 1.5 (the scene's), and the share of clamped in-plane scales.

Run (each writes ``benchmarks/results/paper_table<N>.{json,md}``)::

    python benchmarks/bench_paper_tables.py --table 2 --frames 6
    python benchmarks/bench_paper_tables.py --table 1 --frames 8
    python benchmarks/bench_paper_tables.py --table 4 --frames 8
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_trade import SCENES, run_variant, variant_scene  # noqa: E402

from gasp_studies.accuracy import Track  # noqa: E402
from gasp_studies.images import cameras_for, image_scores, render_frames  # noqa: E402
from gasp_studies.strips import strip_frames, world_splats  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
#: Table 2's rows: name -> object keys
TABLE2 = {"full vertices": {"surface": "material", "core_fraction": 1.0},
          "Core Gaussians (core_fraction 0.2)": {"surface": "material", "core_fraction": 0.2},
          "passive surface": {"surface": "passive", "core_fraction": 1.0},
          "PhysGaussian's covariance (rebuild = covariance)": {"surface": "material", "core_fraction": 1.0,
                                                                 "rebuild": "covariance"},
          "centres (PhysGaussian's layout)": {"surface": "material", "core_fraction": 1.0, "surface_points": "centres",
                                              "rebuild": "covariance"},
          "centres, passive": {"surface": "passive", "core_fraction": 1.0, "surface_points": "centres",
                               "rebuild": "covariance"}}
ALPHAS = (1.0, 1.5, 2.0, 3.0, 5.0, None)


def table2(frames: int, scenes: list[str], work: Path, save=None, rows: list[str] | None = None) -> dict:
    """Each row of :data:`TABLE2` (or those named in ``rows``; "full vertices" always, first) on each scene, one
    process after another (ratios from one call); ``save(out)`` after every row."""
    out: dict = {}
    names = list(TABLE2) if not rows else ["full vertices"] + [r for r in rows if r != "full vertices"]
    for sc in scenes:
        out[sc] = {}
        for name in names:
            keys = TABLE2[name]
            toml = variant_scene(SCENES[sc], keys, {}, frames, work / "s.toml", {"threads": 1})
            print(f"[paper_tables] table 2: {sc}: {name} ...", flush=True)
            rec = run_variant(toml, work / "run", 7200.0)
            out[sc][name] = {k: rec.get(k) for k in ("returncode", "process_wall_s", "process_cpu_s", "n_points",
                                                       "n_render_points", "n_substeps", "prepare_s", "build_s")}
            out[sc][name]["load_avg_1min"] = os.getloadavg()[0]
            import shutil
            shutil.rmtree(work / "run", ignore_errors=True)
            if save is not None:
                save(out)
    return out


def rebuilt_run(scene: str, n_grid: int, frames: int, keep: list[int], rules: dict, work: Path) -> dict:
    """One engine run of ``scene`` on ``n_grid``; at every kept frame each rule's world splats and clamped share.

    ``rules``: name -> (rebuild, alpha). Returns ``{rule: {"splats": {frame: Splats}, "clamped": share}}`` plus
    ``"_means"`` (world means per frame, for the cameras) and ``"_ground"``.
    """
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.run.frames import rebuild
    from gasp_core.scene.spec import load_scene
    from gasp_core.seam.runner import run_engine
    toml = variant_scene(SCENES[scene], {}, {"n_grid": n_grid}, frames, work / f"{scene}_{n_grid}.toml", {"threads": 1})
    prep = prepare_scene(load_scene(toml))
    objs = {r: [dataclasses.replace(o, spec=dataclasses.replace(o.spec, rebuild=rb, alpha=a)) for o in prep.objects]
            for r, (rb, a) in rules.items()}
    prev = {r: [o.rot_rest for o in prep.objects] for r in rules}
    out = {r: {"splats": {}, "clamped": [], "n": sum(o.gaussians.n for o in prep.objects)} for r in rules}
    t0 = time.process_time()
    recs = [(0, np.concatenate([o.placement.to_world(o.gaussians.means) for o in prep.objects]))]
    for r in rules:
        out[r]["splats"][0] = world_splats(prep.objects, [o.gaussians for o in prep.objects])
    for rec in run_engine(prep.info, prep.setup, frames):
        for r, ol in objs.items():
            gs = []
            for k, o in enumerate(ol):
                g, prev[r][k], counts = rebuild(o, rec.x, prev[r][k])
                gs.append(g)
                if rec.frame in keep:
                    out[r]["clamped"].append(counts["clamped"] / (2.0 * len(o.tri_rest)))
            if rec.frame in keep:
                out[r]["splats"][rec.frame] = world_splats(ol, gs)
        if rec.frame in keep:
            recs.append((rec.frame, np.asarray(out[next(iter(rules))]["splats"][rec.frame].means, np.float64)))
    out["_cpu_s"] = time.process_time() - t0
    out["_means"] = dict(recs)
    return out


def fresh_process(fn, *args):
    """``fn(*args)`` in a fresh (spawned) process: an engine's runtime may be process-global, one per process."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(fn, *args).result()


def similarity_rows(ref: dict, coarse: dict, pairs: list[tuple[str, str, str, str]], keep: list[int]) -> dict:
    """PSNR / SSIM for ``pairs`` of (row name, run's rule, 'ref' or 'coarse', against whose rule and run)."""
    frames = [f for f in keep if f > 0]
    means = np.stack([ref["_means"][f] for f in [0] + frames])
    track = Track(means, np.array([0, means.shape[1]]), ["scene"], 1 / 30, None)
    cams, views = cameras_for(track, list(range(1, len(frames) + 1)))
    runs = {"ref": ref, "coarse": coarse}
    cache: dict = {}

    def images(run, rule):
        if (run, rule) not in cache:
            d = runs[run][rule]["splats"]
            t = Track(means, track.obj_start, ["scene"], 1 / 30, None, splats=d.__getitem__)
            cache[(run, rule)] = render_frames(t, frames, cams)
        return cache[(run, rule)]
    rows = {}
    for name, (run, rule), (run_b, rule_b) in pairs:
        sc = image_scores(images(run_b, rule_b), images(run, rule))
        rows[name] = {**{k: v for k, v in sc.items() if k != "not_computed"},
                      "clamped_share": float(np.mean(runs[run][rule]["clamped"]) if runs[run][rule]["clamped"] else 0)}
    return {"views": views, "frames": frames, "rows": rows}


def table14(table: int, frames: int, coarse_grid: int, work: Path) -> dict:
    """Tables 1 (both scenes, games vs covariance) and 4 (the guitar, the alpha rule)."""
    keep = list(strip_frames(frames, 5))
    out = {}
    scenes = ["donut", "guitar"] if table == 1 else ["guitar"]
    for sc in scenes:
        import tomllib
        n_ref = tomllib.loads(SCENES[sc].read_text())["domain"]["n_grid"]
        if table == 1:
            alpha = tomllib.loads(SCENES[sc].read_text())["object"][0].get("alpha", 1.5)
            rules = {"games": ("games", alpha), "covariance": ("covariance", alpha)}
            pairs = [(f"{r} n_grid {coarse_grid} vs {r} n_grid {n_ref}", ("coarse", r), ("ref", r)) for r in rules]
            pairs += [(f"covariance vs games, n_grid {g}", (run, "covariance"), (run, "games"))
                      for run, g in (("ref", n_ref), ("coarse", coarse_grid))]
        else:
            rules = {f"alpha {a:g}" if a else "alpha off": ("games", a) for a in ALPHAS}
            pairs = [(f"{r}, n_grid {coarse_grid} vs the same on {n_ref}", ("coarse", r), ("ref", r)) for r in rules]
            pairs += [(f"{r}, n_grid {n_ref} vs alpha 1.5 (the scene's)", ("ref", r), ("ref", "alpha 1.5"))
                      for r in rules if r != "alpha 1.5"]
        print(f"[paper_tables] table {table}: {sc}: runs on n_grid {n_ref} and {coarse_grid} ...", flush=True)
        ref = fresh_process(rebuilt_run, sc, n_ref, frames, keep, rules, work)
        coarse = fresh_process(rebuilt_run, sc, coarse_grid, frames, keep, rules, work)
        out[sc] = {**similarity_rows(ref, coarse, pairs, keep), "n_grid": [n_ref, coarse_grid],
                   "engine_cpu_s": [ref["_cpu_s"], coarse["_cpu_s"]], "n_gaussians": ref[next(iter(rules))]["n"]}
    return out


def markdown(table: int, doc: dict, cmd: str) -> str:
    """The table in the paper's shape."""
    lines = [f"# Paper table {table} (benchmarks/bench_paper_tables.py)", "", f"`{cmd}`; {doc['machine']}", ""]
    if table == 2:
        lines += ["| scene | model | simulated points | substeps/frame | CPU s | wall s | speed-up (CPU) |",
                  "|---|---|---:|---:|---:|---:|---:|"]
        for sc, rows in doc["result"].items():
            base = rows["full vertices"].get("process_cpu_s") or float("nan")
            for name, r in rows.items():
                if r["returncode"] != 0:
                    lines.append(f"| {sc} | {name} | failed (exit {r['returncode']}) | | | | |")
                    continue
                lines.append(f"| {sc} | {name} | {r['n_points']:,} | {r['n_substeps']} | {r['process_cpu_s']:.1f} | "
                             f"{r['process_wall_s']:.1f} | {base / r['process_cpu_s']:.2f} |")
        return "\n".join(lines) + "\n"
    for sc, d in doc["result"].items():
        lines += [f"## {sc}: {d['n_gaussians']:,} Gaussians, n_grid {d['n_grid'][0]} (reference) and {d['n_grid'][1]}; "
                  f"images: {d['views']}, frames {d['frames']}", "",
                  "| comparison | PSNR, dB | worst PSNR, dB | SSIM | worst SSIM | clamped scales |",
                  "|---|---:|---:|---:|---:|---:|"]
        for name, r in d["rows"].items():
            lines.append(f"| {name} | {r['psnr_db']:.2f} | {r['psnr_worst_db']:.2f} | {r['ssim']:.4f} | "
                         f"{r['ssim_worst']:.4f} | {100 * r['clamped_share']:.2f} % |")
        lines.append("")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--table", type=int, choices=(1, 2, 4), required=True)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--coarse", type=int, default=48, help="the coarser grid of tables 1 and 4")
    ap.add_argument("--scenes", default="donut,guitar", help="table 2's scenes")
    ap.add_argument("--tag", default="", help="results file suffix (paper_table<N><_tag>)")
    ap.add_argument("--rows", default="", help="table 2's rows, ';'-separated names of TABLE2 (default: all; "
                    "'full vertices' always runs first, the speed-ups' base)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    cmd = "python benchmarks/bench_paper_tables.py " + " ".join(argv if argv is not None else sys.argv[1:])
    stem = RESULTS / (f"paper_table{args.table}" + (f"_{args.tag}" if args.tag else ""))

    def save(res):
        import platform
        doc = {"table": args.table, "frames": args.frames, "result": res,
               "machine": f"{platform.platform()}, {os.cpu_count()} CPUs; 1-min load average at the end "
                          f"{os.getloadavg()[0]:.1f}; {time.perf_counter() - t0:.0f} s in all"}
        RESULTS.mkdir(parents=True, exist_ok=True)
        stem.with_suffix(".json").write_text(json.dumps(doc, indent=1, default=float))
        stem.with_suffix(".md").write_text(markdown(args.table, doc, cmd))
        return doc
    with tempfile.TemporaryDirectory(prefix="gasp_paper_") as tmp:
        rows = [r.strip() for r in args.rows.split(";") if r.strip()]
        bad = [r for r in rows if r not in TABLE2]
        if bad:
            ap.error(f"--rows: unknown {bad}; known: {list(TABLE2)}")
        res = (table2(args.frames, args.scenes.split(","), Path(tmp), save, rows) if args.table == 2
               else table14(args.table, args.frames, args.coarse, Path(tmp)))
    print(markdown(args.table, save(res), cmd))
    return 0


if __name__ == "__main__":
    sys.exit(main())
