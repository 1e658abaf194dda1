"""Follow a ``gasp simulate`` run while it is written: the frames so far, then the new ones as they come.

A run writes into a hidden partial folder beside its output folder and renames it onto the output folder
when it finishes (:mod:`gasp_core.fsutil`): while it runs, ``OUT/.gasp-claim`` holds ``TOKEN PID`` and
``.OUT.partial-XXXX/`` holds ``.gasp-pid`` (that PID), a preliminary ``run.json`` (``status: "running"``,
:func:`gasp_core.run.record.running_record`: the objects' placements, boundaries, ``frame_dt``, ``n_frames``)
and ``frames.json``, rewritten after every frame and listing only frames whose files are complete
(:mod:`gasp_core.run.layout`). This module reads that state:

- :func:`locate` says where a run's frames are now and its status (:data:`STATUSES`);
- :func:`find_live` gives the partial folder of a run in progress, else None;
- :class:`LiveRun` is a :class:`~gasp_core.render.run.Run` that :meth:`LiveRun.refresh` re-reads, following
  the folder's rename when the run finishes;
- :func:`follow` yields each frame once it can be read, until the run has finished, stopped or failed.

``gasp view`` (:class:`gasp_core.render.viewer.RunViewer`) and ``gasp studio`` use them. Processes are told
alive or gone by their PID on this machine (a run on another machine writing to a shared disk is not followed).
"""
from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path
from typing import Iterator

from gasp_core.errors import SceneError
from gasp_core.fsutil import CLAIM, PARTIAL_INFIX, STOPPED, leftover_partials
from gasp_core.render.run import Run, load_run
from gasp_core.run.layout import MANIFEST

#: The process has claimed the output folder but has not written its partial folder's ``run.json`` yet.
STARTING = "starting"
#: The process is alive and writing frames.
RUNNING = "running"
#: The run is complete (committed, or about to be: its final ``run.json`` is written).
FINISHED = "finished"
#: Stopped by a signal; the frames it kept stay in its partial folder for ``gasp simulate --resume``.
STOPPED_STATUS = STOPPED
#: The process is gone without finishing (killed, crashed, an engine error; or the run diverged and its output
#: folder holds the frames before the blow-up, ``run.json`` ``status: "diverged"``): what is on disk is all there is.
FAILED = "failed"
STATUSES = (STARTING, RUNNING, FINISHED, STOPPED_STATUS, FAILED)
#: Statuses under which more frames may still come.
LIVE = (STARTING, RUNNING)


