"""See the result: render a run's Gaussian frames to video, PNGs or a strip, or play them in a browser.

Renderers are plugins, found through the ``gasp_renderers`` hook (:mod:`gasp_core.seam.plugins`). The
built-in CPU renderers live in :mod:`gasp_core.render.builtin`: ``cpu`` (a numba kernel, needs the
``render`` extra) and ``numpy`` (pure NumPy, always available, much slower).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

from gasp_core.seam.engine import GaspError


@dataclass(frozen=True)
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


def renderers(pm=None) -> dict[str, RendererInfo]:
    """All registered renderers by name.

    Raises
    ------
    GaspError
        If two plugins register the same renderer name (the message names both).
    """
    from gasp_core.seam.plugins import get_plugin_manager
    pm = pm or get_plugin_manager()
    found: dict[str, RendererInfo] = {}
    for impl in pm.hook.gasp_renderers.get_hookimpls():
        dist, version = getattr(impl.plugin, "__gasp_dist__", (impl.plugin_name, ""))
        for info in impl.function() or []:
            if not info.distribution:
                info = dataclasses.replace(info, distribution=dist, version=version or info.version)
            if info.name in found:
                raise GaspError(f"renderer '{info.name}' is registered twice: by "
                                f"'{found[info.name].distribution}' and by '{info.distribution}'")
            found[info.name] = info
    return dict(sorted(found.items()))


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
        raise GaspError(f"unknown renderer '{name}'; installed renderers: {sorted(found)}")
    reason = found[name].unavailable_reason()
    if reason:
        raise GaspError(f"renderer '{name}' is installed but cannot run: {reason}")
    return found[name].factory(**options)


def __getattr__(name):  # lazy re-exports, so that listing renderers stays cheap
    if name in ("render_run", "render_runs", "render_strip", "load_run"):
        from gasp_core.render import run
        return getattr(run, name)
    raise AttributeError(name)
