"""The one install line of each plugin: what ``gasp engines``, an unknown-engine error and a plugin's own
"cannot run here" reason all print (issue 42, item 5).

A plugin of the repository lives in ``plugins/<name>/pyproject.toml`` beside the core package (the editable
install of a clone). Its ``[tool.gasp]`` table may add to the line:

* ``install-first = "torch==2.13.0"``: a package installed before the plugin (an engine built on torch
  picks up the installed one);
* ``own-venv = "REASON"`` (e.g. "its engine requires numpy<2 and would downgrade numpy and plyfile in this
  environment"): the plugin pins packages older than the core's, so the line says so first and installs it,
  with the core, into a venv of its own (as the CI's tier for such a plugin does).
"""
from __future__ import annotations

import functools
from pathlib import Path

from gasp_core.errors import shown_path

ROOT = Path(__file__).resolve().parents[2]


@functools.cache
def _pyproject(folder: Path) -> dict:
    import tomllib
    try:
        return tomllib.loads((folder / "pyproject.toml").read_text())
    except (OSError, ValueError):
        return {}


def plugin_folder(name: str) -> Path | None:
    """The clone's folder of the plugin called ``name`` (``plugins/<name>`` or, for a renderer,
    ``plugins/render_<name>``), or None outside a clone or for a name no folder has."""
    for folder in (ROOT / "plugins" / name, ROOT / "plugins" / f"render_{name}"):
        if (folder / "pyproject.toml").is_file():
            return folder
    return None


def clone_engine_plugins() -> dict[str, Path]:
    """Engine plugins of this clone by entry-point name (renderer folders, ``render_*``, left out)."""
    out = {}
    for pp in sorted((ROOT / "plugins").glob("*/pyproject.toml")):
        if pp.parent.name.startswith("render_"):
            continue
        for ep in _pyproject(pp.parent).get("project", {}).get("entry-points", {}).get("gasp", {}):
            out[ep] = pp.parent
    return out


def install_hint(name: str, extra: str | None = None, distribution: str | None = None) -> str:
    """The line that installs the plugin called ``name``: from a clone its ``pip install -e`` line (path as
    seen from the working directory), else ``python -m pip install "<distribution>"``, else ``""``.

    Parameters
    ----------
    name : str
        Entry-point name (the ``engine`` of a scene, or a renderer's name).
    extra : str, optional
        The plugin's extra to name; default its one optional extra other than ``test``
        (``plugins/NAME[engine]``: the plugin without it cannot run).
    distribution : str, optional
        ``gasp-NAME[engine]``: what a plugin installed from a wheel names (no clone to point at).

    Returns
    -------
    str
        One line; with ``[tool.gasp] own-venv`` it begins with the reason and installs into ``.venv-<name>``,
        with ``install-first`` it installs that package first (module docstring).
    """
    folder = plugin_folder(name)
    if folder is None:
        return f'python -m pip install "{distribution}"' if distribution else ""
    meta = _pyproject(folder)
    if extra is None:
        needed = [e for e in meta.get("project", {}).get("optional-dependencies", {}) if e != "test"]
        extra = needed[0] if len(needed) == 1 else None
    shown = shown_path(folder)
    target = f'"{shown}[{extra}]"' if extra else shown
    tool = meta.get("tool", {}).get("gasp", {})
    first = f"python -m pip install {tool['install-first']} && " if tool.get("install-first") else ""
    if tool.get("own-venv"):
        venv = f".venv-{name}"
        return (f"{tool['own-venv']}, so install it in a venv of its own: python -m venv {venv} && "
                f"{first.replace('python -m', f'{venv}/bin/python -m')}"
                f"{venv}/bin/python -m pip install -e {shown_path(ROOT)} -e {target} (then run {venv}/bin/gasp)")
    return f"{first}python -m pip install -e {target}"
