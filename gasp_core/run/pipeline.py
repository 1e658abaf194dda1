"""The GASP pipeline: load -> world frame -> flatten -> T -> engine -> T^-1 (+ alpha rule) -> frames.

``G_t = T^-1(phi(T(G), t))`` (GASP paper Sec. 3, Eq. for ``G_t``). The steps live in their own
modules: placement and ``T`` (:mod:`~gasp_core.prepare.placement`), point assembly
(:mod:`~gasp_core.prepare.assembly`), the engine seam (:mod:`~gasp_core.seam.engine`, :mod:`~gasp_core.seam.runner`),
``T^-1`` per frame (:mod:`~gasp_core.run.frames`), the run record (:mod:`~gasp_core.run.record`) and the
output folder (:mod:`~gasp_core.fsutil`). This module strings them together. Frames are written
back in the input file's own frame and order, so frame 0 sits where the input was; opacity, SH
and extra properties are carried bit for bit.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from gasp_core.run import resume as resume_mod
from gasp_core.run import budget, hold, pieces, stop
from gasp_core.run.background import Background, gil_handover
from gasp_core.errors import EngineDivergence, GaspError
from gasp_core.run.frames import Rebuilder, iter_positions
from gasp_core.fsutil import OutputClaim, OutputConflict, atomic_json, leftover_partials
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs import registry
from gasp_core.run.layout import FrameWriter, check_format, default_layout
from gasp_core.prepare.dynamic import follows_model
from gasp_core.prepare.scene import PreparedScene, input_files, prepare_scene
from gasp_core.run.record import run_summary, running_record
from gasp_core.run.report import ConsoleReporter, Reporter
from gasp_core.run.request import SimulateRequest
from gasp_core.seam.runner import RunStats
from gasp_core.scene.spec import Scene


@dataclass
class RunResult:
    """What :func:`simulate_scene` did."""

    outdir: Path
    n_frames: int
    stats: RunStats
    summary: dict = field(default_factory=dict)

    @property
    def run_json(self) -> Path:
        """The run record, ``outdir/run.json``."""
        return self.outdir / "run.json"


def simulate_scene(scene: Scene, outdir: str | Path, request: SimulateRequest | None = None, *,
                   reporter: Reporter | None = None,
                   on_frame: Callable[[int, list[Gaussians]], None] | None = None, **options) -> RunResult:
    """Run a scene and write its frames, by default one graphdeco PLY per object per frame.

    Layout: ``OUTDIR/<object>/frame_0000.ply`` (frame 0 = the input state) to
    ``frame_<n_frames>.ply``, that is ``n_frames + 1`` files per object, ``OUTDIR/frames.json``
    (the manifest, :mod:`gasp_core.run.layout`) and ``OUTDIR/run.json`` (engine, versions,
    parameters, per-frame timings, flatten reports, alpha-rule and degenerate counts). While the run is in
    progress its partial folder holds a preliminary ``run.json`` (``status: "running"``,
    :func:`gasp_core.run.record.running_record`) and a ``frames.json`` of the frames written so far, which
    :mod:`gasp_core.render.live` reads.

    Parameters
    ----------
    scene : Scene
    outdir : str or Path
        Output folder. It is claimed before any work (see :class:`gasp_core.fsutil.OutputClaim`).
    request : SimulateRequest, optional
        The run's options (overwrite, resume, discard, yes, n_frames, engine, fmt, layout, quiet:
        :class:`gasp_core.run.request.SimulateRequest`); default: all defaults.
    reporter : Reporter, optional
        Receives the progress (a ``frame`` event per frame) and the warnings (killed runs' leftovers, the work
        estimate, passive points left behind): :mod:`gasp_core.run.report`. Default: a
        :class:`~gasp_core.run.report.ConsoleReporter` (a tqdm bar unless ``quiet``, warnings on stderr).
    on_frame : callable, optional
        ``on_frame(frame, gaussians_per_object)`` after each frame is handed to the writer (its files are
        written in the background while the next frame runs, :mod:`gasp_core.run.background`).
    **options
        :class:`SimulateRequest` fields, replacing those of ``request`` (``simulate_scene(s, out, n_frames=2)``).

    Returns
    -------
    RunResult

    Raises
    ------
    TypeError
        An ``options`` key that is not a :class:`SimulateRequest` field.
    FileExistsError
        ``outdir`` exists and ``overwrite`` is false, or another run holds it (before any work).
    GaspError
        ``outdir`` unsafe to replace (it holds an input, the scene or the working directory) or
        not a gasp output; the claim lost during the run; ``resume`` with ``discard``.
    SceneError, EngineError
        Bad input or an engine that cannot run the scene, before any simulation.
    EngineDivergence
        The engine blew up (the frame, the likely cause); the frames before it are kept (:func:`_keep_diverged`).
    EngineBug
        The engine raised an exception outside the error contract.
    Stopped
        SIGTERM, SIGINT, SIGHUP (:mod:`gasp_core.run.stop`): the finished frames kept for ``--resume``.
    """
    req = replace(request or SimulateRequest(), **options)
    reporter = reporter if reporter is not None else ConsoleReporter(progress=not req.quiet)
    outdir = Path(outdir)
    n_frames = scene.n_frames if req.n_frames is None else req.n_frames
    _refuse_early(req, outdir)
    claim = OutputClaim(outdir, req.overwrite, input_files(scene), resume=req.resume, discard=req.discard)
    run = _Run(fmt=req.fmt, layout=req.layout or default_layout(req.fmt), yes=req.yes, reporter=reporter, hold=req.hold)
    try:
        run.prep = prepare_scene(scene, req.engine)
        run.fingerprint = resume_mod.fingerprint(scene, run.prep.info.name, run.prep.setup.options, n_frames,
                                                 output=(run.fmt, run.layout))
        _open_partial(run, claim, outdir, req.resume, n_frames)
        run_s = _write_frames(run, n_frames, on_frame)
        summary = run_summary(run.prep, run.stats, n_frames, run.per_frame, run_s)
        _write_record(run, scene, summary)
        claim.commit(run.tmp)
        _warn_stranded(run)
    except KeyboardInterrupt as e:
        reporter.end_progress()
        stop.keep_or_abandon(claim, run.tmp, e, lambda: _stopped_record(run, n_frames), run.saved_frame, n_frames)
    except BaseException as e:
        reporter.end_progress()
        _give_up(run, claim, n_frames, e)
        raise
    return RunResult(outdir=outdir, n_frames=n_frames, stats=run.stats, summary=summary)


def _write_record(run: "_Run", scene, summary: dict) -> None:
    """``run.json``, then for a whole-run format (``--format usd``) its one file, ``<scene name>.usdc``, from the
    frames just written (:mod:`gasp_core.run.export`). ``summary`` gains where a resumed run resumed and how long a
    held run waited (``--hold``)."""
    if run.checkpoint is not None:
        summary["resumed_after_frame"] = run.checkpoint.frame
    summary.update({"held_s": run.held_s} if run.hold is not None else {})
    atomic_json(run.tmp / "run.json", summary)
    if registry.get(run.fmt).sequence:
        from gasp_core.run.export import export_run
        name = getattr(scene, "name", None) or "run"
        export_run(run.tmp, run.fmt, run.tmp / f"{name}{registry.get(run.fmt).suffix}", into_run=True)


@dataclass
class _Run:
    """What the steps of one :func:`simulate_scene` share."""

    prep: PreparedScene | None = None
    #: The partial output folder (``.<outdir>.partial-*``), once claimed or found; removed on failure.
    tmp: Path | None = None
    #: The checkpoint a resumed run continues from; None for a fresh run.
    checkpoint: resume_mod.Checkpoint | None = None
    fingerprint: str = ""
    stats: RunStats = field(default_factory=RunStats)
    #: One row of timings per frame written (``run.json`` ``per_frame``).
    per_frame: list[dict] = field(default_factory=list)
    #: Output format and layout (:mod:`gasp_core.run.layout`).
    fmt: str = "ply"
    layout: str = "frames"
    #: The last frame whose checkpoint is saved (what a stopped run keeps); None before the first.
    saved_frame: int | None = None
    #: Run beyond the work bound (``--yes``).
    yes: bool = False
    reporter: Reporter = field(default_factory=Reporter)
    #: ``{file: [size, crc32]}`` of every finished frame's files, kept in the checkpoint (``--resume`` checks them).
    files: dict = field(default_factory=dict)
    #: The hold file (``--hold``): the run waits after its first frame while it exists; seconds it waited.
    hold: str | None = None
    held_s: float = 0.0
    #: Files written since the last checkpoint (frame 0's are written before the engine can save its state).
    unrecorded: list = field(default_factory=list)


def _open_partial(run: _Run, claim: OutputClaim, outdir: Path, resume: bool, n_frames: int) -> None:
    """Take over a killed run's partial folder (``resume``) or claim a fresh one, and write into it the
    preliminary ``run.json`` a reader of the run in progress needs (:func:`running_record`)."""
    if resume:
        _continue_partial(run, outdir)
    else:
        _start_partial(run, claim, outdir)
    atomic_json(run.tmp / "run.json", running_record(run.prep, run.stats, n_frames, list(run.per_frame),
                                                     run.fmt, run.layout))


def _continue_partial(run: _Run, outdir: Path) -> None:
    """Find the killed run's partial folder and checkpoint of the same fingerprint, and take it over."""
    if "state" not in run.prep.info.capabilities.features:
        raise GaspError(f"engine '{run.prep.info.name}' cannot save its state (feature 'state'), so a "
                        f"killed run cannot be resumed; run again without --resume")
    tmp, checkpoint = resume_mod.find_resumable(outdir, run.fingerprint)
    resume_mod.check_files(tmp, checkpoint)       # before it is ours: a refused resume leaves it as it was
    run.tmp, run.checkpoint = tmp, checkpoint
    (run.tmp / ".gasp-pid").write_text(str(os.getpid()))
    run.files = dict(run.checkpoint.meta.get("files", {}))
    run.per_frame = list(run.checkpoint.meta["per_frame"])
    run.saved_frame = run.checkpoint.frame
    run.stats.frame_s = list(run.checkpoint.meta.get("frame_s", []))


