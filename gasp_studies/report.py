"""Tables, CSV, Markdown reports and plots of ``gasp compare`` and ``gasp bench``.

Plots need matplotlib (the ``studies`` extra); without it they are skipped and the report says so.
"""
from __future__ import annotations

import csv
import json
import math
import os
import platform
from pathlib import Path
from typing import Any

import numpy as np

from .measure import cheapest_ranked, steady_s_per_frame

TABLE_COLUMNS = ["engine", "version", "status", "device", "precision", "threads", "simulated_points",
                 "gaussians", "n_frames", "substeps_per_frame", "dt_s", "build_s", "first_frame_s",
                 "s_per_frame", "cpu_s_per_frame", "peak_rss_mb", "worker_base_rss_mb", "options"]
TABLE_HEADERS = ["engine", "version", "status", "device", "precision", "threads", "simulated points",
                 "Gaussians", "frames", "substeps/frame", "dt, s", "build, s", "frame 1, s",
                 "s/frame (2..n)", "CPU s/frame (2..n)", "peak memory, MB", "worker alone, MB", "options"]
DIVERGENCE_COLUMNS = ["frame", "t_s", "engine", "reference", "mean_dist_m", "max_dist_m", "chamfer_m",
                      "mean_dist_rel", "max_dist_rel", "chamfer_rel"]
#: Setting keys that change the scene (the rest of a setting are engine options).
SCENE_KEYS = ("n_grid", "particles_per_cell", "fill", "core_fraction", "surface")
#: Columns of ``bench.csv`` before and after the setting keys (the scene keys, then the options swept).
BENCH_HEAD = ["engine", "setting"]
BENCH_TAIL = ["is_reference", "status", "simulated_points", "substeps_per_frame", "prepare_s", "build_s",
              "first_frame_s", "s_per_frame", "cpu_s_per_frame", "wall_s", "end_to_end_s", "err_mean", "err_max", "err_final", "err_point_max",
              "err_conv_max", "ref_bound", "ref_method", "ke_left", "ke_vs_ref", "pareto",
              # the accuracy report (gasp_studies.bench_rank): shape residual, in U, rotation, renders, the rule
              "shape_max", "shape_u", "rotation_max_deg", "psnr_db", "ssim", "rule_ok", "rule_misses", "message"]


def bench_columns(option_keys: list[str]) -> list[str]:
    """Columns of ``bench.csv`` for sweeps that set ``option_keys`` (engine options)."""
    return BENCH_HEAD + list(SCENE_KEYS) + sorted(set(option_keys) - set(SCENE_KEYS)) + BENCH_TAIL


def write_csv(path: Path, rows: list[dict], columns: list[str]) -> None:
    """Write ``rows`` (dicts) with the given column order; floats with 6 significant digits."""
    def fmt(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.6g}"
        if isinstance(v, (dict, list)):
            return json.dumps(v, sort_keys=True)
        return "" if v is None else v
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: fmt(r.get(k)) for k in columns})


