"""``gasp compare``: one scene on several engines, each run in a fresh Dask worker process, with a
divergence report against the first engine that ran (the reference).

Measures (:mod:`gasp_studies.measure`): mean and max distance between corresponding Gaussian
means, and the symmetric Chamfer distance between the two clouds, per frame, in metres and
relative to the object size. The report folder is built in a temporary folder next to
``output`` and moved into place only when complete; an existing folder is refused unless
``overwrite``.
"""
from __future__ import annotations

import dataclasses
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from gasp_core.fsutil import output_folder
from gasp_core.errors import EngineError, GaspError, SceneError
from gasp_core.scene.spec import Scene, load_scene

from . import report
from .measure import divergence_rows, steady_s_per_frame
from .run import RUN_TIMEOUT_S, RunOutput, Runner, RunSpec
from .strips import DEFAULT_STRIP_FRAMES, StripRow, render_strips, strip_frames, strips_markdown


def subsample_scene(scene: Scene, max_gaussians: int | None, workdir: Path) -> tuple[Scene, list[int]]:
    """Scene whose objects keep every k-th Gaussian so that each has at most ``max_gaussians``.

    The subsets are written as graphdeco PLYs into ``workdir``; objects already small enough are
    left as they are.

    Returns
    -------
    scene : Scene
        A copy (the input is not changed).
    strides : list of int
        ``k`` per object (1 = all Gaussians).

    Raises
    ------
    SceneError
        If ``max_gaussians`` is not a positive integer, or an object file cannot be read.
    """
    from gasp_core.gs.io import read_gaussians, write_gaussians
    if max_gaussians is None:
        return scene, [1] * len(scene.objects)
    if isinstance(max_gaussians, bool) or not isinstance(max_gaussians, int) or max_gaussians < 1:
        raise SceneError(f"max_gaussians: expected a positive integer, got {max_gaussians!r}")
    objects, strides = [], []
    for i, spec in enumerate(scene.objects):
        g = read_gaussians(spec.file)
        k = max(1, math.ceil(g.n / max_gaussians))
        strides.append(k)
        if k == 1:
            objects.append(spec)
            continue
        path = Path(workdir) / f"{i}_{Path(spec.file).stem}_every{k}.ply"
        write_gaussians(path, g.subset(np.arange(0, g.n, k)), overwrite=True)
        objects.append(dataclasses.replace(spec, file=path))
    return dataclasses.replace(scene, objects=objects), strides


def ground_height(scene: Scene) -> float | None:
    """Height of the scene's lowest ground boundary, metres (None without one)."""
    grounds = [b.height for b in scene.boundaries if b.kind == "ground"]
    return min(grounds) if grounds else None


def engine_options(scene: Scene, engine: str, options: Mapping[str, Mapping] | None = None) -> dict:
    """Options for ``engine``: the scene's ``[engine] options`` if it names this engine, else none;
    then ``options[engine]`` on top."""
    out = dict(scene.engine.options) if scene.engine.name == engine else {}
    if options and engine in options:
        out.update(options[engine])
    return out


def check_engine_names(requested: Iterable[str] | None) -> None:
    """Refuse (:class:`SceneError`) a requested engine name that is not installed: a typo must not run the
    others and bury the name under "Not run" in the report."""
    from gasp_core.seam.plugins import engines as all_engines
    if requested is None:
        return
    found = all_engines()
    unknown = [n for n in dict.fromkeys(requested) if n not in found]
    if unknown:
        raise SceneError(f"--engines: {', '.join(repr(n) for n in unknown)} "
                         f"{'is not an installed engine' if len(unknown) == 1 else 'are not installed engines'} "
                         f"(installed: {', '.join(sorted(found)) or 'none'}; see 'gasp engines')")


