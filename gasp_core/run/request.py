"""What a run is asked to do beyond its scene: :class:`SimulateRequest`, the options of ``gasp simulate``.

Each field is declared once, with its default, its command-line flag and its help text (field
``metadata``); :mod:`gasp_core.cli.simulate` builds the command's options from these fields and hands the
parsed values to :func:`gasp_core.run.pipeline.simulate_scene` as one request.
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

from gasp_core.errors import extra_hint, GaspError
from gasp_core.gs.registry import output_formats

#: Output formats (:mod:`gasp_core.gs.registry`, written by :mod:`gasp_core.run.layout`).
FORMATS = output_formats()
#: Output layouts (:mod:`gasp_core.run.layout`).
LAYOUTS = ("frames", "split")


def _option(default, flags: tuple[str, ...], help: str, **cli):
    """A request field that is also a ``gasp simulate`` option: ``flags``, ``help`` and argparse extras
    (``choices``, ``count=True`` for an integer >= 1) in its metadata."""
    return field(default=default, metadata={"flags": flags, "help": help, **cli})


@dataclass(frozen=True, kw_only=True)
class SimulateRequest:
    """The options of one run (keyword-only; every field has a default).

    Raises
    ------
    GaspError
        ``resume`` and ``discard`` both set; ``hold`` not a file path (empty, ``.``, a folder).
    """

    #: Replace an existing gasp output folder (only after the new run succeeded).
    overwrite: bool = _option(False, ("--overwrite",),
                              "replace an existing output folder written by gasp, never one holding the inputs "
                              "(default: refuse)")
    #: Continue a stopped or killed run from its last checkpoint (:mod:`gasp_core.run.resume`; engines with ``state``).
    resume: bool = _option(False, ("--resume",),
                           "continue a stopped or killed run to the same folder from its last complete frame "
                           "(default: off)")
    #: Throw a stopped or killed run's partial output away and start again.
    discard: bool = _option(False, ("--discard",),
                            "throw away a stopped or killed run's partial output and start again (default: off)")
    #: Run even when it would take longer than :data:`gasp_core.run.budget.MAX_S`.
    yes: bool = _option(False, ("--yes",),
                        "run even when the work estimate is beyond the bound (24 h at the measured rate; "
                        "default: refuse)")
    #: Simulated frames, overriding the scene's ``n_frames``.
    n_frames: int | None = _option(None, ("--frames",), "simulated frames, >= 1 (default: the scene's n_frames)",
                                   count=True)
    #: Frame file format, one of :data:`FORMATS`.
    fmt: str = _option("ply", ("--format",),
                       "frame file format (default: ply; compressed_ply, spz, sog need the formats extra "
                       f"({extra_hint('formats')}), glb, glb_sequence and usd (one file per run beside PLY frames) "
                       f"the export extra ({extra_hint('export')}); sizes and precision: docs/formats.md)",
                       choices=FORMATS)
    #: Output layout, one of :data:`LAYOUTS`; None: ``frames`` for ``ply``, else ``split``.
    layout: str | None = _option(None, ("--layout",),
                                 "'frames': every frame file complete; 'split': static objects and unselected rows "
                                 "written once, frames.json lists the files (default: frames for ply, else split)",
                                 choices=LAYOUTS)
    #: Engine name, overriding the scene's ``[engine] name``.
    engine: str | None = _option(None, ("--engine",),
                                 "engine name (default: the scene's [engine] name; see 'gasp engines')")
    #: Hold the run after its first frame while this file exists (:mod:`gasp_core.run.hold`); None: no hold.
    hold: str | None = _option(None, ("--hold",),
                               "after the first frame (its files written), wait while this file exists, at most "
                               "30 min, then go on: a front end starts a run before its user asks for it "
                               "(docs/studio.md; default: no wait)")
    #: No progress bar on the default console reporter (:class:`gasp_core.run.report.ConsoleReporter`).
    quiet: bool = _option(False, ("-q", "--quiet"), "no progress bar (default: show one)")

    def __post_init__(self) -> None:
        if self.resume and self.discard:
            raise GaspError("--resume and --discard exclude each other: continue the stopped run, or throw it away")
        if self.hold is not None:
            from pathlib import Path
            h = Path(self.hold)
            if not str(self.hold).strip() or h.name in ("", ".", "..") or h.is_dir():
                raise GaspError(f"--hold {self.hold!r}: expected the path of a file whose removal releases the run "
                                "(not empty, not a folder)")


def option_fields():
    """The :class:`SimulateRequest` fields in declaration order (each with its CLI ``metadata``)."""
    return fields(SimulateRequest)
