"""``gasp`` command line: simulate, engines, info; compare and bench with the studies extra.

Every error is one line on stderr, ``gasp: error: ...``, with an exit status from the error
contract (:mod:`gasp_core.errors`): 2 for what the user can fix (bad input, unknown engine,
missing capability, existing output, a folder that cannot be written), 3 when the engine blew up,
4 for a bug in an engine (its traceback saved to a file the line names), 1 for any other exception (the last
resort: a bug in gasp, one line, its traceback saved to a file the line names), 130 when stopped
(Ctrl-C, SIGTERM, SIGHUP: ``gasp simulate`` finishes the frame in flight and keeps the finished frames
for ``--resume``, :mod:`gasp_core.run.stop`). NumPy's floating-point warnings are held back and
printed only after a run that succeeded: before an error line they would be noise.

Stdout is the command's report, never its result: a reader that stops reading stops the run with its frames
kept for ``--resume`` (exit 141), a closed stdout or a full device (one line, exit 2) lets it finish
(:mod:`gasp_core.cli.streams`).

Warnings (gasp's own and Python's), the result and the error line go through one reporter
(:mod:`gasp_core.run.report`): the console's, or JSON lines on stdout for ``gasp simulate --json``
(:mod:`gasp_core.cli.simulate`).
"""
from __future__ import annotations

import argparse
import functools
import json
import os
import sys
from pathlib import Path

import warnings

from gasp_core.cli import early, streams
from gasp_core.cli.args import (MAX_STRIP_FRAMES, GaspArgumentParser, add_export_parser, grid_size, length,
                                positive_float, positive_int, strip_count)
from gasp_core.cli.engines import cmd_engines
from gasp_core.cli.place import add_place_parser
from gasp_core.cli.simulate import add_simulate_parser, reporter_for
from gasp_core.errors import (EngineBug, EngineDivergence, GaspError, SceneError, extra_hint, missing_module_message,
                              save_traceback)
from gasp_core.scene.values import UP_AXES
from gasp_core.run import stop
from gasp_core.run.report import ConsoleReporter, Reporter


def _cmd_plugins(args) -> int:
    """Every installed plugin record by kind (engines, renderers, soup writers): the one registry,
    :func:`gasp_core.seam.plugins.registered`, so ``GASP_LOAD_PLUGINS`` narrows this list too."""
    from gasp_core.render.registry import renderers
    from gasp_core.seam.plugins import BROKEN, engines, soup_writers
    kinds = {"engines": engines(), "renderers": renderers(), "soup_writers": soup_writers()}
    for name, (dist, err) in BROKEN.items():
        args.reporter.warning(f"plugin '{name}' ({dist}) fails to import: {err}")
    if args.json:
        print(json.dumps({kind: {n: {"distribution": r.distribution, "version": r.version,
                                     "available": (r.unavailable_reason() if hasattr(r, "unavailable_reason")
                                                   else None) or "yes",
                                     "description": r.description} for n, r in found.items()}
                          for kind, found in kinds.items()}
                         | {"broken": {n: {"distribution": d, "error": err} for n, (d, err) in BROKEN.items()}},
                         indent=2))
        return 0
    for kind, found in kinds.items():
        print(f"{kind.replace('_', ' ')}:" + ("" if found else " none"))
        for n, r in found.items():
            reason = r.unavailable_reason() if hasattr(r, "unavailable_reason") else None
            print(f"    {n}  ({r.distribution} {r.version})" + (f"  NOT AVAILABLE: {reason}" if reason else "")
                  + (f"  {r.description}" if r.description and not reason else ""))
    return 0


