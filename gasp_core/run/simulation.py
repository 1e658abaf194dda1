"""One ``gasp simulate`` run as an object (issue 51: the run driver right side out): the scene prepared, the output
folder opened, the engine built (:class:`gasp_core.seam.runner.EngineRun`), then a loop over the frames, each rebuilt
(``T^-1``, :class:`gasp_core.run.frames.Rebuilder`) and written on a background writer, a checkpoint after each
(stiff brittle bodies break in :mod:`gasp_core.run.fragment_run`). :func:`gasp_core.run.pipeline.simulate_scene`."""
from __future__ import annotations

import os
import time
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from gasp_core.run import resume as resume_mod
from gasp_core.run import budget, fragment_run, hold, pieces, stop
from gasp_core.run.background import Background, gil_handover
from gasp_core.run.crack_output import crack_output_for
from gasp_core.errors import EngineDivergence, GaspError
from gasp_core.run.frames import Rebuilder
from gasp_core.run.split_output import write_split
from gasp_core.fsutil import OutputClaim, OutputConflict, atomic_json, leftover_partials
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs import registry
from gasp_core.run.layout import FrameWriter, choose_layout, run_bytes
from gasp_core.prepare.dynamic import follows_model
from gasp_core.prepare.scene import PreparedScene, prepare_scene
from gasp_core.run.record import run_summary, running_record
from gasp_core.run.report import Reporter, left_domain_row, stranded_warning
from gasp_core.run.request import SimulateRequest
from gasp_core.seam.runner import RunStats
from gasp_core.scene.spec import Scene


