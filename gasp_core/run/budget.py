"""The work a run asks for, said before it is spent: ``substeps x points x frames`` and the time it takes.

After the second simulated frame (the first includes kernel compilation) the pipeline knows the engine's substeps per frame (``n_substeps``
in its ``stats()``; 1 for an engine without substeps), the number of points and the wall time of
one frame on this machine. A run expected to take longer than :data:`NOTE_S` says so in one line;
one expected to take longer than :data:`MAX_S` is refused unless the user passes ``--yes``
(``n_frames = 1000000000`` is a typo far more often than a plan).

Before the first frame, once the engine is built (:func:`check_before`), the work is known but not the
rate: a run whose work exceeds :data:`MAX_S` even at :data:`FAST_RATE` (faster than any engine measured on
a GPU) is refused at once without ``--yes``, and one asking for more than :data:`NOTE_WORK` point-substeps
says so in one line before it starts (``n_grid = 200`` with ``particles_per_cell = 64`` gave no output for
minutes before).
"""
from __future__ import annotations

from gasp_core.errors import GaspError

#: Runs expected to take longer than this (seconds, at the measured rate) print their estimate.
NOTE_S = 600.0
#: Runs expected to take longer than this (seconds) are refused without ``--yes``: 24 hours.
MAX_S = 24 * 3600.0
#: Point-substeps per second taken as the fastest any engine runs (for the refusal before the first frame).
FAST_RATE = 1e9
#: Point-substeps a second of the 2-core CPU the project is measured on, the whole run's wall time (kernels cached,
#: frames written): the README donut (66,071 points, 79 substeps a frame, 36 frames stepped in 111 s on a quiet
#: machine, round 71's fresh clone of 60b1da04 under the trapezoid stress and the symmetrised midpoint: 1.69e6). Was
#: 3.7e6 from issue 68 to round 71 (65,036 points x 69 substeps in 44 s, under the "start" stress), 5e6 before. What
#: ``gasp place`` and ``gasp simulate`` estimate a run's time at before it starts: a rate, not a promise (an H100 ran
#: 11-40 times faster, a loaded machine slower; a first run adds its kernels' compilation, frame 1: 16.7 s).
CPU_RATE = 1.7e6
#: What ``gasp simulate`` says of the time before it starts (the line after the bytes it writes, issue 68).
TAKES = ("gasp: the run takes about {time} on a 2-core CPU ({points:,} points x {substeps} substeps x {frames} "
         "frames at {rate:.2g} point-substeps/s, docs/performance.md; an H100 ran 11-40 times faster{load})")


def start_estimate(points: int, n_substeps: int | None, frames: int, load: tuple | None = None,
                   settle_substeps: int = 0) -> dict | None:
    """The time a run of ``frames`` frames of ``points`` points at ``n_substeps`` substeps a frame takes at
    :data:`CPU_RATE`: ``{"points", "n_substeps", "frames", "work", "seconds", "line"}`` (``line`` :data:`TAKES`),
    None where the substeps are not known before the engine runs. ``load``: (1-minute load, cores) of this machine;
    a load above the cores is said (the run takes longer). ``settle_substeps``: the substeps of a settled start
    before frame 1 (``gasp_core.seam.settle.settle_substeps``), added to the work and said."""
    if n_substeps is None or points <= 0 or frames <= 0:
        return None
    work = float(points) * (float(n_substeps) * float(frames) + float(settle_substeps))
    seconds = work / CPU_RATE
    note = f"; the settle adds {int(settle_substeps):,} substeps" if settle_substeps else ""
    if load is not None and load[1] and load[0] > load[1]:
        note += f"; this machine's load is {load[0]:.1f} on {load[1]} cores: longer"
    line = TAKES.format(time=duration_text(seconds), points=int(points), substeps=int(n_substeps), frames=int(frames),
                        rate=CPU_RATE, load=note)
    return {"points": int(points), "n_substeps": int(n_substeps), "frames": int(frames), "work": work,
            "seconds": seconds, "line": line}


