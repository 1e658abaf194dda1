"""``gasp bench``: the speed/accuracy trade of the settings a user chooses, per engine.

Each engine offers its own sweep (:attr:`gasp_core.seam.engine.EngineInfo.sweep`,
``sweep(quick) -> (settings, reference)``): the settings to try and the reference setting, its
finest. Keys ``n_grid``, ``particles_per_cell``, ``fill`` and ``core_fraction`` change the scene
(:data:`gasp_studies.report.SCENE_KEYS`); every other key is an engine option. An engine without a
sweep, or whose sweep offers no settings in this mode (a slow engine may leave the quick mode
out), is not benched and the summary says why.

Every run goes to a fresh Dask worker process (:mod:`gasp_studies.run`) and is measured against
the engine's reference run (:func:`gasp_studies.measure.run_errors`): the distance between the
same Gaussian's means, world frame, divided by the object size (bounding-box diagonal of the
frame-0 means). Wall time is simulation only: ``wall_s = n_frames * s_per_frame``, where
``s_per_frame`` is the mean over frames 2..n (frame 1 holds JIT compiles); ``end_to_end_s`` is
what the user waits for: reading, fill and hierarchy, engine build and every frame as it ran.
"""
from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from gasp_core.fsutil import output_folder
from gasp_core.errors import EngineError, SceneError
from gasp_core.scene.spec import Scene
from gasp_core.scene.values import N_GRID_RANGE

from . import report
from .compare import open_study, check_engine_names, engine_options, ground_height, progress_line, save_run, select_engines, subsample_scene
from .convergence import conv_errors
from .measure import cheapest_ranked, energy_figures, pareto_front, run_errors, steady_s_per_frame
from .report import SCENE_KEYS
from .bench_rank import bench_strips, output_track, plot_u, rank_engine, ranking_lines
from .run import RunOutput, Runner, RunSpec
from .strips import DEFAULT_STRIP_FRAMES, StripRow, render_strips, strip_frames, strips_markdown

#: Default number of frames (0.5 s at 30 fps: the fall, the impact and the rebound of the donut).
DEFAULT_FRAMES = 15
#: Default cap on Gaussians per object (every k-th is kept above it), so a sweep fits ~20 min on 2 cores.
DEFAULT_MAX_GAUSSIANS = 6000
#: Default wall-clock limit of one run, seconds.
BENCH_TIMEOUT_S = 1800.0


def setting_label(s: dict) -> str:
    """Short label of a setting, e.g. ``g48 cfl0.4 ppc8 fill f32``.

    Order: ``n_grid`` (``g``), numeric options (``key<value>``), ``particles_per_cell`` (``ppc``),
    ``fill`` / ``nofill``, other true/false options (``key`` / ``nokey``), string options as they
    are, then ``core_fraction`` (``core``) when below 1.
    """
    opts = sorted(k for k in s if k not in SCENE_KEYS)
    num = [k for k in opts if isinstance(s[k], (int, float)) and not isinstance(s[k], bool)]
    flags = [k for k in opts if isinstance(s[k], bool)]
    text = [k for k in opts if k not in num and k not in flags]
    parts = []
    if "n_grid" in s:
        parts.append(f"g{s['n_grid']}")
    parts += [f"{k}{s[k]:g}" for k in num]
    if "particles_per_cell" in s:
        parts.append(f"ppc{s['particles_per_cell']}")
    for k in (["fill"] if "fill" in s else []) + flags:
        parts.append(k if s[k] else f"no{k}")
    parts += [str(s[k]) for k in text]
    if s.get("core_fraction", 1.0) != 1.0:
        parts.append(f"core{s['core_fraction']:g}")
    if s.get("surface", "material") != "material":
        parts.append(str(s["surface"]))
    return " ".join(parts) or "defaults"


