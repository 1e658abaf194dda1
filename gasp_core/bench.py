"""``gasp bench``: the speed/accuracy trade of the settings a user chooses, per engine.

For each engine a sweep of settings runs the same scene, each run in its own process (see
:func:`gasp_core.compare.run_engine_subprocess`), and is measured against that engine's own
**reference run**, the finest settings of the sweep (largest ``n_grid``, smallest ``cfl``, most
particles per cell, interior fill on, ``f64`` where offered; for ``mujoco_flex`` the most lattice
cells across and the smallest ``cfl``). The error of a run is the distance between the same
Gaussian's means in the run and in the reference, world frame, divided by the object size (the
diagonal of the bounding box of the frame-0 Gaussian means):

* ``err_mean``: mean over frames 1..n of the per-frame mean distance;
* ``err_max``: max over frames of the per-frame mean distance (the run stays within ``err_max``
  of the reference on every frame; the 1 % / 5 % budgets of ``summary.md`` use it);
* ``err_final``: the per-frame mean distance at the last frame;
* ``err_point_max``: the largest single-Gaussian distance over all frames.

Wall time is simulation only: ``wall_s = n_frames * s_per_frame`` where ``s_per_frame`` is the
mean wall time of frames 2..n (``step_frame`` plus read-back). Frame 1 holds Taichi's and
Genesis's JIT compile and is left out; building the engine (``build_s``) and the first frame are
reported apart.

Swept settings (MPM engines): ``n_grid`` x ``cfl`` at f32 with 8 particles per cell and fill on,
then around the reference grid and ``cfl`` at f32 one change at a time: particles per
cell, fill off, f64, hierarchy share ``core_fraction`` (when the scene format has it), and the
cheapest combination of all. ``mujoco_flex``: ``cells_across`` x ``cfl``.
"""
from __future__ import annotations

import dataclasses
import itertools
import os
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from .compare import (commit_dir, engine_options, md_table, run_engine_subprocess, select_engines,
                      steady_s_per_frame, subsample_scene, write_csv)
from .engine import EngineError, SceneError
from .scene import ObjectSpec, Scene, load_scene

#: Engines left out of the default sweep, with the reason (pass them in ``engines`` to bench them).
DEFAULT_EXCLUDE = {"genesis": "left out of the default sweep: on CPU its build takes ~50 s and a frame "
                              "~5x longer than taichi_mpm's; pass engines=genesis to bench it"}
#: Default number of frames (0.5 s at 30 fps: the fall, the impact and the rebound of the donut).
DEFAULT_FRAMES = 15
#: Default cap on Gaussians per object (every k-th is kept above it), so the sweep fits ~20 min on 2 cores.
DEFAULT_MAX_GAUSSIANS = 6000

SETTING_KEYS = ["n_grid", "cfl", "particles_per_cell", "fill", "precision", "core_fraction", "cells_across"]
BENCH_COLUMNS = (["engine", "setting"] + SETTING_KEYS +
                 ["is_reference", "status", "simulated_points", "substeps_per_frame", "build_s",
                  "first_frame_s", "s_per_frame", "cpu_s_per_frame", "wall_s", "err_mean", "err_max", "err_final",
                  "err_point_max", "pareto", "message"])


def has_hierarchy() -> bool:
    """True when the scene format has the object key ``core_fraction`` (Core Gaussians hierarchy)."""
    return "core_fraction" in {f.name for f in dataclasses.fields(ObjectSpec)}


