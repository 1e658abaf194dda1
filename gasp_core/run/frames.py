"""Frame rebuild: ``G_t = T^-1(phi(T(G), t))`` with the alpha rule, per object and frame (GASP paper Sec. 3)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from gasp_core.maps.games import EPS
from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
from gasp_core.prepare.dynamic import background_at
from gasp_core.prepare.placed import PreparedObject
from gasp_core.seam.runner import EngineRun, RunStats
from gasp_core.prepare.selection import scatter

if TYPE_CHECKING:
    from gasp_core.prepare.scene import PreparedScene
    from gasp_core.run.resume import Checkpoint


@dataclass
class FrameState:
    """What a checkpoint needs after each frame: the rebuild's rotations and the engine's state."""

    prev_rot: list[np.ndarray] = field(default_factory=list)
    get_state: Callable[[], dict] | None = None


def rebuild(o: PreparedObject, x: np.ndarray, prev_rot: np.ndarray,
            t: float | None = None, labels: np.ndarray | None = None) -> tuple[Gaussians, np.ndarray, dict]:
    """``G_t = T^-1(phi(T(G), t))`` with the alpha rule for one object at one frame, back in the file frame.

    ``T^-1`` is the object's surface map (:meth:`gasp_core.maps.surface.SurfaceMap.gaussians`: its form and its
    ``rebuild`` rule), ``phi(T(G), t)`` the engine's positions ``x``.

    Parameters
    ----------
    o : PreparedObject
    x : ndarray, shape (n_points, 3)
        All simulated positions of the frame, world frame.
    prev_rot : ndarray, shape (n, 3, 3)
        Previous frame's world rotations (fallback for degenerate triangles).
    t : float, optional
        Seconds since the start: rows of a dynamic model that are not simulated follow it,
        ``psi(V, dynamic_time + t)`` (:func:`gasp_core.prepare.dynamic.background_at`); None keeps them as read.
    labels : ndarray, shape (n_points,), int, optional
        The pieces of a broken body (:meth:`gasp_core.run.pieces.PieceTracker.labels`): a Gaussian whose shape
        points (:meth:`~gasp_core.maps.surface.SurfaceMap.shape_rows`) fall in different pieces *straddles* a crack;
        it belongs to its anchor's piece, so it is not stretched across the gap: it keeps its rest scales and the
        previous frame's rotation (its centre still follows the map).

    Returns
    -------
    gaussians : Gaussians
        The whole file, file frame, input order; opacity, SH and extra fields shared with the
        input (never modified); rows that do not move (``select``, ``static``) as read
        (:func:`gasp_core.prepare.selection.scatter`).
    rot : ndarray, shape (n, 3, 3)
        World rotations of this frame.
    counts : dict
        ``degenerate`` faces and ``clamped`` scales (alpha rule) this frame; with ``labels``, ``straddling``.
    """
    if o.spec.static:
        g = o.gaussians if t is None else background_at(o, o.gaussians, t)
        return g, prev_rot, {"degenerate": 0, "clamped": 0}
    means_w, rot, scales_w, counts = o.surface.gaussians(x[o.vertex_slice], x[o.fill_slice], prev_rot)
    if labels is not None:
        lab = np.asarray(labels)[o.vertex_slice][o.surface.shape_rows()]
        straddle = (lab != lab[:, :1]).any(axis=1)
        rot[straddle], scales_w[straddle] = prev_rot[straddle], o.surface.scales_rest[straddle]
        counts["straddling"] = int(straddle.sum())
    pl = o.placement
    scales = scales_w / pl.scale
    scales[:, 0] = o.thin_scale if o.spec.thickness == "keep" else EPS
    out = scatter(o, pl.to_file(means_w), scales, rotmat_to_quat(pl.R.T @ rot))
    if t is not None:
        out = background_at(o, out, t)
    return out, rot, counts


class Rebuilder:
    """``T^-1`` of every object of a prepared scene, frame after frame (its previous rotations kept).

    Parameters
    ----------
    prep : PreparedScene
    prev_rot : list of ndarray, optional
        Each object's rotations of the frame before (a resumed run's checkpoint); default the rest rotations.
    """

    def __init__(self, prep: PreparedScene, prev_rot: list | None = None):
        self.prep = prep
        self.prev_rot = [o.rot_rest for o in prep.objects] if prev_rot is None else list(prev_rot)

    def __call__(self, frame: int, x: np.ndarray, labels: np.ndarray | None = None) -> tuple[list[Gaussians], dict]:
        """Every object's Gaussians at ``frame`` from the positions ``x`` (n_points, 3), world frame, and the
        frame's row (``frame``, ``degenerate``, ``clamped``, with ``labels`` (a broken body's pieces, :func:`rebuild`)
        ``straddling`` and, with colliders, ``colliders``)."""
        prep, prev = self.prep, self.prev_rot
        gs, row = [], {"frame": frame, "degenerate": 0, "clamped": 0}
        for k, o in enumerate(prep.objects):
            g, prev[k], counts = rebuild(o, x, prev[k], frame * prep.setup.frame_dt, labels)
            row["degenerate"] += counts["degenerate"]
            row["clamped"] += counts["clamped"]
            if "straddling" in counts:
                row["straddling"] = row.get("straddling", 0) + counts["straddling"]
            gs.append(g)
        if prep.setup.colliders:  # run.json collider figures (gasp_core.run.contact)
            from gasp_core.run.contact import contact_row
            row["colliders"] = contact_row(prep.setup, x, frame * prep.setup.frame_dt)
        return gs, row


def iter_frames(prep: PreparedScene, n_frames: int, stats: RunStats | None = None,
                resume: Checkpoint | None = None, state: FrameState | None = None):
    """Yield ``(frame, gaussians_per_object, counts)`` for frame 0 (the input) to ``n_frames``: the engine's
    positions through every object's surface map (:class:`Rebuilder`), for a study or a notebook (``gasp simulate``
    writes them on its own: :class:`gasp_core.run.pipeline.SimulationRun`).

    ``counts`` holds ``frame``, ``degenerate`` faces and ``clamped`` scales, and ``sim_s`` (engine
    wall time) from frame 1 on.

    Parameters
    ----------
    prep : PreparedScene
    n_frames : int
    stats : RunStats, optional
    resume : Checkpoint, optional
        Continue after ``resume.frame`` (frames up to it are not yielded again).
    state : FrameState, optional
        Updated before each yield with the frame's rotations and the engine's ``get_state``.

    Raises
    ------
    EngineDivergence, EngineBug
        See :class:`gasp_core.seam.runner.EngineRun`.
    """
    state = state if state is not None else FrameState()
    rebuild_all = Rebuilder(prep, None if resume is None else resume.prev_rot)
    state.prev_rot = rebuild_all.prev_rot
    if resume is None:
        gs, row = rebuild_all(0, prep.setup.x)
        yield 0, gs, row
    with EngineRun(prep.info, prep.setup, stats, start_frame=0 if resume is None else resume.frame,
                   state=None if resume is None else resume.engine_state,
                   sleep=getattr(prep.scene, "sleep", False)) as engine:
        for rec in engine.frames(n_frames):
            gs, row = rebuild_all(rec.frame, rec.x)
            row["sim_s"] = rec.wall_s
            state.get_state = rec.get_state
            yield rec.frame, gs, row