def apply_setting(scene: Scene, setting: dict, base_options: dict) -> tuple[Scene, dict]:
    """The scene and engine options of one setting.

    ``n_grid`` and ``particles_per_cell`` go to ``[domain]``; ``fill``, ``core_fraction`` and
    ``surface`` to every object; every other key to the engine options (over ``base_options``).

    Raises
    ------
    SceneError
        A scene value of the wrong type (the message names the key).
    """
    domain = scene.domain
    try:
        if "n_grid" in setting or "particles_per_cell" in setting:
            domain = dataclasses.replace(domain, n_grid=int(setting.get("n_grid", domain.n_grid)),
                                         particles_per_cell=int(setting.get("particles_per_cell",
                                                                            domain.particles_per_cell)))
        obj_changes: dict[str, Any] = {}
        if "fill" in setting:
            obj_changes["fill"] = bool(setting["fill"])
        if "core_fraction" in setting:
            obj_changes["core_fraction"] = float(setting["core_fraction"])
        if "surface" in setting:
            if setting["surface"] not in ("material", "passive"):
                raise ValueError(f"surface: expected 'material' or 'passive', got {setting['surface']!r}")
            obj_changes["surface"] = str(setting["surface"])
    except (TypeError, ValueError) as e:
        raise SceneError(f"bench setting {setting!r}: {e}") from None
    if "surface" not in setting:   # a sweep measures against the full model unless it sweeps the surface
        obj_changes["surface"] = "material"
    objects = [dataclasses.replace(o, **obj_changes) for o in scene.objects]
    options = {**base_options, **{k: v for k, v in setting.items() if k not in SCENE_KEYS}}
    return dataclasses.replace(scene, domain=domain, objects=objects), options


def plan_sweeps(found: dict, names: list[str], quick: bool, settings: dict[str, list[dict]] | None,
                reference_n_grid: int | None) -> tuple[dict[str, list[dict]], dict[str, str]]:
    """``{engine: [reference, setting, ...]}`` from each engine's own sweep, and why others are left out.

    ``settings[engine]`` (first = reference) replaces an engine's sweep. ``reference_n_grid``
    replaces the reference's ``n_grid`` where it has one. Settings equal to the reference are
    dropped.
    """
    plan: dict[str, list[dict]] = {}
    skipped: dict[str, str] = {}
    for name in names:
        if settings and name in settings:
            ref, rest = dict(settings[name][0]), [dict(s) for s in settings[name][1:]]
        else:
            sweep = found[name].sweep
            if sweep is None:
                skipped[name] = "the engine offers no sweep (EngineInfo.sweep is None)"
                continue
            rest, ref = sweep(quick)
            rest, ref = [dict(s) for s in rest], dict(ref)
            if not rest:
                skipped[name] = f"the engine's sweep offers no settings in {'quick' if quick else 'full'} mode"
                continue
        if reference_n_grid and "n_grid" in ref:
            ref["n_grid"] = int(reference_n_grid)
        out = [ref]
        for s in rest:
            if s not in out:
                out.append(s)
        plan[name] = out
    return plan, skipped


@dataclass
class BenchResult:
    """What :func:`bench_scene` did."""

    outdir: Path
    rows: list[dict]
    skipped: dict[str, str] = field(default_factory=dict)
    summary: dict[str, dict] = field(default_factory=dict)
    columns: list[str] = field(default_factory=list)


