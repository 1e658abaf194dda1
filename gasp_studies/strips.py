"""Rendered strips of frames for the reports of ``gasp compare`` and ``gasp bench``.

A run keeps the rebuilt Gaussians of a few chosen frames (:func:`strip_frames`: evenly spaced,
first and last included) as world-frame :class:`~gasp_core.gs.splat_numpy.Splats`
(:func:`world_splats`, computed in the worker; float32). After the runs, :func:`render_strips`
renders them with the core's CPU splatting renderer (:mod:`gasp_core.render`), every run through
one automatically chosen camera (it frames the Gaussian means of every run and chosen frame over the
scene's ground), and writes one PNG per group of runs (``strip_<name>.png``: a row per run, a
column per frame). Rendering needs the ``render`` extra (numba, imageio); without it, or when
rendering fails, nothing is written and the reason is returned for the report.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

if TYPE_CHECKING:
    from gasp_core.gs.splat_numpy import Splats

#: Frames per strip (evenly spaced from the first to the last frame).
DEFAULT_STRIP_FRAMES = 6
#: Size of one frame of a strip, pixels (width, height).
STRIP_CELL = (256, 192)
#: Renderer used for strips: the numba kernel (the NumPy path takes ~50x longer, see ``gasp render``).
STRIP_RENDERER = "cpu"


def strip_frames(n_frames: int, count: int = DEFAULT_STRIP_FRAMES) -> tuple[int, ...]:
    """Frame numbers of a strip: ``count`` evenly spaced over ``0 .. n_frames`` (both included).

    Parameters
    ----------
    n_frames : int
        Simulated frames (frame 0, the input, comes on top).
    count : int
        How many frames (0: none; more than ``n_frames + 1`` gives every frame).

    Returns
    -------
    tuple of int
        Sorted, distinct.

    Raises
    ------
    SceneError
        ``count`` is negative or not an integer.
    """
    if isinstance(count, bool) or not isinstance(count, int) or count < 0:
        from gasp_core.errors import SceneError
        raise SceneError(f"frames per strip (n_strip_frames, --strip-frames): expected an integer >= 0, "
                         f"got {count!r}")
    if count == 0:
        return ()
    if count == 1:
        return (int(n_frames),)
    count = min(count, int(n_frames) + 1)   # more asks every frame: bounded by the run, not by the number given
    return tuple(sorted(set(np.linspace(0, n_frames, count).round().astype(int).tolist())))


def world_splats(objects, gaussians) -> "Splats":
    """World-frame splats of one frame, every object, float32 (what a strip needs of a run).

    Parameters
    ----------
    objects : sequence of PreparedObject
        Their ``placement`` (``x_world = scale R x_file + t``) maps each object to the world.
    gaussians : sequence of Gaussians
        The frame's rebuilt Gaussians per object, file frame
        (:func:`gasp_core.run.frames.iter_frames`).

    Returns
    -------
    Splats
        ``means`` (n, 3) m, ``covs`` (n, 3, 3) m^2, ``rgb`` (n, 3), ``opacities`` (n,); float32.
    """
    from gasp_core.gs.splat_numpy import Splats, splats_from_gaussians
    parts = [splats_from_gaussians(g, o.placement.R, float(o.placement.scale), o.placement.t)
             for o, g in zip(objects, gaussians)]
    s = Splats.concat(parts)
    return Splats(*(np.asarray(getattr(s, k), np.float32) for k in ("means", "covs", "rgb", "opacities")))


def file_stem(name: str) -> str:
    """``strip_<name>.png``'s ``name`` part: letters, digits, ``_``, ``-`` and ``.`` kept, others ``_``."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)


@dataclass
class StripRow:
    """One run in a strip: a ``label`` (may hold line breaks) and its ``keyframes`` ``{frame: Splats}``
    (missing frames: not reached)."""

    label: str
    keyframes: Mapping[int, object]


@dataclass
class Strips:
    """What :func:`render_strips` did.

    Attributes
    ----------
    files : dict of str -> str
        ``{group: PNG file name}`` (beside the report), in the groups' order.
    frames : tuple of int
    size : tuple of int
        ``(width, height)`` of one frame, pixels.
    skipped : str or None
        Why no strip was written (None when they were).
    render_s : float
        Seconds spent rendering and writing.
    n_gaussians : int
        Gaussians per frame of the first run drawn.
    """

    files: dict[str, str] = field(default_factory=dict)
    frames: tuple[int, ...] = ()
    size: tuple[int, int] = STRIP_CELL
    skipped: str | None = None
    render_s: float = 0.0
    n_gaussians: int = 0


def _label(img: np.ndarray, lines: Sequence[str]) -> np.ndarray:
    """``lines`` of text in the top-left corner, black on a white box (Pillow's default font)."""
    from PIL import Image, ImageDraw
    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    d.rectangle([0, 0, 8 + 6 * max(len(t) for t in lines), 4 + 12 * len(lines)], fill=(255, 255, 255))
    for i, t in enumerate(lines):
        d.text((4, 2 + 12 * i), t, fill=(0, 0, 0))
    return np.asarray(im)


