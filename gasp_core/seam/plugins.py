"""Plugin discovery through pluggy and the ``gasp`` entry-point group: engines, renderers, soup writers.

A plugin is a module with hook implementations (:class:`HookSpec`): ``gasp_engines`` returns
:class:`~gasp_core.seam.engine.EngineInfo` records, ``gasp_renderers`` renderer records,
``gasp_soup_writers`` :class:`SoupWriterInfo` records. Installed distributions register the module under
``[project.entry-points.gasp]``; every kind is listed by the one function :func:`registered`. The core never imports an engine package: factories import
lazily when a simulation is built.

``GASP_LOAD_PLUGINS`` (comma-separated entry-point names) narrows which plugins load;
an empty string loads none.
"""
from __future__ import annotations

import dataclasses
import functools
import importlib.metadata as md
import os
from typing import Any, Callable

import pluggy

from gasp_core.errors import EngineError, GaspError
from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.install import install_hint  # noqa: F401 (re-exported: the one install line)

PROJECT = "gasp"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


class HookSpec:
    """Hook specifications (namespace passed to ``PluginManager.add_hookspecs``).

    Every kind of plugin is one hook here, found by one registry (:func:`registered`), so that
    ``GASP_LOAD_PLUGINS``, broken-plugin isolation and the duplicate-name check apply to all of them.
    """

    @hookspec
    def gasp_engines(self) -> list[EngineInfo]:
        """Return the engines this plugin provides.

        Returns
        -------
        list of EngineInfo
            Each with a unique ``name``. ``distribution`` and ``version`` may be left empty;
            the plugin manager fills them from the entry point's distribution.
        """

    @hookspec
    def gasp_renderers(self) -> list[RendererInfo]:
        """Return the renderers this plugin provides (``gasp render --renderer NAME``).

        Returns
        -------
        list of RendererInfo
        """

    @hookspec
    def gasp_soup_writers(self) -> list[SoupWriterInfo]:
        """Return the extra triangle-soup writers this plugin provides (``gasp export-soup``).

        Returns
        -------
        list of SoupWriterInfo
        """


@dataclasses.dataclass(frozen=True)
class RendererInfo:
    """Registration record a plugin returns from the ``gasp_renderers`` hook.

    Attributes
    ----------
    name : str
        Renderer name (``gasp render --renderer NAME``).
    factory : callable
        ``factory(**options) -> renderer``; the renderer is called as
        ``renderer(splats: Splats, camera: Camera, background) -> (image (h, w, 3) float32, alpha (h, w))``.
        Imports heavy packages lazily.
    available : callable or None
        ``available() -> str | None``: None when it can run here, else the reason it cannot.
    devices : tuple of str
        Where it runs (``"cpu"``, ``"cuda"``).
    distribution, version, description : str
    """

    name: str
    factory: Callable
    available: Callable[[], str | None] | None = None
    devices: tuple[str, ...] = ("cpu",)
    distribution: str = ""
    version: str = ""
    description: str = ""

    def unavailable_reason(self) -> str | None:
        return self.available() if self.available is not None else None


@dataclasses.dataclass(frozen=True)
class SoupWriterInfo:
    """An extra writer for ``gasp export-soup`` (``gasp_soup_writers`` hook).

    Attributes
    ----------
    name : str
        Format name, the key in ``soup.json``'s ``extra_files``.
    write : callable
        ``write(outdir: Path, soups: dict[str, ndarray (n, 3, 3) float64, metres]) -> list[str]`` of the
        files written in ``outdir``; raises :class:`~gasp_core.errors.EngineError` when it cannot run here
        (the writer is then listed as skipped with the reason).
    distribution, version, description : str
    """

    name: str
    write: Callable
    distribution: str = ""
    version: str = ""
    description: str = ""


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


def registered(hook: str, kind: str, pm: pluggy.PluginManager | None = None,
               error: type[GaspError] = GaspError) -> dict[str, Any]:
    """Every record that the plugins return from ``hook``, by name: the one registry of every plugin kind.

    Parameters
    ----------
    hook : str
        ``"gasp_engines"``, ``"gasp_renderers"`` or ``"gasp_soup_writers"``.
    kind : str
        What the records are, for the error message (``"engine"``, ``"renderer"``, ``"soup writer"``).
    pm : pluggy.PluginManager, optional
        Default :func:`get_plugin_manager`.
    error : type
        The error raised for a duplicate name.

    Returns
    -------
    dict of str -> record
        Sorted by name; ``distribution`` and ``version`` filled from the plugin's distribution.

    Raises
    ------
    GaspError (``error``)
        If two plugins register the same name; the message names both distributions.
    """
    pm = pm or get_plugin_manager()
    found: dict[str, Any] = {}
    for impl in getattr(pm.hook, hook).get_hookimpls():
        dist, version = getattr(impl.plugin, "__gasp_dist__", (impl.plugin_name, ""))
        for info in impl.function() or []:
            if not info.distribution:
                info = dataclasses.replace(info, distribution=dist, version=version or info.version)
            if info.name in found:
                raise error(f"{kind} '{info.name}' is registered twice: by '{found[info.name].distribution}' "
                            f"and by '{info.distribution}'")
            found[info.name] = info
    return dict(sorted(found.items()))


def engines(pm: pluggy.PluginManager | None = None) -> dict[str, EngineInfo]:
    """All registered engines by name (:func:`registered` of ``gasp_engines``).

    Raises
    ------
    EngineError
        If two plugins register the same engine name; the message names both distributions.
    """
    return registered("gasp_engines", "engine", pm, EngineError)


def soup_writers(pm: pluggy.PluginManager | None = None) -> dict[str, SoupWriterInfo]:
    """All registered extra soup writers by name (:func:`registered` of ``gasp_soup_writers``)."""
    return registered("gasp_soup_writers", "soup writer", pm)


def unknown_engine_message(name: str, found) -> str:
    """The one-line error for an engine that is not installed: the installed ones, and how to get ``name``."""
    msg = f"unknown engine '{name}'; installed engines: {sorted(found) or 'none'}"
    hint = install_hint(name)
    return f"{msg}; to install it: {hint}" if hint else msg


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
        raise EngineError(unknown_engine_message(name, found))
    info = found[name]
    reason = info.unavailable_reason()
    if reason:
        raise EngineError(f"engine '{name}' is installed but cannot run: {reason}")
    return info


def engine_hook(*records: EngineInfo) -> Callable[[], list[EngineInfo]]:
    """The ``gasp_engines`` hook of a plugin that registers ``records`` (issue 51: registration is a record, not
    code). In the plugin's module: ``gasp_engines = engine_hook(EngineInfo(name=..., factory="pkg.engine:Class",
    requires=("pkg_dependency",), ...))``; the entry point names that module.

    Example
    -------
    >>> from gasp_core.seam import Capabilities, EngineInfo, engine_hook
    >>> gasp_engines = engine_hook(EngineInfo(name="springs", factory="gasp_springs.engine:SpringEngine",
    ...     capabilities=Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset({"ground"}))))
    >>> [info.name for info in gasp_engines()]
    ['springs']
    """
    @hookimpl
    def gasp_engines() -> list[EngineInfo]:
        return list(records)
    return gasp_engines