#: Runs asking for more point-substeps than this say so before their first frame: minutes to hours on a CPU
#: engine (about 1e6 to 1e8 point-substeps/s; the README donut asks for about 1e9, the guitar at
#: ``n_grid = 200``, ``particles_per_cell = 64`` for 7e9).
NOTE_WORK = 3e9


def duration_text(seconds: float) -> str:
    """``"42 s"``, ``"3.5 min"``, ``"24 h"``, ``"185 days"``, ``"3.2e+04 years"``."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= 2 * size or (unit == "min" and seconds >= size):
            v = seconds / size
            return f"{v:.3g} {unit}" if v < 1e4 else f"{v:.2g} {unit}"
    return f"{seconds:.2g} s"


def estimate(engine_stats: dict, n_points: int, n_frames: int, frames_left: int, frame_s: float) -> tuple[float, str]:
    """Seconds the ``frames_left`` frames still take, and the estimate in words.

    Parameters
    ----------
    engine_stats : dict
        The engine's ``stats()`` (``n_substeps`` per frame, else 1).
    n_points : int
        Simulated points.
    n_frames : int
        Frames the run asks for.
    frames_left : int
        Frames still to simulate.
    frame_s : float
        Measured wall time of one frame (simulation, writing and checkpoint), seconds.
    """
    substeps = int(engine_stats.get("n_substeps") or 1)
    work = float(substeps) * n_points * n_frames
    seconds = frame_s * frames_left
    text = (f"{work:.3g} point-substeps ({substeps:,} substeps/frame x {n_points:,} points x {n_frames:,} frames), "
            f"about {duration_text(seconds)} at the measured {frame_s:.3g} s/frame")
    return seconds, text


def check(engine_stats: dict, n_points: int, n_frames: int, frames_left: int, frame_s: float, yes: bool) -> str:
    """The estimate in words when the rest of the run takes longer than :data:`NOTE_S`, else ``""``.

    Raises
    ------
    GaspError
        It takes longer than :data:`MAX_S` and ``yes`` is false; the message gives the estimate.
    """
    seconds, text = estimate(engine_stats, n_points, n_frames, frames_left, frame_s)
    if seconds > MAX_S and not yes:
        raise GaspError(f"n_frames = {n_frames:,} asks for {text}, beyond the bound of {duration_text(MAX_S)}; "
                        f"pass --yes to run it anyway, or ask for fewer frames (--frames)")
    return f"this run asks for {text}" if seconds > NOTE_S else ""


def check_before(engine_stats: dict, n_points: int, n_frames: int, frames_left: int, yes: bool,
                 override: str = "pass --yes to run it anyway, or ") -> str:
    """The work in words when it exceeds :data:`NOTE_WORK`, else ``""``: called once the engine is built.
    ``override``: how the caller's user runs past the bound, the start of the error's advice (``""`` where there is
    no way: ``gasp compare`` and ``gasp bench``).

    Raises
    ------
    GaspError
        The work takes longer than :data:`MAX_S` even at :data:`FAST_RATE`, and ``yes`` is false.
    """
    substeps = int(engine_stats.get("n_substeps") or 1)
    work = float(substeps) * n_points * frames_left
    text = f"{work:.3g} point-substeps ({substeps:,} substeps/frame x {n_points:,} points x {frames_left:,} frames)"
    if work / FAST_RATE > MAX_S and not yes:
        raise GaspError(f"this run asks for {text}, beyond the bound of {duration_text(MAX_S)} even at "
                        f"{FAST_RATE:.0e} point-substeps/s; {override}lower n_grid, particles_per_cell or the frames")
    if work > NOTE_WORK:
        return (f"this run asks for {text}: minutes to hours on a CPU (about 1e6 to 1e8 point-substeps/s); its "
                f"time is estimated after frame 2; n_grid and particles_per_cell set the points and the substeps")
    return ""
