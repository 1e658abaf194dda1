"""Render the frames of a ``gasp simulate`` run (or several side by side) in the world frame, z up.

A run folder holds ``run.json`` and its frames in any format and layout, read through
:func:`gasp_core.run.layout.open_frames` (``frames.json``, or ``<object>/frame_0000.ply ...``); ``run.json``'s
``objects[].placement`` ``{R, scale, t}`` maps each object's file frame to the world:
``x_world = scale * R @ x_file + t``.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.camera import Camera, auto_camera, fit_to_box, ground_background, nice_step
from gasp_core.gs.splat_numpy import Splats, splats_from_gaussians
from gasp_core.run.crack_output import read_crack_faces
from gasp_core.run.split_output import read_split
from gasp_core.run.layout import RunFrames, open_frames
from gasp_core.run.record import ranges_rows
from gasp_core.run.run_json import check_run_json

#: What the default camera frames: the simulated part of a run (the default), or the whole scene.
FRAMINGS = ("moving", "scene")


@dataclass
class Run:
    """A run folder: frame files per object, placements, ground height, frame interval."""

    path: Path
    objects: list[dict]
    frames: RunFrames                  # any layout and format (gasp_core.run.layout)
    ground_z: float | None
    frame_dt: float
    label: str
    #: The whole ``run.json`` (a run in progress: ``status``, ``n_frames`` to come, :mod:`gasp_core.render.live`).
    meta: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        self._rest_rotmats: dict[int, np.ndarray] = {}

    @property
    def n_frames(self) -> int:
        return self.frames.n_frames

    def read(self, frame: int, k: int):
        """Object ``k``'s Gaussians at ``frame`` (file frame): the one place frame files are read."""
        return self.frames.gaussians(frame, k)

    def splats(self, frame: int) -> Splats:
        """World-frame splats of every object at ``frame``; with SH degree >= 1 each Gaussian's SH frame
        turns with it (its rotation at ``frame`` against frame 0, :mod:`gasp_core.gs.sh`). Each object's rows,
        then its crack faces (a fixed count a run); after every object, the sub-triangle Gaussians of split clamped
        triangles (:mod:`gasp_core.run.split_output`, a count that varies by frame: last, so the rows before keep
        their place for :func:`moving_mask`)."""
        parts, late = [], []
        for k, o in enumerate(self.objects):
            g = self.read(frame, k)
            rest = None
            if g.sh_rest.shape[1]:
                if k not in self._rest_rotmats:
                    self._rest_rotmats[k] = g.rotmats() if frame == 0 else self.read(0, k).rotmats()
                rest = self._rest_rotmats[k]
            pl = o["placement"]
            parts.append(splats_from_gaussians(g, pl["R"], float(pl["scale"]), pl["t"], rest_rotmats=rest))
            faces = read_crack_faces(self.path, o["name"], frame)   # a brittle object's crack faces, if written
            if faces is not None:
                parts.append(splats_from_gaussians(faces, pl["R"], float(pl["scale"]), pl["t"]))
            sub = read_split(self.path, o["name"], frame) if "name" in o else None
            if sub is not None:
                parent = np.asarray(sub.extra["parent"], np.int64)
                late.append(splats_from_gaussians(sub, pl["R"], float(pl["scale"]), pl["t"],
                                                  rest_rotmats=None if rest is None else rest[parent]))
        return Splats.concat(parts + late)


def load_run(path) -> Run:
    """Read ``run.json`` and list the frame files of a run folder.

    Raises
    ------
    SceneError
        If the folder, ``run.json``, an object's ``placement`` or its frame files are missing; the
        message names the path or field.
    """
    path = Path(path)
    meta_path = path / "run.json"
    meta = check_run_json(path, need_frame_dt=False)   # frame_dt > 0 where given, names, up axes
    try:
        objects = meta["objects"]
        for o in objects:
            o["placement"]["R"], o["placement"]["scale"], o["placement"]["t"]  # noqa: B018 (presence)
    except (ValueError, KeyError, TypeError) as e:
        raise SceneError(f"{meta_path}: no usable objects[].placement {{R, scale, t}} ({e!r})") from None
    try:
        grounds = [float(b.get("height", 0.0)) for b in meta.get("boundaries", []) if b.get("kind") == "ground"]
        frame_dt = float(meta.get("frame_dt", 1 / 30))
    except (ValueError, TypeError, AttributeError) as e:
        raise SceneError(f"{meta_path}: unusable boundaries[].height or frame_dt ({e!r})") from None
    frames = open_frames(path)
    return Run(path, objects, frames, min(grounds) if grounds else None, frame_dt,
               f"{meta.get('engine', '')}" or path.name, meta)