class SimulationRun:
    """One ``gasp simulate``: the scene prepared, its partial output folder opened (or a killed run's taken over),
    the engine built, then every frame rebuilt (``T^-1``) and written, with a checkpoint after each; the state of
    the run and the steps that share it, in one object.

    Parameters
    ----------
    claim : OutputClaim
        The output folder, claimed before any work.
    n_frames : int
        The last frame.
    fmt : str
        Output format (:mod:`gasp_core.run.layout`).
    layout : str or None
        Output layout; None: :func:`gasp_core.run.layout.choose_layout` once the scene is prepared.
    yes : bool
        Run beyond the work bound (``--yes``).
    reporter : Reporter
    hold : str or None
        The hold file (``--hold``): the run waits after its first frame while it exists.
    """

    def __init__(self, claim: OutputClaim, n_frames: int, fmt: str = "ply", layout: str | None = None,
                 yes: bool = False, reporter: Reporter | None = None, hold: str | None = None):
        self.claim, self.n_frames = claim, n_frames
        self.fmt, self.layout, self.yes, self.hold = fmt, layout, yes, hold
        self.reporter = reporter if reporter is not None else Reporter()
        self.prep: PreparedScene | None = None
        #: The partial output folder (``.<outdir>.partial-*``), once claimed or found; removed on failure.
        self.tmp: Path | None = None
        #: The checkpoint a resumed run continues from; None for a fresh run.
        self.checkpoint: resume_mod.Checkpoint | None = None
        self.fingerprint = ""
        self.stats = RunStats()
        #: One row of timings per frame written (``run.json`` ``per_frame``).
        self.per_frame: list[dict] = []
        self.cracks = None   # gasp_core.run.crack_output.CrackOutput of a scene with a brittle object
        #: The last frame whose checkpoint is saved (what a stopped run keeps); None before the first.
        self.saved_frame: int | None = None
        #: ``{file: [size, crc32]}`` of every finished frame's files, kept in the checkpoint (``--resume`` checks them).
        self.files: dict = {}
        #: Seconds the run waited on its hold file.
        self.held_s = 0.0
        #: The bytes the run writes (:func:`gasp_core.run.layout.run_bytes`), None where it cannot say.
        self.output_bytes: int | None = None
        #: Files written since the last checkpoint (frame 0's are written before the engine can save its state).
        self.unrecorded: list = []

    def run(self, scene: Scene, req: SimulateRequest, on_frame) -> dict:
        """Prepare, simulate and write the run, commit its folder; the run's summary (``run.json``).
        Errors as :func:`simulate_scene`."""
        n_frames, summary = self.n_frames, {}
        try:
            self.prep = prepare_scene(scene, req.engine)
            rows = self.rows()
            if self.layout is None:   # split where what never moves outweighs what does (SPLIT_RATIO)
                self.layout = choose_layout(self.fmt, sum(g.n - m for g, _, m in rows), sum(m for _, _, m in rows))
            self.fingerprint = resume_mod.fingerprint(scene, self.prep.info.name, self.prep.setup.options, n_frames,
                                                      output=(self.fmt, self.layout))
            self.open_partial(req.resume)
            self.output_bytes = run_bytes(rows, n_frames, self.layout, self.fmt)
            run_s = self.write_frames(on_frame)
            summary = run_summary(self.prep, self.stats, n_frames, self.per_frame, run_s)
            self.write_record(scene, summary)
            self.claim.commit(self.tmp)
            self.warn_stranded()
        except KeyboardInterrupt as e:
            self.reporter.end_progress()
            stop.keep_or_abandon(self.claim, self.tmp, e, self.stopped_record, self.saved_frame, n_frames)
        except BaseException as e:
            self.reporter.end_progress()
            self.give_up(e)
            raise
        return summary

    def rows(self) -> list[tuple[Gaussians, int, int]]:
        """Per object: its Gaussians, the rows a ``frames`` layout writes every frame and the rows that move (a
        dynamic model's background moves with it; a static object none; a selection its selected rows)."""
        out = []
        for o in self.prep.objects:
            g = o.gaussians
            moving = g.n if follows_model(o) else 0 if o.spec.static else g.n if o.moving is None else len(o.moving)
            out.append((g, g.n, moving))
        return out

    # ---------------------------------------------------------------- the output folder
    def open_partial(self, resume: bool) -> None:
        """Take over a killed run's partial folder (``resume``) or claim a fresh one, and write into it the
        preliminary ``run.json`` a reader of the run in progress needs (:func:`running_record`)."""
        if resume:
            self.continue_partial()
        else:
            self.start_partial()
        atomic_json(self.tmp / "run.json", running_record(self.prep, self.stats, self.n_frames, list(self.per_frame),
                                                          self.fmt, self.layout))

    def continue_partial(self) -> None:
        """Find the killed run's partial folder and checkpoint of the same fingerprint, and take it over."""
        if "state" not in self.prep.info.capabilities.features:
            raise GaspError(f"engine '{self.prep.info.name}' cannot save its state (feature 'state'), so a "
                            f"killed run cannot be resumed; run again without --resume")
        tmp, checkpoint = resume_mod.find_resumable(self.claim.outdir, self.fingerprint)
        resume_mod.check_files(tmp, checkpoint)       # before it is ours: a refused resume leaves it as it was
        self.tmp, self.checkpoint = tmp, checkpoint
        (self.tmp / ".gasp-pid").write_text(str(os.getpid()))
        self.files = dict(checkpoint.meta.get("files", {}))
        self.per_frame = list(checkpoint.meta["per_frame"])
        self.saved_frame = checkpoint.frame
        self.stats.frame_s = list(checkpoint.meta.get("frame_s", []))

    def start_partial(self) -> None:
        """Claim a fresh partial folder with one subfolder per object (warning of killed runs' leftovers)."""
        for p in leftover_partials(self.claim.outdir):
            self.reporter.warning(f"a killed run left partial output in '{p}' (continue it with --resume, "
                                  f"or remove it when no longer needed)")
        self.tmp = self.claim.partial_dir()
        for name in self.prep.names:
            (self.tmp / name).mkdir()

    def write_record(self, scene, summary: dict) -> None:
        """``run.json``, then for a whole-run format (``--format usd``) its one file, ``<scene name>.usdc``, from the
        frames just written (:mod:`gasp_core.run.export`). ``summary`` gains where a resumed run resumed and how long
        a held run waited (``--hold``)."""
        if self.checkpoint is not None:
            summary["resumed_after_frame"] = self.checkpoint.frame
        summary.update({"held_s": self.held_s} if self.hold is not None else {})
        atomic_json(self.tmp / "run.json", summary)
        if registry.get(self.fmt).sequence:
            from gasp_core.run.export import export_run
            name = getattr(scene, "name", None) or "run"
            export_run(self.tmp, self.fmt, self.tmp / f"{name}{registry.get(self.fmt).suffix}", into_run=True)

    def time_estimate(self, frames: int) -> dict | None:
        """How long the ``frames`` frames left take at :data:`gasp_core.run.budget.CPU_RATE`
        (:func:`~gasp_core.run.budget.start_estimate`), from the engine's step rule as ``gasp place`` reads it;
        None where the engine has none or it refuses the setup (the engine says why when it is built)."""
        import os
        from gasp_core.errors import GaspError
        from gasp_core.run.budget import start_estimate
        from gasp_core.seam.settle import settle_substeps
        info, setup = self.prep.info, self.prep.setup
        try:
            n_sub = None if info.substeps is None else int(info.substeps(setup))
            n_settle = settle_substeps(info, setup) if getattr(self.prep.scene, "settle", False) and frames == self.n_frames else 0
        except (GaspError, ValueError, TypeError, ZeroDivisionError, OverflowError):
            n_sub, n_settle = None, 0
        try:
            load = (os.getloadavg()[0], os.cpu_count())
        except OSError:
            load = None
        return start_estimate(len(setup.x), n_sub, frames, load, settle_substeps=n_settle)

    # ---------------------------------------------------------------- the frames
    def write_frames(self, on_frame: Callable[[int, list[Gaussians]], None] | None) -> float:
        """Frame 0 handed to the writer, the engine built (its work checked, :meth:`before_frames`), then every frame
        simulated and handed over; the wall time of the frames, seconds.

        Each frame's rebuild (``T^-1``) and files are made on the writer (:class:`Background`) while the engine runs
        the next frame; after each, for engines with ``state``, a checkpoint.
        """
        prep, checkpoint = self.prep, self.checkpoint
        first = 0 if checkpoint is None else checkpoint.frame
        self.reporter.start(prep.info.name, self.n_frames, first, output_bytes=self.output_bytes, layout=self.layout,
                            estimate=self.time_estimate(self.n_frames - first))
        t_run = time.perf_counter()
        moves = [follows_model(o) for o in prep.objects]   # a dynamic model's background moves: every row, every frame
        writer = FrameWriter(self.tmp, list(prep.names), [o.spec.static and not m for o, m in zip(prep.objects, moves)],
                             [None if m else o.moving for o, m in zip(prep.objects, moves)], self.fmt, self.layout,
                             overwrite=checkpoint is not None, up_axes=[o.spec.up_axis for o in prep.objects])
        stop.frame_started(None)
        rebuild_all = Rebuilder(prep, None if checkpoint is None else checkpoint.prev_rot)
        tracker = pieces.tracker_for(prep.setup)   # None without a brittle body
        if tracker is not None and checkpoint is not None and checkpoint.pieces:
            tracker.restore(checkpoint.pieces)      # its cut links stay cut
        self.cracks = crack_output_for(prep, tracker)   # crack faces beside a brittle object's frames, or None
        with Background() as writes, gil_handover():
            hand = _Handover(self, writes, writer, rebuild_all, on_frame, tracker)
            if checkpoint is None:
                hand(0, prep.setup.x, None, None)      # its files are written while the engine is built
            with closing(fragment_run.frames(prep.info, prep.setup, self.stats, self.n_frames,
                                             0 if checkpoint is None else checkpoint.frame, None if checkpoint is None
                                             else checkpoint.engine_state, getattr(prep.scene, "sleep", False),
                                             self.before_frames, tracker,
                                             settle=getattr(prep.scene, "settle", False))) as recs:   # stiff brittle bodies break
                for rec in recs:
                    hand(rec.frame, rec.x, rec.wall_s, rec.get_state)
        self.reporter.end_progress()
        writer.finish(self.n_frames, [o.gaussians.n for o in prep.objects])
        (self.tmp / resume_mod.CHECKPOINT).unlink(missing_ok=True)
        return time.perf_counter() - t_run

    def before_frames(self) -> None:
        """Once the engine is built: the work the frames ask for, refused or said before it is spent (:mod:`budget`)."""
        done = 0 if self.checkpoint is None else self.checkpoint.frame
        note = budget.check_before(self.stats.engine, len(self.prep.setup.x), self.n_frames, self.n_frames - done,
                                   self.yes)
        if note:
            self.reporter.warning(note)

    def after_frame(self, writes: Background, frame: int, frame_wall_s: float) -> None:
        """At a frame boundary: the hold (``--hold``) after the first simulated frame, the work estimate after the
        second, then a stop asked for by a signal.

        Raises
        ------
        GaspError
            The run would take longer than :data:`gasp_core.run.budget.MAX_S` (without ``yes``).
        Stopped
            A signal asked the run to stop (:mod:`gasp_core.run.stop`); the frame's checkpoint is saved.
        """
        if frame == 0:
            return
        n_frames, checkpoint = self.n_frames, self.checkpoint
        first = 1 if checkpoint is None else checkpoint.frame + 1
        if self.hold is not None and frame == first and frame < n_frames:
            writes.flush()   # frame 1's files and checkpoint on disk: what a front end shows the moment it releases
            self.held_s = hold.wait(Path(self.hold))
        if frame == (2 if checkpoint is None else checkpoint.frame + 2):   # frame 1 includes JIT warm-up
            note = budget.check(self.stats.engine, len(self.prep.setup.x), n_frames, n_frames - frame, frame_wall_s,
                                self.yes)
            if note:
                self.reporter.warning(note)
        # a reader that went away (gasp simulate --json | head -n 1) stops the run as SIGPIPE stops a Unix tool, but
        # at a frame boundary, its frames kept for --resume (gasp_core.cli.streams)
        gone = "SIGPIPE" if isinstance(getattr(self.reporter, "stdout_error", None), BrokenPipeError) else None
        if frame < n_frames and (stop.requested() or gone):
            writes.flush()   # the frame's files and checkpoint are on disk before the stop is reported
            raise stop.Stopped(stop.requested() or gone)
        stop.frame_started(frame_wall_s)

    def save_frame(self, writer: FrameWriter, rebuild_all: Rebuilder, frame: int, x: np.ndarray, times: dict,
                   engine_state: dict | None, frame_s: list, made: list, labels=None) -> None:
        """Rebuild one frame's Gaussians from the positions ``x`` and write its files, then (``engine_state`` not
        None) its checkpoint (on :class:`Background`'s worker); the Gaussians are appended to ``made``; ``labels``
        (``(point labels, point masses, damage, tracker state, which labels are pieces)`` of a scene with pieces) each
        Gaussian's piece (:mod:`pieces`), the crack faces (:mod:`gasp_core.run.crack_output`) and the checkpoint's
        pieces. ``times``
        (empty for frame 0) go into the frame's row: ``sim_s`` (the engine), ``wall_s`` and ``cpu_s`` (the process's
        CPU time, every thread, from the previous frame's hand-off to the writer to this frame's: ``cpu_s / wall_s``
        is the cores the frame used, the previous frame's rebuild and files on the writer included)."""
        t0 = time.perf_counter()
        gs, row = rebuild_all(frame, x, *((None,) if labels is None else (labels[0], labels[4])))
        row.update(times)
        row["rebuild_s"] = time.perf_counter() - t0
        made.append(gs)
        t0 = time.perf_counter()
        self.unrecorded += writer.write(frame, gs)
        if labels is not None:
            self.unrecorded += pieces.write_frame_pieces(writer.folder, self.prep, frame, *labels[:2], labels[4])
            if self.cracks is not None:
                self.unrecorded += self.cracks.write(writer.folder, frame, x, labels[0], labels[2], labels[4])
                row.update(self.cracks.counts)
        if any(c is not None for c in rebuild_all.split):   # an object that tears: its clamped triangles split
            self.unrecorded += write_split(writer.folder, self.prep.names, frame, rebuild_all.last_split)
        row["write_s"] = time.perf_counter() - t0
        self.per_frame.append(row)
        if engine_state is not None:
            t0 = time.perf_counter()
            self.files.update(resume_mod.file_record(self.tmp, self.unrecorded, self.files))
            self.unrecorded = []
            resume_mod.save(self.tmp, resume_mod.Checkpoint(
                frame, engine_state, list(rebuild_all.prev_rot), {"fingerprint": self.fingerprint,
                                                                  "per_frame": self.per_frame, "frame_s": frame_s,
                                                                  "files": self.files},
                {} if labels is None else labels[3]))
            row["checkpoint_s"] = time.perf_counter() - t0
            self.saved_frame = frame

    # ---------------------------------------------------------------- the end
    def warn_stranded(self) -> None:
        """Pass on the engine's ``passive_stranded`` count as a warning (:func:`stranded_warning`)."""
        stranded_warning(self.reporter, (self.stats.engine or {}).get("passive_stranded"), self.prep.setup.n_passive)

    def stopped_record(self) -> dict:
        """The ``run.json`` of a stopped run: the record of the frames its checkpoint covers."""
        rows = [r for r in self.per_frame if self.saved_frame is not None and r["frame"] <= self.saved_frame]
        return run_summary(self.prep, self.stats, self.n_frames, rows, sum(self.stats.frame_s))

    def give_up(self, error: BaseException) -> None:
        """A run that failed (``error``): a divergence keeps the frames before it (:meth:`keep_diverged`), anything
        else gives the partial folder up (:meth:`OutputClaim.abandon`)."""
        if isinstance(error, EngineDivergence):
            self.keep_diverged(error)
        else:
            self.claim.abandon(self.tmp, error)

    def keep_diverged(self, error: EngineDivergence) -> None:
        """After a blow-up: finalise the partial folder as the output folder with the frames written before it.

        The frames are those whose files are complete (a ``per_frame`` row is added once a frame's files are
        written, in order; ``frames.json`` lists the same); the checkpoint is removed (a blow-up is not resumed:
        it would come again) and ``run.json`` is the record of those frames with ``status: "diverged"`` and
        ``diverged`` (``frame``, ``cause``, ``message``). The folder is committed as a finished run's is
        (:meth:`OutputClaim.commit`: an existing output is replaced only under ``--overwrite``). Sets
        ``error.kept`` and ``error.last_kept``. With no simulated frame written (frame 0, the input, alone), or when
        the folder cannot be finalised, the partial run is given up as before (:meth:`OutputClaim.abandon`).
        """
        claim = self.claim
        last = max((r["frame"] for r in self.per_frame), default=0)
        if self.tmp is None or last < 1:
            claim.abandon(self.tmp, error)
            return
        rows = sorted(self.per_frame, key=lambda r: r["frame"])
        record = {**run_summary(self.prep, self.stats, self.n_frames, rows, sum(self.stats.frame_s)),
                  "status": "diverged", "diverged": {"frame": error.frame, "cause": error.cause, "message": str(error)}}
        if self.checkpoint is not None:
            record["resumed_after_frame"] = self.checkpoint.frame
        try:
            (self.tmp / resume_mod.CHECKPOINT).unlink(missing_ok=True)
            atomic_json(self.tmp / "run.json", record)
            claim.commit(self.tmp)
        except OutputConflict:            # the output folder was changed meanwhile: the frames stay in the partial folder
            claim.release()
            error.kept, error.last_kept = self.tmp, last
            return
        except Exception as e:            # cannot be finalised (a full disk): given up, the divergence is what is said
            claim.abandon(self.tmp, e)
            return
        error.kept, error.last_kept = claim.outdir, last


