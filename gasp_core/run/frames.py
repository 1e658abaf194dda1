"""Frame rebuild: ``G_t = T^-1(phi(T(G), t))`` with the alpha rule, per object and frame (GASP paper Sec. 3)."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from gasp_core.maps.games import EPS
from gasp_core.maps.rows import by_rows
from gasp_core.gs.unseen import hide, unseen_rows
from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
from gasp_core.prepare.dynamic import background_at
from gasp_core.prepare.placed import PreparedObject
from gasp_core.seam.runner import EngineRun, RunStats
from gasp_core.prepare.selection import scatter
from gasp_core.run.apart import (REACH, TIPS, HostMotion, PieceContext, apart_row, hold_to_pieces, piece_points,
                                 piece_rotations)
from gasp_core.run.sides import PieceTree, keep_split_to_side, keep_to_side, opening

if TYPE_CHECKING:
    from gasp_core.prepare.scene import PreparedScene
    from gasp_core.run.resume import Checkpoint


@dataclass
class FrameState:
    """What a checkpoint needs after each frame: the rebuild's rotations and the engine's state."""

    prev_rot: list[np.ndarray] = field(default_factory=list)
    get_state: Callable[[], dict] | None = None


#: Materials that tear (plasticine softens to zero strength, brittle breaks): only their objects split the
#: triangles the alpha rule clamps (:mod:`gasp_core.maps.split`); a stretched jelly keeps the rule alone.
TEARING = ("plasticine", "brittle")


@dataclass(frozen=True)
class SplitContext:
    """What the split of clamped triangles needs of one object (:mod:`gasp_core.maps.split`).

    Attributes
    ----------
    fill_rest : ndarray, shape (m, 3), float64
        The object's fill points at rest, world frame, metres.
    h : float
        Its fill spacing ``max(p_vol)^(1/3)``, metres.
    """

    fill_rest: np.ndarray
    h: float


def split_context(o: PreparedObject, setup) -> SplitContext | None:
    """The :class:`SplitContext` of ``o`` in ``setup`` (a :class:`~gasp_core.seam.setup.SimSetup`) when it splits
    its clamped triangles: a simulated object with the alpha rule whose material tears (:data:`TEARING`); else
    None (nothing is split and nothing more is written)."""
    if o.spec.static or o.surface.alpha is None or o.spec.material.name not in TEARING:
        return None
    rows = np.arange(len(setup.x))[o.fill_slice]
    h = float(np.max(setup.p_vol[rows])) ** (1 / 3) if len(rows) else 0.0
    return SplitContext(np.asarray(setup.x, np.float64)[rows], h)


#: A piece whose best-fit rigid motion leaves no point further than this (m) moves rigidly (:func:`turn_with_pieces`):
#: float32 positions of a rigid body read about 1e-7 m off its fit, a soft piece's deformation far more.
RIGID_FIT = 1e-5


def rebuild(o: PreparedObject, x: np.ndarray, prev_rot: np.ndarray,
            t: float | None = None, labels: np.ndarray | None = None,
            split: SplitContext | None = None, apart=None,
            hidden: np.ndarray | None = None) -> tuple[Gaussians, np.ndarray, dict]:
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
        it belongs to its anchor's piece, so it is not stretched across the gap: it keeps its rest scales and turns
        with its anchor's piece, ``R = R_piece R_rest`` with ``R_piece`` the best-fit rotation (rest to now,
        :func:`piece_rotations`) of the shape points of that piece's Gaussians that do not straddle (the previous
        frame's rotation where a piece has fewer than 3 such points, or all on a line); its centre still follows
        the map.
    split : SplitContext, optional
        Split the triangles the alpha rule clamps and that straddle no crack into sub-triangle Gaussians
        (:mod:`gasp_core.maps.split`; :func:`split_context` says which objects do); None splits nothing.
    hidden : ndarray, shape (len(o.gaussians),), bool, optional
        The file rows drawn hidden (:func:`gasp_core.gs.unseen.unseen_rows`): left out of ``spanning`` and
        ``specks``, which count what is drawn.

    Returns
    -------
    gaussians : Gaussians
        The whole file, file frame, input order; opacity, SH and extra fields shared with the
        input (never modified); rows that do not move (``select``, ``static``) as read
        (:func:`gasp_core.prepare.selection.scatter`).
    rot : ndarray, shape (n, 3, 3)
        World rotations of this frame.
    counts : dict
        ``degenerate`` faces and ``clamped`` scales (alpha rule) this frame; with ``labels``, ``straddling``; with
        ``apart``, ``held``, ``trimmed``, ``pulled``, ``spanning`` and ``specks``; with ``split``, ``split`` (the
        sub-Gaussians made) and ``split_gaussians`` (:class:`Gaussians` of them, file frame, with the int32 field
        ``parent``: the file row each comes from; None when there are none).
    """
    if o.spec.static:
        g = o.gaussians if t is None else background_at(o, o.gaussians, t)
        return g, prev_rot, {"degenerate": 0, "clamped": 0}
    detail = {} if split is not None else None
    means_w, rot, scales_w, counts = o.surface.gaussians(x[o.vertex_slice], x[o.fill_slice], prev_rot, detail)
    straddle, sides = None, None
    if labels is not None:
        sr = o.surface.shape_rows()
        lab = np.asarray(labels)[o.vertex_slice][sr]
        straddle = (lab != lab[:, :1]).any(axis=1)
        rot[straddle], scales_w[straddle] = prev_rot[straddle], o.surface.scales_rest[straddle]
        if straddle.any():
            turn_with_pieces(o, x, sr, lab, straddle, rot, means_w)
        counts["straddling"] = int(straddle.sum())
        if apart is not None:
            shown = None if hidden is None else ~np.asarray(hidden)[o.moving if o.moving is not None else slice(None)]
            straddle, sides = keep_apart(o, x, labels, apart, prev_rot, means_w, rot, scales_w, straddle, counts, shown)
    pl = o.placement
    scales = scales_w / pl.scale
    scales[:, 0] = o.thin_scale if o.spec.thickness == "keep" else EPS
    quats, = by_rows(lambda r: (rotmat_to_quat(pl.R.T @ r),), len(rot), rot)   # on the host's cores (maps.rows)
    out = scatter(o, pl.to_file(means_w), scales, quats)
    if t is not None:
        out = background_at(o, out, t)
    if split is not None:
        counts["split_gaussians"] = split_gaussians(o, x, detail, straddle, split, sides)
        counts["split"] = 0 if counts["split_gaussians"] is None else counts["split_gaussians"].n
    return out, rot, counts


