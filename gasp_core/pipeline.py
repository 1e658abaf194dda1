"""The GASP pipeline: load -> world frame -> flatten -> T -> engine -> T^-1 (+ alpha rule) -> frames.

``G_t = T^-1(phi(T(G), t))`` (GASP paper Sec. 3, Eq. for ``G_t``). Each object is read in its own
file frame, turned into the world frame (metres, z up), flattened into GaMeS form, mapped to
triangles whose vertices (plus interior fill points) the engine moves, and rebuilt every frame.
Frames are written back in the input file's own frame and order, so frame 0 sits where the input
was; opacity, SH and extra properties are carried bit for bit.
"""
from __future__ import annotations

import dataclasses
import json
import os
import platform
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Callable

import numpy as np

from . import __version__
from .engine import EngineError, EngineInfo, SceneError, SimSetup
from .fill import fill_interior
from .games import EPS, FlattenReport, alpha_rule, flatten, gaussians_to_triangles, triangles_to_gaussians
from .gaussians import Gaussians, rotmat_to_quat
from .hierarchy import Hierarchy, build_hierarchy, sub_triangles
from .io import read_gaussians, read_splatv, splatv_at, write_gaussians
from .plugins import engines as all_engines, get_engine
from .runner import RunStats, run_engine
from .scene import ObjectSpec, Scene, check_object

#: Rotation taking each file up-axis to world +z (proper rotations; x_world = R @ x_file).
UP_ROTATIONS = {
    "+z": np.eye(3),
    "-z": np.diag([1.0, -1.0, -1.0]),
    "+y": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "-y": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
    "+x": np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]]),
    "-x": np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
}


@dataclass
class Placement:
    """Similarity transform file -> world: ``x_world = scale * R @ x_file + t``."""

    R: np.ndarray
    scale: float
    t: np.ndarray

    def to_world(self, x: np.ndarray) -> np.ndarray:
        return self.scale * x @ self.R.T + self.t

    def to_file(self, x: np.ndarray) -> np.ndarray:
        return ((x - self.t) / self.scale) @ self.R


@dataclass
class PreparedObject:
    """One object ready to simulate, and what is needed to rebuild its Gaussians.

    Attributes
    ----------
    spec : ObjectSpec
    gaussians : Gaussians
        As read (file frame).
    placement : Placement
    rot_rest, scales_rest : ndarray, shapes (n, 3, 3), (n, 3)
        Flattened rest rotations and scales, world frame (metres).
    tri_rest : ndarray, shape (n, 3, 3)
        Rest triangles, world frame.
    hierarchy : Hierarchy or None
        Core Gaussians and bindings when ``spec.core_fraction < 1``.
    thin_scale : ndarray, shape (n,)
        The input's own thinnest scale, file units (``thickness = "keep"``).
    flatten_report : FlattenReport
    vertex_slice, fill_slice : slice
        Rows of this object's triangle vertices and fill points in ``SimSetup.x``.
    """

    spec: ObjectSpec
    gaussians: Gaussians
    placement: Placement
    rot_rest: np.ndarray
    scales_rest: np.ndarray
    tri_rest: np.ndarray
    thin_scale: np.ndarray
    flatten_report: FlattenReport
    hierarchy: Hierarchy | None = None
    vertex_slice: slice = field(default_factory=lambda: slice(0, 0))
    fill_slice: slice = field(default_factory=lambda: slice(0, 0))
    name: str = ""


def place(g: Gaussians, spec: ObjectSpec) -> Placement:
    """The file -> world transform of an object (up-axis, metres, position).

    With ``recentre``, the bottom centre of the means' bounding box (world orientation) lands on
    ``spec.position``; otherwise ``spec.position`` is a plain offset.
    """
    R = UP_ROTATIONS[spec.up_axis]
    s = float(spec.scale)
    x = s * g.means @ R.T
    if spec.recentre:
        lo, hi = x.min(axis=0), x.max(axis=0)
        anchor = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
        t = np.asarray(spec.position) - anchor
    else:
        t = np.asarray(spec.position, dtype=np.float64)
    return Placement(R, s, t)


