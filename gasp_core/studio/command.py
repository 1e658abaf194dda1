"""``gasp studio`` command-line handler (argparse wiring for :mod:`gasp_core.cli.main`)."""
from __future__ import annotations

import sys
from pathlib import Path

from gasp_core.errors import SceneError


def add_parser(sub) -> None:
    """Add the ``studio`` subcommand to an argparse subparsers object."""
    s = sub.add_parser("studio", help="open a splat file or scene in the browser: click to select, pick a "
                                      "material, run and watch (viser)")
    s.add_argument("input", type=Path, help="a Gaussian Splatting file (any format 'gasp info' reads) or a scene .toml")
    s.add_argument("--workdir", type=Path, default=None,
                   help="folder for the studio's scene file, selection masks and runs (default: "
                        "./studio/<input name>)")
    s.add_argument("--save-dir", type=Path, default=None,
                   help="folder where 'Save scene' and 'Export page' may write (default: the --workdir); the page "
                        "names a file inside it, never outside")
    s.add_argument("--host", default="127.0.0.1",
                   help="interface to listen on (default 127.0.0.1: this machine only; the page and its websocket "
                        "need the token in the printed URL)")
    s.add_argument("--port", type=int, default=8080, help="TCP port (default 8080; 0: the next free one)")
    s.set_defaults(func=cmd_studio)


def cmd_studio(args) -> int:
    from gasp_core.render.commands import check_host, check_port
    check_port(args.port)
    check_host(args.host)
    if not args.input.exists():
        raise SceneError(f"{args.input}: no such file; expected a Gaussian Splatting file or a scene .toml")
    workdir = args.workdir or Path("studio") / args.input.stem
    if workdir.exists() and not workdir.is_dir():
        raise SceneError(f"--workdir {workdir}: exists and is not a folder")
    workdir.mkdir(parents=True, exist_ok=True)
    save_dir = args.save_dir
    if save_dir is not None:
        if save_dir.exists() and not save_dir.is_dir():
            raise SceneError(f"--save-dir {save_dir}: exists and is not a folder")
        save_dir.mkdir(parents=True, exist_ok=True)
    from gasp_core.studio.app import serve
    try:
        serve(args.input, workdir, host=args.host, port=args.port, save_dir=save_dir)
    except KeyboardInterrupt as e:
        print(f"gasp: studio stopped by {getattr(e, 'signal_name', 'Ctrl-C')}", file=sys.stderr)
        return 130
    return 0
