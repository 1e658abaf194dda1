"""The run record: what ``run.json`` holds (engine, versions, parameters, per-frame timings, objects)."""
from __future__ import annotations

import dataclasses
import os
import platform
from importlib import metadata

import numpy as np

from gasp_core import __version__
from gasp_core.seam.engine import EngineInfo
from gasp_core.run.contact import collider_records
from gasp_core.prepare.selection import selection_record, selection_totals

def _versions(info: EngineInfo) -> dict:
    out = {"gasp": __version__, "python": platform.python_version()}
    for dist in ("numpy", "pluggy", "plyfile", "scipy", info.distribution):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            pass
    return out


def run_summary(prep, stats, n_frames: int, per_frame: list[dict], wall_s: float) -> dict:
    """The ``run.json`` document of a finished run.

    Parameters
    ----------
    prep : PreparedScene
    stats : RunStats
    n_frames : int
    per_frame : list of dict
        One row per frame (frame 0 included): ``frame``, ``degenerate``, ``clamped``, ``sim_s``, ``write_s``,
        from frame 1 ``wall_s`` and ``cpu_s`` (the process's CPU seconds, all threads, over the frame: their ratio
        is the cores it used), and ``colliders`` when the scene has colliders (:mod:`gasp_core.run.contact`, which
        also gives ``run.json`` ``colliders``).
    wall_s : float
        Seconds from the engine build to the last frame written.
    """
    scene, info, setup = prep.scene, prep.info, prep.setup
    return {
        "scene": str(scene.path), "engine": info.name, "engine_distribution": info.distribution,
        "versions": _versions(info), "engine_stats": stats.engine,
        "quality": scene.quality, "engine_options": setup.options, "build_s": stats.build_s, "prepare_s": prep.prepare_s,
        "wall_s": wall_s, "n_frames": n_frames, "frame_dt": scene.frame_dt,
        # sleep (gasp_core.seam.sleep): the last simulated frame when the scene fell asleep, later frames repeat it
        # and per body (gasp_core.seam.body_sleep, engines with the feature sleep): when each slept and woke
        "sleep": {"enabled": bool(getattr(scene, "sleep", False)), "asleep_after_frame": stats.asleep_after,
                  "bodies": _named(stats.bodies, prep.names)},
        # round 84: the settled start (gasp_core.seam.settle): its frames, its largest displacement, its residual
        "settle": {"enabled": bool(getattr(scene, "settle", False)), **(stats.settle or {})},
        "gravity": list(scene.gravity),
        "domain": {"lo": setup.domain_lo.tolist(), "hi": setup.domain_hi.tolist(),
                   "n_grid": setup.n_grid, "dx": setup.dx},
        "boundaries": [dataclasses.asdict(b) for b in setup.boundaries],
        "n_points": len(setup.x), "n_render_points": setup.n_render, **selection_totals(prep),
        "objects": [_object_record(o, name, setup.boundaries) for o, name in zip(prep.objects, prep.names)],
        "colliders": collider_records(setup, per_frame),
        # what the scene around a selection supplied where the file states none (gasp_core.prepare.around)
        "around_selection": list(getattr(prep, "around", [])),
        "frames": per_frame,
        **({"fragments": stats.fragments} if getattr(stats, "fragments", None) else {}),
        # the energy watchdog (gasp_core.seam.energy_watch): the largest gain over the start's energy seen, a
        # fraction of the scene's energy scale (a run stops past the allowance), or why the scene is not watched
        **({"energy": stats.energy} if getattr(stats, "energy", None) else {}),
    }


def running_record(prep, stats, n_frames: int, per_frame: list[dict], fmt: str, layout: str) -> dict:
    """The ``run.json`` a run writes into its partial folder before its first frame, for a reader of the run in
    progress (:mod:`gasp_core.render.live`): :func:`run_summary` of the frames so far (none for a fresh run, the
    checkpoint's for a resumed one) with ``status: "running"``, the output ``format`` and ``layout``, and the
    writer's ``pid``. The finished (or stopped) run's record replaces it."""
    return {**run_summary(prep, stats, n_frames, per_frame, 0.0), "status": "running", "format": fmt,
            "layout": layout, "pid": os.getpid()}