def _running(pid: int) -> bool:
    """True if process ``pid`` exists on this machine and is not a zombie (exited, not yet reaped)."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return True                    # no /proc (macOS): os.kill said it exists
    return state not in ("Z", "X")


def _read_pid(path: Path) -> int:
    """The PID in a ``.gasp-pid`` file; 0 when missing or unreadable."""
    try:
        return int(path.read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 0


def _read_claim(outdir: Path) -> tuple[int, bool] | None:
    """``(pid, stopped)`` from ``outdir/.gasp-claim`` (``TOKEN PID [stopped]``); None when there is none."""
    try:
        words = (outdir / CLAIM).read_text().split()
    except OSError:
        return None
    try:
        return int(words[1]), STOPPED in words[2:]
    except (ValueError, IndexError):
        return 0, False


def _record(folder: Path) -> dict:
    """``folder/run.json`` as a dict; {} when missing or unreadable (being written, renamed)."""
    try:
        rec = json.loads((folder / "run.json").read_text())
    except (OSError, ValueError, RecursionError):
        return {}
    return rec if isinstance(rec, dict) else {}


def outdir_of(path) -> Path:
    """The output folder of ``path``: ``path`` itself, or for a partial folder ``D/.x.partial-abcd`` ``D/x``."""
    path = Path(path)
    name = path.name
    if name.startswith(".") and PARTIAL_INFIX in name:
        return path.parent / name[1:name.rindex(PARTIAL_INFIX)]
    return path


def _partial_status(partial: Path) -> str:
    """The status of the run that writes (or wrote) the partial folder ``partial``."""
    if _running(_read_pid(partial / ".gasp-pid")):
        return RUNNING if (partial / "run.json").is_file() else STARTING
    rec = _record(partial)
    if "stopped" in rec:
        return STOPPED_STATUS
    if rec and rec.get("status") != RUNNING:    # finished: being committed (its claim still held), or kept
        claim = _read_claim(outdir_of(partial))  # after an output conflict
        return RUNNING if claim is not None and not claim[1] and _running(claim[0]) else FINISHED
    return FAILED


def _inode(folder: Path) -> tuple | None:
    """``(device, inode)`` of ``folder`` (a rename keeps it); None when it is gone."""
    try:
        st = folder.stat()
    except OSError:
        return None
    return st.st_dev, st.st_ino


def _newest(partials: list[Path], want: str | None = None) -> Path | None:
    """The partial folder among ``partials`` whose ``run.json`` is newest (with key ``want``, if given)."""
    found = [p for p in partials if (p / "run.json").is_file() and (want is None or want in _record(p))]
    return max(found, key=lambda p: (p / "run.json").stat().st_mtime_ns, default=None)


def locate(path) -> tuple[Path | None, str]:
    """Where the frames of the run at ``path`` are now, and its status.

    Parameters
    ----------
    path : path-like
        An output folder (``gasp simulate -o``), finished or in progress, or a partial folder ``.x.partial-*``.

    Returns
    -------
    folder : Path or None
        The folder to read (``run.json``, ``frames.json``, frames): the output folder once committed, else the
        partial folder of the run; None when there is none (not started writing, or removed after a failure).
    status : str
        One of :data:`STATUSES`, or ``"missing"`` when neither ``path`` nor its output folder exists.
    """
    path = Path(path).resolve()                      # a link to the output folder: its partial folder lies beside the target
    outdir = outdir_of(path)
    if path != outdir:                               # a partial folder
        if path.is_dir():
            return path, _partial_status(path)
        path = outdir                                # renamed onto the output folder, or removed
    if not path.exists():
        return None, "missing"
    claim = _read_claim(path)
    if claim is None:
        record = _record(path)
        if record.get("status") == "diverged":
            return path, FAILED
        return path, (STOPPED_STATUS if "stopped" in record else FINISHED)
    pid, stopped = claim
    if stopped:
        return _newest(leftover_partials(path), "stopped"), STOPPED_STATUS
    if _running(pid):
        mine = [p for p in path.parent.glob(f".{path.name}{PARTIAL_INFIX}*") if _read_pid(p / ".gasp-pid") == pid]
        if not mine:
            return None, STARTING
        return mine[0], _partial_status(mine[0])
    return _newest(leftover_partials(path)), FAILED


def find_live(outdir) -> Path | None:
    """The partial folder of the run in progress that writes ``outdir`` (or ``outdir`` itself, a live partial
    folder), once its preliminary ``run.json`` is there; None for a finished, stopped or failed run, a run
    still starting, or a folder that is not a run's."""
    folder, status = locate(outdir)
    return folder if status == RUNNING else None


