"""``gasp view RUN --export page.html``: a self-contained player page that opens from disk (no server).

The page (``player.html`` beside this module) is WebGL2 splatting in plain JavaScript; the run's frames
are embedded as one gzip + base64 block, decoded in the browser with ``DecompressionStream``. The frames are
compressed by :mod:`gasp_core.render.page_codec`: colours once, rows that never move once, centres on a
10-bit grid over the sequence's box, rotations and log scales of later frames as small steps from frame 0,
each frame predicted from the one before. What the compression moves is in :func:`pack_run`'s metadata
(``errors``, with ``errors=True``); the README donut's figures are in ``benchmarks/results/bench_share.md``.
"""
from __future__ import annotations

import base64
import gzip
import json
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.camera import nice_step
from gasp_core.render.page_codec import decode, encode, Frames, sqrt_cov, world_quats
from gasp_core.render.run import load_run, make_view
from gasp_core.gs.splat_numpy import SH_C0

PLAYER = Path(__file__).with_name("player.html")
FOV_DEG = 40.0


def run_frames(run, frames) -> Frames:
    """World-frame centres, rotations, scales and frame-0 colours of ``run`` (:class:`~gasp_core.render.run.Run`)
    at ``frames``, every object's Gaussians one after the other (``x = scale R x_file + t``)."""
    means, quats, scales, rgba = [], [], [], []
    for f in frames:
        ms, qs, ss = [], [], []
        for k, o in enumerate(run.objects):
            g, pl = run.read(f, k), o["placement"]
            R, sc = np.asarray(pl["R"], float), float(pl["scale"])
            ms.append(sc * g.means @ R.T + np.asarray(pl["t"], float))
            qs.append(world_quats(R, g.rotmats()))
            ss.append(sc * g.scales)
            if f == frames[0]:
                with np.errstate(over="ignore"):
                    opac = 1.0 / (1.0 + np.exp(-g.opacities.astype(np.float64)))
                rgba.append(np.concatenate([0.5 + SH_C0 * g.sh_dc, opac[:, None]], axis=1))
        means.append(np.concatenate(ms)), quats.append(np.concatenate(qs)), scales.append(np.concatenate(ss))
    return Frames(np.array(means), np.array(quats), np.array(scales), np.concatenate(rgba))


def codec_errors(fr: Frames, meta: dict, data: bytes, order: np.ndarray) -> dict:
    """What the page's compression moves, over every Gaussian and frame: ``centre`` (largest centre error)
    and ``shape`` (largest entry of ``S_page - S`` with ``S S`` the covariance), both over ``size``, the
    longest side of the sequence's box; ``rotation_deg``; ``scale_rel`` (largest ``|s_page / s - 1|``)."""
    dec = decode(meta, data, len(fr.means))
    true = Frames(fr.means[:, order], fr.quats[:, order], fr.scales[:, order], fr.rgba[order])
    dot = np.abs(np.sum(dec.quats * true.quats, axis=-1))
    shape = max(float(np.abs(sqrt_cov(dec.quats[k], dec.scales[k]) - sqrt_cov(true.quats[k], true.scales[k])).max())
                for k in range(len(fr.means)))
    return {"centre": float(np.abs(dec.means - true.means).max()) / meta["size"], "shape": shape / meta["size"],
            "rotation_deg": float(np.degrees(2.0 * np.arccos(np.clip(dot, 0.0, 1.0))).max()),
            "scale_rel": float(np.abs(dec.scales / true.scales - 1.0).max())}


def pack_run(run_dir, frames=None, errors: bool = False) -> tuple[dict, bytes]:
    """The page's metadata and binary block (before gzip) for a run folder.

    Parameters
    ----------
    run_dir : path
        Run folder written by ``gasp simulate``.
    frames : sequence of int, optional
        Frame numbers to include (default: all).
    errors : bool
        Decode the block again and add ``errors`` (:func:`codec_errors`) to the metadata.

    Returns
    -------
    meta : dict
        :func:`gasp_core.render.page_codec.encode`'s (``n``, ``n_moving``, the box ``lo``, ``hi``, ``size`` in
        metres, quantisation steps, byte offsets), plus ``n_frames``, ``frame_dt`` (s between included
        frames), ``ground_z`` and the grid (m), and the start camera of ``gasp render`` (``target``,
        ``azimuth_deg``, ``elevation_deg``, ``distance``, ``fov_deg``).
    data : bytes
        :mod:`gasp_core.render.page_codec`'s layout.

    Raises
    ------
    SceneError
        The run folder is unusable (:func:`gasp_core.render.run.load_run`), or ``frames`` selects none.
    """
    run = load_run(run_dir)
    frames = list(range(run.n_frames)) if frames is None else [f for f in frames if 0 <= f < run.n_frames]
    if not frames:
        raise SceneError(f"{run_dir}: no frames to export (the run has {run.n_frames})")
    fr = run_frames(run, frames)
    meta, data, order = encode(fr)
    step = frames[1] - frames[0] if len(frames) > 1 else 1
    # the start view is gasp render's: framing the 0.1-99.9 percentile box, strays left out
    vlo = np.min([np.percentile(m, 0.1, axis=0) for m in fr.means], axis=0)
    vhi = np.max([np.percentile(m, 99.9, axis=0) for m in fr.means], axis=0)
    view = make_view(vlo, vhi, run.ground_z, 800, 600, FOV_DEG)
    d = view.camera.position - view.camera.look_at
    dist = float(np.linalg.norm(d))
    meta.update({"n_frames": len(frames), "frame_dt": run.frame_dt * step, "speed": 1.0,
                 "ground_z": view.ground_z, "grid_centre": (0.5 * (vlo + vhi))[:2].tolist(),
                 "grid_size": float(max(np.max(vhi[:2] - vlo[:2]), 1e-3)),
                 "grid_step": nice_step(float(max(np.max(vhi[:2] - vlo[:2]), 1e-3)) / 4.0),
                 "target": view.camera.look_at.tolist(), "distance": dist, "fov_deg": FOV_DEG,
                 "azimuth_deg": float(np.degrees(np.arctan2(d[1], d[0]))),
                 "elevation_deg": float(np.degrees(np.arcsin(d[2] / dist))), "autoplay": True, "label": run.label})
    if errors:
        meta["errors"] = codec_errors(fr, meta, data, order)
    return meta, data


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
    blob = base64.b64encode(gzip.compress(data, compresslevel=9, mtime=0)).decode("ascii")
    page = (PLAYER.read_text().replace("__TITLE__", _html_text(title))
            .replace("__META__", json.dumps(meta).replace("</", "<\\/")).replace("__DATA__", blob))
    return atomic_write(out, lambda f: f.write(page.encode("utf-8")), overwrite=True)


def _html_text(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