@dataclass
class _Handover:
    """Hands each frame from the engine to the writer, timed from the previous hand-off (``wall_s``, ``cpu_s``)."""

    run: SimulationRun
    writes: Background
    writer: FrameWriter
    rebuild_all: Rebuilder
    on_frame: Callable[[int, list[Gaussians]], None] | None
    #: The pieces of a scene with a brittle body (:mod:`gasp_core.run.pieces`); None without one.
    tracker: object = None
    #: Frames between checkpoints, set at the first (:func:`gasp_core.run.resume.checkpoint_every`); 0 before it.
    ckpt_every: int = 0
    left_warned: bool = False
    t_frame: float = field(default_factory=time.perf_counter)
    c_frame: float = field(default_factory=time.process_time)

    def __call__(self, frame: int, x: np.ndarray, sim_s: float | None, get_state) -> None:
        run = self.run
        stop.frame_started(sim_s)   # its rebuild, writes and checkpoint take about as long as it did
        # a checkpoint every frame, or every few for a state of hundreds of MB (resume_mod.checkpoint_every)
        due = get_state is not None and frame < run.n_frames and (not self.ckpt_every or frame % self.ckpt_every == 0)
        state = get_state() if due else None
        if state is not None and self.ckpt_every == 0:
            self.ckpt_every = resume_mod.checkpoint_every(state)
        made: list = []
        wall_s, cpu_s = time.perf_counter() - self.t_frame, time.process_time() - self.c_frame
        times = {"sim_s": sim_s, "wall_s": wall_s, "cpu_s": cpu_s} if sim_s is not None else {}
        labels = None
        if run.stats.left_domain is not None and frame:   # points out of the grid drop out (feature left_domain)
            times["left_domain"] = run.stats.left_domain
            self.left_warned = left_domain_row(run.reporter, frame, run.stats.left_domain, self.left_warned)
        if self.tracker is not None:
            times.update(pieces.frame_row(self.tracker, run.reporter, frame, x, run.stats.damage if frame else None))
            labels = (self.tracker.last_labels, self.tracker.mass, run.stats.damage if frame else None,
                      self.tracker.state() if state is not None else {}, self.tracker.pieces)
        self.writes.submit(run.save_frame, self.writer, self.rebuild_all, frame, np.array(x), times, state,
                           list(run.stats.frame_s), made, labels)
        run.reporter.frame(frame, wall_s, sim_s, run.stats.engine.get("n_substeps"))
        if self.on_frame is not None:
            self.writes.flush()
            self.on_frame(frame, made[0])
        run.after_frame(self.writes, frame, wall_s)
        self.t_frame, self.c_frame = time.perf_counter(), time.process_time()
