"""Stopping a run politely: SIGTERM, SIGINT (Ctrl-C) and SIGHUP end it at the next frame boundary.

A batch scheduler's time limit, a closed terminal and Ctrl-C must not lose more than ``kill -9``
does. While :func:`handlers` is active (``gasp simulate`` installs it), the first of these signals
only *asks* the run to stop: the pipeline finishes the frame in flight, writes its PLYs and its
checkpoint, and then raises :class:`Stopped`; the partial folder is kept, resumable with
``--resume`` (engines with the feature ``state``). A frame expected to take longer than
:data:`LONG_FRAME_S` (or a run not yet in its frame loop) is interrupted right away instead, losing
only the frame in flight, as ``kill -9`` would; so does a second signal.

The pipeline tells this module where it is with :func:`frame_started` / :func:`frame_finished` and
asks :func:`requested` after each checkpoint. Signals are a process-wide matter, hence module state.
"""
from __future__ import annotations

import signal
import threading
from contextlib import contextmanager
from pathlib import Path
from typing import Callable, Iterator, NoReturn

from gasp_core.fsutil import OutputClaim, atomic_json

#: A frame expected to take longer than this (seconds, the last frame's wall time) is not waited for.
LONG_FRAME_S = 10.0
#: The signals that stop a run.
SIGNALS = tuple(s for s in (getattr(signal, n, None) for n in ("SIGTERM", "SIGINT", "SIGHUP")) if s is not None)


class Stopped(KeyboardInterrupt):
    """The run was stopped by a signal (a :class:`KeyboardInterrupt`, so code that handles Ctrl-C handles it).

    Attributes
    ----------
    signal_name : str
        ``"SIGTERM"``, ``"SIGINT"`` or ``"SIGHUP"``.
    kept : Path or None
        The partial folder kept for ``--resume`` (None: nothing was kept).
    frame, n_frames : int or None
        The last frame kept, of how many.
    """

    def __init__(self, signal_name: str, kept: Path | None = None, frame: int | None = None,
                 n_frames: int | None = None):
        super().__init__(signal_name)
        self.signal_name, self.kept, self.frame, self.n_frames = signal_name, kept, frame, n_frames

    def __str__(self) -> str:
        if self.kept is None:
            return f"interrupted by {self.signal_name}; no partial output was kept"
        return (f"stopped by {self.signal_name} after frame {self.frame} of {self.n_frames}; the finished frames "
                f"are kept in '{self.kept}': continue with --resume, or start again with --discard")


class _State:
    """What the handler needs: the signal asked for, and how long the frame in flight should take."""

    def __init__(self):
        self.signal_name: str | None = None
        #: Expected wall time of the frame in flight, seconds; None outside the frame loop.
        self.frame_s: float | None = None
        #: True while a stop is being saved: further signals are only recorded.
        self.saving = False


_STATE = _State()


def _handler(signum, _frame) -> None:
    name = signal.Signals(signum).name
    if _STATE.saving:
        return
    at_boundary = _STATE.frame_s is not None and _STATE.frame_s <= LONG_FRAME_S
    if _STATE.signal_name is None and at_boundary:
        _STATE.signal_name = name      # finish the frame in flight, then stop
        return
    raise Stopped(name)


@contextmanager
def handlers() -> Iterator[None]:
    """Install the stop handlers for SIGTERM, SIGINT and SIGHUP (main thread only), restore them after."""
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in SIGNALS:
            previous[sig] = signal.signal(sig, _handler)
    reset()
    try:
        yield
    finally:
        for sig, h in previous.items():
            signal.signal(sig, h)
        reset()


def reset() -> None:
    """Forget a stop asked for (a new run starts)."""
    _STATE.signal_name, _STATE.frame_s, _STATE.saving = None, None, False


def frame_started(expected_s: float | None) -> None:
    """The pipeline starts a frame expected to take ``expected_s`` seconds (None: unknown, stop at once)."""
    _STATE.frame_s = expected_s


def requested() -> str | None:
    """The name of the signal that asked the run to stop at this frame boundary, else None."""
    return _STATE.signal_name


def saving() -> None:
    """The stop is being saved (partial record, claim): further signals no longer interrupt it."""
    _STATE.saving = True


def keep_or_abandon(claim: OutputClaim, tmp: Path | None, error: KeyboardInterrupt, record: Callable[[], dict],
                    saved_frame: int | None, n_frames: int) -> NoReturn:
    """After a stop (a :class:`Stopped` or Ctrl-C's ``KeyboardInterrupt``): keep the partial folder ``tmp`` for
    ``--resume`` when it holds a checkpoint (writing ``record()`` as its ``run.json``, with ``stopped``:
    the signal and the last saved frame), else give it up as a failed run does; then raise :class:`Stopped`.

    Raises
    ------
    Stopped
        Always; ``kept`` names the partial folder (None when nothing was kept).
    """
    from gasp_core.run.resume import CHECKPOINT   # here: the CLI imports this module at start-up
    saving()
    name = error.signal_name if isinstance(error, Stopped) else "SIGINT"
    if tmp is None or saved_frame is None or not (tmp / CHECKPOINT).exists():
        claim.abandon(tmp, error)
        raise Stopped(name) from None
    atomic_json(tmp / "run.json", {**record(), "stopped": {"signal": name, "after_frame": saved_frame}})
    claim.keep_for_resume(tmp)
    raise Stopped(name, kept=tmp, frame=saved_frame, n_frames=n_frames) from None
