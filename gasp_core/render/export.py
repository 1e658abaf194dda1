"""``gasp view RUN --export page.html``: a self-contained player page that opens from disk (no server).

The page (``player.html`` beside this module) is WebGL2 splatting in plain JavaScript; the run's frames
are embedded as one gzip + base64 block, decoded in the browser with ``DecompressionStream``:

* colours once: ``n x 4`` uint8, ``(r, g, b, opacity)`` of frame 0 (SH degree 0: a run never changes
  appearance, and the page shows no view-dependent colour);
* the rows that change in some frame (``m`` uint32 indices): the rest is stored once;
* frame 0, all ``n`` rows, then every later frame's ``m`` changing rows: centres ``x 3`` uint16
  quantised over the sequence's box ``[lo, hi]`` (step ``(hi - lo) / 65535``, under 0.02 mm for a 1 m
  scene), then the symmetric square root ``S`` of each covariance (``Sigma = S S``), its six entries
  ``S00 S01 S02 S11 S12 S22`` as float16 in units of the scene size.

18 bytes per moving Gaussian and frame before gzip: the 45,624-Gaussian donut is 0.8 MB a frame, a
kitchen run with 351 of 62,442 Gaussians moving 6 kB a frame beyond the first.
"""
from __future__ import annotations

import base64
import gzip
import json
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.render.camera import nice_step
from gasp_core.render.run import load_run, make_view, sequence_bounds

PLAYER = Path(__file__).with_name("player.html")
FOV_DEG = 40.0


def sqrt_covariances(covs: np.ndarray) -> np.ndarray:
    """Symmetric square roots ``S`` with ``S @ S = covs`` (eigenvalues below 0 taken as 0).

    Parameters
    ----------
    covs : ndarray, shape (n, 3, 3)
        Symmetric positive semi-definite matrices.

    Returns
    -------
    ndarray, shape (n, 6), float64
        ``S00, S01, S02, S11, S12, S22``.
    """
    w, V = np.linalg.eigh(covs)
    S = (V * np.sqrt(np.maximum(w, 0.0))[:, None, :]) @ V.transpose(0, 2, 1)
    return S[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]