def _start_partial(run: _Run, claim: OutputClaim, outdir: Path) -> None:
    """Claim a fresh partial folder with one subfolder per object (warning of killed runs' leftovers)."""
    for p in leftover_partials(outdir):
        run.reporter.warning(f"a killed run left partial output in '{p}' (continue it with --resume, "
                             f"or remove it when no longer needed)")
    run.tmp = claim.partial_dir()
    for name in run.prep.names:
        (run.tmp / name).mkdir()


def _write_frames(run: _Run, n_frames: int, on_frame: Callable[[int, list[Gaussians]], None] | None) -> float:
    """Run the engine and write every frame (and a checkpoint after each, for engines with ``state``).

    Returns the wall time of the frames, seconds.
    """
    prep, tmp, checkpoint = run.prep, run.tmp, run.checkpoint
    run.reporter.start(prep.info.name, n_frames, 0 if checkpoint is None else checkpoint.frame)
    t_run = time.perf_counter()
    moves = [follows_model(o) for o in prep.objects]   # a dynamic model's background moves: every row, every frame
    writer = FrameWriter(tmp, list(prep.names), [o.spec.static and not m for o, m in zip(prep.objects, moves)],
                         [None if m else o.moving for o, m in zip(prep.objects, moves)], run.fmt, run.layout,
                         overwrite=checkpoint is not None, up_axes=[o.spec.up_axis for o in prep.objects])
    stop.frame_started(None)
    t_frame, c_frame = time.perf_counter(), time.process_time()
    rebuild_all = Rebuilder(prep, None if checkpoint is None else checkpoint.prev_rot)
    tracker = pieces.tracker_for(prep.setup)   # None without a brittle body
    # a frame's rebuild (T^-1) and files are made on the writer while the engine runs the next frame
    with Background() as writes, gil_handover():
        for frame, x, sim_s, get_state in iter_positions(
                prep, n_frames, run.stats, resume=checkpoint,
                before_frames=lambda stats: _before_frames(run, stats, n_frames)):
            stop.frame_started(sim_s)   # its rebuild, writes and checkpoint take about as long as it did
            state = get_state() if get_state is not None and frame < n_frames else None
            made: list = []
            wall_s, cpu_s = time.perf_counter() - t_frame, time.process_time() - c_frame
            times = {"sim_s": sim_s, "wall_s": wall_s, "cpu_s": cpu_s} if sim_s is not None else {}
            if tracker is not None:
                times.update(pieces.frame_row(tracker, run.reporter, frame, x, run.stats.damage if frame else None))
            writes.submit(_save_frame, run, writer, rebuild_all, frame, np.array(x), times, state,
                          list(run.stats.frame_s), made)
            run.reporter.frame(frame, wall_s, sim_s, run.stats.engine.get("n_substeps"))
            if on_frame is not None:
                writes.flush()
                on_frame(frame, made[0])
            _after_frame(run, writes, frame, n_frames, wall_s)
            t_frame, c_frame = time.perf_counter(), time.process_time()
    run.reporter.end_progress()
    writer.finish(n_frames, [o.gaussians.n for o in prep.objects])
    (tmp / resume_mod.CHECKPOINT).unlink(missing_ok=True)
    return time.perf_counter() - t_run


