"""``gasp render`` and ``gasp view`` command-line handlers (argparse wiring for :mod:`gasp_core.cli.main`)."""
from __future__ import annotations

import math
import sys
import time

from gasp_core.errors import SceneError
from gasp_core.fsmarker import record_written

#: Largest picture ``gasp render`` makes, pixels (width x height of all runs side by side): 8K UHD.
MAX_PIXELS = 7680 * 4320
#: Largest GIF, bytes of its frames held in memory (a GIF is written from all its frames at once).
MAX_GIF_BYTES = 2 * 2**30
#: Largest frames per second of a video.
MAX_FPS = 1000.0
#: ``--camera`` presets: what the camera frames (``gasp_core.render.run.FRAMINGS``, kept light to import here).
FRAMINGS = ("moving", "scene")


def _vec3(text: str, what: str):
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not all(math.isfinite(x) and abs(x) <= 1e6 for x in v):
        raise SceneError(f"{what}: expected three comma-separated finite numbers within +-1e6 (metres), got {text!r}")
    return v


def _check_render_args(args, size) -> None:
    """Refuse (one :class:`SceneError` line) a field of view, fps, orbit or picture size that cannot be rendered,
    before any run is read."""
    if not (math.isfinite(args.fov) and 0.0 < args.fov < 180.0):
        raise SceneError(f"--fov: expected a field of view between 0 and 180 degrees (exclusive), got {args.fov:g}")
    if args.fps is not None and not (math.isfinite(args.fps) and 0.0 < args.fps <= MAX_FPS):
        raise SceneError(f"--fps: expected frames per second in (0, {MAX_FPS:g}], got {args.fps:g}")
    if args.orbit is not None and not (math.isfinite(args.orbit) and abs(args.orbit) <= 36000.0):
        raise SceneError(f"--orbit: expected finite degrees within +-36000 (100 turns), got {args.orbit:g}")
    if size is not None and size[0] * size[1] * len(args.runs) > MAX_PIXELS:
        raise SceneError(f"--resolution {args.resolution}: {size[0] * size[1] * len(args.runs):,} pixels per picture "
                         f"({len(args.runs)} run(s) side by side); at most {MAX_PIXELS:,} (7680x4320)")
    if (args.camera and args.camera not in FRAMINGS and args.look_at
            and _vec3(args.camera, "--camera") == _vec3(args.look_at, "--look-at")):
        raise SceneError(f"--camera {args.camera} and --look-at {args.look_at} are the same point; the camera "
                         "must look at a point away from it")


def add_parsers(sub) -> None:
    """Add the ``render`` and ``view`` subcommands to an argparse subparsers object."""
    r = sub.add_parser("render", help="render a run (or runs side by side) to .mp4, .gif or a PNG folder")
    r.add_argument("runs", nargs="+", help="run folder(s) written by 'gasp simulate'; several render side by side")
    r.add_argument("-o", "--output", default=None,
                   help="out.mp4, out.gif, or a folder for PNG frames (default: RUN/render.mp4; for several "
                        "runs RUN1_vs_RUN2.mp4 beside the first)")
    r.add_argument("--overwrite", action="store_true", help="replace an existing output (default: refuse)")
    r.add_argument("--renderer", default=None, help="renderer plugin (default: cpu, else numpy; see 'gasp plugins')")
    r.add_argument("--resolution", default=None,
                   help="WIDTHxHEIGHT per run, pixels (default 640x480; with --camera-index the camera's own)")
    r.add_argument("--fov", type=float, default=40.0, help="vertical field of view, degrees (default 40)")
    r.add_argument("--camera", default=None,
                   help="camera position x,y,z, world metres, z up; or a preset: 'moving' (the default: framing the "
                        "simulated part over the sequence, all of it where everything moves), 'scene' (framing the "
                        "whole sequence)")
    r.add_argument("--look-at", default=None, help="point the camera looks at, x,y,z metres (default: the centre)")
    r.add_argument("--camera-index", type=int, default=None, metavar="N",
                   help="render from camera N (0 = first) of the capture's graphdeco cameras.json (default: off)")
    r.add_argument("--cameras", default=None, metavar="JSON",
                   help="the cameras.json for --camera-index (default: found beside the first object's PLY "
                        "or up to three folders above it)")
    r.add_argument("--orbit", type=float, default=None, metavar="DEGREES",
                   help="circle the scene about the vertical by DEGREES over the video (default: still camera)")
    r.add_argument("--camera-path", default=None, metavar="JSON",
                   help='keyframed camera: {"keyframes": [{"frame": 0, "position": [x,y,z], "look_at": [x,y,z]}, '
                        '...]}, world metres, frame = video frame, one keyframe per frame; linear in between '
                        '(default: off)')
    r.add_argument("--fps", type=float, default=None, help="video frames per second (default: 1 / frame_dt of the run)")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar (default: show one)")
    r.set_defaults(func=cmd_render)
    v = sub.add_parser("view", help="play a run in the browser (viser)")
    v.add_argument("run", help="run folder written by 'gasp simulate'; a run still in progress shows its frames so far "
                               "and follows the new ones")
    v.add_argument("--host", default="127.0.0.1", help="interface to listen on (default 127.0.0.1: this machine only)")
    v.add_argument("--port", type=int, default=8080, help="TCP port (default 8080)")
    v.add_argument("--camera", choices=FRAMINGS, default="moving",
                   help="what the first camera frames: 'moving' the simulated part (default), 'scene' everything")
    v.add_argument("--export", default=None, metavar="PAGE",
                   help="write a self-contained player instead of serving: PAGE.html, or a folder that gets "
                        "index.html; it opens from disk in a browser, no server needed (default: serve)")
    v.add_argument("--overwrite", action="store_true", help="replace an existing --export page (default: refuse)")
    v.set_defaults(func=cmd_view)


