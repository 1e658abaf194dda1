"""A studio run followed as it is written: its process (:class:`~gasp_core.studio.job.Job`) and its frames
(:class:`~gasp_core.render.live.LiveRun`, which reads the run's partial folder, then its output folder)."""
from __future__ import annotations

import time
from pathlib import Path

from gasp_core.errors import SceneError
from gasp_core.render.live import LIVE, LiveRun
from gasp_core.studio.job import Job

#: Most runs one studio folder holds (``run1`` ... ``run999``); a bound on what a stuck loop could create.
MAX_RUNS = 999


def next_run_dir(workdir: Path) -> Path:
    """The first ``workdir/runN`` that does not exist (N from 1).

    Raises
    ------
    SceneError
        All :data:`MAX_RUNS` names are taken.
    """
    for i in range(1, MAX_RUNS + 1):
        p = workdir / f"run{i}"
        if not p.exists() and not p.with_suffix(".toml").exists() and not any(workdir.glob(f".run{i}.partial-*")):
            return p
    raise SceneError(f"{workdir}: run1 ... run{MAX_RUNS} all exist; remove old runs or choose another --workdir")


class RunStream:
    """A run of the studio's scene and the frames it has written so far.

    Attributes
    ----------
    job : Job
    outdir : Path
        The run folder (``gasp simulate -o``).
    started : float
        ``time.monotonic()`` of the click on Run (default: the job's launch; a held run launched earlier,
        :mod:`gasp_core.studio.warm`, counts from its release).
    first_frame_s : float or None
        Seconds from :attr:`started` to frame 1's files being readable (None before).
    """

    def __init__(self, job: Job, outdir: Path, started: float | None = None):
        self.job, self.outdir = job, outdir
        self.started = job.started if started is None else started
        self.live: LiveRun | None = None
        self.first_frame_s: float | None = None

    @classmethod
    def start(cls, scene) -> RunStream:
        """Write the scene as ``runN.toml`` (with its masks) and run ``gasp simulate`` on it into ``runN``, the next
        free N in the studio's folder. Each run keeps its own scene file: ``--resume`` refuses a run whose inputs
        changed since (:func:`gasp_core.run.resume.fingerprint`), and the file says what the run was.

        Raises
        ------
        SceneError
            The scene is refused (nothing is written or started).
        """
        outdir = next_run_dir(scene.workdir)
        path = scene.write(outdir.with_suffix(".toml"))
        return cls(Job(path, outdir), outdir)

    def resumed(self) -> RunStream:
        """The same run continued with ``--resume`` (a stopped run's frames are kept).

        Raises
        ------
        SceneError
            The run was not stopped.
        """
        if self.job.outcome() != "stopped":
            raise SceneError(f"{self.outdir.name} was not stopped ({self.job.outcome()}); nothing to resume")
        return RunStream(Job(self.job.scene, self.outdir, resume=True), self.outdir)

    @property
    def n_ready(self) -> int:
        """Frames readable now (frame 0 = the rest state)."""
        return 0 if self.live is None else self.live.n_frames

    def refresh(self) -> bool:
        """Look for new frames; True when there are more than before."""
        before = self.n_ready
        if self.live is None:
            if not self.outdir.exists():
                return False
            try:
                self.live = LiveRun(self.outdir)
            except SceneError:
                if self.job.running:
                    return False
                raise
        else:
            self.live.refresh()
        if self.first_frame_s is None and self.n_ready >= 2:
            self.first_frame_s = time.monotonic() - self.started
        return self.n_ready > before

    def splats(self, k: int):
        """World-frame splats of frame ``k`` (:meth:`gasp_core.render.live.LiveRun.splats`)."""
        return self.live.splats(k)

    def status(self, before_frame1: str = "") -> str:
        """One line: the run, its state, frames so far, time to frame 1; while frame 1 is not there,
        ``before_frame1`` (what the run does meanwhile: compiling kernels) and the seconds since the launch."""
        state = self.job.outcome()
        total = self.live.n_total if self.live is not None else None
        done = max(self.n_ready - 1, 0)
        text = f"{self.outdir.name}: {state}, {done}" + (f" of {total - 1}" if total else "") + " frames"
        if state == "running" and done == 0 and before_frame1:
            text += f": {before_frame1}… {time.monotonic() - self.started:.0f} s"
        if self.first_frame_s is not None:
            text += f" (frame 1 after {self.first_frame_s:.1f} s)"
        if state == "running" and self.live is not None and self.live.status not in LIVE:
            text += f" [{self.live.status}]"
        return text
