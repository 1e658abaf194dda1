"""The GASP pipeline: load -> world frame -> flatten -> T -> engine -> T^-1 (+ alpha rule) -> frames.

``G_t = T^-1(phi(T(G), t))`` (GASP paper Sec. 3, Eq. for ``G_t``). The steps live in their own
modules: placement and ``T`` (:mod:`~gasp_core.prepare.placement`), point assembly
(:mod:`~gasp_core.prepare.assembly`), the engine seam (:mod:`~gasp_core.seam.engine`, :mod:`~gasp_core.seam.runner`),
``T^-1`` per frame (:mod:`~gasp_core.run.frames`), the run record (:mod:`~gasp_core.run.record`) and the
output folder (:mod:`~gasp_core.fsutil`). This module is the entry; :class:`~gasp_core.run.simulation.SimulationRun`
strings the steps together: it prepares the scene, opens the output, builds the engine, then loops over the
frames. Frames are written
back in the input file's own frame and order, so frame 0 sits where the input was; opacity, SH
and extra properties are carried bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

from gasp_core.run import resume as resume_mod
from gasp_core.fsutil import OutputClaim
from gasp_core.gs.gaussians import Gaussians
from gasp_core.run.layout import check_format
from gasp_core.prepare.scene import input_files
from gasp_core.run.report import ConsoleReporter, Reporter
from gasp_core.run.request import SimulateRequest
from gasp_core.run.simulation import SimulationRun
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
        ``outdir`` unsafe to replace (it holds an input, the scene or the working directory),
        not a gasp output or a symbolic link; the claim lost during the run; ``resume`` with ``discard``.
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
    run = SimulationRun(claim, n_frames, fmt=req.fmt, layout=req.layout, yes=req.yes,
                        reporter=reporter, hold=req.hold)
    summary = run.run(scene, req, on_frame)
    return RunResult(outdir=outdir, n_frames=n_frames, stats=run.stats, summary=summary)


def _refuse_early(req: SimulateRequest, outdir: Path) -> None:
    """What is refused before the output is claimed or an engine built: an output format whose writer is missing
    (issue 41: it came after, naming a hidden folder), ``--resume`` of a run that diverged (it would blow up again)
    or is finished (nothing to resume).

    Raises
    ------
    GaspError
        See :func:`gasp_core.run.layout.check_format` and :func:`gasp_core.run.resume.refuse_unresumable`.
    """
    check_format(req.fmt)
    if req.resume:
        resume_mod.refuse_unresumable(outdir)
