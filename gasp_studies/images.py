"""Rendered frames of a run against the reference's: PSNR and SSIM (scikit-image), with a hook for LPIPS / FID.

A user judges the renders. Both runs are rendered with the core's numba splatting renderer
(:mod:`gasp_core.render`, ``cpu``) from the same cameras: the capture's own, where a graphdeco
``cameras.json`` sits beside (or up to three folders above) the first object's PLY (up to
:data:`N_VIEWS` of them, evenly through the list), else a fixed orbit of :data:`N_VIEWS` views around
the reference's box over all compared frames (azimuths 90 degrees apart, 25 degrees up). A plain grey
background, so that only the splats differ.

* PSNR: ``10 log10(1 / MSE)`` of images in [0, 1] (``skimage.metrics.peak_signal_noise_ratio``);
* SSIM: Wang, Bovik, Sheikh, Simoncelli, IEEE TIP 13 (2004) 600, 7x7 window, per channel
  (``skimage.metrics.structural_similarity``).

LPIPS (Zhang et al. 2018) and FID (Heusel et al. 2017), the GASP paper's measure, need network
weights (AlexNet / VGG, Inception v3) that this project cannot download; :data:`IMAGE_METRICS` is the
hook: register ``name -> fn(ref_images, images) -> float`` (lists of float32 (H, W, 3) arrays) and
:func:`image_scores` reports it beside PSNR and SSIM.
"""
from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

#: Views rendered per frame.
N_VIEWS = 4
#: Image size, pixels (width, height).
IMAGE_SIZE = (256, 192)
#: Background grey (the same for every run).
BACKGROUND = (0.5, 0.5, 0.5)
#: Extra image metrics: name -> fn(ref_images, images) -> float. Empty here: LPIPS and FID need weights.
IMAGE_METRICS: dict[str, Callable[[list, list], float]] = {}
#: Why the paper's metrics are not computed.
NO_WEIGHTS = ("LPIPS and FID need pretrained network weights (AlexNet/VGG, Inception v3) that cannot be "
              "downloaded here; register them in gasp_studies.images.IMAGE_METRICS to report them")


def register_image_metric(name: str, fn: Callable[[list, list], float]) -> None:
    """Add an image metric (e.g. LPIPS with local weights): ``fn(ref_images, images) -> float``."""
    IMAGE_METRICS[name] = fn


def cameras_for(ref, frames: Sequence[int]) -> tuple[list, str]:
    """The cameras both runs are rendered from, and where they come from.

    ``ref``: the reference :class:`gasp_studies.accuracy.Track`. Returns (cameras, description).
    """
    from gasp_core.gs.camera import auto_camera
    from gasp_core.render.paths import graphdeco_camera
    w, h = IMAGE_SIZE
    if ref.cameras_json is not None:
        import json
        n = len(json.loads(ref.cameras_json.read_text()))
        idx = sorted(set(np.linspace(0, n - 1, min(N_VIEWS, n)).round().astype(int).tolist()))
        cams = [graphdeco_camera(ref.cameras_json, i, ref.placement, w, h) for i in idx]
        return cams, f"the capture's cameras {idx} ({ref.cameras_json.name})"
    pts = np.concatenate([ref.means[f] for f in frames])
    lo, hi = np.percentile(pts, 0.5, axis=0), np.percentile(pts, 99.5, axis=0)
    cams = [auto_camera(lo, hi, w, h, 40.0, -60.0 + 90.0 * i, 25.0) for i in range(N_VIEWS)]
    return cams, f"a fixed orbit of {N_VIEWS} views (no cameras.json)"


def render_frames(track, frames: Sequence[int], cameras: Sequence) -> list[np.ndarray]:
    """Images of ``track`` at ``frames`` from every camera, frame-major; float32 (H, W, 3) in [0, 1].

    Raises
    ------
    RuntimeError
        The track has no splats (nothing to render) or numba is missing (``pip install -e ".[render]"``).
    """
    import importlib.util
    from gasp_core.render.builtin import CpuRenderer
    if track.splats is None:
        raise RuntimeError(f"{track.label}: no rendered Gaussians kept for the image comparison")
    if importlib.util.find_spec("numba") is None:
        raise RuntimeError('the image comparison needs numba: python -m pip install -e ".[render]"')
    render = CpuRenderer(jit=True)
    out = []
    for f in frames:
        s = track.splats(f)
        for cam in cameras:
            img, _ = render(s, cam, BACKGROUND)
            out.append(np.clip(img, 0.0, 1.0).astype(np.float32))
    return out


def psnr(ref: np.ndarray, img: np.ndarray) -> float:
    """PSNR of ``img`` against ``ref`` (float images in [0, 1]), dB; inf when identical."""
    from skimage.metrics import peak_signal_noise_ratio
    if np.array_equal(ref, img):
        return float("inf")
    return float(peak_signal_noise_ratio(ref, img, data_range=1.0))


def ssim(ref: np.ndarray, img: np.ndarray) -> float:
    """SSIM of ``img`` against ``ref`` (float (H, W, 3) images in [0, 1]), 1 when identical."""
    from skimage.metrics import structural_similarity
    return float(structural_similarity(ref, img, channel_axis=2, data_range=1.0))


def image_scores(ref_images: list, images: list) -> dict:
    """PSNR (of the pooled MSE over every image), mean and worst SSIM, and any registered metric.

    Returns
    -------
    dict
        ``psnr_db``, ``psnr_worst_db``, ``ssim``, ``ssim_worst``, one key per :data:`IMAGE_METRICS`
        entry, and ``not_computed`` (:data:`NO_WEIGHTS` while none is registered).

    Raises
    ------
    ValueError
        Different numbers or sizes of images.
    """
    if len(ref_images) != len(images) or any(a.shape != b.shape for a, b in zip(ref_images, images)):
        raise ValueError(f"image_scores: {len(images)} images against {len(ref_images)} reference images "
                         "of other sizes or counts")
    mse = float(np.mean([np.mean((a.astype(np.float64) - b) ** 2) for a, b in zip(ref_images, images)]))
    per = [psnr(a, b) for a, b in zip(ref_images, images)]
    ss = [ssim(a, b) for a, b in zip(ref_images, images)]
    out = {"psnr_db": float("inf") if mse == 0 else float(-10.0 * np.log10(mse)), "psnr_worst_db": float(min(per)),
           "ssim": float(np.mean(ss)), "ssim_worst": float(min(ss)), "n_images": len(images)}
    for name, fn in IMAGE_METRICS.items():
        out[name] = float(fn(ref_images, images))
    if not IMAGE_METRICS:
        out["not_computed"] = NO_WEIGHTS
    return out
