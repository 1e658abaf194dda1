"""The record a renderer plugin returns from the ``gasp_renderers`` hook."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


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