def sequence_bounds(frames: Iterable[Splats], q: float = 0.1, mask: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Box holding the means of every frame (``q``/``100 - q`` percentiles, so strays do not count); of the rows
    ``mask`` (bool, one per row) alone when given; rows past the mask's length (the sub-triangle Gaussians a frame
    adds at its end, :meth:`Run.splats`) count as moving."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for s in frames:
        m = None if mask is None else np.concatenate([mask, np.ones(max(0, s.n - len(mask)), bool)])[:s.n]
        x = s.means if m is None else s.means[m]
        lo = np.minimum(lo, np.percentile(x, q, axis=0))
        hi = np.maximum(hi, np.percentile(x, 100 - q, axis=0))
    return lo, hi


def moving_mask(run: Run) -> np.ndarray | None:
    """Which rows of :meth:`Run.splats` (objects in order) the run simulates, bool: ``run.json``'s per-object
    ``moving_rows`` (:func:`gasp_core.run.record.row_ranges`; null: every row), none of a static object's, and a
    brittle object's crack faces (drawn after its rows: one per fill point, every frame the same count).
    None when every row moves, when nothing does, or for a run recorded without ``moving_rows``."""
    parts, partial = [], False
    for o in run.objects:
        m = np.zeros(int(o.get("n_gaussians", 0)), dtype=bool)
        if "moving_rows" not in o and not o.get("static"):
            return None
        if o.get("static"):
            partial = True
        elif o["moving_rows"] is None:
            m[:] = True
        else:
            m[ranges_rows(o["moving_rows"])] = True
            partial = True
        parts.append(m)
        faces = read_crack_faces(run.path, o["name"], 0) if "name" in o else None   # drawn after its rows: they move
        if faces is not None:
            parts.append(np.ones(faces.n, dtype=bool))
    mask = np.concatenate(parts) if parts else np.zeros(0, dtype=bool)
    return mask if partial and mask.any() else None


def framed_bounds(runs: Sequence[Run], frames: Sequence[Splats], what: str = "moving"):
    """The box the default camera frames: ``what = "moving"`` the simulated rows of every frame
    (:func:`moving_mask`; the whole scene where everything moves), ``"scene"`` everything. ``frames`` holds each
    run's splats, run by run. Raises SceneError for another ``what``."""
    if what not in FRAMINGS:
        raise SceneError(f"camera framing {what!r}: expected one of {list(FRAMINGS)}")
    masks = [moving_mask(r) for r in runs] if what == "moving" else [None] * len(runs)
    if all(m is None for m in masks):
        return sequence_bounds(frames)
    per_run = len(frames) // len(runs)
    boxes = [sequence_bounds(frames[i * per_run:(i + 1) * per_run], mask=m) for i, m in enumerate(masks)]
    return np.min([b[0] for b in boxes], axis=0), np.max([b[1] for b in boxes], axis=0)


@dataclass
class View:
    """Camera plus ground-grid background shared by every frame of a rendering."""

    camera: Camera
    background: np.ndarray
    ground_z: float