def _camera_path(args, run_dirs, size):
    """The ``--camera-index`` / ``--orbit`` / ``--camera-path`` choice as a camera path (or ``None``)."""
    from gasp_core.render import paths
    chosen = [o for o, v in (("--camera-index", args.camera_index), ("--orbit", args.orbit),
                             ("--camera-path", args.camera_path),
                             ("--camera", None if args.camera in FRAMINGS else args.camera)) if v is not None]
    if len(chosen) > 1:
        raise SceneError(f"{' and '.join(chosen)}: choose one way to place the camera")
    if args.orbit is not None:
        return paths.orbit_path(args.orbit)
    if args.camera_path is not None:
        return paths.keyframe_path(args.camera_path)
    if args.camera_index is None:
        if args.cameras is not None:   # it was ignored without a word: the default camera rendered
            raise SceneError(f"--cameras {args.cameras}: names the cameras.json for --camera-index; "
                             "give --camera-index N too")
        return None
    from gasp_core.render.run import load_run
    obj = load_run(run_dirs[0]).objects[0]
    found = args.cameras or paths.find_cameras_json(obj.get("file", ""))
    if found is None:
        raise SceneError(f"--camera-index: no cameras.json beside {obj.get('file')!r} or above it; name one "
                         "with --cameras")
    cam = paths.graphdeco_camera(found, args.camera_index, obj["placement"], *(size or (None, None)))
    return lambda lo, hi, n, *_: [cam] * n