def md_table(rows: list[dict], columns: list[str], headers: list[str] | None = None) -> str:
    """A GitHub Markdown table (floats with 4 significant digits, missing values as ``-``)."""
    def fmt(v):
        if isinstance(v, float):
            return "-" if math.isnan(v) else f"{v:.4g}"
        if isinstance(v, dict):
            return ", ".join(f"{k}={val}" for k, val in v.items()) or "-"
        return "-" if v is None or v == "" else str(v)
    headers = headers or columns
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(fmt(r.get(c)) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def machine_line() -> str:
    """Machine, logical CPUs and load average, one phrase."""
    return (f"{platform.machine()} with {os.cpu_count()} logical CPUs (load average at the end: "
            f"{', '.join(f'{x:.1f}' for x in os.getloadavg())})")


def table_row(rec: dict) -> dict:
    """One row of the compare table (:data:`TABLE_COLUMNS`) from a run record."""
    st = rec.get("engine_stats") or {}
    frame_s = rec.get("frame_s") or []
    status = rec["status"] if rec["status"] != "diverged" else \
        f"diverged at frame {rec.get('frame')}: {rec.get('cause', '')}"
    return {"engine": rec["label"], "version": rec.get("version", ""), "status": status,
            "device": st.get("device", rec.get("options", {}).get("device", "")),
            "precision": st.get("precision", ""), "threads": st.get("threads", ""),
            "simulated_points": rec.get("simulated_points"), "gaussians": rec.get("gaussians"),
            "n_frames": len(frame_s), "substeps_per_frame": st.get("n_substeps"),
            "dt_s": st.get("dt"), "build_s": rec.get("build_s"),
            "first_frame_s": frame_s[0] if frame_s else None,
            "s_per_frame": steady_s_per_frame(frame_s) if frame_s else None,
            "cpu_s_per_frame": steady_s_per_frame(rec.get("frame_cpu_s") or []) if frame_s else None,
            "peak_rss_mb": rec.get("peak_rss_mb"), "worker_base_rss_mb": rec.get("worker_base_rss_mb"),
            "options": rec.get("options", {})}


def _pyplot():
    """matplotlib.pyplot on the Agg backend, or None when matplotlib is not installed."""
    try:
        import matplotlib
    except ImportError:
        return None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


NO_PLOTS = "Plots skipped: matplotlib is not installed (pip install -e \".[studies]\")."


def compare_plots(outdir: Path, table: list[dict], div: list[dict], reference: str | None) -> bool:
    """``divergence.png`` and ``timing.png``; False (nothing written) without matplotlib."""
    plt = _pyplot()
    if plt is None:
        return False
    order = [t["engine"] for t in table]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    labels = sorted({r["engine"] for r in div if r["engine"] != reference}, key=order.index)
    for lab in labels:
        rs = [r for r in div if r["engine"] == lab]
        t = [r["t_s"] for r in rs]
        axes[0].plot(t, [100 * r["mean_dist_rel"] for r in rs], marker="o", ms=3, label=lab)
        axes[1].plot(t, [100 * r["chamfer_rel"] for r in rs], marker="o", ms=3, label=lab)
    axes[0].set_title(f"mean distance of Gaussian means vs {reference}")
    axes[1].set_title(f"symmetric Chamfer distance vs {reference}")
    for ax in axes:
        ax.set_xlabel("time, s")
        ax.set_ylabel("% of object size (bbox diagonal)")
        ax.grid(alpha=0.3)
        if labels:
            ax.legend()
    fig.tight_layout()
    fig.savefig(outdir / "divergence.png", dpi=110)
    plt.close(fig)

    ran = [r for r in table if r.get("s_per_frame") is not None]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    y = np.arange(len(ran))
    axes[0].barh(y, [r["s_per_frame"] for r in ran], color="tab:blue", label="frames 2..n (mean)")
    axes[0].scatter([r["first_frame_s"] for r in ran], y, color="tab:red", zorder=3,
                    label="frame 1 (incl. JIT compile)")
    axes[0].set_xlabel("wall time per frame, s")
    axes[0].legend(fontsize=8)
    axes[1].barh(y, [r["peak_rss_mb"] or 0 for r in ran], color="tab:green")
    axes[1].set_xlabel("peak resident memory of the run's worker process, MB")
    for ax in axes:
        ax.set_yticks(y, [r["engine"] for r in ran])
        ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    fig.savefig(outdir / "timing.png", dpi=110)
    plt.close(fig)
    return True


def compare_report(path: Path, *, scene_name: str, scene_path: Any, n_frames: int, frame_dt: float,
                   table_md: str, div: list[dict], records: list[dict], reference: dict | None,
                   skipped: dict, failed: dict, strides: list[int], runner_line: str, plots: bool,
                   strips_md: list[str] | None = None) -> None:
    """Write ``report.md`` of ``gasp compare``; ``strips_md``: its ``## Frames`` section
    (:func:`gasp_studies.strips.strips_markdown`)."""
    lines = [f"# Engine comparison: {scene_name}", "",
             f"Scene `{scene_path}`, {n_frames} frames of {frame_dt:.4g} s ({n_frames * frame_dt:.3g} s "
             f"simulated), on {machine_line()}. {runner_line}", ""]
    if any(k > 1 for k in strides):
        lines += [f"Objects were cut to every k-th Gaussian, k = {strides} (max_gaussians).", ""]
    lines += ["## Engines", "", table_md, "",
              "`s/frame (2..n)` is the mean wall time of `step_frame` plus read-back over frames 2..n; "
              "frame 1 also holds any JIT compile and is shown apart. `CPU s/frame` is the process CPU time "
              "per frame (all threads, T^-1 rebuild included): on a shared machine it depends less on the "
              "load than wall time. Peak memory is the `ru_maxrss` of the run's fresh worker process "
              "(Python, the Dask worker, the engine runtime and the scene); `worker alone` is the same "
              "figure when the run started.", ""]
    if skipped:
        lines += ["## Not run", ""] + [f"- `{k}`: {v}" for k, v in skipped.items()] + [""]
    if failed:
        lines += ["## Failed", ""] + [f"- `{k}`: {v}" for k, v in failed.items()] + [""]
    if reference is not None:
        lines += [f"## Divergence against `{reference['label']}`", "",
                  f"Object size (bounding-box diagonal of the frame-0 Gaussian means, world frame): "
                  f"{reference['size_m']:.4g} m. `mean`/`max`: distance between the same Gaussian's means "
                  f"in the two runs; `Chamfer`: symmetric Chamfer distance between the two clouds of "
                  f"means (0.5 (mean_a min_b + mean_b min_a)). Full per-frame values: `divergence.csv`.", ""]
        summ = []
        for r in records:
            rs = [d for d in div if d["engine"] == r["label"]]
            if r is reference or not rs:
                continue
            last = rs[-1]
            worst = max(rs, key=lambda d: d["mean_dist_rel"])
            summ.append({"engine": r["label"], "frames": len(rs) - 1,
                         "final_mean": 100 * last["mean_dist_rel"], "final_max": 100 * last["max_dist_rel"],
                         "final_chamfer": 100 * last["chamfer_rel"], "worst_mean": 100 * worst["mean_dist_rel"],
                         "worst_frame": worst["frame"], "final_mean_mm": 1000 * last["mean_dist_m"]})
        if summ:
            lines += [md_table(summ, ["engine", "frames", "final_mean_mm", "final_mean", "final_max",
                                      "final_chamfer", "worst_mean", "worst_frame"],
                               ["engine", "frames compared", "final mean, mm", "final mean, % size",
                                "final max, % size", "final Chamfer, % size", "worst mean, % size",
                                "at frame"]), ""]
        lines += (["![divergence](divergence.png)", "", "![timing](timing.png)", ""] if plots else [NO_PLOTS, ""])
    lines += strips_md or []
    path.write_text("\n".join(lines))


def plot_pareto(ax, rows: list[dict], engine: str) -> None:
    """One engine's wall time vs ``err_max`` (log-log), Pareto front highlighted, 1 % and 5 % lines.

    Errors below 0.01 % (the reference's 0 among them) are drawn on the 0.01 % floor.
    """
    floor = 0.01
    ok = [r for r in rows if r["status"] == "ok" and np.isfinite(r["err_max"])]
    for r in ok:
        y = max(r["err_max"] * 100, floor)
        if r["is_reference"]:
            ax.scatter(r["wall_s"], y, marker="*", s=160, color="black", zorder=4, label="reference (error 0)")
        else:
            ax.scatter(r["wall_s"], y, s=40 if r["pareto"] else 18,
                       color="tab:red" if r["pareto"] else "tab:gray", zorder=3)
        if r["pareto"] or r["is_reference"]:
            ax.annotate(r["setting"], (r["wall_s"], y), fontsize=7, xytext=(4, 3), textcoords="offset points")
    fr = sorted([r for r in ok if r["pareto"]], key=lambda r: r["wall_s"])
    if fr:
        ax.plot([r["wall_s"] for r in fr], [max(r["err_max"] * 100, floor) for r in fr], color="tab:red",
                lw=1.2, label="Pareto front (labelled)", zorder=2)
    ax.scatter([], [], s=18, color="tab:gray", label="dominated setting")
    for lvl, ls in ((1, "--"), (5, ":")):
        ax.axhline(lvl, color="tab:blue", ls=ls, lw=1, label=f"{lvl}% of object size")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(floor / 2, max([30.0] + [r["err_max"] * 200 for r in ok]))
    ax.set_xlabel("simulation wall time, s (frames 2..n, scaled to n)")
    ax.set_ylabel("error: worst frame's mean distance, % of size")
    failed = [r for r in rows if r["status"] != "ok"]
    ax.set_title(engine + (f"  ({len(failed)} run(s) failed: see summary.md)" if failed else ""), fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower left")


def bench_plots(outdir: Path, rows: list[dict], engines: list[str]) -> bool:
    """``pareto_<engine>.png`` per engine and ``pareto.png`` (a panel per engine); False without matplotlib."""
    plt = _pyplot()
    if plt is None:
        return False
    for eng in engines:
        fig, ax = plt.subplots(figsize=(7, 5))
        plot_pareto(ax, [r for r in rows if r["engine"] == eng], eng)
        fig.tight_layout()
        fig.savefig(outdir / f"pareto_{eng}.png", dpi=110)
        plt.close(fig)
    if engines:
        fig, axes = plt.subplots(1, len(engines), figsize=(6.5 * len(engines), 5), squeeze=False)
        for ax, eng in zip(axes[0], engines):
            plot_pareto(ax, [r for r in rows if r["engine"] == eng], eng)
        fig.tight_layout()
        fig.savefig(outdir / "pareto.png", dpi=110)
        plt.close(fig)
    return True


def bench_summary(path: Path, *, scene_name: str, scene_path: Any, n_frames: int, frame_dt: float,
                  rows: list[dict], engines: list[str], skipped: dict, strides: list[int], total_s: float,
                  runner_line: str, plots: bool, strips_md: list[str] | None = None,
                  ranking_md: list[str] | None = None) -> dict[str, dict]:
    """Write ``summary.md`` of ``gasp bench``; return ``{engine: {reference, within_1pct, within_5pct}}``.

    ``strips_md``: its ``## Frames`` section (:func:`gasp_studies.strips.strips_markdown`), after the
    Pareto plot."""
    out: dict[str, dict] = {}
    lines = [f"# Speed / accuracy: {scene_name}", "",
             f"Scene `{scene_path}`, {n_frames} frames of {frame_dt:.4g} s ({n_frames * frame_dt:.3g} s simulated)"
             + (f"; objects cut to every k-th Gaussian, k = {strides}" if any(k > 1 for k in strides) else "")
             + f". {machine_line()}; the whole sweep took {total_s / 60:.1f} min. {runner_line}", "",
             "Each engine's sweep and reference (its finest setting, first row) come from the engine plugin "
             "(`EngineInfo.sweep`). Error: distance between the same Gaussian's means in a run and in the "
             "engine's reference run, world frame, divided by the object size = diagonal of the bounding box "
             "of the frame-0 Gaussian means. `err_max` = worst frame's mean distance (the run stays within it "
             "on every frame); `err_mean` = mean over frames. Wall time: simulation only, mean of frames 2..n "
             "times n (frame 1 holds any JIT compile); `end to end` adds what a user waits for besides: reading, "
             "fill and hierarchy (`prepare_s`), the engine build, every frame as it ran (JIT compile included) "
             "and its T^-1 rebuild (not the worker's start-up or PLY writes: `gasp bench` writes none). "
             "Energy (docs/dissipation.md): `KE left` = the Gaussians' mean kinetic energy over the last quarter "
             "of the frames over its peak, `KE vs ref` = their kinetic energy over the run over the reference's "
             "(< 1: the setting damps more than the reference; the numerics damp every run, the reference too).", ""]
    if skipped:
        lines += ["Not benched:", ""] + [f"- `{k}`: {v}" for k, v in skipped.items()] + [""]
    lines += ["## Cheapest setting within 1 % and 5 % of the object size", "",
              "Errors are against the converged reference (`gasp_studies.convergence`: a Richardson estimate from the "
              "reference's model on the three finest grids swept, or the finest with its distance to the next coarser); "
              "a tolerance finer than that reference's own uncertainty is not ranked. Times are end to end "
              "(build and JIT included).", "",
              "| engine | reference setting | reference end to end, s | within 1 %: setting | end to end, s | err | "
              "speed-up | within 5 %: setting | end to end, s | err | speed-up |", "|" + "---|" * 11]
    for eng in engines:
        rs = [r for r in rows if r["engine"] == eng]
        ref = rs[0]
        (c1, why1), (c5, why5) = cheapest_ranked(rs, 0.01), cheapest_ranked(rs, 0.05)
        out[eng] = {"reference": ref, "within_1pct": c1, "within_5pct": c5}
        conv = np.isfinite(ref.get("ref_bound", np.nan))
        key = "err_conv_max" if conv else "err_max"

        def cell(c, why):
            if ref["status"] != "ok":
                return "no reference | - | - | -"
            if c is None:
                return f"{why} | - | - | -"
            return (f"{c['setting']} | {c['end_to_end_s']:.3g} | {100 * c[key]:.2g} % | "
                    f"{ref_s / c['end_to_end_s']:.1f}x")
        ref_s = ref.get("end_to_end_s", float("nan"))
        lines.append(f"| {eng} | {ref['setting']} ({ref['status']}) | {ref_s:.3g} | "
                     f"{cell(c1, why1)} | {cell(c5, why5)} |")
        if conv:
            lines.append(f"|  | converged reference: {ref['ref_method']}, uncertain by "
                         f"{100 * ref['ref_bound']:.2g} % of the size | | | | | | | | | |")
    lines += ["", "![pareto](pareto.png)" if plots else NO_PLOTS, ""] + (strips_md or [])
    if ranking_md:
        lines += ["## Ranking: shape, events and renders in units of the reference's uncertainty U", "",
                  "U: the reference's twin (its model on the next coarser grid swept) against the reference. A run is "
                  "ranked when its shape residual after the best rigid fit is within 1.5 U, its events are in their "
                  "bands and its renders (PSNR) are at least as close to the reference's as the twin's "
                  "(docs/speed_accuracy.md, 'Choosing the default'); ranked runs are ordered by end-to-end time.",
                  ""] + ranking_md
    lines += ["## All runs", ""]
    view = [{**r, "err_mean_pct": 100 * r["err_mean"], "err_max_pct": 100 * r["err_max"],
             "err_conv_pct": 100 * r.get("err_conv_max", float("nan")),
             "err_final_pct": 100 * r["err_final"], "front": "yes" if r.get("pareto") else ""} for r in rows]
    lines += [md_table(view, ["engine", "setting", "status", "simulated_points", "substeps_per_frame",
                              "s_per_frame", "cpu_s_per_frame", "wall_s", "end_to_end_s", "err_mean_pct", "err_max_pct",
                              "err_final_pct", "err_conv_pct", "ke_left", "ke_vs_ref", "front"],
                       ["engine", "setting", "status", "points", "substeps/frame", "s/frame", "CPU s/frame",
                        "wall, s", "end to end, s", "err_mean, %", "err_max, %", "err_final, %", "err vs converged, %",
                        "KE left", "KE vs ref", "Pareto"])]
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        lines += ["## Failed runs", ""] + [f"- {r['engine']} `{r['setting']}`: {r['status']}: {r['message']}"
                                           for r in failed] + [""]
    path.write_text("\n".join(lines))
    return out


def runner_line(runner) -> str:
    """One sentence on how the runs were made (for the reports)."""
    where = f"the Dask cluster at {runner.scheduler}" if runner.scheduler else \
        f"a local Dask cluster of {runner._n_workers} worker process(es) running one run at a time each (the " \
        f"engine inside a run uses the CPU threads its own options give it: see each run's run.json)"
    iso = ("every run in a fresh worker process (restarted after each run)" if runner.isolated
           else "runs sharing worker processes (they could not be restarted: " + "; ".join(runner.notes) + ")")
    return f"Runs went to {where}, {iso}; the cluster took {runner.startup_s:.1f} s to start."