def keep_apart(o: PreparedObject, x: np.ndarray, labels: np.ndarray, apart: PieceContext, prev_rot: np.ndarray,
               means: np.ndarray, rot: np.ndarray, scales: np.ndarray, straddle: np.ndarray,
               counts: dict, shown: np.ndarray | None = None) -> tuple[np.ndarray, tuple | None]:
    """A broken object's Gaussians kept on their pieces (:func:`hold_to_pieces`, then each on its own side of every
    crack: :func:`gasp_core.run.sides.keep_to_side`), in place, and the frame's ``held``, ``trimmed``, ``spanning``
    and ``specks`` (of the ``shown`` Gaussians, (n,) bool; None: all) put in ``counts``. One tree over the pieces' material points serves the rule and the counts: with
    ``apart.gap`` a :class:`gasp_core.run.sides.PieceTree` that keeps them to their side only where the pieces are
    apart by it (``gasp_core.run.sides``, "Apart there").
    Returns ``straddle`` (n,) with the Gaussians held or trimmed added (the split of clamped triangles leaves them
    alone) and, when the rule keeps sides, ``(own, tree, piece, reach)`` for the split's sub-Gaussians (else None)."""
    pts = piece_points(o, labels, apart)
    lab = np.asarray(labels)
    gap = None if apart.gap is None or apart.p_vol is None or not len(pts) else \
        opening(np.asarray(apart.p_vol)[pts], apart.gap)
    tree = PieceTree(x[pts], lab[pts], gap) if len(pts) else None
    motion = HostMotion(o, x, labels, apart, prev_rot, pts) if len(pts) else None
    sides = None
    if apart.hold:
        held = hold_to_pieces(o, x, labels, apart, prev_rot, means, rot, scales, pts, tree, motion)
        if apart.trim and motion is not None:
            sides = (motion.own, tree, lab[pts], apart.reach)
            moved, trimmed, pulled = keep_to_side(means, rot, scales, *sides, TIPS,
                                                  lambda idx: motion.move(idx, means, rot, scales),
                                                  None if not apart.pull else x[motion.host])
            held |= moved
            counts["trimmed"], counts["pulled"] = int(trimmed.sum()), int(pulled.sum())
            straddle = straddle | trimmed
        counts["held"], straddle = int(held.sum()), straddle | held
    fs = o.fill_slice
    counts.update(apart_row(means, rot, scales, x[fs], np.asarray(labels)[fs], apart.p_mass[fs], apart.pieces,
                            apart.reach, tree, None if motion is None else motion.own, shown))
    return straddle, sides