def make_view(lo, hi, ground_z: float | None, width: int = 640, height: int = 480, fov_deg: float = 40.0,
              position=None, look_at=None, tight: bool = False) -> View:
    """The camera (given, or framing the box ``[lo, hi]``) and a grid at ``ground_z`` (else ``lo[2]``);
    ``tight``: the default camera fits the box's corners, not its bounding sphere (:func:`fit_to_box`)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    gz = float(lo[2]) if ground_z is None else float(ground_z)
    lo_g = lo.copy()
    lo_g[2] = min(lo[2], gz)
    if position is None:
        cam = auto_camera(lo_g, hi, width, height, fov_deg)
        if tight:
            cam = fit_to_box(cam, lo_g, hi)
        if look_at is not None:
            cam = Camera(cam.position, look_at, fov_deg, width, height, cam.near)
    else:
        target = 0.5 * (lo + hi) if look_at is None else look_at
        cam = Camera(position, target, fov_deg, width, height,
                     near=1e-3 * float(np.linalg.norm(np.asarray(position) - target)))
    return View(cam, _background(cam, lo, hi, gz), gz)


def run_view(runs: Sequence[Run], frames: Sequence[Splats], framing: str = "moving", width: int = 640,
             height: int = 480, fov_deg: float = 40.0, position=None, look_at=None):
    """The view :func:`render_runs` renders from, and the box it frames: :func:`framed_bounds` of ``frames``
    (each run's splats, run by run), the grid at the runs' lowest ground; where only a part of the scene moves
    (``framing = "moving"``), the camera fits that part's box tightly. Returns ``(View, lo, hi)``."""
    lo, hi = framed_bounds(runs, frames, framing)
    grounds = [r.ground_z for r in runs if r.ground_z is not None]
    tight = framing == "moving" and any(moving_mask(r) is not None for r in runs)
    return make_view(lo, hi, min(grounds) if grounds else None, width, height, fov_deg, position, look_at,
                     tight), lo, hi


def to_uint8(img: np.ndarray) -> np.ndarray:
    return (np.clip(img, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def label_image(img: np.ndarray, text: str, height_frac: float = 0.06) -> np.ndarray:
    """``text`` in black on a white box at the top left, about ``height_frac`` of the image tall
    (at least 14 px), so an engine's name reads at a video's size (Pillow's scalable default font)."""
    from PIL import Image, ImageDraw, ImageFont
    size = max(14, int(round(height_frac * img.shape[0])))
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:                       # Pillow < 10.1: the fixed bitmap font only
        font = ImageFont.load_default()
    im = Image.fromarray(img)
    d = ImageDraw.Draw(im)
    pad = max(3, size // 4)
    x0, y0, x1, y1 = d.textbbox((pad, pad), text, font=font)
    d.rectangle([0, 0, x1 + pad, y1 + pad], fill=(255, 255, 255))
    d.text((pad, pad), text, fill=(0, 0, 0), font=font)
    return np.asarray(im)


def render_runs(run_dirs: Sequence, renderer=None, frames: Sequence[int] | None = None, width: int = 640,
                height: int = 480, fov_deg: float = 40.0, position=None, look_at=None, labels: bool | None = None,
                progress: bool = False, camera_path=None, framing: str = "moving"):
    """Yield ``(frame, image)`` for the runs in ``run_dirs``, side by side (one camera for all).

    Parameters
    ----------
    run_dirs : sequence of path
        One or more run folders; with several, each frame is the runs' images left to right.
    renderer : callable or None
        From :func:`gasp_core.render.registry.get_renderer` (default: the best available CPU renderer).
    frames : sequence of int, optional
        Frame numbers (default: all frames every run has).
    width, height : int
        Size of each run's picture, pixels.
    fov_deg : float
        Vertical field of view, degrees.
    position, look_at : array-like (3,), optional
        Camera placement, world metres; by default the camera frames ``framing``.
    labels : bool, optional
        Write the engine name in the corner (default: when there are several runs).
    camera_path : callable, optional
        ``camera_path(lo, hi, n, width, height, fov_deg) -> list[Camera]``, one camera per rendered
        frame (:mod:`gasp_core.render.paths`); overrides ``position`` / ``look_at``.
    framing : str
        What the default camera frames (:func:`framed_bounds`): ``"moving"`` the simulated part of the runs over
        the sequence (all of it where everything moves), ``"scene"`` the whole sequence.

    Yields
    ------
    frame : int
    image : ndarray, shape (height, width * len(run_dirs), 3), uint8

    Raises
    ------
    SceneError
        A run folder is unusable (see :func:`load_run`).
    """
    from gasp_core.render.registry import get_renderer
    renderer = renderer or get_renderer()
    runs = [load_run(p) for p in run_dirs]
    n = min(r.n_frames for r in runs)
    frames = list(range(n)) if frames is None else [f for f in frames if 0 <= f < n]
    cache = {}
    for i, r in enumerate(runs):
        for f in frames:
            cache[i, f] = r.splats(f)
    view, lo, hi = run_view(runs, [cache[i, f] for i in range(len(runs)) for f in frames], framing, width,
                            height, fov_deg, position, look_at)
    cams = camera_path(lo, hi, len(frames), width, height, fov_deg) if camera_path else [view.camera] * len(frames)
    labels = len(runs) > 1 if labels is None else labels
    bar = None
    if progress:
        from tqdm import tqdm
        bar = tqdm(total=len(frames), unit="frame", desc="render")
    backgrounds = {id(view.camera): view.background}
    try:
        for f, cam in zip(frames, cams):
            if id(cam) not in backgrounds:
                backgrounds = {id(cam): _background(cam, lo, hi, view.ground_z)}
            tiles = []
            for i, r in enumerate(runs):
                img, _ = renderer(cache.pop((i, f)).seen_from(cam.position), cam, backgrounds[id(cam)])
                tile = to_uint8(img)
                tiles.append(label_image(tile, r.label) if labels else tile)
            if bar is not None:
                bar.update(1)
            yield f, np.concatenate(tiles, axis=1)
    finally:   # also on an error or an early close: a line printed next starts a line of its own
        if bar is not None:
            bar.close()


def _background(cam: Camera, lo, hi, ground_z: float) -> np.ndarray:
    size = max(float(np.max(hi[:2] - lo[:2])), 1e-3)
    return ground_background(cam, ground_z, nice_step(size / 4.0), 3.0 * size, centre=0.5 * (lo + hi)[:2])


def default_output(run_dirs: Sequence) -> Path:
    """Where ``gasp render`` writes without ``-o``: ``RUN/render.mp4`` for one run, else
    ``<first run's folder>/<run1>_vs_<run2>....mp4`` beside the runs."""
    paths = [Path(p) for p in run_dirs]
    if len(paths) == 1:
        return paths[0] / "render.mp4"
    return paths[0].resolve().parent / ("_vs_".join(p.resolve().name for p in paths) + ".mp4")


def render_run(run_dirs, output, *, overwrite: bool = False, fps: float | None = None, **kw) -> Path:
    """Render one run (or several side by side) to ``output``: ``.mp4``, ``.gif`` or a PNG folder.

    Parameters
    ----------
    run_dirs : path or sequence of path
    output : path
        ``*.mp4`` / ``*.gif``, or any other name: a folder of ``frame_0000.png ...``.
    overwrite : bool
        Replace an existing output; otherwise an existing output is an error.
    fps : float, optional
        Frames per second (default ``1 / frame_dt`` of the first run).
    **kw
        Passed to :func:`render_runs` (``renderer``, ``frames``, ``width``, ``height``, camera).

    Returns
    -------
    Path
        ``output``, written atomically (temporary file or folder, then renamed).

    Raises
    ------
    SceneError
        Bad run folder, or ``output`` exists and ``overwrite`` is false.
    """
    from gasp_core.render.video import write_frames
    if isinstance(run_dirs, (str, Path)):
        run_dirs = [run_dirs]
    fps = fps or 1.0 / load_run(run_dirs[0]).frame_dt
    with contextlib.closing(render_runs(run_dirs, **kw)) as frames:   # its progress bar closed before an error line
        return write_frames((img for _, img in frames), output, fps=fps, overwrite=overwrite)



def render_strip(run_dirs: dict, out_png, frames: Sequence[int] | int = 5, width: int = 320, height: int = 240,
                 renderer=None) -> Path:
    """A PNG with one row per run (e.g. per engine) and one column per chosen frame, one camera for all.

    Parameters
    ----------
    run_dirs : dict of str -> path
        Row label (engine name) -> run folder.
    out_png : path
        Written atomically.
    frames : int or sequence of int
        Frame numbers, or how many frames evenly spaced from first to last (default 5).
    width, height : int
        Size of each cell, pixels.

    Returns
    -------
    Path
    """
    from gasp_core.render.video import write_png
    labels = list(run_dirs)
    runs = [load_run(run_dirs[k]) for k in labels]
    n = min(r.n_frames for r in runs)
    if isinstance(frames, int):
        frames = sorted(set(np.linspace(0, n - 1, max(1, frames)).round().astype(int).tolist()))
    rows = {k: [] for k in labels}
    all_frames = list(render_runs([run_dirs[k] for k in labels], renderer, frames, width, height, labels=False))
    for f, img in all_frames:
        for i, k in enumerate(labels):
            tile = img[:, i * width:(i + 1) * width]
            rows[k].append(label_image(tile, f"{k}  frame {f}"))
    grid = np.concatenate([np.concatenate(rows[k], axis=1) for k in labels], axis=0)
    return write_png(grid, out_png)
