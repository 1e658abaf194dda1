"""One reporter: the progress, warnings, result and error of a run go through one object.

A run says six kinds of thing, each an event (a dict with ``"event"`` naming its kind):

``start``
    ``engine`` (its name), ``n_frames`` (the last frame), ``first_frame`` (0, or the checkpoint a
    resumed run continues from).
``frame``
    ``frame`` (its index; 0 is the input), ``wall_s`` (wall seconds since the previous frame was handed
    on: engine, rebuild and, for frame 1, the engine's build and JIT warm-up), ``sim_s`` (the engine's own
    seconds, from frame 1 on), ``n_substeps`` (the engine's substeps per frame, when it says).
``warning``
    ``message``: one line in words.
``pieces``
    ``frame``, ``pieces`` (the count, crumbs apart), ``piece_mass`` (kg, largest first), ``debris`` (the crumbs'
    count), ``debris_mass`` (kg), ``broken_mass`` (kg at or above damage 0.9) and ``cut_links`` (the rest links
    opened past their gap with a point broken) of a scene with a ``brittle`` body, at frame 0 and whenever the count
    of pieces or of crumbs changes (:mod:`gasp_core.run.pieces`).
``result``
    ``message`` (the line the console prints) and the record's fields (``gasp simulate``: ``run_json``,
    ``output``, ...).
``error``
    ``message`` (the line after ``gasp: ``) and ``status`` (the exit status, :mod:`gasp_core.errors`); a
    diverged ``gasp simulate`` that kept its frames before the blow-up adds ``output`` and ``run_json``.

Backends: :class:`Reporter` keeps the events in a list (a notebook or a test reads them);
:class:`ConsoleReporter` is what the ``gasp`` command shows (a tqdm bar, ``gasp: warning: ...`` lines on
stderr, the result line on stdout); :class:`JsonLinesReporter` writes each event as one JSON object on a
line (``gasp simulate --json``).
"""
from __future__ import annotations

import json
import math
import sys
import time
from typing import TextIO


#: What ``gasp simulate`` says before it builds the engine (the console, with progress).
BUILDING = "gasp: {engine}: building the engine (its kernels compile on a first run, cached afterwards)…"
#: What the run will write (issue 54: a big capture rewrote 125 MB a frame without a word).
WRITES = ("gasp: the run writes about {size:,.1f} MB (layout {layout}: 'split' writes what never moves once; "
          "--layout chooses)")
#: ... and once the first frame it computes is done.
BUILT = "gasp: {engine}: frame {frame} after {seconds:.3g} s (the engine's build and its kernels included)"


class Reporter:
    """Receives a run's events and keeps them in :attr:`events` (nothing is printed).

    Subclasses override :meth:`emit` (every event) or the methods of the kinds they show differently.
    """

    def __init__(self) -> None:
        self.events: list[dict] = []
        #: The first write to stdout that failed (a broken pipe, a closed stdout, a full device); the backends
        #: writing stdout stop there and the run goes on (:mod:`gasp_core.cli.streams` says it at the end).
        self.stdout_error: OSError | None = None
        #: The result's output folder (its ``output`` field), once the command has a result.
        self.output: str | None = None

    def emit(self, event: dict) -> None:
        """Every event ends here; this one keeps it."""
        self.events.append(event)

    def start(self, engine: str, n_frames: int, first_frame: int = 0, output_bytes: int | None = None,
              layout: str | None = None, estimate: dict | None = None) -> None:
        """The frames begin: ``first_frame`` is done already (a resumed run), ``n_frames`` is the last;
        ``output_bytes`` the bytes the run will write in its ``layout`` (None: not known for the format);
        ``estimate`` the time it takes (:func:`gasp_core.run.budget.start_estimate`; its ``seconds`` become the
        event's ``estimate_s``)."""
        event = {"event": "start", "engine": engine, "n_frames": n_frames, "first_frame": first_frame,
                 "output_bytes": output_bytes, "layout": layout,
                 "estimate_s": None if estimate is None else round(estimate["seconds"], 3)}
        self.emit({k: v for k, v in event.items() if v is not None})

    def frame(self, frame: int, wall_s: float, sim_s: float | None = None, n_substeps: int | None = None) -> None:
        """Frame ``frame`` is done (see the module docstring for the fields); None fields are left out."""
        event = {"event": "frame", "frame": frame, "wall_s": wall_s, "sim_s": sim_s, "n_substeps": n_substeps}
        self.emit({k: v for k, v in event.items() if v is not None})

    def end_progress(self) -> None:
        """The frames are done (or stopped): a progress display ends here."""

    def warning(self, message: str) -> None:
        """Something the user should know, in one line of words."""
        self.emit({"event": "warning", "message": message})

    def result(self, message: str, **record) -> None:
        """The command's result: ``message`` in words and its record (JSON-serialisable values)."""
        self.output = record.get("output")
        self.emit({"event": "result", "message": message, **record})

    def error(self, message: str, status: int, **record) -> None:
        """The command failed: ``message`` is the line after ``gasp: ``, ``status`` the exit status, ``record``
        what it kept (``output``, ``run_json``: JSON-serialisable values)."""
        self.end_progress()
        self.emit({"event": "error", "message": message, "status": status, **record})


