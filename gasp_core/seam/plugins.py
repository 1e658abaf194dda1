"""Engine discovery through pluggy and the ``gasp`` entry-point group.

A plugin is a module with a ``gasp_engines`` hook implementation that returns a list of
:class:`~gasp_core.seam.engine.EngineInfo`. Installed distributions register the module under
``[project.entry-points.gasp]``. The core never imports an engine package: factories import
lazily when a simulation is built.

``GASP_LOAD_PLUGINS`` (comma-separated entry-point names) narrows which plugins load;
an empty string loads none.
"""
from __future__ import annotations

import functools
import importlib.metadata as md
import os

import pluggy

from gasp_core.seam.engine import EngineError, EngineInfo

PROJECT = "gasp"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


class HookSpec:
    """Hook specifications (namespace passed to ``PluginManager.add_hookspecs``)."""

    @hookspec
    def gasp_engines(self) -> list[EngineInfo]:
        """Return the engines this plugin provides.

        Returns
        -------
        list of EngineInfo
            Each with a unique ``name``. ``distribution`` and ``version`` may be left empty;
            the plugin manager fills them from the entry point's distribution.
        """


class RendererSpec:
    """Renderer hook (``gasp_core.render``): return a list of ``RendererInfo``."""

    @hookspec
    def gasp_renderers(self) -> list:
        """Return the renderers this plugin provides (``gasp_core.render.RendererInfo``)."""


def _entry_points():
    eps = md.entry_points(group=PROJECT)
    only = os.environ.get("GASP_LOAD_PLUGINS")
    if only is not None:
        wanted = {s.strip() for s in only.split(",") if s.strip()}
        eps = [ep for ep in eps if ep.name in wanted]
    return list(eps)


#: Plugins whose module failed to import: ``{entry point name: (distribution, error)}``.
BROKEN: dict[str, tuple[str, str]] = {}


@functools.cache
def get_plugin_manager() -> pluggy.PluginManager:
    """The process-wide plugin manager, built once: entry points of group ``gasp``, then checked.

    Raises
    ------
    pluggy.PluginValidationError
        If a plugin implements a hook that is not in the specification (a typo fails loudly).
    """
    pm = pluggy.PluginManager(PROJECT)
    pm.add_hookspecs(HookSpec)
    pm.add_hookspecs(RendererSpec)
    from gasp_core.render import builtin as _render_builtin
    pm.register(_render_builtin, name="gasp_render_builtin")
    for ep in _entry_points():
        if pm.get_plugin(ep.name) is not None:
            continue
        try:
            module = ep.load()
        except Exception as e:  # a broken plugin must not take the others down
            dist = getattr(ep, "dist", None)
            BROKEN[ep.name] = (f"{dist.metadata['Name']} {dist.version}" if dist is not None else ep.value,
                               f"{type(e).__name__}: {e}")
            continue
        pm.register(module, name=ep.name)
        dist = getattr(ep, "dist", None)
        if dist is not None:
            module.__gasp_dist__ = (dist.metadata["Name"], dist.version)
    pm.check_pending()
    return pm


def engines(pm: pluggy.PluginManager | None = None) -> dict[str, EngineInfo]:
    """All registered engines by name.

    Raises
    ------
    EngineError
        If two plugins register the same engine name; the message names both distributions.
    """
    pm = pm or get_plugin_manager()
    found: dict[str, EngineInfo] = {}
    for impl in pm.hook.gasp_engines.get_hookimpls():
        dist, version = getattr(impl.plugin, "__gasp_dist__", (impl.plugin_name, ""))
        for info in impl.function() or []:
            if not info.distribution:
                info = _with(info, distribution=dist, version=version or info.version)
            if info.name in found:
                raise EngineError(
                    f"engine '{info.name}' is registered twice: by '{found[info.name].distribution}' "
                    f"and by '{info.distribution}'")
            found[info.name] = info
    return dict(sorted(found.items()))


def get_engine(name: str, pm: pluggy.PluginManager | None = None) -> EngineInfo:
    """The engine called ``name``.

    Raises
    ------
    EngineError
        If no installed plugin provides it (the message lists the installed ones), or if it is
        installed but cannot run here (the message gives the reason).
    """
    found = engines(pm)
    if name not in found and name in BROKEN:
        dist, err = BROKEN[name]
        raise EngineError(f"engine plugin '{name}' ({dist}) is installed but fails to import: {err}")
    if name not in found:
        raise EngineError(f"unknown engine '{name}'; installed engines: {sorted(found) or 'none'}")
    info = found[name]
    reason = info.unavailable_reason()
    if reason:
        raise EngineError(f"engine '{name}' is installed but cannot run: {reason}")
    return info


def _with(info: EngineInfo, **kw) -> EngineInfo:
    import dataclasses
    return dataclasses.replace(info, **kw)
