"""``gasp`` command line: simulate, engines, info (compare and bench where installed).

Errors the user can fix are one line on stderr, ``gasp: error: ...``, with exit status 2
(bad input, unknown engine, missing capability, existing output) or 3 (the engine blew up).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .engine import EngineDivergence, GaspError


def _cmd_simulate(args) -> int:
    from .pipeline import simulate_scene
    from .scene import load_scene
    scene = load_scene(args.scene)
    out = args.output or scene.output
    if out is None:
        raise GaspError("no output folder: pass -o OUTDIR or set 'output' in the scene")
    res = simulate_scene(scene, out, overwrite=args.overwrite, progress=not args.quiet,
                         n_frames=args.frames, engine=args.engine)
    s = res.summary
    fps = len(s["frames"]) - 1
    per_frame = sum(f.get("sim_s", 0.0) for f in s["frames"]) / max(fps, 1)
    print(f"wrote {fps + 1} frames x {len(s['objects'])} object(s) to {res.outdir} "
          f"({s['n_points']} simulated points, {s['engine_stats'].get('n_substeps', '-')} substeps/frame, "
          f"{per_frame:.3f} s/frame)")
    return 0


def _cmd_engines(args) -> int:
    from .plugins import engines
    found = engines()
    if args.json:
        print(json.dumps({n: {"distribution": e.distribution, "version": e.version,
                              "available": e.unavailable_reason() or "yes",
                              "capabilities": e.capabilities.as_dict(),
                              "description": e.description} for n, e in found.items()}, indent=2))
        return 0
    if not found:
        print("no engines installed (pip install -e plugins/taichi_mpm)")
        return 0
    for name, e in found.items():
        c = e.capabilities
        reason = e.unavailable_reason()
        print(f"{name}  ({e.distribution} {e.version})" + (f"  NOT AVAILABLE: {reason}" if reason else ""))
        print(f"    materials:  {', '.join(sorted(c.materials))}")
        print(f"    boundaries: {', '.join(sorted(c.boundaries))}")
        print(f"    devices:    {', '.join(sorted(c.devices))}; precisions: {', '.join(sorted(c.precisions))}; "
              f"dims: {', '.join(map(str, sorted(c.dims)))}")
        if e.description:
            print(f"    {e.description}")
    return 0


def _cmd_info(args) -> int:
    from .io import describe
    d = describe(args.file)
    if args.json:
        print(json.dumps(d, indent=2, default=str))
        return 0
    for k, v in d.items():
        print(f"{k:>14}: {v}")
    return 0


def _cmd_compare(args) -> int:
    from .compare import compare_scene
    compare_scene(args.scene, [e.strip() for e in args.engines.split(",") if e.strip()] if args.engines else None,
                  args.output, overwrite=args.overwrite, n_frames=args.frames, max_gaussians=args.max_gaussians)
    return 0


def _cmd_bench(args) -> int:
    from .bench import bench_scene
    from .bench import DEFAULT_MAX_GAUSSIANS
    kw = dict(n_grid=(32, 48), cfl=(0.4, 0.8), particles_per_cell=(8,), fill=(True,), precision=("f32",),
              cells_across=(4, 8), flex_cfl=(0.5,), flex_reference_cells=8) if args.quick else {}
    kw["reference_n_grid"] = args.reference_n_grid or None
    bench_scene(args.scene, args.output, engines=args.engines.split(",") if args.engines else None,
                overwrite=args.overwrite, n_frames=args.frames,
                max_gaussians=DEFAULT_MAX_GAUSSIANS if args.max_gaussians is None else
                (None if args.max_gaussians == 0 else args.max_gaussians), **kw)
    return 0


def _cmd_export_soup(args) -> int:
    from .scene import load_scene
    from .soup import export_soup
    m = export_soup(load_scene(args.scene), args.output, overwrite=args.overwrite)
    faces = ", ".join(f"{o['name']}: {o['n_gaussians']} faces" for o in m["objects"])
    skipped = "".join(f"; {k} skipped: {v}" for k, v in m["skipped_writers"].items())
    print(f"wrote the rest triangle soup of {len(m['objects'])} object(s) to {args.output} ({faces}){skipped}")
    return 0


def _cmd_import_motion(args) -> int:
    from .scene import load_scene
    from .soup import import_motion
    s = import_motion(load_scene(args.scene), args.motion_dir, args.output, overwrite=args.overwrite)
    print(f"wrote {s['n_frames'] + 1} frames x {len(s['objects'])} object(s) to {args.output}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="gasp", description="GASP: physics for Gaussian Splatting scenes.")
    sub = p.add_subparsers(dest="command", required=True)

    s = sub.add_parser("simulate", help="run a scene file and write one PLY per frame")
    s.add_argument("scene", type=Path)
    s.add_argument("-o", "--output", type=Path, help="output folder (must not exist unless --overwrite)")
    s.add_argument("--overwrite", action="store_true", help="replace an existing output folder")
    s.add_argument("--frames", type=int, help="override n_frames")
    s.add_argument("--engine", help="override the scene's engine name")
    s.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=_cmd_simulate)

    e = sub.add_parser("engines", help="list installed engines and their capabilities")
    e.add_argument("--json", action="store_true")
    e.set_defaults(func=_cmd_engines)

    i = sub.add_parser("info", help="describe a Gaussian Splatting file")
    i.add_argument("file", type=Path)
    i.add_argument("--json", action="store_true")
    i.set_defaults(func=_cmd_info)

    c = sub.add_parser("compare", help="run one scene on several engines and write a comparison report")
    c.add_argument("scene", type=Path)
    c.add_argument("--engines", help="comma-separated engine names (default: all installed that can run it)")
    c.add_argument("-o", "--output", type=Path, required=True)
    c.add_argument("--overwrite", action="store_true")
    c.add_argument("--frames", type=int)
    c.add_argument("--max-gaussians", type=int, help="keep every k-th Gaussian so each object has at most this many")
    c.set_defaults(func=_cmd_compare)

    b = sub.add_parser("bench", help="sweep speed/accuracy settings against a converged reference")
    b.add_argument("scene", type=Path)
    b.add_argument("--engines", help="comma-separated engine names (default: all installed grid engines)")
    b.add_argument("-o", "--output", type=Path, required=True)
    b.add_argument("--overwrite", action="store_true")
    b.add_argument("--frames", type=int)
    b.add_argument("--max-gaussians", type=int,
                   help="keep every k-th Gaussian so each object has at most this many (default 6000; 0 = all)")
    b.add_argument("--quick", action="store_true", help="a small sweep (n_grid 32/48, cfl 0.4/0.8, f32)")
    b.add_argument("--reference-n-grid", type=int, default=0,
                   help="a finer grid for the MPM engines' reference run alone (default 0: the finest of the sweep, n_grid 96)")
    b.set_defaults(func=_cmd_bench)

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


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except EngineDivergence as e:
        print(f"gasp: error: simulation diverged at {e}", file=sys.stderr)
        return 3
    except (FileExistsError, FileNotFoundError) as e:
        print(f"gasp: error: {e}", file=sys.stderr)
        return 2
    except GaspError as e:
        print(f"gasp: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("gasp: interrupted; no partial output was kept", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