# --------------------------------------------------------------------------- sweeps
def mpm_sweep(n_grid: Sequence[int] = (32, 48, 64), cfl: Sequence[float] = (0.2, 0.4, 0.8),
              particles_per_cell: Sequence[int] = (1, 8), fill: Sequence[bool] = (True, False),
              precision: Sequence[str] = ("f32", "f64"),
              core_fraction: Sequence[float] = (1.0, 0.5, 0.2),
              reference_n_grid: int | None = None) -> list[dict]:
    """Settings of a grid-engine sweep; the first is the reference (the finest).

    Parameters
    ----------
    n_grid, cfl, particles_per_cell, fill, precision, core_fraction : sequences
        Values to try. ``n_grid`` x ``cfl`` are crossed (f32 if offered, most particles per cell,
        fill on, all Gaussians simulated); the others vary one at a time around the largest
        ``n_grid`` and smallest ``cfl``; one more run takes the cheapest value of every setting.
    reference_n_grid : int, optional
        A finer grid for the reference run alone (the donut is not grid-converged at n_grid 64:
        ``docs/speed_accuracy.md``); default: the largest ``n_grid``.

    Returns
    -------
    list of dict
        Keys ``n_grid, cfl, particles_per_cell, fill, precision, core_fraction``; no duplicates.
    """
    ng, cf = sorted(n_grid), sorted(cfl)
    ppc, prec = sorted(particles_per_cell), list(precision)
    cores = sorted(core_fraction)
    fills = sorted(set(fill), reverse=True)
    lo_prec = "f32" if "f32" in prec else prec[0]
    ref = {"n_grid": max(ng[-1], reference_n_grid or 0), "cfl": cf[0], "particles_per_cell": ppc[-1],
           "fill": fills[0], "precision": "f64" if "f64" in prec else prec[0], "core_fraction": cores[-1]}
    out = [ref]
    base = {**ref, "n_grid": ng[-1], "precision": lo_prec}
    for g, c in itertools.product(ng, cf):
        out.append({**base, "n_grid": g, "cfl": c})
    for key, values in (("particles_per_cell", ppc), ("fill", fills), ("precision", prec),
                        ("core_fraction", cores)):
        for v in values:
            out.append({**base, key: v})
    out.append({"n_grid": ng[0], "cfl": cf[-1], "particles_per_cell": ppc[0], "fill": fills[-1],
                "precision": lo_prec, "core_fraction": cores[0]})
    return _dedupe(out)