def render_strips(outdir: Path, groups: Mapping[str, Sequence[StripRow]], frames: Sequence[int], frame_dt: float,
                  ground_z: float | None, *, size: tuple[int, int] = STRIP_CELL,
                  renderer: str = STRIP_RENDERER) -> Strips:
    """Render ``strip_<group>.png`` per group into ``outdir``: a row per run, a column per frame.

    Every run and frame is seen through one camera (:func:`gasp_core.gs.camera.auto_camera`
    framing the 0.1-99.9 percentile box of the means of every run and frame drawn, over a ground
    grid at ``ground_z``), so strips of different runs and groups compare directly. Each frame is
    labelled with its time and number (the first column with the run's label too); a frame a run
    did not reach (it diverged or failed) is the bare background, labelled ``not reached``.

    Parameters
    ----------
    outdir : Path
        The report folder (PNG files are written atomically).
    groups : mapping of str -> sequence of StripRow
        ``{group name: rows}``; one PNG per group (``strip_<file_stem(name)>.png``).
    frames : sequence of int
        Frame numbers, columns left to right.
    frame_dt : float
        Seconds per frame (for the labels).
    ground_z : float or None
        Ground height, metres (None: the lowest point drawn).
    size : (int, int)
        Width and height of one frame, pixels.
    renderer : str
        A registered renderer (:func:`gasp_core.render.registry.get_renderer`).

    Returns
    -------
    Strips
        Never raises for a rendering problem: a missing ``render`` extra, an unknown renderer or a
        failure while rendering leaves ``files`` empty and ``skipped`` says why (nothing half-written
        stays: the PNG files are written only once every image is rendered).
    """
    t0 = time.perf_counter()
    frames = tuple(int(f) for f in frames)
    res = Strips(frames=frames, size=tuple(size))
    drawn = [r for rows in groups.values() for r in rows if any(f in r.keyframes for f in frames)]
    if not frames or not drawn:
        res.skipped = "no run has any of the chosen frames" if frames else "no frames were chosen"
        return res
    res.n_gaussians = int(next(r.keyframes[f] for r in drawn for f in frames if f in r.keyframes).n)
    try:
        from gasp_core.render.registry import get_renderer
        from gasp_core.render.run import make_view, sequence_bounds, to_uint8
        from gasp_core.gs.splat_numpy import Splats
        from gasp_core.render.video import write_png
        draw = get_renderer(renderer)
        lo, hi = sequence_bounds(r.keyframes[f] for r in drawn for f in frames if f in r.keyframes)
        w, h = size
        view = make_view(lo, hi, ground_z, w, h)
        bg = to_uint8(view.background)
        images = {}
        for name, rows in groups.items():
            grid = []
            for r in rows:
                tiles = []
                for j, f in enumerate(frames):
                    s = r.keyframes.get(f)
                    if s is None:
                        tile, when = bg, "not reached"
                    else:
                        s64 = Splats(*(np.asarray(getattr(s, k), np.float64) for k in ("means", "covs")),
                                     np.asarray(s.rgb, np.float32), np.asarray(s.opacities, np.float32))
                        tile, when = to_uint8(draw(s64, view.camera, view.background)[0]), ""
                    text = [f"t = {f * frame_dt:.3f} s (frame {f})" + (f": {when}" if when else "")]
                    tiles.append(_label(tile, (r.label.splitlines() if j == 0 else []) + text))
                grid.append(np.concatenate(tiles, axis=1))
            images[name] = np.concatenate(grid, axis=0)
        for name, img in images.items():
            fname = f"strip_{file_stem(name)}.png"
            write_png(img, Path(outdir) / fname)
            res.files[name] = fname
    except Exception as e:  # the report is kept; it says why the strips are missing
        for fname in res.files.values():
            (Path(outdir) / fname).unlink(missing_ok=True)
        res.files = {}
        res.skipped = f"{type(e).__name__}: {e}"
    res.render_s = time.perf_counter() - t0
    return res


def strips_markdown(strips: Strips, frame_dt: float, captions: Mapping[str, str] | None = None) -> list[str]:
    """Markdown lines of a report's ``## Frames`` section: an image per group with its caption, or why not.

    ``captions[group]`` is put before the frame list of that group's caption.
    """
    lines = ["## Frames", ""]
    if strips.skipped:
        return lines + [f"Strips of rendered frames skipped: {strips.skipped}.", ""]
    times = ", ".join(f"{f} ({f * frame_dt:.3g} s)" for f in strips.frames)
    w, h = strips.size
    lines += [f"Rendered with the CPU splatting renderer (`gasp render`'s, {w}x{h} px per frame, SH degree 0 "
              f"colour) through one camera for every strip, which frames the Gaussian means of every run and "
              f"frame shown, world frame, z up, over the ground; {strips.render_s:.1f} s to render.", ""]
    for name, fname in strips.files.items():
        cap = (captions or {}).get(name, f"`{name}`")
        lines += [f"![{name}]({fname})", "", f"{cap}: frames {times}.", ""]
    return lines