def _before_frames(run: _Run, engine_stats: dict, n_frames: int) -> None:
    """Once the engine is built: the work the frames ask for, refused or said before it is spent (:mod:`budget`)."""
    done = 0 if run.checkpoint is None else run.checkpoint.frame
    note = budget.check_before(engine_stats, len(run.prep.setup.x), n_frames, n_frames - done, run.yes)
    if note:
        run.reporter.warning(note)


def _after_frame(run: _Run, writes: Background, frame: int, n_frames: int, frame_wall_s: float) -> None:
    """At a frame boundary: the work estimate after the second simulated frame, then a stop asked for by a signal.

    Raises
    ------
    GaspError
        The run would take longer than :data:`gasp_core.run.budget.MAX_S` (without ``yes``).
    Stopped
        A signal asked the run to stop (:mod:`gasp_core.run.stop`); the frame's checkpoint is saved.
    """
    if frame == 0:
        return
    first = 1 if run.checkpoint is None else run.checkpoint.frame + 1
    if run.hold is not None and frame == first and frame < n_frames:
        writes.flush()   # frame 1's files and checkpoint on disk: what a front end shows the moment it releases
        run.held_s = hold.wait(Path(run.hold))
    if frame == (2 if run.checkpoint is None else run.checkpoint.frame + 2):   # frame 1 includes JIT warm-up
        note = budget.check(run.stats.engine, len(run.prep.setup.x), n_frames, n_frames - frame, frame_wall_s, run.yes)
        if note:
            run.reporter.warning(note)
    # a reader that went away (gasp simulate --json | head -n 1) stops the run as SIGPIPE stops a Unix tool, but
    # at a frame boundary, its frames kept for --resume (gasp_core.cli.streams)
    gone = "SIGPIPE" if isinstance(getattr(run.reporter, "stdout_error", None), BrokenPipeError) else None
    if frame < n_frames and (stop.requested() or gone):
        writes.flush()   # the frame's files and checkpoint are on disk before the stop is reported
        raise stop.Stopped(stop.requested() or gone)
    stop.frame_started(frame_wall_s)