def select_engines(scene: Scene, requested: Iterable[str] | None) -> tuple[list[str], dict[str, str]]:
    """Engines that can run ``scene``, and the reason for each that cannot.

    Parameters
    ----------
    scene : Scene
    requested : iterable of str or None
        Engine names in order (duplicates allowed: a repeated run of the same engine); None for
        every installed engine.

    Returns
    -------
    runnable : list of str
    skipped : dict
        ``{engine: reason}``: not installed, not available here, or a material or boundary it
        lacks (:func:`gasp_core.seam.build.check_supported` of
        :func:`gasp_core.prepare.scene.scene_needs`).
    """
    from gasp_core.prepare.scene import scene_needs
    from gasp_core.seam.build import check_supported
    from gasp_core.seam.plugins import engines as all_engines
    found = all_engines()
    names = list(requested) if requested is not None else list(found)
    runnable, skipped = [], {}
    for name in names:
        if name not in found:
            skipped[name] = f"not installed (installed engines: {sorted(found) or 'none'})"
            continue
        info = found[name]
        reason = info.unavailable_reason()
        if reason:
            skipped[name] = f"not available: {reason}"
            continue
        try:
            check_supported(info, **scene_needs(scene), others=found)
        except GaspError as e:
            skipped[name] = str(e)
            continue
        runnable.append(name)
    return runnable, skipped


def save_run(out: RunOutput, folder: Path, stem: str, keep_means: bool = True) -> None:
    """``<stem>.json`` (record), ``<stem>.log`` and, with ``keep_means``, ``<stem>.npz`` (``means``,
    ``m_per_unit``, ``obj_start``: see :class:`gasp_studies.run.RunOutput`) into ``folder``."""
    import json
    (folder / f"{stem}.json").write_text(json.dumps(out.record, indent=2, default=str))
    (folder / f"{stem}.log").write_text(out.log)
    if keep_means and out.means is not None:
        np.savez_compressed(folder / f"{stem}.npz", means=out.means, m_per_unit=out.m_per_unit,
                            obj_start=out.obj_start)


def progress_line(tool: str, label: str, rec: dict) -> str:
    """``gasp compare: LABEL: ok, 0.123 s/frame, peak 300 MB`` (or the failure)."""
    sp = steady_s_per_frame(rec.get("frame_s") or [])
    return (f"gasp {tool}: {label}: {rec['status']}"
            + (f", {sp:.3f} s/frame, peak {rec.get('peak_rss_mb', 0):.0f} MB" if rec.get("frame_s") else "")
            + (f" ({rec.get('message')})" if rec["status"] != "ok" else ""))


@dataclass
class CompareResult:
    """What :func:`compare_scene` did: the table rows, divergence rows, skipped and failed engines,
    and the runs themselves (``outputs``, in the order run)."""

    outdir: Path
    reference: str | None
    table: list[dict]
    divergence: list[dict]
    skipped: dict[str, str] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)
    outputs: list[RunOutput] = field(default_factory=list)
    startup_s: float = 0.0


def open_study(output, overwrite: bool, scene_path, n_frames: int | None, minimum: int, cap: int | None):
    """The output folder (refused if it exists and not ``overwrite``: before any work), the scene, and the frames
    to run (``n_frames``, else the scene's, at most ``cap``).

    Raises
    ------
    FileExistsError, SceneError
        The folder exists; a bad scene, or ``n_frames`` not an integer >= ``minimum``.
    """
    output = Path(output)
    if output.exists() and not overwrite:  # early, before any work; output_folder claims it for good
        raise FileExistsError(f"output folder '{output}' exists; pass --overwrite to replace it")
    scene = load_scene(scene_path)
    if n_frames is not None and (isinstance(n_frames, bool) or not isinstance(n_frames, int) or n_frames < minimum):
        raise SceneError(f"n_frames: expected an integer >= {minimum}"
                         + (" (frame 1 is left out of the timing)" if minimum > 1 else "") + f", got {n_frames!r}")
    if n_frames is None:
        n_frames = scene.n_frames if cap is None else min(scene.n_frames, cap)
    return output, scene, n_frames