def turn_with_pieces(o: PreparedObject, x: np.ndarray, sr: np.ndarray, lab: np.ndarray, straddle: np.ndarray,
                     rot: np.ndarray, means: np.ndarray | None = None) -> None:
    """Set ``rot`` (n, 3, 3, world) of the straddling Gaussians (``straddle``, (n,) bool) to their anchor piece's
    rotation since rest times their rest rotation (:func:`rebuild`), in place; ``sr`` (n, k) their shape rows in
    :meth:`~gasp_core.maps.surface.SurfaceMap.points`, ``lab`` (n, k) those points' pieces. With ``means`` (n, 3,
    world), a straddling Gaussian of a piece that moves rigidly (the best fit's largest residual under
    :data:`RIGID_FIT` m: the rigid fragments of a stiff brittle body, ``gasp_core.run.fragment_run``) is also put where
    that motion takes its rest centre, ``c_t + R (m_rest - c_rest)``, instead of the face's map between two pieces
    apart (issue 66: a trail of Gaussians between the cup's fragments)."""
    inner = sr[~straddle].ravel()
    if len(inner) == 0:
        return
    p_rest, p_t, piece = o.surface.points()[inner], x[o.vertex_slice][inner], lab[~straddle].ravel()
    pieces, R, ok = piece_rotations(p_rest, p_t, piece)
    anchor = lab[straddle, 0]
    at = np.clip(np.searchsorted(pieces, anchor), 0, len(pieces) - 1)
    found = (pieces[at] == anchor) & ok[at]
    idx = np.flatnonzero(straddle)[found]
    rot[idx] = R[at[found]] @ o.surface.rot_rest[idx]
    if means is None:
        return
    inv = np.searchsorted(pieces, piece)
    count = np.bincount(inv, minlength=len(pieces))[:, None]
    c0 = np.stack([np.bincount(inv, p_rest[:, d], len(pieces)) for d in range(3)], 1) / count
    c1 = np.stack([np.bincount(inv, p_t[:, d], len(pieces)) for d in range(3)], 1) / count
    resid = np.linalg.norm(p_t - c1[inv] - np.einsum("kij,kj->ki", R[inv], p_rest - c0[inv]), axis=1)
    worst = np.zeros(len(pieces))
    np.maximum.at(worst, inv, resid)
    keep = worst[at[found]] < RIGID_FIT
    j, a = idx[keep], at[found][keep]
    means[j] = c1[a] + np.einsum("kij,kj->ki", R[a], o.surface.tri_rest[j, 0] - c0[a])


def split_gaussians(o: PreparedObject, x: np.ndarray, detail: dict, straddle: np.ndarray | None,
                    split: SplitContext, sides: tuple | None = None) -> Gaussians | None:
    """The sub-triangle Gaussians of ``o``'s clamped triangles that straddle no crack and lie on material
    (:mod:`gasp_core.maps.split`), file frame, each with its parent's opacity and SH and the int32 field ``parent``
    (its row in the object's file); None when there are none. With ``sides`` (:func:`keep_apart`'s) each is kept to
    its parent's side of every crack (:func:`gasp_core.run.sides.keep_split_to_side`)."""
    from gasp_core.maps.split import near_material, split_triangles
    rows = detail["clamped"] if straddle is None else detail["clamped"] & ~straddle
    rows = np.flatnonzero(rows)
    if len(rows) == 0:
        return None
    sm = o.surface
    parent, means, rot, scales, centres_rest = split_triangles(sm.tri_rest, detail["tri"], rows, sm.alpha)
    keep = near_material(means, centres_rest, x[o.fill_slice], split.fill_rest, split.h)
    if sides is not None and keep.any():
        own, tree, piece, reach = sides
        kept = np.flatnonzero(keep)
        sub = scales[kept].copy()
        keep[kept] = keep_split_to_side(means[kept], rot[kept], sub, own[parent[kept]], tree, piece, reach, TIPS)
        scales[kept] = sub
    if not keep.any():
        return None
    parent, means, rot, scales = parent[keep], means[keep], rot[keep], scales[keep]
    pl = o.placement
    scales = scales / pl.scale
    scales[:, 0] = o.thin_scale[parent] if o.spec.thickness == "keep" else EPS
    row = parent if o.moving is None else np.asarray(o.moving)[parent]
    g = o.gaussians
    return Gaussians(means=pl.to_file(means), scales=scales, rotations=rotmat_to_quat(pl.R.T @ rot),
                     opacities=g.opacities[row], sh_dc=g.sh_dc[row], sh_rest=g.sh_rest[row],
                     extra={"parent": row.astype(np.int32)}, source=f"{g.source} split")