def _stopped_record(run: _Run, n_frames: int) -> dict:
    """The ``run.json`` of a stopped run: the record of the frames its checkpoint covers."""
    rows = [r for r in run.per_frame if run.saved_frame is not None and r["frame"] <= run.saved_frame]
    return run_summary(run.prep, run.stats, n_frames, rows, sum(run.stats.frame_s))


def _refuse_early(req: SimulateRequest, outdir: Path) -> None:
    """What is refused before the output is claimed or an engine built: an output format whose writer is missing
    (issue 41: it came after, naming a hidden folder), ``--resume`` of a run that diverged (it would blow up again).

    Raises
    ------
    GaspError
        See :func:`gasp_core.run.layout.check_format` and :func:`gasp_core.run.resume.refuse_diverged`.
    """
    check_format(req.fmt)
    if req.resume:
        resume_mod.refuse_diverged(outdir)


def _give_up(run: _Run, claim: OutputClaim, n_frames: int, error: BaseException) -> None:
    """A run that failed (``error``): a divergence keeps the frames before it (:func:`_keep_diverged`), anything
    else gives the partial folder up (:meth:`OutputClaim.abandon`)."""
    if isinstance(error, EngineDivergence):
        _keep_diverged(run, claim, n_frames, error)
    else:
        claim.abandon(run.tmp, error)