def bench_scene(scene_path: str | Path, output: str | Path, engines: list[str] | None = None, *,
                overwrite: bool = False, n_frames: int | None = None, quick: bool = False,
                max_gaussians: int | None = DEFAULT_MAX_GAUSSIANS,
                settings: dict[str, list[dict]] | None = None, reference_n_grid: int | None = None,
                options: dict[str, dict] | None = None, timeout_s: float = BENCH_TIMEOUT_S,
                progress: bool = True, scheduler: str | None = None, workers: int = 1,
                n_strip_frames: int = DEFAULT_STRIP_FRAMES) -> BenchResult:
    """Sweep each engine's speed/accuracy settings against its reference and write a report.

    Layout of ``output``: ``bench.csv`` (one row per engine and setting; columns from
    :func:`gasp_studies.report.bench_columns`; errors are fractions of the object size),
    ``pareto_<engine>.png`` and ``pareto.png`` (with matplotlib), ``strip_<engine>.png`` (frames of
    the reference run and of the cheapest settings within 1 % and 5 %, rendered through one camera
    for every engine, see :mod:`gasp_studies.strips`), ``summary.md``, ``runs/`` (records and logs).

    Parameters
    ----------
    scene_path : str or Path
    output : str or Path
        Must not exist unless ``overwrite``.
    engines : list of str, optional
        Default: every installed, available engine whose capabilities fit the scene; those
        without a sweep (or with an empty one in this mode) are listed as not benched.
    overwrite : bool
    n_frames : int, optional
        Default ``min(scene.n_frames, DEFAULT_FRAMES)``; at least 2.
    quick : bool
        Ask each engine for its quick sweep.
    max_gaussians : int or None
        Keep every k-th Gaussian so that each object has at most this many (None: all).
    settings : dict, optional
        ``{engine: [reference, setting, ...]}`` replacing that engine's own sweep.
    reference_n_grid : int, optional
        A finer ``n_grid`` for the reference run alone (where it has one; :func:`check_reference_grid`).
    options : dict, optional
        ``{engine: {option: value}}`` fixed for every run of that engine (e.g. ``threads``).
    timeout_s : float
        Per-run wall-clock limit, seconds.
    progress : bool
        One line per run on stderr.
    scheduler : str, optional
        Address of an existing Dask scheduler (default: a local cluster).
    workers : int
        Local worker processes (1 keeps timings comparable).
    n_strip_frames : int
        Frames per rendered strip, evenly spaced from frame 0 to the last (0: no strips). Every run
        keeps these frames (world-frame splats, in memory; not timed), the few shown are rendered at
        the end. Without the ``render`` extra the summary says the strips were skipped and why.

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
        No engine can run the scene, or none offers a sweep.
    """
    output, scene, n_frames = open_study(output, overwrite, scene_path, n_frames, 2, DEFAULT_FRAMES)
    check_reference_grid(reference_n_grid)
    keep = strip_frames(n_frames, n_strip_frames)
    plan, skipped = plan_engines(scene, scene_path, engines, quick, settings, reference_n_grid)
    option_keys = sorted({k for sw in plan.values() for s in sw for k in s if k not in SCENE_KEYS})
    columns = report.bench_columns(option_keys)
    work = Path(tempfile.mkdtemp(prefix="gasp-bench-"))
    try:
        with output_folder(output, overwrite=overwrite, protected=[scene_path]) as tmp:
            rows, summary, rank_md = bench_into(tmp, scene, scene_path, plan, skipped, columns, options, n_frames,
                                                keep, subsample_scene(scene, max_gaussians, work),
                                                (scheduler, workers, timeout_s), progress)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if progress:
        print(f"gasp bench: wrote {output}/summary.md", file=sys.stderr)
        print("\n".join(["", "Ranking (docs/speed_accuracy.md, 'Choosing the default'):", ""] + rank_md))
    return BenchResult(output, rows, skipped, summary, columns)