def compare_scene(scene_path: str | Path, engines: list[str] | None, output: str | Path, *,
                  overwrite: bool = False, n_frames: int | None = None,
                  options: Mapping[str, Mapping] | None = None, max_gaussians: int | None = None,
                  timeout_s: float = RUN_TIMEOUT_S, keep_runs: bool = True, progress: bool = True,
                  scheduler: str | None = None, workers: int = 1,
                  n_strip_frames: int = DEFAULT_STRIP_FRAMES) -> CompareResult:
    """Run one scene on several engines (a fresh Dask worker process each) and write a report.

    Layout of ``output``: ``table.csv``/``table.md`` (per engine: version, device, simulated
    points, substeps per frame, wall time per frame, peak memory), ``divergence.csv`` (per frame
    and engine against the reference), ``divergence.png``, ``timing.png`` (with matplotlib),
    ``strip_<engine>.png`` (frames rendered through one camera for every engine, see
    :mod:`gasp_studies.strips`), ``report.md``, and ``runs/`` (per run: means ``.npz``, record
    ``.json``, log).

    Parameters
    ----------
    scene_path : str or Path
        Scene TOML.
    engines : list of str or None
        Engine names in order; the first one that runs is the reference. None: every installed
        engine that can run the scene. A name may repeat (a repeated run, labelled ``name#2``).
    output : str or Path
        Report folder; must not exist unless ``overwrite``.
    overwrite : bool
    n_frames : int, optional
        Override the scene's ``n_frames``.
    options : dict, optional
        ``{engine: {option: value}}`` on top of the scene's ``[engine] options`` (which apply only
        to the engine the scene names).
    max_gaussians : int, optional
        Keep every k-th Gaussian so that each object has at most this many (None: all).
    timeout_s : float
        Per-run wall-clock limit, seconds; a run past it is killed and reported as ``timeout``.
    keep_runs : bool
        Keep ``runs/*.npz`` (the means per frame).
    progress : bool
        One line per engine on stderr.
    scheduler : str, optional
        Address of an existing Dask scheduler (default: a local cluster, see :class:`Runner`).
    workers : int
        Local worker processes (runs in parallel; 1 keeps timings comparable).
    n_strip_frames : int
        Frames per rendered strip, evenly spaced from frame 0 to the last (0: no strips). Without
        the ``render`` extra the report says the strips were skipped and why.

    Returns
    -------
    CompareResult

    Raises
    ------
    FileExistsError
        ``output`` exists and ``overwrite`` is false (before any work).
    SceneError
        Bad scene file or argument; an engine name that is not installed.
    EngineError
        No engine could run the scene at all (the reasons are in the message).
    """
    output, scene, n_frames = open_study(output, overwrite, scene_path, n_frames, 1, None)
    check_engine_names(engines)
    keep = strip_frames(n_frames, n_strip_frames)
    runnable, skipped = select_engines(scene, engines)
    if not runnable:
        raise EngineError(f"no engine can run {scene_path}: " + "; ".join(f"{k}: {v}" for k, v in skipped.items()))
    with output_folder(output, overwrite=overwrite, protected=[scene_path]) as tmp:
        runs = tmp / "runs"
        runs.mkdir()
        scene_run, strides = subsample_scene(scene, max_gaussians, runs)
        outputs, how, startup_s = compare_runs(scene, scene_run, runnable, options, n_frames, keep, runs,
                                               (scheduler, workers, timeout_s), keep_runs, progress)
        ref, table, div, failed = compare_outputs(tmp, scene, scene_path, outputs, keep, n_frames, skipped, strides,
                                                  how, progress)
    if progress:
        print(f"gasp compare: wrote {output}/report.md", file=sys.stderr)
    return CompareResult(output, ref.record["label"] if ref else None, table, div, skipped, failed, outputs,
                         startup_s)


