"""GASP renderer plugin ``gsplat``: CUDA rasterisation with nerfstudio's gsplat (optional).

Not run on the project's CPU-only machine: :func:`available` says why. Same camera convention as
:class:`gasp_core.gs.camera.Camera` (x right, y down, z forward; pixel ``i`` spans ``[i, i+1)``).
"""
from __future__ import annotations

import importlib.util

import numpy as np

from gasp_core.seam import hookimpl, install_hint, RendererInfo


def available() -> str | None:
    """None when torch, gsplat and a CUDA device are present, else the reason."""
    for mod in ("torch", "gsplat"):
        if importlib.util.find_spec(mod) is None:
            return f"{mod} is not installed: {install_hint('gsplat', distribution='gasp-render-gsplat[gpu]')}"
    import torch
    if not torch.cuda.is_available():
        return "no CUDA device (torch.cuda.is_available() is False)"
    return None


class GsplatRenderer:
    """``renderer(splats, camera, background) -> (image (h, w, 3) float32, alpha (h, w) float32)``."""

    def __init__(self, device: str = "cuda", dilation: float = 0.3):
        self.device = device
        self.dilation = dilation

    def __call__(self, splats, camera, background=None):
        import torch
        from gsplat import rasterization
        dev = torch.device(self.device)
        W, t = camera.world_to_camera()
        view = np.eye(4)
        view[:3, :3], view[:3, 3] = W, t
        f = camera.focal_px
        K = np.array([[f, 0, camera.cx], [0, f, camera.cy], [0, 0, 1.0]])
        tt = lambda a: torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float32, device=dev)  # noqa: E731
        colors, alphas, _ = rasterization(
            means=tt(splats.means), quats=None, scales=None, covars=tt(splats.covs),
            opacities=tt(splats.opacities), colors=tt(splats.rgb), viewmats=tt(view)[None], Ks=tt(K)[None],
            width=camera.width, height=camera.height, eps2d=self.dilation, near_plane=camera.near,
            sh_degree=None, packed=False)
        img = colors[0].cpu().numpy().astype(np.float64)
        a = alphas[0, ..., 0].cpu().numpy().astype(np.float64)
        if background is not None:
            img = img + (1.0 - a)[..., None] * np.broadcast_to(np.asarray(background, float), img.shape)
        return img.astype(np.float32), a.astype(np.float32)


@hookimpl
def gasp_renderers():
    return [RendererInfo("gsplat", lambda **kw: GsplatRenderer(**kw), available, ("cuda",),
                         description="gsplat CUDA rasteriser (optional; needs torch, gsplat and a GPU)")]
