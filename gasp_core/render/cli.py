"""``gasp render`` and ``gasp view`` command-line handlers (argparse wiring for :mod:`gasp_core.cli.main`)."""
from __future__ import annotations

import time

from gasp_core.errors import SceneError


def _vec3(text: str, what: str):
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3:
        raise SceneError(f"{what}: expected three comma-separated numbers (metres), got {text!r}")
    return v


def add_parsers(sub) -> None:
    """Add the ``render`` and ``view`` subcommands to an argparse subparsers object."""
    r = sub.add_parser("render", help="render a run (or runs side by side) to .mp4, .gif or a PNG folder")
    r.add_argument("runs", nargs="+", help="run folder(s) written by 'gasp simulate'")
    r.add_argument("-o", "--output", required=True, help="out.mp4, out.gif, or a folder for PNG frames")
    r.add_argument("--overwrite", action="store_true")
    r.add_argument("--renderer", default=None, help="renderer plugin (default: cpu, else numpy)")
    r.add_argument("--resolution", default="640x480", help="WIDTHxHEIGHT per run, pixels (default 640x480)")
    r.add_argument("--fov", type=float, default=40.0, help="vertical field of view, degrees")
    r.add_argument("--camera", default=None, help="camera position x,y,z (world metres, z up)")
    r.add_argument("--look-at", default=None, help="point the camera looks at, x,y,z")
    r.add_argument("--fps", type=float, default=None, help="default: 1 / frame_dt of the run")
    r.add_argument("-q", "--quiet", action="store_true")
    r.set_defaults(func=cmd_render)
    v = sub.add_parser("view", help="play a run in the browser (viser)")
    v.add_argument("run", help="run folder written by 'gasp simulate'")
    v.add_argument("--host", default="127.0.0.1", help="interface to listen on (default 127.0.0.1: this machine only)")
    v.add_argument("--port", type=int, default=8080, help="TCP port (default 8080)")
    v.add_argument("--export", default=None, metavar="PAGE",
                   help="write a self-contained player instead of serving: PAGE.html, or a folder that gets "
                        "index.html; it opens from disk in a browser, no server needed (default: serve)")
    v.add_argument("--overwrite", action="store_true", help="replace an existing --export page (default: refuse)")
    v.set_defaults(func=cmd_view)


def cmd_render(args) -> int:
    from gasp_core.render.registry import get_renderer
    from gasp_core.render.run import render_run
    try:
        w, h = (int(x) for x in args.resolution.lower().split("x"))
    except ValueError:
        raise SceneError(f"--resolution: expected WIDTHxHEIGHT, got {args.resolution!r}") from None
    pos = _vec3(args.camera, "--camera") if args.camera else None
    look = _vec3(args.look_at, "--look-at") if args.look_at else None
    t0 = time.perf_counter()
    out = render_run(args.runs, args.output, overwrite=args.overwrite, fps=args.fps,
                     renderer=get_renderer(args.renderer), width=w, height=h, fov_deg=args.fov,
                     position=pos, look_at=look, progress=not args.quiet)
    print(f"wrote {out} ({time.perf_counter() - t0:.1f} s)")
    return 0


def cmd_view(args) -> int:
    if args.export:
        from gasp_core.render.export import export_page
        out = export_page(args.run, args.export, overwrite=args.overwrite)
        print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB; open it in a browser, no server needed)")
        return 0
    from gasp_core.render.viewer import serve
    serve(args.run, host=args.host, port=args.port)
    return 0