def _keep_diverged(run: _Run, claim: OutputClaim, n_frames: int, error: EngineDivergence) -> None:
    """After a blow-up: finalise the partial folder as the output folder with the frames written before it.

    The frames are those whose files are complete (a ``per_frame`` row is added once a frame's files are
    written, in order; ``frames.json`` lists the same); the checkpoint is removed (a blow-up is not resumed:
    it would come again) and ``run.json`` is the record of those frames with ``status: "diverged"`` and
    ``diverged`` (``frame``, ``cause``, ``message``). The folder is committed as a finished run's is
    (:meth:`OutputClaim.commit`: an existing output is replaced only under ``--overwrite``). Sets
    ``error.kept`` and ``error.last_kept``. With no simulated frame written (frame 0, the input, alone), or when
    the folder cannot be finalised, the partial run is given up as before (:meth:`OutputClaim.abandon`).
    """
    from gasp_core.run.resume import CHECKPOINT
    last = max((r["frame"] for r in run.per_frame), default=0)
    if run.tmp is None or last < 1:
        claim.abandon(run.tmp, error)
        return
    rows = sorted(run.per_frame, key=lambda r: r["frame"])
    record = {**run_summary(run.prep, run.stats, n_frames, rows, sum(run.stats.frame_s)), "status": "diverged",
              "diverged": {"frame": error.frame, "cause": error.cause, "message": str(error)}}
    if run.checkpoint is not None:
        record["resumed_after_frame"] = run.checkpoint.frame
    try:
        (run.tmp / CHECKPOINT).unlink(missing_ok=True)
        atomic_json(run.tmp / "run.json", record)
        claim.commit(run.tmp)
    except OutputConflict:            # the output folder was changed meanwhile: the frames stay in the partial folder
        claim.release()
        error.kept, error.last_kept = run.tmp, last
        return
    except Exception as e:            # cannot be finalised (a full disk): given up, the divergence is what is said
        claim.abandon(run.tmp, e)
        return
    error.kept, error.last_kept = claim.outdir, last


def _save_frame(run: _Run, writer: FrameWriter, rebuild_all: Rebuilder, frame: int, x: np.ndarray,
                times: dict, engine_state: dict | None, frame_s: list, made: list) -> None:
    """Rebuild one frame's Gaussians from the positions ``x`` and write its files, then (``engine_state`` not None)
    its checkpoint (on :class:`Background`'s worker); the Gaussians are appended to ``made``. ``times`` (empty for
    frame 0) go into the frame's row: ``sim_s`` (the engine), ``wall_s`` and ``cpu_s`` (the process's CPU time,
    every thread, from the previous frame's hand-off to the writer to this frame's: ``cpu_s / wall_s`` is the
    cores the frame used, the previous frame's rebuild and files on the writer included)."""
    t0 = time.perf_counter()
    gs, row = rebuild_all(frame, x)
    row.update(times)
    row["rebuild_s"] = time.perf_counter() - t0
    made.append(gs)
    t0 = time.perf_counter()
    run.unrecorded += writer.write(frame, gs)
    row["write_s"] = time.perf_counter() - t0
    run.per_frame.append(row)
    if engine_state is not None:
        t0 = time.perf_counter()
        run.files.update(resume_mod.file_record(run.tmp, run.unrecorded, run.files))
        run.unrecorded = []
        resume_mod.save(run.tmp, resume_mod.Checkpoint(
            frame, engine_state, list(rebuild_all.prev_rot), {"fingerprint": run.fingerprint, "per_frame": run.per_frame,
                                            "frame_s": frame_s, "files": run.files}))
        row["checkpoint_s"] = time.perf_counter() - t0
        run.saved_frame = frame


def _warn_stranded(run: _Run) -> None:
    """Pass on the engine's ``passive_stranded`` count (surface points the material left behind) as a warning."""
    stranded = (run.stats.engine or {}).get("passive_stranded")
    if stranded:
        run.reporter.warning(f"{stranded} of {int(run.prep.setup.n_passive)} passive surface points had no material within "
             "their interpolation stencil at the last frame: they stayed where the material left them "
             "(pieces of surface left hanging, typical of sand or liquid flowing away); surface = "
             "\"material\" simulates the surface points as material")