def flex_sweep(cells_across: Sequence[int] = (4, 8, 12), cfl: Sequence[float] = (0.25, 0.5, 1.0),
               reference_cells: int = 16, core_fraction: Sequence[float] = (1.0,)) -> list[dict]:
    """Settings of a ``mujoco_flex`` sweep (lattice cells across the body x ``cfl``); first = reference.

    The reference takes ``reference_cells`` cells across and the smallest ``cfl``.
    """
    cf = sorted(cfl)
    cores = sorted(core_fraction)
    out = [{"cells_across": int(reference_cells), "cfl": cf[0], "core_fraction": cores[-1]}]
    out += [{"cells_across": int(n), "cfl": c, "core_fraction": cores[-1]}
            for n, c in itertools.product(sorted(cells_across), cf)]
    mid = sorted(cells_across)[len(cells_across) // 2]
    out += [{"cells_across": mid, "cfl": cf[len(cf) // 2], "core_fraction": k} for k in cores]
    return _dedupe(out)


def _dedupe(settings: list[dict]) -> list[dict]:
    seen, out = set(), []
    for s in settings:
        key = tuple(sorted(s.items()))
        if key not in seen:
            seen.add(key)
            out.append(s)
    return out


def setting_label(s: dict) -> str:
    """Short label of a setting, e.g. ``g48 cfl0.4 ppc8 fill f32``."""
    parts = []
    if "n_grid" in s:
        parts.append(f"g{s['n_grid']}")
    if "cells_across" in s:
        parts.append(f"cells{s['cells_across']}")
    parts.append(f"cfl{s['cfl']:g}")
    if "particles_per_cell" in s:
        parts.append(f"ppc{s['particles_per_cell']}")
    if "fill" in s:
        parts.append("fill" if s["fill"] else "nofill")
    if "precision" in s:
        parts.append(s["precision"])
    if s.get("core_fraction", 1.0) != 1.0:
        parts.append(f"core{s['core_fraction']:g}")
    return " ".join(parts)


def apply_setting(scene: Scene, engine: str, setting: dict, base_options: dict) -> tuple[Scene, dict]:
    """The scene and engine options of one setting.

    ``n_grid``, ``particles_per_cell`` go to ``[domain]``; ``fill`` and ``core_fraction`` to every
    object; ``cfl``, ``precision`` and ``cells_across`` to the engine options.

    Raises
    ------
    SceneError
        ``core_fraction`` below 1 while the scene format has no hierarchy.
    """
    domain = scene.domain
    if "n_grid" in setting or "particles_per_cell" in setting:
        domain = dataclasses.replace(domain, n_grid=int(setting.get("n_grid", domain.n_grid)),
                                     particles_per_cell=int(setting.get("particles_per_cell",
                                                                        domain.particles_per_cell)))
    obj_changes: dict[str, Any] = {}
    if "fill" in setting:
        obj_changes["fill"] = bool(setting["fill"])
    if setting.get("core_fraction", 1.0) != 1.0:
        if not has_hierarchy():
            raise SceneError("setting core_fraction: this GASP version has no object key 'core_fraction'")
        obj_changes["core_fraction"] = float(setting["core_fraction"])
    objects = [dataclasses.replace(o, **obj_changes) for o in scene.objects] if obj_changes else scene.objects
    options = dict(base_options)
    for key in ("cfl", "precision", "cells_across"):
        if key in setting:
            options[key] = setting[key]
    if "cells_across" in setting:
        options.pop("cell_size", None)
    return dataclasses.replace(scene, domain=domain, objects=objects), options


# --------------------------------------------------------------------------- Pareto
def pareto_front(cost: Sequence[float], err: Sequence[float]) -> np.ndarray:
    """Mask of the points no other point beats on both axes (minimising both).

    A point is dominated when another has ``cost <=`` and ``err <=`` with at least one strictly
    smaller. Points with a non-finite value are never on the front.

    Parameters
    ----------
    cost, err : sequences of float, same length

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    c = np.asarray(cost, dtype=np.float64)
    e = np.asarray(err, dtype=np.float64)
    if c.shape != e.shape:
        raise ValueError(f"pareto_front: cost and err must have the same length, got {c.shape} and {e.shape}")
    ok = np.isfinite(c) & np.isfinite(e)
    front = ok.copy()
    for i in np.flatnonzero(ok):
        dominated = ok & (c <= c[i]) & (e <= e[i]) & ((c < c[i]) | (e < e[i]))
        if dominated.any():
            front[i] = False
    return front


def cheapest_within(rows: list[dict], budget: float, key: str = "err_max") -> dict | None:
    """The row with the least ``wall_s`` whose ``key`` error is at most ``budget`` (a fraction)."""
    ok = [r for r in rows if r["status"] == "ok" and np.isfinite(r.get(key, np.nan)) and r[key] <= budget]
    return min(ok, key=lambda r: r["wall_s"]) if ok else None


# --------------------------------------------------------------------------- errors
def run_errors(ref: dict, rec: dict) -> dict:
    """``err_mean, err_max, err_final, err_point_max`` of a run against the reference (fractions of size)."""
    nan = {"err_mean": float("nan"), "err_max": float("nan"), "err_final": float("nan"),
           "err_point_max": float("nan")}
    if rec.get("status") != "ok" or not rec.get("npz") or ref is None or not ref.get("npz"):
        return nan
    A, B = np.load(ref["npz"]), np.load(rec["npz"])
    ma, mb = A["means"].astype(np.float64), B["means"].astype(np.float64)
    if ma.shape != mb.shape:
        return nan
    d = np.linalg.norm(ma[1:] - mb[1:], axis=2) * A["m_per_unit"][None, :]
    per_frame = d.mean(axis=1) / ref["size_m"]
    return {"err_mean": float(per_frame.mean()), "err_max": float(per_frame.max()),
            "err_final": float(per_frame[-1]), "err_point_max": float(d.max() / ref["size_m"])}


# --------------------------------------------------------------------------- plots
def plot_pareto(ax, rows: list[dict], engine: str) -> None:
    """One engine's wall time vs ``err_max`` (log-log), Pareto front highlighted, 1 % and 5 % lines.

    Errors below 0.01 % (the reference's 0 among them) are drawn on the 0.01 % floor.
    """
    floor = 0.01
    ok = [r for r in rows if r["status"] == "ok" and np.isfinite(r["err_max"])]
    for r in ok:
        y = max(r["err_max"] * 100, floor)
        if r["is_reference"]:
            ax.scatter(r["wall_s"], y, marker="*", s=160, color="black", zorder=4,
                       label="reference (error 0)")
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
    title = engine + (f"  ({len(failed)} run(s) diverged: see summary.md)" if failed else "")
    ax.set_title(title, fontsize=9)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="lower left")


def write_plots(outdir: Path, rows: list[dict], engines: list[str]) -> None:
    """``pareto_<engine>.png`` per engine and ``pareto.png`` with a panel per engine."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
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


# --------------------------------------------------------------------------- main entry
@dataclass
class BenchResult:
    """What :func:`bench_scene` did."""

    outdir: Path
    rows: list[dict]
    skipped: dict[str, str] = field(default_factory=dict)
    summary: dict[str, dict] = field(default_factory=dict)


def bench_scene(scene_path: str | Path, output: str | Path, engines: list[str] | None = None, *,
                overwrite: bool = False, n_frames: int | None = None,
                max_gaussians: int | None = DEFAULT_MAX_GAUSSIANS,
                settings: dict[str, list[dict]] | None = None,
                n_grid: Sequence[int] = (32, 48, 64, 80, 96), cfl: Sequence[float] = (0.2, 0.4, 0.8),
                reference_n_grid: int | None = None,
                particles_per_cell: Sequence[int] = (1, 8), fill: Sequence[bool] = (True, False),
                precision: Sequence[str] = ("f32", "f64"),
                core_fraction: Sequence[float] | None = None,
                cells_across: Sequence[int] = (4, 8, 12), flex_cfl: Sequence[float] = (0.25, 0.5, 1.0),
                flex_reference_cells: int = 16, options: dict[str, dict] | None = None,
                timeout_s: float = 1800.0, progress: bool = True) -> BenchResult:
    """Sweep speed/accuracy settings per engine against a converged reference and write a report.

    Layout of ``output``: ``bench.csv`` (one row per engine and setting; columns
    :data:`BENCH_COLUMNS`; errors are fractions of the object size), ``pareto_<engine>.png``,
    ``pareto.png`` (a panel per engine), ``summary.md``, ``runs/`` (records and logs).

    Parameters
    ----------
    scene_path : str or Path
    output : str or Path
        Must not exist unless ``overwrite``.
    engines : list of str, optional
        Default: the installed grid engines and ``mujoco_flex`` except :data:`DEFAULT_EXCLUDE`.
    overwrite : bool
    n_frames : int, optional
        Default ``min(scene.n_frames, DEFAULT_FRAMES)``.
    max_gaussians : int or None
        Keep every k-th Gaussian so that each object has at most this many (None: all).
    settings : dict, optional
        ``{engine: [setting, ...]}`` replacing the generated sweep of that engine; the first
        setting is the reference. Keys as in :data:`SETTING_KEYS`.
    n_grid, cfl, particles_per_cell, fill, precision : sequences
        Grid-engine sweep values (see :func:`mpm_sweep`); ``precision`` is cut to what the engine offers.
    reference_n_grid : int, optional
        Finer grid for the reference run alone (``gasp bench`` passes 96).
    core_fraction : sequence of float, optional
        Hierarchy shares in (0, 1]; default ``(1.0, 0.5, 0.2)`` when the scene format has
        ``core_fraction``, else not swept.
    cells_across, flex_cfl, flex_reference_cells :
        ``mujoco_flex`` sweep (see :func:`flex_sweep`).
    options : dict, optional
        ``{engine: {option: value}}`` fixed for every run of that engine (e.g. ``threads``).
    timeout_s : float
        Per-run wall-clock limit, seconds.
    progress : bool
        One line per run on stderr.

    Returns
    -------
    BenchResult

    Raises
    ------
    FileExistsError
        ``output`` exists and ``overwrite`` is false (before any work).
    SceneError
        Bad scene or argument.
    EngineError
        No requested engine can run the scene.
    """
    output = Path(output)
    if output.exists() and not overwrite:
        raise FileExistsError(f"output folder '{output}' exists; pass --overwrite to replace it")
    scene = load_scene(scene_path)
    if n_frames is not None and (isinstance(n_frames, bool) or not isinstance(n_frames, int) or n_frames < 2):
        raise SceneError(f"n_frames: expected an integer >= 2 (frame 1 is left out of the timing), got {n_frames!r}")
    n_frames = min(scene.n_frames, DEFAULT_FRAMES) if n_frames is None else n_frames
    hier = has_hierarchy()
    if core_fraction is None:
        core_fraction = (1.0, 0.5, 0.2) if hier else (1.0,)
    elif any(k != 1.0 for k in core_fraction) and not hier:
        raise SceneError("core_fraction: this GASP version has no object key 'core_fraction' (hierarchy)")
    from .plugins import engines as all_engines
    found = all_engines()
    skipped: dict[str, str] = {}
    if engines is None:
        requested = [n for n, e in found.items()
                     if ("grid" in e.capabilities.features or n == "mujoco_flex") and n not in DEFAULT_EXCLUDE]
        skipped.update({n: r for n, r in DEFAULT_EXCLUDE.items() if n in found})
    else:
        requested = list(dict.fromkeys(e.strip() for e in engines if e.strip()))
    runnable, why = select_engines(scene, requested)
    skipped.update(why)
    if not runnable:
        raise EngineError(f"no engine can run {scene_path}: " + "; ".join(f"{k}: {v}" for k, v in skipped.items()))

    plan: dict[str, list[dict]] = {}
    for name in runnable:
        caps = found[name].capabilities
        if settings and name in settings:
            plan[name] = [dict(s) for s in settings[name]]
        elif "grid" in caps.features:
            prec = [p for p in precision if p in caps.precisions] or sorted(caps.precisions)[:1]
            plan[name] = mpm_sweep(n_grid, cfl, particles_per_cell, fill, prec, core_fraction,
                                   reference_n_grid)
        elif name == "mujoco_flex":
            plan[name] = flex_sweep(cells_across, flex_cfl, flex_reference_cells, core_fraction)
        else:
            skipped[name] = "no sweep defined for this engine (pass settings={name: [...]})"
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=output.parent, prefix=f".{output.name}.partial-"))
    work = Path(tempfile.mkdtemp(prefix="gasp-bench-"))
    t_all = time.perf_counter()
    try:
        runs = tmp / "runs"
        runs.mkdir()
        scene_run, strides = subsample_scene(scene, max_gaussians, work)
        rows: list[dict] = []
        n_total = sum(len(v) for v in plan.values())
        k_run = 0
        for name, sweep in plan.items():
            base_opts = engine_options(scene, name, options)
            ref_rec = None
            eng_rows = []
            for i, s in enumerate(sweep):
                k_run += 1
                label = setting_label(s)
                sc, opts = apply_setting(scene_run, name, s, base_opts)
                stem = f"{name}_{i:02d}"
                rec = run_engine_subprocess(sc, name, opts, n_frames, work, label=stem, timeout_s=timeout_s)
                for ext in (".json", ".log"):
                    src = work / f"{stem}{ext}"
                    if src.exists():
                        shutil.copy2(src, runs / src.name)
                if i == 0:
                    ref_rec = rec if rec["status"] == "ok" else None
                frame_s = rec.get("frame_s") or []
                sp = steady_s_per_frame(frame_s) if rec["status"] == "ok" else float("nan")
                st = rec.get("engine_stats") or {}
                msg = "" if rec["status"] == "ok" else rec.get("message", "")
                if i == 0 and ref_rec is None:
                    msg = "reference run failed, no errors can be measured: " + msg
                row = {"engine": name, "setting": label, **{k: s.get(k) for k in SETTING_KEYS},
                       "is_reference": i == 0, "status": rec["status"] if rec["status"] != "diverged"
                       else f"diverged@{rec.get('frame')}", "simulated_points": rec.get("simulated_points"),
                       "substeps_per_frame": st.get("n_substeps"), "build_s": rec.get("build_s"),
                       "first_frame_s": frame_s[0] if frame_s else None, "s_per_frame": sp,
                       "cpu_s_per_frame": steady_s_per_frame(rec.get("frame_cpu_s") or [])
                       if rec["status"] == "ok" else float("nan"),
                       "wall_s": sp * n_frames, **run_errors(ref_rec, rec), "message": msg}
                eng_rows.append(row)
                if rec.get("npz") and i > 0:
                    Path(rec["npz"]).unlink(missing_ok=True)
                if progress:
                    print(f"gasp bench [{k_run}/{n_total}] {name} {label}: {row['status']}, "
                          f"{sp:.3f} s/frame, err_max {100 * row['err_max']:.3g}% "
                          f"({time.perf_counter() - t_all:.0f} s so far)", file=sys.stderr, flush=True)
            front = pareto_front([r["wall_s"] for r in eng_rows], [r["err_max"] for r in eng_rows])
            for r, p in zip(eng_rows, front):
                r["pareto"] = bool(p)
            rows += eng_rows
            if ref_rec and ref_rec.get("npz"):
                Path(ref_rec["npz"]).unlink(missing_ok=True)
        write_csv(tmp / "bench.csv", rows, BENCH_COLUMNS)
        names = list(plan)
        write_plots(tmp, rows, names)
        summary = _summary(tmp, scene, scene_path, n_frames, rows, names, skipped, strides, hier,
                           time.perf_counter() - t_all)
        commit_dir(tmp, output)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if progress:
        print(f"gasp bench: wrote {output}/summary.md", file=sys.stderr)
    return BenchResult(output, rows, skipped, summary)


def _summary(tmp: Path, scene: Scene, scene_path, n_frames: int, rows: list[dict], engines: list[str],
             skipped: dict, strides: list[int], hier: bool, total_s: float) -> dict:
    import platform
    out: dict[str, dict] = {}
    lines = [f"# Speed / accuracy: {scene.name}", "",
             f"Scene `{scene_path}`, {n_frames} frames of {scene.frame_dt:.4g} s "
             f"({n_frames * scene.frame_dt:.3g} s simulated)"
             + (f"; objects cut to every k-th Gaussian, k = {strides}" if any(k > 1 for k in strides) else "")
             + f". {platform.machine()}, {os.cpu_count()} logical CPUs, load average at the end "
             f"{', '.join(f'{x:.1f}' for x in os.getloadavg())}; the whole sweep took {total_s / 60:.1f} min.", "",
             "Error: distance between the same Gaussian's means in a run and in the engine's reference run "
             "(its finest setting, first row), world frame, divided by the object size = diagonal of the "
             "bounding box of the frame-0 Gaussian means. `err_max` = worst frame's mean distance (the run "
             "stays within it on every frame); `err_mean` = mean over frames. Wall time: simulation only, "
             "mean of frames 2..n times n (frame 1 holds the JIT compile; build and frame 1 are in "
             "`bench.csv`).", ""]
    if not hier:
        lines += ["Hierarchy share (`core_fraction`) not swept: this GASP version's scene format has no "
                  "`core_fraction` object key.", ""]
    if skipped:
        lines += ["Not benched:", ""] + [f"- `{k}`: {v}" for k, v in skipped.items()] + [""]
    lines += ["## Cheapest setting within 1 % and 5 % of the object size", "",
              "| engine | reference setting | reference wall, s | within 1 %: setting | wall, s | err_max | "
              "speed-up | within 5 %: setting | wall, s | err_max | speed-up |", "|" + "---|" * 11]
    for eng in engines:
        rs = [r for r in rows if r["engine"] == eng]
        ref = rs[0]
        c1, c5 = cheapest_within(rs[1:], 0.01), cheapest_within(rs[1:], 0.05)
        out[eng] = {"reference": ref, "within_1pct": c1, "within_5pct": c5}

        def cell(c):
            if ref["status"] != "ok":
                return "no reference | - | - | -"
            if c is None or c is ref:
                return "none but the reference | - | - | -"
            return (f"{c['setting']} | {c['wall_s']:.3g} | {100 * c['err_max']:.2g} % | "
                    f"{ref['wall_s'] / c['wall_s']:.1f}x")
        lines.append(f"| {eng} | {ref['setting']} ({ref['status']}) | {ref['wall_s']:.3g} | {cell(c1)} | {cell(c5)} |")
    lines += ["", "![pareto](pareto.png)", "", "## All runs", ""]
    view = []
    for r in rows:
        view.append({**r, "err_mean_pct": 100 * r["err_mean"], "err_max_pct": 100 * r["err_max"],
                     "err_final_pct": 100 * r["err_final"], "front": "yes" if r.get("pareto") else ""})
    lines += [md_table(view, ["engine", "setting", "status", "simulated_points", "substeps_per_frame",
                              "s_per_frame", "cpu_s_per_frame", "wall_s", "err_mean_pct", "err_max_pct", "err_final_pct", "front"],
                       ["engine", "setting", "status", "points", "substeps/frame", "s/frame", "CPU s/frame", "wall, s",
                        "err_mean, %", "err_max, %", "err_final, %", "Pareto"])]
    failed = [r for r in rows if r["status"] != "ok"]
    if failed:
        lines += ["## Failed runs", ""] + [f"- {r['engine']} `{r['setting']}`: {r['status']}: {r['message']}"
                                           for r in failed] + [""]
    (tmp / "summary.md").write_text("\n".join(lines))
    return out