def bench_into(tmp: Path, scene: Scene, scene_path, plan: dict, skipped: dict, columns: list[str], options,
               n_frames: int, keep: tuple[int, ...], cut: tuple[Scene, list[int]], runner_args: tuple,
               progress: bool) -> tuple[list[dict], dict, list[str]]:
    """Run the sweeps and write the report into ``tmp``; the rows, the summary and the ranking's lines.

    ``cut``: the scene with every k-th Gaussian and the strides k (:func:`subsample_scene`); ``runner_args``:
    (scheduler, workers, timeout_s)."""
    t_all = time.perf_counter()
    (tmp / "runs").mkdir()
    scene_run, strides = cut
    specs, where = bench_specs(scene, scene_run, plan, options, n_frames)
    outputs, how = run_specs(specs, where, tmp / "runs", *runner_args, progress, t_all)
    rows, row_k, rank_md = bench_rows(plan, where, outputs, n_frames, scene, keep, tmp, progress, columns)
    strips_md = bench_strips(tmp, scene, keep, rows, row_k, outputs, progress) if keep else []
    outputs.clear()
    report.write_csv(tmp / "bench.csv", rows, columns)
    names = list(plan)
    plots = report.bench_plots(tmp, rows, names)
    summary = report.bench_summary(tmp / "summary.md", scene_name=scene.name, scene_path=scene_path,
                                   n_frames=n_frames, frame_dt=scene.frame_dt, rows=rows, engines=names,
                                   skipped=skipped, strides=strides, total_s=time.perf_counter() - t_all,
                                   runner_line=how, plots=plots, strips_md=strips_md, ranking_md=rank_md)
    return rows, summary, rank_md


def check_reference_grid(reference_n_grid) -> None:
    """Raise :class:`SceneError` unless ``reference_n_grid`` is None or an integer in ``[domain] n_grid``'s range
    (round 100: ``--reference-n-grid -3`` ran the whole sweep and its reference failed on the grid it was given)."""
    if reference_n_grid is not None and (isinstance(reference_n_grid, bool) or not isinstance(reference_n_grid, int)
                                         or not N_GRID_RANGE[0] <= reference_n_grid <= N_GRID_RANGE[1]):
        raise SceneError(f"reference_n_grid (--reference-n-grid): expected an integer in [{N_GRID_RANGE[0]}, "
                         f"{N_GRID_RANGE[1]}] as [domain] n_grid, got {reference_n_grid!r}")


def plan_engines(scene: Scene, scene_path, engines: list[str] | None, quick: bool, settings, reference_n_grid):
    """The engines to bench and their sweeps (:func:`plan_sweeps`), and why others are not benched.

    Raises
    ------
    EngineError
        No engine can be benched (the message gives each one's reason).
    """
    from gasp_core.seam.plugins import engines as all_engines
    found = all_engines()
    requested = None if engines is None else list(dict.fromkeys(e.strip() for e in engines if e.strip()))
    check_engine_names(requested)
    runnable, skipped = select_engines(scene, requested)
    plan, no_sweep = plan_sweeps(found, runnable, quick, settings, reference_n_grid)
    skipped.update(no_sweep)
    if not plan:
        raise EngineError(f"no engine can be benched on {scene_path}: "
                          + "; ".join(f"{k}: {v}" for k, v in skipped.items()))
    return plan, skipped


def bench_specs(scene: Scene, scene_run: Scene, plan: dict, options, n_frames: int):
    """One :class:`RunSpec` per engine and setting (every frame's splats kept for the accuracy report), and
    ``(engine, index, setting)`` of each."""
    specs, where = [], []
    for name, sweep in plan.items():
        base = engine_options(scene, name, options)
        for i, s in enumerate(sweep):
            sc, opts = apply_setting(scene_run, s, base)
            specs.append(RunSpec(sc, name, opts, n_frames, f"{name}_{i:02d}", tuple(range(n_frames + 1))))
            where.append((name, i, s))
    return specs, where


def run_specs(specs, where, runs: Path, scheduler, workers, timeout_s, progress, t_all):
    """Run every spec (fresh worker process each), saving records under ``runs``; the outputs and the
    runner's one-line description."""
    outputs: list[RunOutput | None] = [None] * len(specs)
    n_done = [0]

    def done(k: int, out: RunOutput) -> None:
        outputs[k] = out
        save_run(out, runs, specs[k].label, keep_means=False)
        n_done[0] += 1
        if progress:
            name, _, s = where[k]
            print(f"[{n_done[0]}/{len(specs)}, {time.perf_counter() - t_all:.0f} s] "
                  + progress_line("bench", f"{name} {setting_label(s)}", out.record), file=sys.stderr, flush=True)

    with Runner(scheduler=scheduler, workers=workers, timeout_s=timeout_s) as runner:
        runner.run(specs, done)
        how = report.runner_line(runner)
    return outputs, how


