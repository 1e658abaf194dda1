"""Built-in renderer plugin: CPU Gaussian splatting (numba kernel ``cpu``, pure NumPy ``numpy``).

Measured on the project's 2-core machine, the README donut (45,624 Gaussians) at 640x480:
``cpu`` about 1 s per frame, ``numpy`` about 60 s (``benchmarks/bench_render.py``), hence the
numba kernel is the default.
"""
from __future__ import annotations

import importlib.util

from gasp_core.errors import extra_hint
from gasp_core.seam.plugins import hookimpl, RendererInfo


class CpuRenderer:
    """``renderer(splats, camera, background)`` with the numba (``jit=True``) or NumPy path."""

    def __init__(self, jit: bool = True, dilation: float = 0.3):
        self.jit = jit
        self.dilation = dilation

    def __call__(self, splats, camera, background=None):
        import numpy as np
        from gasp_core.gs.splat_numpy import composite_ordered, project, render
        if not self.jit:
            return render(splats, camera, background, dilation=self.dilation)
        p = project(splats, camera, self.dilation)
        colour, T, _ = composite_ordered(p, camera.width, camera.height)
        H, W = camera.height, camera.width
        img = colour.reshape(H, W, 3)
        if background is not None:
            img = img + T.reshape(H, W, 1) * np.broadcast_to(np.asarray(background, float), (H, W, 3))
        return img.astype(np.float32), (1.0 - T).reshape(H, W).astype(np.float32)


def _numba_missing() -> str | None:
    if importlib.util.find_spec("numba") is None:
        return f"numba is not installed ({extra_hint('render')})"
    return None


@hookimpl
def gasp_renderers():
    return [
        RendererInfo("cpu", lambda **kw: CpuRenderer(jit=True, **kw), _numba_missing, ("cpu",),
                     description="EWA splatting, front-to-back blending, numba kernel on CPU threads"),
        RendererInfo("numpy", lambda **kw: CpuRenderer(jit=False, **kw), None, ("cpu",),
                     description="the same maths in vectorised NumPy (slow; no extra dependency)"),
    ]
