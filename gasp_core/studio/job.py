"""A studio run: ``gasp simulate SCENE -o RUN --json`` in a process of its own, its events read as they come.

The run is the command itself (``python -m gasp_core simulate``, the studio's own Python), so it goes through
the same scene checks, work bounds, stop and resume as any run; its JSON lines (:mod:`gasp_core.run.report`)
arrive on a reader thread and are kept in :attr:`Job.events`. Stop sends SIGTERM: the run keeps its finished
frames (:mod:`gasp_core.run.stop`) and :meth:`Job.resume` continues it with ``--resume``.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

#: The studio's runs write graphdeco PLY frames, one file per object per frame (the ``frames`` layout).
RUN_FORMAT = ("--format", "ply", "--layout", "frames")


#: How much lower than the studio's own the run's CPU priority is (``nice``): the page stays responsive while an
#: engine's threads take every core, and the run loses nothing when the page is idle.
RUN_NICENESS = 5


def _lower_priority() -> None:
    """In the run's process before it starts: ``os.nice(RUN_NICENESS)`` (where the platform has it)."""
    if hasattr(os, "nice"):
        os.nice(RUN_NICENESS)


class Job:
    """One ``gasp simulate`` process and what it said.

    Parameters
    ----------
    scene : Path
        The scene TOML.
    outdir : Path
        The run folder (must not exist, unless ``resume``).
    resume : bool
        Continue a stopped run in ``outdir`` (``--resume``).
    hold : Path, optional
        Hold the run after its first frame while this file exists (``--hold``, :mod:`gasp_core.run.hold`).

    Attributes
    ----------
    events : list of dict
        Every JSON event so far (``start``, ``frame``, ``warning``, ``result``, ``error``).
    started : float
        ``time.monotonic()`` at launch.
    """

    def __init__(self, scene: Path, outdir: Path, resume: bool = False, hold: Path | None = None):
        self.scene, self.outdir = Path(scene), Path(outdir)
        cmd = [sys.executable, "-m", "gasp_core", "simulate", str(self.scene), "-o", str(self.outdir), "--json",
               *RUN_FORMAT] + (["--resume"] if resume else []) + (["--hold", str(hold)] if hold else [])
        self.events: list[dict] = []
        self.stderr: list[str] = []
        self.started = time.monotonic()
        self._lock = threading.Lock()
        self.proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     start_new_session=True, preexec_fn=_lower_priority)
        self._readers = [threading.Thread(target=self._read_events, daemon=True),
                         threading.Thread(target=self._read_stderr, daemon=True)]
        for t in self._readers:
            t.start()

    def _read_events(self) -> None:
        for line in self.proc.stdout:
            try:
                event = json.loads(line)
            except ValueError:
                event = {"event": "output", "message": line.rstrip()}
            event["at_s"] = time.monotonic() - self.started
            with self._lock:
                self.events.append(event)

    def _read_stderr(self) -> None:
        for line in self.proc.stderr:
            self.stderr.append(line.rstrip())

    def frames_done(self) -> int:
        """The last frame the run reported done (0 before frame 1)."""
        return max((e["frame"] for e in self.snapshot() if e.get("event") == "frame"), default=0)

    def snapshot(self) -> list[dict]:
        with self._lock:
            return list(self.events)

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def outcome(self) -> str:
        """``running``, ``finished``, ``stopped`` (exit 130 or 143: its frames kept for ``--resume``) or
        ``failed: <the run's one line>``."""
        code = self.proc.poll()
        if code is None:
            return "running"
        for t in self._readers:
            t.join(timeout=2.0)
        if code == 0:
            return "finished"
        if code in (130, 143):        # a signal: the finished frames are kept for --resume (gasp_core.run.stop)
            return "stopped"
        return "failed: " + (self.last_error() or (self.stderr[-1] if self.stderr else f"exit status {code}"))

    def last_error(self) -> str:
        """The run's one-line error (its ``error`` event; for a stopped run, what it kept), or ``""``."""
        errors = [e["message"] for e in self.snapshot() if e.get("event") == "error"]
        return errors[-1] if errors else ""

    def stop(self, timeout: float = 60.0) -> str:
        """SIGTERM the run and wait for it to keep its frames (at most ``timeout`` s, then SIGKILL)."""
        if self.running:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        return self.outcome()
