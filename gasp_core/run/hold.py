"""A run held after its first frame until a front end releases it (``gasp simulate --hold FILE``).

A front end (the studio, :mod:`gasp_core.studio.warm`) starts the run its user is about to ask for while they are
still choosing: the process loads the scene, prepares the points, builds the engine, compiles its kernels and
simulates frame 1, whose files are on disk, then waits while ``FILE`` exists. Removing ``FILE`` releases it: the
run goes on as if it had never waited, so a Run button answers with frame 1 at once. A front end whose user chose
otherwise stops the held run as any run is stopped (SIGTERM, :mod:`gasp_core.run.stop`). The wait is bounded:
after :data:`MAX_HOLD_S`, or once the process that started it is gone, the run stops as a signal would stop it
(its frame kept for ``--resume``). ``run.json`` records the seconds held (``held_s``).
"""
from __future__ import annotations

import os
import time
from pathlib import Path

from gasp_core.run import stop

#: Longest a run waits for its release, seconds (a bound on a front end that forgets it).
MAX_HOLD_S = 1800.0
#: How often the hold file is looked at, seconds (the delay a release can add).
POLL_S = 0.02


def wait(hold: Path, max_s: float | None = None) -> float:
    """Wait while ``hold`` exists; return the seconds waited.

    Parameters
    ----------
    hold : Path
        The hold file; its removal releases the run.
    max_s : float, optional
        Longest wait, seconds (default :data:`MAX_HOLD_S`).

    Raises
    ------
    Stopped
        The wait ran past ``max_s``, or the parent process is gone (the front end died without releasing it).
        A stop signal received meanwhile ends the wait; the caller's stop check raises it at the frame boundary.
    """
    max_s = MAX_HOLD_S if max_s is None else max_s
    parent = os.getppid()
    stop.frame_started(0.0)   # a signal now asks for a stop at this boundary instead of interrupting the wait
    t0 = time.monotonic()
    while Path(hold).exists() and not stop.requested():
        if time.monotonic() - t0 > max_s:
            raise stop.Stopped(f"its hold running out ({max_s:.0f} s, {hold} still there)")
        if os.getppid() != parent:
            raise stop.Stopped(f"the end of the process that held it ({hold} still there)")
        time.sleep(POLL_S)
    return time.monotonic() - t0
