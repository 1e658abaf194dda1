"""``gasp engines``: the installed engines, their options (from each engine's typed config, issue 51) and the quality
presets each declares."""
from __future__ import annotations

import json

from gasp_core.seam.config import options_markdown

#: The head of docs/engine_options.md (``gasp engines --markdown`` writes it; tests/test_config.py keeps it current).
MARKDOWN_HEAD = """# Engine options (generated: `gasp engines --markdown > docs/engine_options.md`)

Each engine declares its settings once: a typed config (a frozen dataclass whose fields are its options,
`gasp_core.seam.config`) or a tuple of options, and the options each quality level sets
(`EngineInfo.presets`). The core checks a scene's `[engine] options` against these declarations
(`check_options`), gives a level's options only to an engine that declares them, and records the resolved
options in `run.json` (`engine_options`). A level's column is blank where it sets nothing.

"""


def engines_markdown(found) -> str:
    """docs/engine_options.md for the engines ``found`` (name -> EngineInfo), in name order."""
    return MARKDOWN_HEAD + "\n".join(options_markdown(n, found[n].options, found[n].presets) for n in sorted(found))


def cmd_engines(args) -> int:
    """``gasp engines``: every installed engine's record (``--json``: as JSON; ``--markdown``: the options tables of
    ``docs/engine_options.md``, :func:`gasp_core.seam.config.options_markdown`)."""
    from gasp_core.seam.install import clone_engine_plugins
    from gasp_core.seam.plugins import BROKEN, engines, install_hint
    found = engines()
    missing = {n: install_hint(n) for n in clone_engine_plugins() if n not in found and n not in BROKEN}
    for name, (dist, err) in BROKEN.items():
        args.reporter.warning(f"plugin '{name}' ({dist}) fails to import: {err}")
    if getattr(args, "markdown", False):
        print(engines_markdown(found), end="")
        return 0
    if args.json:
        print(json.dumps({n: {"distribution": e.distribution, "version": e.version,
                              "available": e.unavailable_reason() or "yes",
                              "capabilities": e.capabilities.as_dict(),
                              "options": [{"name": o.name, "default": o.default, "expected": o.expected(),
                                           "doc": o.doc} for o in e.options],
                              "limits": {k: lim.describe(k) for k, lim in e.limits.items()},
                              "presets": {lv: dict(p.options) for lv, p in e.presets.items()},
                              "deterministic_options": dict(e.deterministic_options),
                              "known_failures": dict(e.known_failures),
                              "description": e.description, "install": install_hint(n)}
                          for n, e in found.items()}, indent=2))
        return 0
    if not found:
        print("no engines installed (each engine is a plugin distribution: see README, 'Engines')")
    for name, e in found.items():
        c = e.capabilities
        reason = e.unavailable_reason()
        print(f"{name}  ({e.distribution} {e.version})" + (f"  NOT AVAILABLE: {reason}" if reason else ""))
        print(f"    materials:  {', '.join(sorted(c.materials))}")
        print(f"    boundaries: {', '.join(sorted(c.boundaries))}")
        print(f"    devices:    {', '.join(sorted(c.devices))}; precisions: {', '.join(sorted(c.precisions))}")
        for device in sorted(c.devices):
            print(f"    speed on {device}: {e.speed.get(device, 'not measured')}")
        if c.features:
            print(f"    features:   {', '.join(sorted(c.features))}")
        for o in e.options:
            print(f"    option {o.name} = {o.default!r}: {o.doc} ({o.expected()})")
        for lv, p in e.presets.items():
            print(f"    quality {lv}: " + (", ".join(f"{k} = {v!r}" for k, v in p.options.items()) or "no option")
                  + (f" (measured: {p.measured})" if p.measured else " (not measured on this engine)"))
        for k, lim in e.limits.items():
            print(f"    limit {k}: {lim.describe(k)}")
        if e.known_failures:
            print(f"    known failures: {', '.join(sorted(e.known_failures))}")
        if e.description:
            print(f"    {e.description}")
    for name, line in missing.items():         # this clone's engines not installed: the same line as errors give
        print(f"{name}  NOT INSTALLED: {line}")
    return 0