def ground_in_file_frame(placement, height: float) -> dict:
    """A ground plane at world height ``height`` (metres, z up) in an object's file frame, where its frames are.

    Returns
    -------
    dict
        ``normal`` (unit, file frame, pointing up) and ``offset`` (file units): the ground is the points
        ``x`` with ``normal . x = offset``. When the normal is a file axis, also ``axis`` (``"x"``, ``"y"``,
        ``"z"``) and ``at``, that coordinate of the ground (file units): e.g. ``{"axis": "z", "at": -0.059}``.
    """
    n = np.asarray(placement.R, float)[2]                       # R^T e_z: world up in file coordinates
    d = (float(height) - float(placement.t[2])) / float(placement.scale)
    out = {"normal": n.round(12).tolist(), "offset": d}
    k = int(np.argmax(np.abs(n)))
    if abs(abs(n[k]) - 1.0) < 1e-9:
        out.update(axis="xyz"[k], at=d * float(np.sign(n[k])))
    return out


def _named(bodies: list, names) -> list:
    """Per body sleep records (``RunStats.bodies``) with the scene object's name where objects and bodies match."""
    names = list(names or [])
    return [{**b, "name": names[b["body"]] if len(names) == len(bodies) else b.get("name")} for b in bodies]


def row_ranges(rows) -> list | None:
    """``run.json``'s ``moving_rows``: the sorted rows ``rows`` (int array; None: every row moves) as half-open
    ``[start, stop]`` ranges, so that a renderer can frame what moves (:func:`ranges_rows`)."""
    if rows is None:
        return None
    rows = np.asarray(rows, dtype=np.int64)
    if not len(rows):
        return []
    cut = np.flatnonzero(np.diff(rows) != 1) + 1
    starts, stops = rows[np.r_[0, cut]], rows[np.r_[cut - 1, len(rows) - 1]] + 1
    return [[int(a), int(b)] for a, b in zip(starts, stops)]


def ranges_rows(ranges) -> np.ndarray:
    """The rows (int64) of :func:`row_ranges`' ``[start, stop]`` list."""
    return np.concatenate([np.arange(a, b, dtype=np.int64) for a, b in ranges] or [np.zeros(0, np.int64)])


def _object_record(o, name: str, boundaries=()) -> dict:
    s = o.spec
    return {
        "name": name, "file": str(s.file), "n_gaussians": o.gaussians.n,
        "layout": o.gaussians.layout, "material": dataclasses.asdict(s.material),
        "up_axis": s.up_axis, "up": s.up if s.up is None or isinstance(s.up, str) else list(s.up),
        "moving_rows": row_ranges(o.moving), "dynamic_time": s.dynamic_time, "scale": s.scale, "fill": s.fill,
        "velocity": list(s.velocity), "angular_velocity": list(s.angular_velocity),
        "velocity_from_model": s.velocity_from_model,
        "n_fill_points": o.fill_slice.stop - o.fill_slice.start,
        "fill_report": o.fill_report.as_dict() if o.fill_report else None,
        "volume": o.fill_report.volume if o.fill_report else None,
        "mass": s.material.rho * o.fill_report.volume if o.fill_report else None,
        "core_fraction": s.core_fraction,
        "surface": (o.surface_rule or {}).get("surface", s.surface), "surface_rule": o.surface_rule,
        "surface_points": s.surface_points,
        "model": o.body_model,
        **o.surface.record(),
        **selection_record(o),
        "alpha": s.alpha, "thickness": s.thickness,
        "flatten": o.flatten_report.as_dict(),
        "placement": {"R": o.placement.R.tolist(), "scale": o.placement.scale, "t": o.placement.t.tolist()},
        "ground_in_file_frame": [ground_in_file_frame(o.placement, b.height) for b in boundaries
                                 if b.kind == "ground"],
    }