def row_of(name: str, i: int, s: dict, out: RunOutput, ref: RunOutput | None, columns_of: dict, n_frames: int) -> dict:
    """The bench row of one run: setting, status, sizes, timings, errors against the reference run."""
    rec = out.record
    frame_s = rec.get("frame_s") or []
    ok = rec["status"] == "ok"
    sp = steady_s_per_frame(frame_s) if ok else float("nan")
    msg = "" if ok else rec.get("message", "")
    if i == 0 and ref is None:
        msg = "reference run failed, no errors can be measured: " + msg
    st = rec.get("engine_stats") or {}
    return {"engine": name, "setting": setting_label(s), **columns_of, "is_reference": i == 0,
            "status": rec["status"] if rec["status"] != "diverged" else f"diverged@{rec.get('frame')}",
            "simulated_points": rec.get("simulated_points"), "substeps_per_frame": st.get("n_substeps"),
            "prepare_s": rec.get("prepare_s"), "build_s": rec.get("build_s"),
            "first_frame_s": frame_s[0] if frame_s else None, "s_per_frame": sp,
            "cpu_s_per_frame": steady_s_per_frame(rec.get("frame_cpu_s") or []) if ok else float("nan"),
            "wall_s": sp * n_frames,
            "end_to_end_s": rec.get("end_to_end_s", float("nan")) if ok else float("nan"),
            **run_errors(ref, out), **energy_figures(ref, out), "message": msg}


def bench_rows(plan, where, outputs, n_frames, scene, keep, outdir, progress, columns):
    """Rows of every engine (errors, converged reference, Pareto front, the accuracy report's figures) and the
    ranking's Markdown lines (:mod:`gasp_studies.bench_rank`)."""
    rows: list[dict] = []
    row_k: list[int] = []  # the output behind each row
    rank_md: list[str] = []
    for name in plan:
        ks = [k for k, w in enumerate(where) if w[0] == name]
        ref = outputs[ks[0]] if outputs[ks[0]].record["status"] == "ok" else None
        eng_rows = [row_of(name, where[k][1], where[k][2], outputs[k], ref,
                           {c: where[k][2].get(c) for c in columns if c in where[k][2]}, n_frames) for k in ks]
        conv_errors(eng_rows, [(where[k][2], outputs[k]) for k in ks])
        front = pareto_front([r["end_to_end_s"] for r in eng_rows], [r["err_max"] for r in eng_rows])
        for r, p in zip(eng_rows, front):
            r["pareto"] = bool(p)
        rank_md += rank_rows(name, eng_rows, [outputs[k] for k in ks], [where[k][2] for k in ks], scene, keep,
                             outdir, progress)
        rows += eng_rows
        row_k += ks
    return rows, row_k, rank_md


def rank_rows(name, eng_rows, outs, settings, scene, keep, outdir, progress) -> list[str]:
    """The accuracy report's figures on one engine's rows and its ranking lines (a failure is reported, not raised)."""
    try:
        tracks = [output_track(o, scene.frame_dt, ground_height(scene), r["setting"]) for o, r in zip(outs, eng_rows)]
        rank = rank_engine(eng_rows, tracks, settings, keep)
        plot = plot_u(outdir, name, eng_rows)
    except (RuntimeError, ImportError, ValueError) as e:
        if progress:
            print(f"gasp bench: {name}: no accuracy report ({e})", file=sys.stderr)
        return [f"**{name}**: no accuracy report ({e})", ""]
    return ranking_lines(name, eng_rows, rank) + ([f"![{name}: time against shape in U]({plot})", ""] if plot else [])