def cmd_render(args) -> int:
    from gasp_core.render.registry import get_renderer
    from gasp_core.render.run import default_output, load_run, render_run
    size = None
    if args.resolution:
        try:
            size = tuple(int(x) for x in args.resolution.lower().split("x"))
            assert len(size) == 2 and min(size) >= 2
        except (ValueError, AssertionError):
            raise SceneError(f"--resolution: expected WIDTHxHEIGHT in pixels, got {args.resolution!r}") from None
    _check_render_args(args, size)
    framing = args.camera if args.camera in FRAMINGS else "moving"
    pos = _vec3(args.camera, "--camera") if args.camera and args.camera not in FRAMINGS else None
    look = _vec3(args.look_at, "--look-at") if args.look_at else None
    path = _camera_path(args, args.runs, size)
    w, h = size or (640, 480)
    if args.camera_index is not None:               # the capture camera's own size unless --resolution
        w, h = path(None, None, 1)[0].width, path(None, None, 1)[0].height
    if args.output == "":   # read as "not given", it wrote RUN/render.mp4
        raise SceneError("-o '': expected the video's file name (.mp4, .gif) or a folder for PNG frames")
    output = args.output or default_output(args.runs)
    if w * h * len(args.runs) > MAX_PIXELS:
        raise SceneError(f"--camera-index {args.camera_index}: the camera's {w}x{h} px exceed {MAX_PIXELS:,} pixels "
                         "per picture; pass a smaller --resolution")
    runs = [load_run(p) for p in args.runs]
    n = min(r.n_frames for r in runs)
    dt = runs[0].frame_dt
    fps = args.fps if args.fps is not None else (1.0 / dt if math.isfinite(dt) and dt > 0 else math.nan)
    if not (math.isfinite(fps) and 0.0 < fps <= MAX_FPS):
        raise SceneError(f"{args.runs[0]}/run.json: frame_dt = {runs[0].frame_dt!r} gives {fps:g} frames per "
                         f"second; pass --fps")
    if str(output).lower().endswith(".gif") and n * w * h * len(runs) * 3 > MAX_GIF_BYTES:
        raise SceneError(f"{output}: a GIF of {n} frames of {w * len(runs)}x{h} px needs "
                         f"{n * w * h * len(runs) * 3 / 2**30:.1f} GiB in memory (at most "
                         f"{MAX_GIF_BYTES / 2**30:g}); write .mp4 or a PNG folder, or lower --resolution")
    t0 = time.perf_counter()
    out = render_run(args.runs, output, overwrite=args.overwrite, fps=fps, renderer=get_renderer(args.renderer),
                     width=w, height=h, fov_deg=args.fov, position=pos, look_at=look, progress=not args.quiet,
                     camera_path=path, framing=framing)
    took = time.perf_counter() - t0
    record_written(out)      # RUN/render.mp4: gasp's own, so gasp simulate --overwrite may replace it (issue 68)
    print(f"wrote {out}: {n} frames of {w * len(runs)}x{h} px, plays {n / fps:.2f} s at {fps:g} fps "
          f"(rendering took {took:.1f} s, {took / max(n, 1):.2f} s per frame)")
    return 0


def check_port(port: int) -> None:
    """Refuse (one :class:`SceneError` line) a ``--port`` that is not a TCP port (``gasp view``, ``gasp studio``)."""
    if not 0 <= port <= 65535:
        raise SceneError(f"--port {port}: expected a TCP port from 0 to 65535 (0: the next free one)")


def check_host(host: str) -> None:
    """Refuse a ``--host`` this machine cannot listen on (``gasp view``, ``gasp studio``), before the server starts:
    viser's server thread fails on it without a word and its constructor then waits forever (round 101b).

    Raises
    ------
    SceneError
        ``host`` does not resolve (``256.1.1.1``, ``bad host``) or is not an address of this machine.
    """
    import socket
    try:
        family, kind, proto, _, address = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)[0]
        with socket.socket(family, kind, proto) as probe:
            probe.bind(address)
    except (OSError, UnicodeError) as e:
        raise SceneError(f"--host {host!r}: cannot listen there ({getattr(e, 'strerror', None) or e}); expected an "
                         "address of this machine (127.0.0.1, the default; 0.0.0.0: every interface)") from None


def cmd_view(args) -> int:
    check_port(args.port)
    if args.export == "":
        raise SceneError("--export '': expected the page's file name (or a folder, which gets index.html)")
    if args.export:
        from gasp_core.render.export import export_page
        from gasp_core.render.live import LIVE, locate
        if locate(args.run)[1] in LIVE:
            raise SceneError(f"{args.run}: a run still in progress; --export it once it has finished, or watch it "
                             f"with 'gasp view {args.run}'")
        out = export_page(args.run, args.export, overwrite=args.overwrite)
        record_written(out)  # a page written into a run folder: gasp's own, as gasp render's video (issue 68)
        print(f"wrote {out} ({out.stat().st_size / 1e6:.1f} MB; open it in a browser, no server needed)")
        return 0
    check_host(args.host)
    from gasp_core.render.viewer import serve
    try:
        serve(args.run, host=args.host, port=args.port, framing=args.camera)
    except KeyboardInterrupt as e:  # a viewer writes nothing: "no partial output was kept" would not fit
        print(f"gasp: viewer stopped by {getattr(e, 'signal_name', 'Ctrl-C')}", file=sys.stderr)
        return 130
    return 0
