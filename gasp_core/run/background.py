"""One background worker for the frame loop: a frame's files are written while the engine runs the next frame.

The loop hands each frame's writes (its PLY files, then its checkpoint) to :class:`Background` and goes on
simulating. One job is in flight at a time and jobs run in the order given, so a checkpoint is written
only after the frame files it covers, and a killed run never has a checkpoint ahead of its frames
(``--resume`` continues exactly as before). Files are written atomically (:mod:`gasp_core.fsutil`), so an
interrupted job leaves no half-written file.

A job is the frame's rebuild (``T^-1`` and the alpha rule, :class:`gasp_core.run.frames.Rebuilder`), its files
and its checkpoint. What it buys depends on whether the engine releases Python's GIL while it computes: if it
does, the job runs on a second core; if its kernels hold the GIL, only the parts of a job that release it
themselves (NumPy, file writes) overlap. Which engine does which is measured in docs/performance.md.
"""
from __future__ import annotations

import sys
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import contextmanager
from typing import Callable

#: Python's thread switch interval (s) in the frame loop, where the engine and the writer share the GIL: the engine's
#: thread takes the GIL back after each kernel launch (about 1,500 a frame on the README donut) and, with Python's
#: default 5 ms, may wait that long each time the writer holds it. Measured per frame (the README donut, the rebuild
#: on a second thread, ``docs/performance.md`` "The rebuild on the writer"): 5 ms 2.41 s, 1 ms 2.07 s, 0.2 ms 2.12 s
#: with another job on one core; quiet, the three alike (1.30 s) and 1.37 s with the rebuild in the loop.
SWITCH_INTERVAL = 1e-3


@contextmanager
def gil_handover(interval: float = SWITCH_INTERVAL):
    """Python's switch interval set to ``interval`` seconds inside the block, restored after it."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(interval)
    try:
        yield
    finally:
        sys.setswitchinterval(old)


class Background:
    """Run jobs one at a time, in order, on one worker thread; errors come back to the caller.

    Use as a context manager: leaving it normally waits for the last job and raises its error; leaving
    it by an exception waits for the job in flight (so its files are complete or absent) and lets the
    exception through.
    """

    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="gasp-writer")
        self._pending: Future | None = None

    def submit(self, fn: Callable, *args) -> None:
        """Run ``fn(*args)`` in the background once the previous job is done.

        Raises
        ------
        Exception
            Whatever the previous job raised (it is waited for first).
        """
        self.flush()
        self._pending = self._pool.submit(fn, *args)

    def flush(self) -> None:
        """Wait for the job in flight, if any, and raise its exception."""
        pending, self._pending = self._pending, None
        if pending is not None:
            pending.result()

    def __enter__(self) -> Background:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self.flush()
        finally:
            self._pool.shutdown(wait=True)   # on an error: the job in flight finishes, its own error is dropped
        return False