def load_gaussians(spec: ObjectSpec) -> Gaussians:
    """An object's Gaussians: a static file, or a dynamic model ``psi(V, s)`` at ``s = spec.dynamic_time``.

    Raises
    ------
    SceneError
        From :func:`gasp_core.io.read_gaussians` / :func:`gasp_core.io.read_splatv`.
    """
    if spec.dynamic_time is not None:
        base, motion = read_splatv(spec.file)
        return splatv_at(base, motion, spec.dynamic_time)
    return read_gaussians(spec.file)


def prepare_object(spec: ObjectSpec, g: Gaussians | None = None) -> PreparedObject:
    """Read (unless given), place, flatten and triangulate one object.

    Raises
    ------
    SceneError
        From reading the file (see :func:`load_gaussians`), or from
        :func:`gasp_core.scene.check_object` (no Gaussians, placed beyond the float32 limits).
    """
    g = load_gaussians(spec) if g is None else g
    check_object(spec, g)
    pl = place(g, spec)
    R_world = pl.R @ g.rotmats()
    scales_flat, rot_flat, report = flatten(g.scales * pl.scale, R_world)
    means_w = pl.to_world(g.means)
    tri = gaussians_to_triangles(means_w, rot_flat, scales_flat)
    hier = build_hierarchy(means_w, tri, spec.core_fraction) if spec.core_fraction < 1.0 else None
    return PreparedObject(spec=spec, gaussians=g, placement=pl, rot_rest=rot_flat,
                          scales_rest=scales_flat, tri_rest=tri, thin_scale=g.scales.min(axis=1),
                          flatten_report=report, hierarchy=hier, name=Path(spec.file).stem)


def simulated_triangles(o: PreparedObject) -> np.ndarray:
    """The triangles whose vertices the engine moves: the cores' if there is a hierarchy, else all."""
    return o.tri_rest if o.hierarchy is None else o.hierarchy.core_tri


