"""``gasp`` command line: simulate, engines, info; compare and bench with the studies extra.

Every error is one line on stderr, ``gasp: error: ...``, with an exit status from the error
contract (:mod:`gasp_core.errors`): 2 for what the user can fix (bad input, unknown engine,
missing capability, existing output, a folder that cannot be written), 3 when the engine blew up,
4 for a bug in an engine (its traceback saved to a file the line names), 130 when interrupted
(Ctrl-C, SIGTERM, SIGHUP; nothing partial is kept).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import signal
import warnings

from gasp_core.cli.args import GaspArgumentParser, length, positive_float, positive_int
from gasp_core.errors import EngineBug, EngineDivergence, GaspError


def _cmd_simulate(args) -> int:
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    scene = load_scene(args.scene)
    out = args.output or scene.output
    if out is None:
        raise GaspError("no output folder: pass -o OUTDIR or set 'output' in the scene")
    res = simulate_scene(scene, out, overwrite=args.overwrite, progress=not args.quiet,
                         n_frames=args.frames, engine=args.engine, resume=args.resume,
                         warn=lambda msg: print(f"gasp: warning: {msg}", file=sys.stderr))
    s = res.summary
    fps = len(s["frames"]) - 1
    per_frame = sum(f.get("sim_s", 0.0) for f in s["frames"]) / max(fps, 1)
    print(f"wrote {fps + 1} frames (frame 0 = the input) x {len(s['objects'])} object(s) to {res.outdir} "
          f"({s['n_points']} simulated points, {s['engine_stats'].get('n_substeps', '-')} substeps/frame, "
          f"{per_frame:.3f} s/frame)")
    return 0


def _cmd_engines(args) -> int:
    from gasp_core.seam.plugins import BROKEN, engines
    found = engines()
    for name, (dist, err) in BROKEN.items():
        print(f"gasp: warning: plugin '{name}' ({dist}) fails to import: {err}", file=sys.stderr)
    if args.json:
        print(json.dumps({n: {"distribution": e.distribution, "version": e.version,
                              "available": e.unavailable_reason() or "yes",
                              "capabilities": e.capabilities.as_dict(),
                              "options": [{"name": o.name, "default": o.default, "expected": o.expected(),
                                           "doc": o.doc} for o in e.options],
                              "limits": {k: lim.describe(k) for k, lim in e.limits.items()},
                              "deterministic_options": dict(e.deterministic_options),
                              "known_failures": dict(e.known_failures),
                              "description": e.description} for n, e in found.items()}, indent=2))
        return 0
    if not found:
        print("no engines installed (each engine is a plugin distribution: see README, 'Engines')")
        return 0
    for name, e in found.items():
        c = e.capabilities
        reason = e.unavailable_reason()
        print(f"{name}  ({e.distribution} {e.version})" + (f"  NOT AVAILABLE: {reason}" if reason else ""))
        print(f"    materials:  {', '.join(sorted(c.materials))}")
        print(f"    boundaries: {', '.join(sorted(c.boundaries))}")
        print(f"    devices:    {', '.join(sorted(c.devices))}; precisions: {', '.join(sorted(c.precisions))}")
        if c.features:
            print(f"    features:   {', '.join(sorted(c.features))}")
        for o in e.options:
            print(f"    option {o.name} = {o.default!r}: {o.doc} ({o.expected()})")
        for k, lim in e.limits.items():
            print(f"    limit {k}: {lim.describe(k)}")
        if e.known_failures:
            print(f"    known failures: {', '.join(sorted(e.known_failures))}")
        if e.description:
            print(f"    {e.description}")
    return 0


def _cmd_plugins(args) -> int:
    """Every installed plugin record by kind (engines, renderers, soup writers): the one registry,
    :func:`gasp_core.seam.plugins.registered`, so ``GASP_LOAD_PLUGINS`` narrows this list too."""
    from gasp_core.render.registry import renderers
    from gasp_core.seam.plugins import BROKEN, engines, soup_writers
    kinds = {"engines": engines(), "renderers": renderers(), "soup_writers": soup_writers()}
    for name, (dist, err) in BROKEN.items():
        print(f"gasp: warning: plugin '{name}' ({dist}) fails to import: {err}", file=sys.stderr)
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
        d = info(args.file, size=args.size, rho=args.rho, n_grid=args.n_grid)
    if args.json:
        print(json.dumps(d, indent=2, default=str))
        return 0
    for k, v in d.items():
        print(f"{k:>18}: {v}")
    return 0


def _studies(module: str):
    """``gasp_studies.<module>``, imported only for compare and bench (an optional extra)."""
    import importlib
    import importlib.util
    missing = [m for m in ("gasp_studies", "distributed") if importlib.util.find_spec(m) is None]
    if missing:
        raise GaspError(f"'gasp {module}' needs the studies extra ({', '.join(missing)} not installed): "
                        f'pip install -e ".[studies]"')
    return importlib.import_module(f"gasp_studies.{module}")


def _cmd_compare(args) -> int:
    kw = {"timeout_s": args.timeout} if args.timeout else {}
    _studies("compare").compare_scene(
        args.scene, [e.strip() for e in args.engines.split(",") if e.strip()] if args.engines else None,
        args.output, overwrite=args.overwrite, n_frames=args.frames, max_gaussians=args.max_gaussians,
        scheduler=args.scheduler, workers=args.workers, n_strip_frames=args.strip_frames, **kw)
    return 0


def _cmd_bench(args) -> int:
    bench = _studies("bench")
    kw = {"timeout_s": args.timeout} if args.timeout else {}
    bench.bench_scene(args.scene, args.output, engines=args.engines.split(",") if args.engines else None,
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
    p.add_argument("--timeout", type=float, help="wall-clock limit of one run, seconds")
    p.add_argument("--strip-frames", type=int, default=6, metavar="N",
                   help="frames per rendered strip in the report (default 6; 0 = none; needs the render extra)")


def _cmd_export_soup(args) -> int:
    from gasp_core.scene.spec import load_scene
    from gasp_core.run.soup import export_soup
    m = export_soup(load_scene(args.scene), args.output, overwrite=args.overwrite)
    faces = ", ".join(f"{o['name']}: {o['n_gaussians']} faces" for o in m["objects"])
    skipped = "".join(f"; {k} skipped: {v}" for k, v in m["skipped_writers"].items())
    print(f"wrote the rest triangle soup of {len(m['objects'])} object(s) to {args.output} ({faces}){skipped}")
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

    s = sub.add_parser("simulate", help="run a scene file and write one PLY per frame")
    s.add_argument("scene", type=Path)
    s.add_argument("-o", "--output", type=Path, help="output folder (must not exist unless --overwrite)")
    s.add_argument("--overwrite", action="store_true",
                   help="replace an existing output folder written by gasp (never one holding the inputs)")
    s.add_argument("--resume", action="store_true",
                   help="continue a killed run to the same folder from its last complete frame")
    s.add_argument("--frames", type=positive_int, help="override n_frames")
    s.add_argument("--engine", help="override the scene's engine name")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=_cmd_simulate)

    e = sub.add_parser("engines", help="list installed engines and their capabilities")
    e.add_argument("--json", action="store_true")
    e.set_defaults(func=_cmd_engines)

    pl = sub.add_parser("plugins", help="list every installed plugin record by kind: engines, renderers, "
                                        "soup writers")
    pl.add_argument("--json", action="store_true")
    pl.set_defaults(func=_cmd_plugins)

    i = sub.add_parser("info", help="describe a Gaussian Splatting file")
    i.add_argument("file", type=Path)
    i.add_argument("--json", action="store_true")
    i.add_argument("--size", type=length, help="the object's real height along its up axis (1.7m, 170cm): "
                                               "prints the scale that gives it")
    i.add_argument("--rho", type=positive_float, help="density, kg/m^3: prints the filled solid's mass")
    i.add_argument("--n-grid", type=positive_int, default=64, help="grid of the fill reported (default 64)")
    i.set_defaults(func=_cmd_info)

    c = sub.add_parser("compare", help="run one scene on several engines and write a comparison report")
    c.add_argument("scene", type=Path)
    c.add_argument("--engines", help="comma-separated engine names (default: all installed that can run it)")
    c.add_argument("-o", "--output", type=Path, required=True)
    c.add_argument("--overwrite", action="store_true")
    c.add_argument("--frames", type=positive_int)
    c.add_argument("--max-gaussians", type=int, help="keep every k-th Gaussian so each object has at most this many")
    _add_study_args(c)
    c.set_defaults(func=_cmd_compare)

    b = sub.add_parser("bench", help="sweep speed/accuracy settings against a converged reference")
    b.add_argument("scene", type=Path)
    b.add_argument("--engines", help="comma-separated engine names (default: all installed that can run it and offer a sweep)")
    b.add_argument("-o", "--output", type=Path, required=True)
    b.add_argument("--overwrite", action="store_true")
    b.add_argument("--frames", type=positive_int)
    b.add_argument("--max-gaussians", type=int,
                   help="keep every k-th Gaussian so each object has at most this many (default 6000; 0 = all)")
    b.add_argument("--quick", action="store_true", help="each engine's quick sweep (a few settings)")
    b.add_argument("--reference-n-grid", type=int, default=0,
                   help="a finer n_grid for the reference runs alone (default 0: each engine's own reference)")
    _add_study_args(b)
    b.set_defaults(func=_cmd_bench)

    from gasp_core.testing.cli import add_parser as add_conform_parser
    add_conform_parser(sub)
    from gasp_core.render.cli import add_parsers as add_render_parsers
    add_render_parsers(sub)

    x = sub.add_parser("export-soup", help="write the rest triangle soup per object (OBJ, PLY, ...) for a mesh tool")
    x.add_argument("scene", type=Path)
    x.add_argument("-o", "--output", type=Path, required=True)
    x.add_argument("--overwrite", action="store_true")
    x.set_defaults(func=_cmd_export_soup)

    m = sub.add_parser("import-motion", help="rebuild Gaussian frames from an animated triangle soup")
    m.add_argument("scene", type=Path)
    m.add_argument("motion_dir", type=Path)
    m.add_argument("-o", "--output", type=Path, required=True)
    m.add_argument("--overwrite", action="store_true")
    m.set_defaults(func=_cmd_import_motion)
    return p


def _interrupt(signum, _frame):
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    print(f"gasp: warning: {message}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    warnings.showwarning = _show_warning  # a warning is one line, not a source location and code
    warnings.filterwarnings("ignore", category=ResourceWarning)  # libraries' unclosed files: not the user's concern
    previous = {}
    for sig in (signal.SIGTERM, signal.SIGHUP):
        try:
            previous[sig] = signal.signal(sig, _interrupt)
        except ValueError:  # not the main thread (tests calling main in a thread)
            pass
    try:
        return args.func(args)
    except EngineDivergence as e:
        print(f"gasp: error: simulation diverged at {e}", file=sys.stderr)
        return 3
    except EngineBug as e:
        print(f"gasp: error: {e}", file=sys.stderr)
        return 4
    except (GaspError, FileExistsError, FileNotFoundError, IsADirectoryError, NotADirectoryError) as e:
        print(f"gasp: error: {e}", file=sys.stderr)
        return 2
    except PermissionError as e:
        print(f"gasp: error: permission denied: {e.filename or e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"gasp: error: {e.strerror or e}{f': {e.filename}' if e.filename else ''}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as e:
        why = f" by {e.args[0]}" if e.args else ""
        print(f"gasp: interrupted{why}; no partial output was kept", file=sys.stderr)
        return 130
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":
    sys.exit(main())