def _cmd_info(args) -> int:
    from gasp_core.cli.info import info
    with warnings.catch_warnings():          # the fill's and the floaters' warnings are reported as fields
        warnings.simplefilter("ignore")
        d = info(args.file, size=args.size, rho=args.rho, n_grid=args.n_grid, up=args.up)
    if args.json:
        print(json.dumps(d, indent=2, default=str))
        return 0
    for k, v in d.items():
        if k == "up_vector" and v is None:
            v = "unsure (no support plane sure enough: see up_figures)"
        elif isinstance(v, dict) and not all(isinstance(c, dict) for c in v.values()):   # the support plane
            v = ", ".join(f"{n} {x}" for n, x in v.items())
        elif isinstance(v, dict):          # up_axis_candidates: one line per axis
            v = [f"{a}: " + ", ".join(f"{n} {x:.4g}" for n, x in c.items()) for a, c in v.items()]
        if isinstance(v, list) and v and isinstance(v[0], str):   # the cues: one line each
            v = ("\n" + " " * 20).join(v)
        print(f"{k:>18}: {v}")
    return 0


def _studies(module: str):
    """``gasp_studies.<module>``, imported only for compare and bench (an optional extra)."""
    import importlib
    import importlib.util
    missing = [m for m in ("gasp_studies", "distributed") if importlib.util.find_spec(m) is None]
    if missing:
        raise GaspError(f"'gasp {module}' needs the studies extra ({', '.join(missing)} not installed): "
                        f"{extra_hint('studies')}")
    return importlib.import_module(f"gasp_studies.{module}")


def _engine_names(text: str | None) -> list[str] | None:
    """``--engines`` as a list of names (None where it is not given: every engine that can run the scene).

    Raises
    ------
    SceneError
        Given but naming no engine (``--engines ""``: round 100, it ran every engine as if not given)."""
    if text is None:
        return None
    names = [e.strip() for e in text.split(",") if e.strip()]
    if not names:
        raise SceneError(f"--engines: expected comma-separated engine names (see 'gasp engines'), got {text!r}; "
                         "leave it out to run every engine that can")
    return names


def _cmd_compare(args) -> int:
    kw = {} if args.timeout is None else {"timeout_s": args.timeout}
    _studies("compare").compare_scene(
        args.scene, _engine_names(args.engines),
        args.output, overwrite=args.overwrite, n_frames=args.frames, max_gaussians=args.max_gaussians,
        scheduler=args.scheduler, workers=args.workers, n_strip_frames=args.strip_frames, **kw)
    return 0


def _cmd_bench(args) -> int:
    bench = _studies("bench")
    kw = {} if args.timeout is None else {"timeout_s": args.timeout}
    bench.bench_scene(args.scene, args.output, engines=_engine_names(args.engines),
                      overwrite=args.overwrite, n_frames=args.frames, quick=args.quick,
                      reference_n_grid=args.reference_n_grid or None,
                      max_gaussians=bench.DEFAULT_MAX_GAUSSIANS if args.max_gaussians is None else
                      (None if args.max_gaussians == 0 else args.max_gaussians),
                      scheduler=args.scheduler, workers=args.workers, n_strip_frames=args.strip_frames, **kw)
    return 0


def _add_study_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run on an existing Dask cluster (default: a local one, a fresh process per run)")
    p.add_argument("--workers", type=int, default=1,
                   help="local worker processes running at once (default 1: comparable timings)")
    p.add_argument("--timeout", type=positive_float,
                   help="wall-clock limit of one run, seconds, finite and > 0 (default 3600 for compare, 1800 for "
                        "bench)")
    p.add_argument("--strip-frames", type=strip_count, default=6, metavar="N",
                   help=f"frames per rendered strip in the report, 0 to {MAX_STRIP_FRAMES} (default 6; 0 = none; "
                        "needs the render extra)")


def _cmd_export_soup(args) -> int:
    from gasp_core.scene.spec import load_scene
    from gasp_core.run.soup import export_soup
    m = export_soup(load_scene(args.scene), args.output, overwrite=args.overwrite)
    faces = ", ".join(f"{o['name']}: {o['n_gaussians']} faces" for o in m["objects"])
    skipped = "".join(f"; {k} skipped: {v}" for k, v in m["skipped_writers"].items())
    print(f"wrote the rest triangle soup of {len(m['objects'])} object(s) to {args.output} ({faces}){skipped}")
    return 0


