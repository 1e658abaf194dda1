"""``gasp place SCENE.toml -o PICTURE.png``: a picture of a scene as the run would start it, in seconds, before any
engine is built (issue 54 item 3).

Two orthographic views (front: x-z, side: y-z, world frame, z up against gravity) of the placed objects (what moves in
its own colours, the unselected rest and static objects in grey), the domain box, each ground plane, the colliders'
surfaces (the zero level of their distance fields), the up vector, and what a simulation would cost: points,
substeps a frame (the engine's own step rule, ``EngineInfo.substeps``), memory (:func:`gasp_core.seam.memory.
estimate_bytes`) and a time at a stated rate. Where the engine cannot run here the picture is still drawn, and says so.
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np

from gasp_core.errors import EngineError, GaspError, missing_module_message
from gasp_core.fsutil import atomic_path
from gasp_core.gs.ply import SH_C0
from gasp_core.run.budget import CPU_RATE, duration_text   # CPU_RATE: the rate the time is estimated at

#: At most this many Gaussians drawn per object and per kind (moving, rest), chosen evenly.
MAX_DRAWN = 40_000


def place_picture(scene_path: str | Path, output: str | Path, quality: str | None = None,
                  overwrite: bool = False) -> dict:
    """Draw ``scene_path`` as placed into ``output`` (PNG) and return the figures it shows.

    Returns
    -------
    dict
        ``points``, ``n_substeps`` (None where the engine has no step rule or cannot run here), ``memory_bytes``,
        ``work`` (point-substeps), ``seconds`` (at :data:`CPU_RATE`), ``engine``, ``engine_note``, ``prepare_s``.

    Raises
    ------
    GaspError
        matplotlib missing (the ``studies`` extra), the output exists without ``overwrite``, or a scene error.
    """
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise GaspError(missing_module_message(e, "'gasp place'", "studies") or str(e)) from None
    from gasp_core.scene.spec import load_scene
    output = Path(output)
    if output.exists() and not overwrite:
        raise GaspError(f"{output}: file exists; pass --overwrite to replace it")
    t0 = time.perf_counter()
    scene = load_scene(scene_path, quality=quality)
    setup, objects, info, note = _prepared(scene)
    facts = _cost(scene, setup, info, note)
    facts["prepare_s"] = round(time.perf_counter() - t0, 2)
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.5))
    for ax, (a, b, title) in zip(axes, ((0, 2, "front (x, z)"), (1, 2, "side (y, z)"))):
        _view(ax, scene, setup, objects, a, b, title)
    fig.suptitle(_caption(scene, facts), fontsize=9, family="monospace", ha="left", x=0.02)
    fig.tight_layout(rect=(0, 0, 1, 0.86))
    with atomic_path(output, overwrite=overwrite) as tmp:
        fig.savefig(tmp, dpi=90)
    plt.close(fig)
    return facts


def _prepared(scene):
    """(setup, objects, EngineInfo or None, note): the scene prepared as ``gasp simulate`` would, or without its
    engine where that engine cannot run here."""
    from gasp_core.prepare.assembly import build_setup
    from gasp_core.prepare.ground import has_auto_ground, resolve_ground
    from gasp_core.prepare.placement import prepare_object
    from gasp_core.prepare.scene import around_selection, prepare_scene
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            prep = prepare_scene(scene)
            return prep.setup, prep.objects, prep.info, ""
        except EngineError as e:
            objects = [prepare_object(spec) for spec in scene.objects]
            if has_auto_ground(scene):
                scene = resolve_ground(scene, objects)
            scene = around_selection(scene, objects)[0]
            setup, objects = build_setup(scene, objects)
            return setup, objects, None, str(e).split(":")[0]


def _cost(scene, setup, info, note: str) -> dict:
    from gasp_core.seam.memory import estimate_bytes
    n_sub = None
    if info is not None and info.substeps is not None:
        try:
            n_sub = int(info.substeps(setup))
        except GaspError as e:
            note = f"the step rule refuses the scene: {e}"
    n = len(setup.x)
    work = None if n_sub is None else float(n_sub) * n * scene.n_frames
    precision = str((setup.options or {}).get("precision", "f32"))
    return {"engine": None if info is None else info.name, "engine_note": note, "points": n, "n_substeps": n_sub,
            "memory_bytes": int(estimate_bytes(n, int(setup.n_grid), precision)), "work": work,
            "seconds": None if work is None else work / CPU_RATE, "n_frames": scene.n_frames}


def _caption(scene, f: dict) -> str:
    up = -np.asarray(scene.gravity, float)
    up = (up / np.linalg.norm(up) if np.linalg.norm(up) > 0 else up) + 0.0     # no "-0.0"
    lines = [f"{Path(scene.path).name}: {f['points']:,} simulated points, n_grid {scene.domain.n_grid}, "
             f"{f['n_frames']} frames, engine {f['engine'] or scene.engine.name}"
             + (f" ({f['engine_note']})" if f["engine_note"] else ""),
             f"memory about {f['memory_bytes'] / 2**20:.0f} MiB; "
             + (f"{f['n_substeps']} substeps a frame; {f['work']:.3g} point-substeps, about "
                f"{duration_text(f['seconds'])} at {CPU_RATE:.0e} point-substeps/s (a 2-core CPU)"
                if f["n_substeps"] is not None else "substeps: not known before the engine runs"),
             f"up (against gravity) {np.round(up, 3).tolist()}; blue box: the domain; brown: ground; "
             "red: collider surfaces; grey: what stays still"]
    return "\n".join(lines)


def _view(ax, scene, setup, objects, a: int, b: int, title: str) -> None:
    lo, hi = np.asarray(setup.domain_lo, float), np.asarray(setup.domain_hi, float)
    pad = 0.25 * (hi - lo)
    box_lo, box_hi = lo - pad, hi + pad
    for o in objects:
        rest = getattr(o, "static_tri", None)
        if rest is not None and len(rest):
            p = _clip(rest[:, 0], box_lo, box_hi)
            ax.scatter(p[:, a], p[:, b], s=0.3, c="0.75", linewidths=0)
        if not o.spec.static:
            p = o.tri_rest[:, 0]
            rgb = np.clip(0.5 + SH_C0 * o.simulated_rows(o.gaussians.sh_dc)[:, :3], 0, 1)
            k = _even(len(p))
            ax.scatter(p[k, a], p[k, b], s=float(np.clip(4000 / max(len(k), 1), 0.6, 4.0)), c=rgb[k], linewidths=0)
    for c in getattr(setup, "colliders", None) or []:
        p = _clip(_collider_surface(c), box_lo, box_hi)
        ax.scatter(p[:, a], p[:, b], s=0.3, c="tab:red", linewidths=0, alpha=0.5)
    ax.add_patch(_rect(lo[[a, b]], hi[[a, b]]))
    for g in setup.boundaries:     # the run's: a ground under a selection included (gasp_core.prepare.around)
        if g.kind == "ground" and isinstance(g.height, (int, float)):
            ax.axhline(g.height, color="saddlebrown", lw=1.5)
    centre, size = (lo + hi) / 2, float(np.max(hi - lo))
    ax.annotate("", xy=(lo[a] + 0.05 * size, lo[b] + 0.25 * size), xytext=(lo[a] + 0.05 * size, lo[b] + 0.05 * size),
                arrowprops=dict(arrowstyle="->", color="k"))
    ax.text(lo[a] + 0.07 * size, lo[b] + 0.2 * size, "up", fontsize=8)
    ax.set_xlim(centre[a] - 0.75 * size, centre[a] + 0.75 * size)
    ax.set_ylim(centre[b] - 0.75 * size, centre[b] + 0.75 * size)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=10)
    ax.set_xlabel("xyz"[a] + " (m)")
    ax.set_ylabel("xyz"[b] + " (m)")


def _rect(lo, hi):
    from matplotlib.patches import Rectangle
    return Rectangle(tuple(lo), *(hi - lo), fill=False, edgecolor="tab:blue", lw=1.2)


def _even(n: int) -> np.ndarray:
    return np.arange(n) if n <= MAX_DRAWN else np.linspace(0, n - 1, MAX_DRAWN).astype(np.int64)


def _clip(p: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    p = p[((p >= lo) & (p <= hi)).all(axis=1)]
    return p[_even(len(p))]


def _collider_surface(c) -> np.ndarray:
    """World points of a collider's zero level (samples within half a sample of it), at ``t = 0``."""
    idx = np.argwhere(np.abs(c.phi) <= 0.5 * c.h)
    local = np.asarray(c.origin, float) + idx * c.h
    return local @ np.asarray(c.rotation, float).T + np.asarray(c.position, float)