class LiveRun:
    """A run followed while it is written: :attr:`run` holds the frames readable now; :meth:`refresh` re-reads.

    Parameters
    ----------
    path : path-like
        An output folder or a partial folder (see :func:`locate`); a finished run is read once as
        :func:`~gasp_core.render.run.load_run` reads it.

    Attributes
    ----------
    path : Path
        As given.
    status : str
        One of :data:`STATUSES`, as of the last :meth:`refresh`.
    run : Run or None
        The frames readable at the last :meth:`refresh` (``run.path`` the folder they are in: the partial
        folder, then the output folder once the run finished); None before the first frame is listed.

    Raises
    ------
    SceneError
        ``path`` does not exist, or it is a finished (or stopped, or failed) run folder that
        :func:`~gasp_core.render.run.load_run` refuses; the message names the path.
    """

    def __init__(self, path):
        self.path = Path(path)
        self.status = STARTING
        self.run: Run | None = None
        self._where = self.path           # where to look next: the partial folder once it is found
        self._inode: tuple | None = None  # that partial folder's (device, inode): the output folder's once renamed
        folder, status = locate(self.path)
        if status == "missing":
            raise SceneError(f"{self.path}: no such run folder (make one with 'gasp simulate')")
        if folder is None and status not in LIVE:
            raise SceneError(f"{self.path}: the run {status} before writing any frame; nothing to show")
        self.refresh()

    @property
    def n_frames(self) -> int:
        """Frames readable now (frame 0 = the input state)."""
        return 0 if self.run is None else self.run.n_frames

    @property
    def n_total(self) -> int | None:
        """Frames the run will have when finished (``run.json`` ``n_frames`` + 1); None before its ``run.json``."""
        n = None if self.run is None else self.run.meta.get("n_frames")
        return int(n) + 1 if isinstance(n, int) else None

    def refresh(self) -> int:
        """Re-read where the run is, its status and its frames; returns :attr:`n_frames`.

        A state caught mid-change (a manifest or ``run.json`` being replaced, the partial folder being renamed)
        keeps the previous frames and is read again at the next call.

        Raises
        ------
        SceneError
            A run that is not in progress and whose folder :func:`~gasp_core.render.run.load_run` refuses.
        """
        folder, status = locate(self._where)
        if folder is not None and self._inode is not None and folder == outdir_of(folder) and \
                _inode(folder) != self._inode:           # the partial folder was removed, not renamed: the output
            folder, status = None, FAILED                # folder holds another run's results (kept by --overwrite)
        if folder is None:
            if status == "missing" or status not in LIVE and self.run is not None:
                status = FAILED                           # its partial folder removed after an error
            self.status = status
            return self.n_frames
        if status in LIVE and not (folder / MANIFEST).is_file():
            self.status = status                          # frame 0 not written yet
            return self.n_frames
        try:
            run = load_run(folder)
        except (SceneError, OSError):
            if status in LIVE or not folder.exists():
                return self.n_frames                      # caught mid-change: next time
            raise
        if self.run is not None:                          # keep what was read once (rest, static)
            run.frames._cache.update(self.run.frames._cache)
        self.run, self.status = run, status
        if folder != outdir_of(folder):                   # a partial folder: follow its rename
            self._where, self._inode = folder, _inode(folder)
        else:
            self._where = self.path
        return self.n_frames

    def wait(self, n: int = 1, poll_s: float = 0.5, timeout_s: float | None = None) -> int:
        """Refresh every ``poll_s`` seconds until ``n`` frames are readable, the run is no longer in progress, or
        ``timeout_s`` seconds passed (None: no limit); returns :attr:`n_frames`."""
        t0 = time.monotonic()
        while self.refresh() < n and self.status in LIVE:
            if timeout_s is not None and time.monotonic() - t0 > timeout_s:
                break
            time.sleep(poll_s)
        return self.n_frames

    def read(self, frame: int, k: int):
        """Object ``k``'s Gaussians at ``frame`` (file frame, :meth:`Run.read`), following a rename in between."""
        try:
            return self.run.read(frame, k)
        except (FileNotFoundError, SceneError):
            self.refresh()
            return self.run.read(frame, k)

    def splats(self, frame: int):
        """World-frame splats of every object at ``frame`` (:meth:`Run.splats`), following a rename in between."""
        try:
            return self.run.splats(frame)
        except (FileNotFoundError, SceneError):
            self.refresh()
            return self.run.splats(frame)


def follow(path, poll_s: float = 0.5, stop: threading.Event | None = None,
           start: int = 0) -> Iterator[tuple[LiveRun, int]]:
    """Yield ``(live, frame)`` for each frame of the run at ``path`` once it can be read, in order.

    Read a frame's objects with ``live.read(frame, k)`` (Gaussians) or ``live.splats(frame)`` (world frame).
    The generator ends when the run is no longer in progress and every frame on disk was yielded, or when
    ``stop`` is set.

    Parameters
    ----------
    path : path-like or LiveRun
        An output folder or partial folder (see :func:`locate`).
    poll_s : float
        Seconds between looks for new frames.
    stop : threading.Event, optional
        Set it to end the generator from another thread.
    start : int
        The first frame to yield.

    Raises
    ------
    SceneError
        See :class:`LiveRun`.
    """
    live = path if isinstance(path, LiveRun) else LiveRun(path)
    done = start
    while True:
        live.refresh()
        while done < live.n_frames:
            yield live, done
            done += 1
        if live.status not in LIVE:
            return
        if stop is not None:
            if stop.wait(poll_s):
                return
        else:
            time.sleep(poll_s)