def default_domain(scene: Scene, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A cubic domain around ``points`` padded by ``domain.padding`` times their extent.

    With a ground plane the box starts three cells below it, so points resting on the ground
    stay inside the grid's interpolation stencil.
    """
    if scene.domain.lo is not None:
        return np.array(scene.domain.lo, float), np.array(scene.domain.hi, float)
    lo, hi = points.min(axis=0), points.max(axis=0)
    ext = float(np.max(hi - lo))
    side = ext * (1.0 + 2.0 * scene.domain.padding)
    centre = (lo + hi) / 2
    dlo = centre - side / 2
    grounds = [b.height for b in scene.boundaries if b.kind == "ground"]
    if grounds:
        dlo[2] = min(grounds) - 3.0 * side / scene.domain.n_grid
    return dlo, dlo + side


def build_setup(scene: Scene, objects: list[PreparedObject]) -> SimSetup:
    """Assemble the engine's point set: all objects' triangle vertices, then their fill points.

    Raises
    ------
    SceneError
        If an object lies outside an explicit domain.
    """
    vertices = [simulated_triangles(o).reshape(-1, 3) for o in objects]
    lo, hi = default_domain(scene, np.concatenate([o.tri_rest.reshape(-1, 3) for o in objects]))
    n_grid = scene.domain.n_grid
    dx = float(np.max(hi - lo)) / n_grid
    h = dx / scene.domain.particles_per_cell ** (1.0 / 3.0)
    xs, vols, bodies, vels, fills = [], [], [], [], []
    start = 0
    for i, (o, verts) in enumerate(zip(objects, vertices)):
        opaque = 1.0 / (1.0 + np.exp(-o.gaussians.opacities.astype(np.float64))) >= o.spec.min_opacity
        fr = fill_interior(verts, h, occupancy=o.tri_rest[opaque].reshape(-1, 3), fill=o.spec.fill)
        o.vertex_slice = slice(start, start + len(verts))
        start += len(verts)
        xs.append(verts)
        vols.append(fr.p_vol_surface)
        bodies.append(np.full(len(verts), i))
        vels.append(np.broadcast_to(o.spec.velocity, verts.shape))
        fills.append((i, fr))
    for i, fr in fills:
        objects[i].fill_slice = slice(start, start + len(fr.fill_x))
        start += len(fr.fill_x)
        xs.append(fr.fill_x)
        vols.append(fr.p_vol_fill)
        bodies.append(np.full(len(fr.fill_x), i))
        vels.append(np.broadcast_to(objects[i].spec.velocity, fr.fill_x.shape))
    x = np.concatenate(xs)
    outside = ((x < lo) | (x > hi)).any(axis=1)
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise SceneError(f"{scene.path}: {int(outside.sum())} point(s) start outside the domain "
                         f"[{lo.tolist()}, {hi.tolist()}] (first at {x[k].tolist()}); enlarge [domain]")
    return SimSetup(
        x=x, v=np.concatenate(vels), p_vol=np.concatenate(vols), body_id=np.concatenate(bodies),
        materials=[o.spec.material for o in objects], gravity=np.array(scene.gravity),
        domain_lo=lo, domain_hi=hi, n_grid=n_grid, boundaries=list(scene.boundaries),
        frame_dt=scene.frame_dt, n_render=sum(len(v) for v in vertices),
        options=dict(scene.engine.options))


def check_capabilities(info: EngineInfo, scene: Scene, others: dict[str, EngineInfo] | None = None) -> None:
    """Fail before any work if the engine lacks a material or boundary the scene uses.

    Raises
    ------
    EngineError
        Naming what is missing and the installed engines that support it.
    """
    others = all_engines() if others is None else others
    caps = info.capabilities
    needs = [("material", o.material.name, "materials") for o in scene.objects] + \
            [("boundary", b.kind, "boundaries") for b in scene.boundaries]
    for what, name, attr in needs:
        if name not in getattr(caps, attr):
            able = sorted(n for n, e in others.items() if name in getattr(e.capabilities, attr))
            raise EngineError(f"engine '{info.name}' does not support the {what} '{name}'; "
                              f"engines that do: {able or 'none installed'}")


def rebuild(o: PreparedObject, x: np.ndarray, prev_rot: np.ndarray) -> tuple[Gaussians, np.ndarray, dict]:
    """``T^-1`` and the alpha rule for one object at one frame, back in the file frame.

    Parameters
    ----------
    o : PreparedObject
    x : ndarray, shape (n_points, 3)
        All simulated positions of the frame, world frame.
    prev_rot : ndarray, shape (n, 3, 3)
        Previous frame's world rotations (fallback for degenerate triangles).

    Returns
    -------
    gaussians : Gaussians
        File frame; opacity, SH and extra fields shared with the input (never modified).
    rot : ndarray, shape (n, 3, 3)
        World rotations of this frame.
    counts : dict
        ``degenerate`` faces and ``clamped`` scales (alpha rule) this frame.
    """
    tri = x[o.vertex_slice].reshape(-1, 3, 3)
    if o.hierarchy is not None:
        tri = sub_triangles(o.hierarchy, tri)
    means_w, rot, scales_w, degenerate = triangles_to_gaussians(tri, fallback=prev_rot)
    clamped = np.zeros((len(tri), 2), bool)
    if o.spec.alpha is not None:
        scales_w, clamped = alpha_rule(o.tri_rest, tri, scales_w, o.scales_rest, o.spec.alpha)
    pl = o.placement
    scales = scales_w / pl.scale
    scales[:, 0] = o.thin_scale if o.spec.thickness == "keep" else EPS
    g = o.gaussians
    out = dataclasses.replace(g, means=pl.to_file(means_w), scales=scales,
                              rotations=rotmat_to_quat(pl.R.T @ rot))
    return out, rot, {"degenerate": int(degenerate.sum()), "clamped": int(clamped.sum())}


@dataclass
class RunResult:
    """What :func:`simulate_scene` did."""

    outdir: Path
    n_frames: int
    stats: RunStats
    summary: dict = field(default_factory=dict)


@dataclass
class PreparedScene:
    """A scene ready to run: engine chosen and checked, objects placed, points assembled."""

    scene: Scene
    info: EngineInfo
    objects: list[PreparedObject]
    names: list[str]
    setup: SimSetup


def prepare_scene(scene: Scene, engine: str | None = None, options: dict | None = None) -> PreparedScene:
    """Choose and check the engine, read and place every object, build the point set.

    Parameters
    ----------
    scene : Scene
    engine : str, optional
        Override ``scene.engine.name``.
    options : dict, optional
        Engine options replacing ``scene.engine.options`` (e.g. from a settings sweep).

    Raises
    ------
    EngineError
        Unknown engine, engine not runnable here, or a material/boundary it lacks (before any work).
    SceneError
        Unreadable object file, object outside an explicit domain.
    """
    info = get_engine(engine or scene.engine.name)
    check_capabilities(info, scene)
    objects = [prepare_object(spec) for spec in scene.objects]
    stems = [o.name for o in objects]
    names = [n if stems.count(n) == 1 else f"{i}_{n}" for i, n in enumerate(stems)]
    setup = build_setup(scene, objects)
    if options is not None:
        setup.options = dict(options)
    return PreparedScene(scene, info, objects, names, setup)


def iter_frames(prep: PreparedScene, n_frames: int, stats: RunStats | None = None):
    """Yield ``(frame, gaussians_per_object, counts)`` for frame 0 (the input) to ``n_frames``.

    ``counts`` holds ``frame``, ``degenerate`` faces and ``clamped`` scales, and ``sim_s`` (engine
    wall time) from frame 1 on.

    Raises
    ------
    EngineDivergence
        See :func:`gasp_core.runner.run_engine`.
    """
    prev = [o.rot_rest for o in prep.objects]

    def rebuild_all(frame: int, x: np.ndarray):
        gs, row = [], {"frame": frame, "degenerate": 0, "clamped": 0}
        for k, o in enumerate(prep.objects):
            g, prev[k], counts = rebuild(o, x, prev[k])
            row["degenerate"] += counts["degenerate"]
            row["clamped"] += counts["clamped"]
            gs.append(g)
        return gs, row

    gs, row = rebuild_all(0, prep.setup.x)
    yield 0, gs, row
    for rec in run_engine(prep.info, prep.setup, n_frames, stats):
        gs, row = rebuild_all(rec.frame, rec.x)
        row["sim_s"] = rec.wall_s
        yield rec.frame, gs, row


def _versions(info: EngineInfo) -> dict:
    out = {"gasp": __version__, "python": platform.python_version()}
    for dist in ("numpy", "pluggy", "plyfile", "scipy", info.distribution):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            pass
    return out


def commit_dir(tmp: Path, outdir: Path) -> None:
    """Move the finished ``tmp`` folder to ``outdir`` (replacing an old one only now)."""
    if outdir.exists():
        trash = Path(tempfile.mkdtemp(dir=outdir.parent, prefix=f".{outdir.name}.old-"))
        os.replace(outdir, trash / "old")
        os.replace(tmp, outdir)
        shutil.rmtree(trash, ignore_errors=True)
    else:
        os.replace(tmp, outdir)


def _atomic_json(path: Path, obj) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    with os.fdopen(fd, "w") as f:
        json.dump(obj, f, indent=2, default=str)
    os.replace(tmp, path)


def simulate_scene(scene: Scene, outdir: str | Path, overwrite: bool = False,
                   progress: bool = True, n_frames: int | None = None,
                   engine: str | None = None,
                   on_frame: Callable[[int, list[Gaussians]], None] | None = None) -> RunResult:
    """Run a scene and write one graphdeco PLY per object per frame.

    Layout: ``OUTDIR/<object>/frame_0000.ply`` (frame 0 = the input state) to
    ``frame_<n_frames>.ply``, and ``OUTDIR/run.json`` (engine, versions, parameters, per-frame
    timings, flatten reports, alpha-rule and degenerate counts).

    Parameters
    ----------
    scene : Scene
    outdir : str or Path
        Output folder; it must not exist unless ``overwrite``.
    overwrite : bool
        Replace an existing ``outdir`` (only after the new run succeeded).
    progress : bool
        Show a tqdm progress bar.
    n_frames, engine : optional
        Override the scene's ``n_frames`` and ``engine.name``.
    on_frame : callable, optional
        ``on_frame(frame, gaussians_per_object)`` after each frame is written.

    Returns
    -------
    RunResult

    Raises
    ------
    FileExistsError
        If ``outdir`` exists and ``overwrite`` is false (checked before any work).
    SceneError, EngineError
        Bad input or an engine that cannot run the scene, before any simulation.
    EngineDivergence
        The engine blew up; the message names the frame and the likely cause. Nothing is left
        in ``outdir`` (the partial run is removed).
    """
    outdir = Path(outdir)
    if outdir.exists() and not overwrite:
        raise FileExistsError(f"output folder '{outdir}' exists; pass --overwrite to replace it")
    n_frames = scene.n_frames if n_frames is None else n_frames
    prep = prepare_scene(scene, engine)
    info, objects, names, setup = prep.info, prep.objects, prep.names, prep.setup

    outdir.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=outdir.parent, prefix=f".{outdir.name}.partial-"))
    try:
        for name in names:
            (tmp / name).mkdir()
        per_frame = []
        stats = RunStats()
        bar = None
        if progress:
            from tqdm import tqdm
            bar = tqdm(total=n_frames, unit="frame", desc=f"{info.name}", leave=True)
        t_run = time.perf_counter()
        for frame, gs, row in iter_frames(prep, n_frames, stats):
            t0 = time.perf_counter()
            for g, name in zip(gs, names):
                write_gaussians(tmp / name / f"frame_{frame:04d}.ply", g)
            row["write_s"] = time.perf_counter() - t0
            per_frame.append(row)
            if bar is not None and frame > 0:
                bar.update(1)
            if on_frame is not None:
                on_frame(frame, gs)
        if bar is not None:
            bar.close()
        summary = {
            "scene": str(scene.path), "engine": info.name, "engine_distribution": info.distribution,
            "versions": _versions(info), "engine_stats": stats.engine,
            "engine_options": setup.options, "build_s": stats.build_s,
            "wall_s": time.perf_counter() - t_run, "n_frames": n_frames, "frame_dt": scene.frame_dt,
            "gravity": list(scene.gravity),
            "domain": {"lo": setup.domain_lo.tolist(), "hi": setup.domain_hi.tolist(),
                       "n_grid": setup.n_grid, "dx": setup.dx},
            "boundaries": [dataclasses.asdict(b) for b in setup.boundaries],
            "n_points": len(setup.x), "n_render_points": setup.n_render,
            "objects": [{
                "name": name, "file": str(o.spec.file), "n_gaussians": o.gaussians.n,
                "layout": o.gaussians.layout, "material": dataclasses.asdict(o.spec.material),
                "up_axis": o.spec.up_axis, "dynamic_time": o.spec.dynamic_time, "scale": o.spec.scale, "fill": o.spec.fill,
                "n_fill_points": o.fill_slice.stop - o.fill_slice.start,
                "core_fraction": o.spec.core_fraction,
                "n_simulated_gaussians": len(simulated_triangles(o)),
                "alpha": o.spec.alpha, "thickness": o.spec.thickness,
                "flatten": o.flatten_report.as_dict(),
                "placement": {"R": o.placement.R.tolist(), "scale": o.placement.scale,
                              "t": o.placement.t.tolist()}} for o, name in zip(objects, names)],
            "frames": per_frame,
        }
        _atomic_json(tmp / "run.json", summary)
        commit_dir(tmp, outdir)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return RunResult(outdir=outdir, n_frames=n_frames, stats=stats, summary=summary)
