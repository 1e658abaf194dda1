"""``gasp simulate``: its options, built from :class:`~gasp_core.run.request.SimulateRequest`, and its reporter.

The options that are request fields (``--overwrite``, ``--resume``, ``--discard``, ``--yes``, ``--frames``,
``--format``, ``--layout``, ``--engine``, ``-q``) come from the fields' metadata; the scene, ``-o``,
``--quality`` and ``--json`` are the command's own. With ``--json`` the run's events
(:mod:`gasp_core.run.report`) are JSON lines on stdout and nothing else is: what a library or an
engine prints while the command runs goes to stderr (:func:`reporter_for`).
"""
from __future__ import annotations

import contextlib
import io
import os
import sys
from pathlib import Path

from gasp_core.cli.args import positive_int
from gasp_core.errors import GaspError
from gasp_core.run.report import ConsoleReporter, JsonLinesReporter
from gasp_core.run.request import SimulateRequest, option_fields
from gasp_core.scene.quality import QUALITY_LEVELS


def add_simulate_parser(sub) -> None:
    """The ``simulate`` subcommand on ``sub`` (argparse subparsers)."""
    s = sub.add_parser("simulate", help="run a scene file and write one PLY per frame")
    s.add_argument("scene", type=Path, help="scene file (.toml); every key: docs/scene_reference.md")
    s.add_argument("-o", "--output", type=Path,
                   help="output folder, must not exist unless --overwrite (default: the scene's 'output' key)")
    for f in option_fields():
        m = f.metadata
        if isinstance(f.default, bool):
            s.add_argument(*m["flags"], dest=f.name, action="store_true", help=m["help"])
        else:
            s.add_argument(*m["flags"], dest=f.name, default=f.default, help=m["help"], choices=m.get("choices"),
                           type=positive_int if m.get("count") else None,
                           metavar=None if "choices" in m else m["flags"][-1].lstrip("-").upper())
    s.add_argument("--quality", choices=QUALITY_LEVELS,
                   help="override the scene's 'quality' level (default: the scene's, else 'default'; "
                        "docs/speed_accuracy.md, 'Quality levels')")
    s.add_argument("--json", action="store_true",
                   help="print the run's events as JSON lines on stdout, one object per line: a frame event per "
                        "frame with its timings, warnings, the result with the run.json path, or the error "
                        "(docs/cli.md; default: text and a progress bar)")
    s.set_defaults(func=cmd_simulate)


def request_from(args) -> SimulateRequest:
    """The :class:`SimulateRequest` of parsed ``gasp simulate`` arguments."""
    return SimulateRequest(**{f.name: getattr(args, f.name) for f in option_fields()})


def cmd_simulate(args) -> int:
    """Run ``args.scene`` (``args.reporter`` receives its events) and report the result; exit status 0."""
    from gasp_core.run.pieces import summary_clause
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    request = request_from(args)   # its options checked before the scene is loaded
    scene = load_scene(args.scene, quality=args.quality)
    out = args.output or scene.output
    if out is None:
        raise GaspError("no output folder: pass -o OUTDIR or set 'output' in the scene")
    reporter = args.reporter
    res = simulate_scene(scene, out, request, reporter=reporter)
    s = res.summary
    fps = len(s["frames"]) - 1
    per_frame = sum(f.get("sim_s", 0.0) for f in s["frames"]) / max(fps, 1)
    substeps = s["engine_stats"].get("n_substeps")
    per_body = s["engine_stats"].get("contact_per_body") or []   # the grid engines' contact chosen per body
    mixed = (f", contact per body: grid for {per_body.count('grid')} flowing, particle for "
             f"{per_body.count('particle')}" + (", two velocity fields" if s["engine_stats"].get("contact_fields") else "")
             if s["engine_stats"].get("contact") == "mixed" else "")
    reporter.result(f"wrote {fps + 1} frames (frame 0 = the input) x {len(s['objects'])} object(s) to {res.outdir} "
                    f"({s['n_points']} simulated points, {'-' if substeps is None else substeps} substeps/frame, "
                    f"{per_frame:.3f} s/frame{mixed}){summary_clause(s['frames'])}",
                    output=str(res.outdir.resolve()), run_json=str(res.run_json.resolve()), n_frames=fps + 1, n_objects=len(s["objects"]),
                    n_points=s["n_points"], n_substeps=substeps, sim_s_per_frame=per_frame)
    return 0


@contextlib.contextmanager
def reporter_for(args):
    """The command's reporter: JSON lines on stdout for ``gasp simulate --json``, else the console's.

    Under ``--json`` everything else written to stdout while the command runs (Python's ``print`` and, when
    stdout is a real file descriptor, what C code writes to fd 1: engine banners) goes to stderr, so that
    stdout holds the JSON lines alone.
    """
    if not (getattr(args, "command", None) == "simulate" and getattr(args, "json", False)):
        yield ConsoleReporter(progress=not getattr(args, "quiet", False))
        return
    with _stdout_to_stderr() as real_stdout:
        yield JsonLinesReporter(real_stdout)


@contextlib.contextmanager
def _stdout_to_stderr():
    """Point stdout (``sys.stdout`` and fd 1 when it has one) at stderr; yield a stream on the real stdout."""
    sys.stdout.flush()
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, io.UnsupportedOperation):
        fd = None
    if fd is None:                     # a captured stdout (pytest's capsys): Python-level redirection only
        real = sys.stdout
        with contextlib.redirect_stdout(sys.stderr):
            yield real
        return
    saved = os.dup(fd)
    real = open(saved, "w", buffering=1, encoding="utf-8", closefd=True)
    sys.stderr.flush()
    os.dup2(sys.stderr.fileno(), fd)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield real
    finally:
        sys.stderr.flush()
        try:
            real.flush()
        except OSError:         # the reporter has it (stdout_error): gasp_core.cli.streams says it
            pass
        os.dup2(saved, fd)
        try:
            real.close()        # closes ``saved`` even when its last flush fails
        except OSError:
            pass