class ConsoleReporter(Reporter):
    """What the ``gasp`` command shows: a tqdm bar on stderr (``progress``), ``gasp: warning: ...`` and
    ``gasp: <error>`` lines on stderr, the result line on stdout. The streams are looked up when written
    (``sys.stdout`` / ``sys.stderr`` at that moment).

    With ``progress``, the wait for the first frame is said (issue 39: a first run sat at 0 % for a minute):
    :data:`BUILDING` before the engine is built, and the seconds it took once its first frame is done
    (:data:`BUILT`)."""

    def __init__(self, progress: bool = True) -> None:
        super().__init__()
        self.progress = progress
        self._bar = None
        self._first: tuple | None = None          # (engine, frame, perf_counter at start) until that frame is done

    def emit(self, event: dict) -> None:
        """Nothing is kept: the console has shown it."""

    def start(self, engine: str, n_frames: int, first_frame: int = 0, output_bytes: int | None = None,
              layout: str | None = None, estimate: dict | None = None) -> None:
        """Say that the engine builds, what the run will write and how long it takes (with ``progress``), and open
        the progress bar, named after the engine."""
        if self.progress:
            from tqdm import tqdm
            print(BUILDING.format(engine=engine), file=sys.stderr, flush=True)
            if output_bytes is not None:
                print(WRITES.format(size=output_bytes / 1e6, layout=layout), file=sys.stderr, flush=True)
            if estimate is not None:
                print(estimate["line"], file=sys.stderr, flush=True)
            self._first = (engine, first_frame + 1, time.perf_counter())
            self._bar = tqdm(total=n_frames, initial=first_frame, unit="frame", desc=engine, leave=True)

    def frame(self, frame: int, wall_s: float, sim_s: float | None = None, n_substeps: int | None = None) -> None:
        """One step of the bar for each simulated frame (frame 0, the input, is not counted); after the first one
        computed, the line :data:`BUILT`."""
        if self._bar is not None and frame > 0:
            if self._first is not None and frame >= self._first[1]:
                engine, _, t0 = self._first
                self._first = None
                self._bar.write(BUILT.format(engine=engine, frame=frame, seconds=time.perf_counter() - t0),
                                file=sys.stderr)
            self._bar.update(1)

    def end_progress(self) -> None:
        """Close the bar, so that a line printed next starts a line of its own."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def warning(self, message: str) -> None:
        print(f"gasp: warning: {message}", file=sys.stderr)

    def result(self, message: str, **record) -> None:
        """The line on stdout, flushed at once; a failed write is kept (:attr:`stdout_error`), not raised."""
        self.output = record.get("output")
        try:
            print(message)
            if sys.stdout is not None:
                sys.stdout.flush()
        except OSError as e:
            self.stdout_error = self.stdout_error or e

    def error(self, message: str, status: int, **record) -> None:
        self.end_progress()
        print(f"gasp: {message}", file=sys.stderr)


class JsonLinesReporter(Reporter):
    """Each event as one JSON object on a line of ``stream`` (flushed at once); warnings and the error are
    also said on stderr as the console says them (``gasp: warning: ...``, ``gasp: error: ...``). A write that
    fails (the reader went away, a full device) is kept in :attr:`stdout_error` and ends the lines, not the run.

    Floats that are not finite are written as null (JSON has no NaN).
    """

    def __init__(self, stream: TextIO) -> None:
        super().__init__()
        self.stream = stream

    def emit(self, event: dict) -> None:
        """One line on the stream, flushed; after a failed write (kept in :attr:`stdout_error`) nothing more."""
        if self.stdout_error is not None:
            return
        clean = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in event.items()}
        try:
            self.stream.write(json.dumps(clean, default=str, allow_nan=False) + "\n")
            self.stream.flush()
        except OSError as e:
            self.stdout_error = e

    def warning(self, message: str) -> None:
        super().warning(message)
        print(f"gasp: warning: {message}", file=sys.stderr)

    def error(self, message: str, status: int, **record) -> None:
        """The event's ``message`` without the line's ``error: `` prefix; the line itself on stderr."""
        super().error(message.removeprefix("error: "), status, **record)
        print(f"gasp: {message}", file=sys.stderr)


def left_domain_row(reporter: Reporter, frame: int, left: int, warned: bool) -> bool:
    """The frame's ``run.json`` figure ``left_domain`` (points out of the grid, feature ``left_domain``): the first
    frame with any says so once through ``reporter``; returns whether that warning has been given."""
    if left and not warned:
        reporter.warning(f"frame {frame}: {left} point(s) left the domain: they stay there, out of the simulation "
                         "(run.json left_domain counts them; walls or a larger domain keep them)")
    return warned or bool(left)


def stranded_warning(reporter: Reporter, stranded: int | None, n_passive: int) -> None:
    """The engine's ``passive_stranded`` count (surface points the material left behind at the last frame) as a
    warning through ``reporter``; nothing when it is 0 or None."""
    if stranded:
        reporter.warning(
            f"{stranded} of {int(n_passive)} passive surface points had no material within their interpolation "
            "stencil at the last frame: they stayed where the material left them (pieces of surface left hanging, "
            "typical of sand or liquid flowing away); surface = \"material\" simulates the surface points as material")