class Rebuilder:
    """``T^-1`` of every object of a prepared scene, frame after frame (its previous rotations kept).

    Parameters
    ----------
    prep : PreparedScene
    prev_rot : list of ndarray, optional
        Each object's rotations of the frame before (a resumed run's checkpoint); default the rest rotations.

    Attributes
    ----------
    split : list of SplitContext or None
        Per object, whether (and how) it splits its clamped triangles (:func:`split_context`).
    last_split : list of Gaussians or None
        Per object, the sub-triangle Gaussians of the last frame (:func:`rebuild`; None: none).
    """

    def __init__(self, prep: PreparedScene, prev_rot: list | None = None):
        self.prep = prep
        self.prev_rot = [o.rot_rest for o in prep.objects] if prev_rot is None else list(prev_rot)
        self.split = [split_context(o, prep.setup) for o in prep.objects]
        self.unseen = [unseen_rows(o, TEARING) for o in prep.objects]   # the capture's inside, hidden after frame 0
        self.last_split: list = [None] * len(prep.objects)
        self.hold = True    # False: the Gaussians of crumbs and specks drawn where the map puts them (the rule before)
        self.trim = True    # False: the Gaussians not kept to their side of a crack (the rule before round 32)
        self.pull = True    # False: a centre the hold leaves on another piece's side not pulled (the trim rule)
        self.gap = True     # False: kept to their side wherever another piece's side is, touching or not (the pull rule's)

    def __call__(self, frame: int, x: np.ndarray, labels: np.ndarray | None = None,
                 pieces: np.ndarray | None = None) -> tuple[list[Gaussians], dict]:
        """Every object's Gaussians at ``frame`` from the positions ``x`` (n_points, 3), world frame, and the
        frame's row (``frame``, ``degenerate``, ``clamped``, with ``labels`` (a broken body's pieces, :func:`rebuild`;
        ``pieces`` per label whether it is a piece, :attr:`gasp_core.run.pieces.PieceTracker.pieces`) ``straddling``,
        ``held``, ``trimmed``, ``pulled``, ``spanning``, ``specks`` and ``apart_reach`` (m:
        :mod:`gasp_core.run.apart`), with an object that splits its clamped triangles ``split`` (the sub-Gaussians
        made, :attr:`last_split`) and, with colliders, ``colliders``)."""
        prep, prev = self.prep, self.prev_rot
        gs, row = [], {"frame": frame, "degenerate": 0, "clamped": 0}
        apart = None if labels is None else PieceContext(prep.setup.p_mass, pieces, REACH * float(prep.setup.dx),
                                                         prep.setup.x, self.hold, self.trim, self.pull,
                                                         prep.setup.p_vol, float(prep.setup.dx) if self.gap else None)
        for k, o in enumerate(prep.objects):
            hidden = self.unseen[k] if frame > 0 else None
            g, prev[k], counts = rebuild(o, x, prev[k], frame * prep.setup.frame_dt, labels, self.split[k], apart, hidden)
            row["degenerate"] += counts["degenerate"]
            row["clamped"] += counts["clamped"]
            for key in ("straddling", "held", "trimmed", "pulled", "spanning", "specks"):
                if key in counts:
                    row[key] = row.get(key, 0) + counts[key]
            if "split" in counts:
                row["split"] = row.get("split", 0) + counts["split"]
            sub = counts.get("split_gaussians")
            if hidden is not None and hidden.any():
                g = hide(g, hidden)
                sub = None if sub is None else hide(sub, hidden[np.asarray(sub.extra["parent"])])
                row["unseen"] = row.get("unseen", 0) + int(hidden.sum())
            self.last_split[k] = sub
            gs.append(g)
        if apart is not None:
            row["apart_reach"] = apart.reach
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
                   sleep=getattr(prep.scene, "sleep", False), settle=getattr(prep.scene, "settle", False)) as engine:
        for rec in engine.frames(n_frames):
            gs, row = rebuild_all(rec.frame, rec.x)
            row["sim_s"] = rec.wall_s
            state.get_state = rec.get_state
            yield rec.frame, gs, row
