"""Finding a renderer: the built-in CPU renderers and every ``gasp_renderers`` plugin."""
from __future__ import annotations

from gasp_core import __version__
from gasp_core.errors import GaspError
from gasp_core.render import builtin
from gasp_core.seam.plugins import get_plugin_manager, install_hint, registered, RendererInfo

#: Plugin name the built-in renderers are registered under.
BUILTIN = "gasp_render_builtin"


def renderers(pm=None) -> dict[str, RendererInfo]:
    """All registered renderers by name: the built-in ones (:mod:`gasp_core.render.builtin`) and the
    plugins' (:func:`gasp_core.seam.plugins.registered` of ``gasp_renderers``).

    Raises
    ------
    GaspError
        If two plugins register the same renderer name (the message names both).
    """
    pm = pm or get_plugin_manager()
    if pm.get_plugin(BUILTIN) is None:
        builtin.__gasp_dist__ = ("gasp", __version__)
        pm.register(builtin, name=BUILTIN)
    return registered("gasp_renderers", "renderer", pm)


def get_renderer(name: str | None = None, **options):
    """A ready renderer: ``name``, or the first available of ``cpu``, ``numpy``.

    Raises
    ------
    GaspError
        Unknown name (lists the installed ones) or a renderer that cannot run here (gives the reason).
    """
    found = renderers()
    if name is None:
        name = next((n for n in ("cpu", "numpy") if n in found and not found[n].unavailable_reason()), "numpy")
    if name not in found:
        hint = install_hint(name)
        raise GaspError(f"unknown renderer '{name}'; installed renderers: {sorted(found)}"
                        + (f"; to install it: {hint}" if hint else ""))
    reason = found[name].unavailable_reason()
    if reason:
        raise GaspError(f"renderer '{name}' is installed but cannot run: {reason}")
    return found[name].factory(**options)