def pack_run(run_dir, frames=None) -> tuple[dict, bytes]:
    """The page's metadata and binary block (before gzip) for a run folder.

    Parameters
    ----------
    run_dir : path
        Run folder written by ``gasp simulate``.
    frames : sequence of int, optional
        Frame numbers to include (default: all).

    Returns
    -------
    meta : dict
        ``n``, ``n_frames``, ``frame_dt`` (s between included frames), ``lo``, ``hi``, ``size`` (m, the
        quantisation box), ``n_moving``, byte offsets, ``ground_z`` and the grid (m), and the start
        camera of ``gasp render`` (``target``, ``azimuth_deg``, ``elevation_deg``, ``distance``, ``fov_deg``).
    data : bytes
        Colours, then per frame centres and square-root covariances (see the module docstring).

    Raises
    ------
    SceneError
        The run folder is unusable (:func:`gasp_core.render.run.load_run`), or ``frames`` selects none.
    """
    run = load_run(run_dir)
    frames = list(range(run.n_frames)) if frames is None else [f for f in frames if 0 <= f < run.n_frames]
    if not frames:
        raise SceneError(f"{run_dir}: no frames to export (the run has {run.n_frames})")
    splats = [run.splats(f) for f in frames]
    lo, hi = sequence_bounds(splats, q=0.0)
    size = float(max(np.max(hi - lo), 1e-6))
    hi = np.maximum(hi, lo + 1e-9)
    s0 = splats[0]
    colours = np.concatenate([s0.rgb, s0.opacities[:, None]], axis=1)
    enc = [_encode(s, lo, hi, size) for s in splats]
    moving = np.zeros(s0.n, bool)
    for c, q in enc[1:]:
        moving |= (c != enc[0][0]).any(axis=1) | (q != enc[0][1]).any(axis=1)
    rows = np.flatnonzero(moving).astype("<u4")
    parts = [(np.clip(colours, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8).tobytes(), rows.tobytes(),
             enc[0][0].tobytes(), enc[0][1].tobytes()]
    for c, q in enc[1:]:
        parts += [c[rows].tobytes(), q[rows].tobytes()]
    step = frames[1] - frames[0] if len(frames) > 1 else 1
    # the start view is gasp render's: framing the 0.1-99.9 percentile box, strays left out
    vlo, vhi = sequence_bounds(splats)
    view = make_view(vlo, vhi, run.ground_z, 800, 600, FOV_DEG)
    d = view.camera.position - view.camera.look_at
    dist = float(np.linalg.norm(d))
    meta = {"n": s0.n, "n_frames": len(frames), "frame_dt": run.frame_dt * step, "speed": 1.0,
            "lo": lo.tolist(), "hi": hi.tolist(), "size": size, "n_moving": len(rows),
            "moving_offset": len(parts[0]), "frames_offset": len(parts[0]) + len(parts[1]),
            "ground_z": view.ground_z, "grid_centre": (0.5 * (vlo + vhi))[:2].tolist(),
            "grid_size": float(max(np.max(vhi[:2] - vlo[:2]), 1e-3)),
            "grid_step": nice_step(float(max(np.max(vhi[:2] - vlo[:2]), 1e-3)) / 4.0),
            "target": view.camera.look_at.tolist(), "distance": dist, "fov_deg": FOV_DEG,
            "azimuth_deg": float(np.degrees(np.arctan2(d[1], d[0]))),
            "elevation_deg": float(np.degrees(np.arcsin(d[2] / dist))), "autoplay": True, "label": run.label}
    return meta, b"".join(parts)


def _encode(s, lo, hi, size) -> tuple[np.ndarray, np.ndarray]:
    """Centres quantised to uint16 over ``[lo, hi]`` (n, 3) and square-root covariances as float16 (n, 6)."""
    q = np.clip((s.means - lo) / (hi - lo), 0.0, 1.0)
    return ((q * 65535.0 + 0.5).astype("<u2"), (sqrt_covariances(s.covs) / size).astype("<f2"))


def export_page(run_dir, output, *, overwrite: bool = False, frames=None) -> Path:
    """Write a player page for ``run_dir``: ``output`` if it ends in ``.html``, else ``output/index.html``.

    The page needs no server and no network: open it from disk (``file://``) in a browser with WebGL2.

    Parameters
    ----------
    run_dir : path
    output : path
        ``page.html``, or a folder (made if missing) that receives ``index.html``.
    overwrite : bool
        Replace an existing page; otherwise an existing page is an error.
    frames : sequence of int, optional
        Frames to include (default all).

    Returns
    -------
    Path
        The page, written atomically.

    Raises
    ------
    SceneError
        Bad run folder, the page exists and ``overwrite`` is false, or the output's folder is missing.
    """
    from gasp_core.fsutil import atomic_write
    out = Path(output)
    if out.suffix.lower() not in (".html", ".htm"):
        if out.exists() and not out.is_dir():
            raise SceneError(f"--export '{out}': expected a .html file name or a folder")
        out.mkdir(parents=True, exist_ok=True)
        out = out / "index.html"
    if not out.parent.is_dir():
        raise SceneError(f"--export '{out}': folder '{out.parent}' does not exist")
    if out.exists() and not overwrite:
        raise SceneError(f"output '{out}' exists; pass --overwrite to replace it")
    meta, data = pack_run(run_dir, frames)
    title = f"GASP: {Path(run_dir).resolve().name} ({meta['label']})"
    blob = base64.b64encode(gzip.compress(data, compresslevel=6, mtime=0)).decode("ascii")
    page = (PLAYER.read_text().replace("__TITLE__", _html_text(title))
            .replace("__META__", json.dumps(meta).replace("</", "<\\/")).replace("__DATA__", blob))
    return atomic_write(out, lambda f: f.write(page.encode("utf-8")), overwrite=True)


def _html_text(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