def _cmd_export(args) -> int:
    from gasp_core.run.export import export_run
    r = export_run(args.run, args.format, args.output, overwrite=args.overwrite, split_pieces=args.split_pieces,
                   crack_faces=args.crack_faces, allow_missing=args.allow_missing)
    print(f"wrote {r['n_frames']} frames x {len(r['objects'])} object(s) of {args.run} as {r['format']} to "
          f"{r['output']} ({r['files']} file(s){', each piece its own node or prim' if args.split_pieces else ''})")
    return 0


def _cmd_import_motion(args) -> int:
    from gasp_core.scene.spec import load_scene
    from gasp_core.run.soup import import_motion
    s = import_motion(load_scene(args.scene), args.motion_dir, args.output, overwrite=args.overwrite)
    print(f"wrote {s['n_frames'] + 1} frames x {len(s['objects'])} object(s) to {args.output}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = GaspArgumentParser(prog="gasp", description="GASP: physics for Gaussian Splatting scenes.")
    sub = p.add_subparsers(dest="command", required=True)
    add_simulate_parser(sub)

    e = sub.add_parser("engines", help="list installed engines and their capabilities")
    e.add_argument("--json", action="store_true", help="print JSON instead of a table")
    e.add_argument("--markdown", action="store_true", help="print each engine's options and quality presets as "
                                                           "the tables of docs/engine_options.md")
    e.set_defaults(func=cmd_engines)

    pl = sub.add_parser("plugins", help="list every installed plugin record by kind: engines, renderers, "
                                        "soup writers")
    pl.add_argument("--json", action="store_true", help="print JSON instead of a table")
    pl.set_defaults(func=_cmd_plugins)

    i = sub.add_parser("info", help="describe a Gaussian Splatting file")
    from gasp_core.gs.registry import FORMATS, readable
    i.add_argument("file", type=Path, help="a Gaussian Splatting file (" + ", ".join(
        f"{FORMATS[n].title.split(':')[0]}" for n in readable()) + "; docs/formats.md)")
    i.add_argument("--json", action="store_true", help="print JSON instead of text")
    i.add_argument("--size", type=length, help="the object's real height along its up axis (1.7m, 170cm): "
                                               "prints the scale that gives it (default: none)")
    i.add_argument("--rho", type=positive_float, help="density, kg/m^3: prints the filled solid's mass (default: none)")
    i.add_argument("--n-grid", type=grid_size, default=64, help="grid of the fill reported (default 64)")
    i.add_argument("--up", choices=UP_AXES, help="the up axis, stated (write --up=-y for a minus): the height, "
                                                 "scale and stand figures along it (default: guessed; when unsure, "
                                                 "every axis listed)")
    i.set_defaults(func=_cmd_info)

    _add_study_parsers(sub)

    from gasp_core.cli.conform import add_parser as add_conform_parser
    add_conform_parser(sub)
    from gasp_core.render.commands import add_parsers as add_render_parsers
    add_render_parsers(sub)
    from gasp_core.studio.command import add_parser as add_studio_parser
    add_studio_parser(sub)

    x = sub.add_parser("export-soup", help="write the rest triangle soup per object (OBJ, PLY, ...) for a mesh tool")
    x.add_argument("scene", type=Path, help="scene file (.toml)")
    x.add_argument("-o", "--output", type=Path, required=True, help="folder for the soup files (required)")
    x.add_argument("--overwrite", action="store_true", help="replace an existing folder (default: refuse)")
    x.set_defaults(func=_cmd_export_soup)

    add_place_parser(sub)
    add_export_parser(sub, _cmd_export)

    m = sub.add_parser("import-motion", help="rebuild Gaussian frames from an animated triangle soup")
    m.add_argument("scene", type=Path, help="the scene file the soup was exported from (.toml)")
    m.add_argument("motion_dir", type=Path,
                   help="folder of the animated soup: MOTION_DIR/<object>/*.obj|*.ply, one file per frame")
    m.add_argument("-o", "--output", type=Path, required=True, help="output folder for the Gaussian frames (required)")
    m.add_argument("--overwrite", action="store_true", help="replace an existing output folder (default: refuse)")
    m.set_defaults(func=_cmd_import_motion)
    return p


def _add_study_parsers(sub) -> None:
    c = sub.add_parser("compare", help="run one scene on several engines and write a comparison report")
    c.add_argument("scene", type=Path, help="scene file (.toml)")
    c.add_argument("--engines", help="comma-separated engine names (default: all installed that can run it)")
    c.add_argument("-o", "--output", type=Path, required=True, help="report folder (required)")
    c.add_argument("--overwrite", action="store_true", help="replace an existing report folder (default: refuse)")
    c.add_argument("--frames", type=positive_int, help="simulated frames, >= 1 (default: the scene's n_frames)")
    c.add_argument("--max-gaussians", type=int,
                   help="keep every k-th Gaussian so each object has at most this many (default: all)")
    _add_study_args(c)
    c.set_defaults(func=_cmd_compare)

    b = sub.add_parser("bench", help="sweep speed/accuracy settings against a converged reference")
    b.add_argument("scene", type=Path, help="scene file (.toml)")
    b.add_argument("--engines", help="comma-separated engine names (default: all installed that can run it and offer a sweep)")
    b.add_argument("-o", "--output", type=Path, required=True, help="report folder (required)")
    b.add_argument("--overwrite", action="store_true", help="replace an existing report folder (default: refuse)")
    b.add_argument("--frames", type=positive_int, help="simulated frames, >= 1 (default: the scene's n_frames)")
    b.add_argument("--max-gaussians", type=int,
                   help="keep every k-th Gaussian so each object has at most this many (default 6000; 0 = all)")
    b.add_argument("--quick", action="store_true",
                   help="each engine's quick sweep, a few settings (default: the full sweep)")
    b.add_argument("--reference-n-grid", type=int, default=0,
                   help="a finer n_grid for the reference runs alone (default 0: each engine's own reference)")
    _add_study_args(b)
    b.set_defaults(func=_cmd_bench)


#: NumPy's floating-point warnings of this command, held back (see the module docstring).
_HELD: dict[str, int] = {}


def _show_warning(reporter: Reporter, message, category, filename, lineno, file=None, line=None):
    """``warnings.showwarning`` of the command: one line through the reporter (NumPy's floating-point ones held; a
    library's ``DeprecationWarning`` dropped: an engine's library on Python 3.12 warned of ``locale.getdefaultlocale``
    at its import, which made the first run in a process print two lines where one error was due)."""
    if issubclass(category, RuntimeWarning) and " encountered in " in str(message):   # numpy's floating point
        _HELD[str(message)] = _HELD.get(str(message), 0) + 1
        return
    origin = _foreign_origin(filename)
    if origin and issubclass(category, (DeprecationWarning, PendingDeprecationWarning)):
        return   # a library's deprecation speaks to its callers' developers, not to the user
    text = " ".join(str(message).split())         # one line, whatever the library wrote
    reporter.warning(f"from {origin} (a library GASP uses, not GASP itself): {text}" if origin else text)


def _foreign_origin(filename) -> str:
    """The installed package a warning was raised in when it is not GASP's (``""`` for GASP's own code and the
    standard library): its top-level folder under ``site-packages``/``dist-packages`` (issue 55: Dask's "Port 8787
    is already in use" read as GASP's)."""
    parts = Path(str(filename)).parts
    at = [i for i, p in enumerate(parts) if p in ("site-packages", "dist-packages")]
    if not at or at[-1] + 1 >= len(parts):
        return ""
    name = parts[at[-1] + 1].split(".")[0]
    return "" if name.startswith(("gasp", "_gasp")) else name


def main(argv: list[str] | None = None) -> int:
    streams.guard_closed()   # started with stdout closed (>&-): no file the run opens may take fd 1
    args = build_parser().parse_args(argv)
    with reporter_for(args) as reporter:   # gasp simulate --json: JSON lines, and nothing else, on stdout
        args.reporter = reporter
        warnings.showwarning = functools.partial(_show_warning, reporter)  # one line, not a source location
        warnings.filterwarnings("ignore", category=ResourceWarning)  # libraries' unclosed files: not the user's concern
        _HELD.clear()
        with stop.handlers():
            code = _run(args, reporter)
        if code == 0:
            for message, count in _HELD.items():
                reporter.warning(f"numpy: {message}" + (f" ({count} times)" if count > 1 else ""))
    code = streams.finish(reporter, code)   # stdout cut short: said once here, the run itself kept (streams)
    # later warnings (the reporter's stream may be closed now) are still one line, on stderr
    warnings.showwarning = functools.partial(_show_warning, ConsoleReporter(progress=False))
    early.finished()   # the gasp command only (gasp_core.cli.early): a later signal cannot change the status
    return code


def _run(args, reporter: Reporter) -> int:
    """``args.func(args)`` under the error contract: its exit status, and an error as one line (``reporter.error``)."""
    try:
        try:
            os.getcwd()
        except FileNotFoundError:
            raise GaspError("the working directory no longer exists (deleted or moved away); cd to an existing "
                            "folder and run again") from None
        return args.func(args)
    except (GaspError, OSError, KeyboardInterrupt) as e:
        code = _exit_status(e)
        kept = getattr(e, "kept", None) if isinstance(e, EngineDivergence) else None   # its good frames
        reporter.error(_error_line(e), code, **({} if kept is None else
                                                {"output": str(kept.resolve()),
                                                 "run_json": str((kept / "run.json").resolve())}))
        return code
    except ImportError as e:             # an optional extra that is not installed: its install line
        message = missing_module_message(e, f"'gasp {args.command}'")
        if message is None:
            return _last_resort(e, args, reporter)
        reporter.error(f"error: {message}", 2)
        return 2
    except Exception as e:               # the last resort: any other exception is one line, its traceback saved
        return _last_resort(e, args, reporter)


def _last_resort(e: Exception, args, reporter: Reporter) -> int:
    """An exception outside the error contract: one line naming it and the file its traceback was saved to
    (:func:`gasp_core.errors.save_traceback`, as :class:`EngineBug` does); exit status 1."""
    saved = save_traceback(e, f"gasp-bug-{args.command}-", f"gasp {args.command}")
    reporter.error(f"error: unexpected {type(e).__name__}: {str(e)[:300] or '(no message)'}; this is a bug in "
                   f"gasp, not in your input{f'; traceback saved to {saved}' if saved else ''}", 1)
    return 1


def _exit_status(e: BaseException) -> int:
    """The error contract's exit status (:mod:`gasp_core.errors`): 3 diverged, 4 engine bug, 130 stopped, else 2."""
    if isinstance(e, EngineDivergence):
        return 3
    if isinstance(e, EngineBug):
        return 4
    return 130 if isinstance(e, KeyboardInterrupt) else 2


def _error_line(e: BaseException) -> str:
    """``e`` in one line, after ``gasp: ``."""
    if isinstance(e, KeyboardInterrupt):
        return str(e) if isinstance(e, stop.Stopped) else "interrupted; no partial output was kept"
    if isinstance(e, EngineDivergence):
        if e.kept is None:
            return f"error: simulation diverged at {e}"
        return (f"error: simulation diverged at {e}; frames 0-{e.last_kept} before it are kept in '{e.kept}' "
                f"(run.json status 'diverged')")
    if isinstance(e, (GaspError, FileExistsError, FileNotFoundError, IsADirectoryError, NotADirectoryError)):
        return f"error: {e}"
    if isinstance(e, PermissionError):
        return f"error: permission denied: {e.filename or e}"
    return f"error: {e.strerror or e}{f': {e.filename}' if e.filename else ''}"


if __name__ == "__main__":
    sys.exit(main())