def compare_outputs(tmp: Path, scene: Scene, scene_path, outputs: list[RunOutput], keep, n_frames: int, skipped: dict,
                    strides: list[int], how: str, progress: bool):
    """Write ``gasp compare``'s tables, plots, strips and report in ``tmp`` from the runs' ``outputs`` (the first
    run that finished is the reference); return (reference output or None, table rows, divergence rows, failed)."""
    records = [o.record for o in outputs]
    failed = {r["label"]: (f"diverged at frame {r['frame']}: {r.get('message', '')}" if r["status"] == "diverged"
                           else f"{r['status']}: {r.get('message', '')}") for r in records if r["status"] != "ok"}
    ref = next((o for o in outputs if o.record["status"] == "ok"), None)
    table = [report.table_row(r) for r in records]
    div: list[dict] = []
    if ref is not None:
        for o in outputs:
            if o is not ref:
                div += divergence_rows(ref, o, scene.frame_dt)
    report.write_csv(tmp / "table.csv", table, report.TABLE_COLUMNS)
    table_md = report.md_table(table, report.TABLE_COLUMNS, report.TABLE_HEADERS)
    (tmp / "table.md").write_text(table_md)
    report.write_csv(tmp / "divergence.csv", div, report.DIVERGENCE_COLUMNS)
    plots = report.compare_plots(tmp, table, div, ref.record["label"] if ref else None)
    strips_md = []
    if keep:
        strips = render_strips(tmp, {o.record["label"]: [StripRow(o.record["label"], o.keyframes)]
                                     for o in outputs if o.keyframes}, keep, scene.frame_dt, ground_height(scene))
        for o in outputs:
            o.keyframes = {}
        strips_md = strips_markdown(strips, scene.frame_dt)
        if progress:
            print("gasp compare: strips: " + (f"skipped ({strips.skipped})" if strips.skipped else
                  f"{len(strips.files)} rendered in {strips.render_s:.1f} s"), file=sys.stderr, flush=True)
    report.compare_report(tmp / "report.md", scene_name=scene.name, scene_path=scene_path, n_frames=n_frames,
                          frame_dt=scene.frame_dt, table_md=table_md, div=div, records=records,
                          reference=ref.record if ref else None, skipped=skipped, failed=failed,
                          strides=strides, runner_line=how, plots=plots, strips_md=strips_md)
    return ref, table, div, failed


def compare_runs(scene: Scene, scene_run: Scene, runnable: list[str], options, n_frames: int, keep, runs: Path,
                 runner_args: tuple, keep_runs: bool, progress: bool) -> tuple[list[RunOutput], str, float]:
    """One run per engine in ``runnable`` (a fresh worker process each), saved under ``runs``; the outputs, the
    runner's one-line description and its start-up time, s. ``runner_args``: (scheduler, workers, timeout_s)."""
    scheduler, workers, timeout_s = runner_args
    specs, seen = [], {}
    for name in runnable:
        seen[name] = seen.get(name, 0) + 1
        label = name if seen[name] == 1 else f"{name}#{seen[name]}"
        specs.append(RunSpec(scene_run, name, engine_options(scene, name, options), n_frames, label, keep))

    def done(i: int, out: RunOutput) -> None:
        save_run(out, runs, specs[i].label.replace("#", "_"), keep_runs)
        if progress:
            print(progress_line("compare", specs[i].label, out.record), file=sys.stderr, flush=True)

    with Runner(scheduler=scheduler, workers=workers, timeout_s=timeout_s) as runner:
        if progress:   # the plan once the runner stands (a scheduler that cannot be reached is the only line)
            print(f"gasp compare: {len(specs)} run(s) of {n_frames} frames: {', '.join(s.label for s in specs)}",
                  file=sys.stderr, flush=True)
        outputs = runner.run(specs, done)
        how = report.runner_line(runner)
    return outputs, how, runner.startup_s