def add_place_parser(sub) -> None:
    """The ``gasp place`` subcommand."""
    from gasp_core.scene.quality import QUALITY_LEVELS
    p = sub.add_parser("place", help="draw a scene as the run would start it (objects, domain, ground, colliders, "
                                     "up) with what it would cost, in seconds, before any engine is built")
    p.add_argument("scene", type=Path, help="scene TOML")
    p.add_argument("-o", "--output", type=Path, required=True, help="the picture to write (.png)")
    p.add_argument("--quality", choices=QUALITY_LEVELS, help="the level to place at (default: the scene's)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing picture (default: refuse)")
    p.set_defaults(func=_cmd_place)


def _cmd_place(args) -> int:
    if args.output.suffix.lower() != ".png":
        raise GaspError(f"-o {args.output}: gasp place writes a PNG picture; name it .png")
    f = place_picture(args.scene, args.output, quality=args.quality, overwrite=args.overwrite)
    cost = (f"{f['n_substeps']} substeps a frame, about {duration_text(f['seconds'])} on a 2-core CPU"
            if f["n_substeps"] is not None else "substeps not known before the engine runs")
    print(f"{args.output}: {f['points']:,} points, {cost}, memory about {f['memory_bytes'] / 2**20:.0f} MiB "
          f"(placed in {f['prepare_s']} s)")
    return 0
