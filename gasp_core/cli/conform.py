"""``gasp conform ENGINE [--scenes a,b] [--slow] [--json]``: the conformance kit from the command line.

Exit status 0 when every scene passed, was skipped for a missing capability or failed as a declared
known failure; 1 otherwise (a failure, an ``EngineBug``, or a known failure that passed). An unknown
engine or scene, or a ``--scenes`` naming none, is a user error (exit 2, through :func:`gasp_core.cli.main.main`).
"""
from __future__ import annotations

import json


def add_parser(sub) -> None:
    """Add the ``conform`` subcommand to the ``gasp`` argument parser's subparsers."""
    c = sub.add_parser("conform", help="run the engine conformance scenes (error contract included) on one engine")
    c.add_argument("engine", help="an installed engine's name (see 'gasp engines')")
    c.add_argument("--scenes", help="comma-separated scene names (default: all but the slow ones)")
    c.add_argument("--slow", action="store_true", help="include the slow scenes (default: skip them)")
    c.add_argument("--json", action="store_true", help="print the results as JSON")
    c.set_defaults(func=conform_command)


def conform_command(args) -> int:
    """Run :func:`gasp_core.testing.check_engine` and print a table (or JSON); see the module doc."""
    from gasp_core.errors import SceneError
    from gasp_core.testing.scenes import check_engine
    scenes = None if args.scenes is None else [s.strip() for s in args.scenes.split(",") if s.strip()]
    if scenes == []:   # --scenes "" (an empty shell variable) ran every scene: leave the option out for that
        raise SceneError(f"--scenes: expected comma-separated conformance scene names, got {args.scenes!r}; leave it "
                         "out to run every scene")
    report = check_engine(args.engine, scenes=scenes, include_slow=args.slow)
    if args.json:
        print(json.dumps({"engine": report.engine, "ok": report.ok, "counts": report.counts(),
                          "results": [r.as_dict() for r in report.results]}, indent=2, default=float))
    else:
        print(report.table())
        counts = ", ".join(f"{n} {s}" for s, n in sorted(report.counts().items()))
        print(f"\n{report.engine}: {counts} -> {'OK' if report.ok else 'NOT CONFORMING'}")
    return 0 if report.ok else 1
