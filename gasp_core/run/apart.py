"""Whether a broken body's Gaussians read as its pieces (issue 66, "What a user sees"): per frame, the Gaussians
drawn across two pieces and the specks away from every piece, counted from the drawn Gaussians and the material.

A Gaussian is drawn at its centre ``m`` with its in-plane axes ``r2, r3`` and scales ``s2, s3`` (GaMeS, the flat
Gaussian; the thin axis ``r1`` is the face's normal). Its *samples* are its centre and the
:data:`gasp_core.run.sides.SIDES` points of its ellipse at ``TIPS`` standard deviations (where a splat's alpha has
fallen to ``exp(-2)`` = 14 % of its centre's). Each sample lies on the *side* of the piece of the nearest material
point of a piece within ``reach`` (m; :data:`REACH` grid cells ``dx``, the support of the quadratic B-spline the
engines weigh a point's nodes with: a Gaussian further than it from every material point of a piece shares no node
with one; the rest surface of the bundled donut lies within 1.22 ``dx`` of its fill), or on none.

* A Gaussian *spans two pieces* when a sample lies on the side of a piece not its own (its own: its host's,
  :mod:`gasp_core.run.sides`): its ellipse reaches past the mid-surface of a crack, whatever the crack's width, or
  it is drawn on another piece. One wholly on its piece beside a narrow crack is not counted.
* A Gaussian is a *speck* when its centre is further than ``reach`` from every material point of every piece: it is
  drawn in the air or on the floor, away from the parts that have come apart.

The pieces are the piece tracker's (:class:`gasp_core.run.pieces.PieceTracker`: crumbs, the pieces under its debris
share, are not pieces), each body's material points (``p_mass > 0``) in them. ``run.json`` holds, per frame, the
counts ``spanning`` and ``specks`` and the ``reach`` (m) they were counted at (:func:`apart_row`), ``held``: the
Gaussians put back on their pieces (:func:`hold_to_pieces`, and those whose centre lay on another piece's side), and
``trimmed``: those kept to their side and ``pulled``: those pulled towards their host
(:func:`gasp_core.run.sides.keep_to_side`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.run.sides import FRACTIONS, across, across_rays, ellipse_points, host_rows, side_of

#: The reach, in grid cells ``dx`` (module notes).
REACH = 1.5
#: The tips are this many standard deviations from the centre along each in-plane axis (module notes).
TIPS = 2.0
#: The skin of crumbled material (round 60, :func:`hold_to_pieces`): a held Gaussian whose rest centre lay further
#: than the reach from every material point still in a piece (its material has all crumbled: no piece is under it) is
#: drawn as a dot at its host, its scales times :data:`DOT`. False: at its rest offset from its host (round 31's rule,
#: the catch of ``tests/test_apart.py``): a speck, the skin of crumbs drawn in the air beside the piece.
CRUMBLED_DOT = True
#: A dot's share of a Gaussian's rest scales: the trim rule's floor (half the first of
#: :data:`gasp_core.run.sides.FRACTIONS`), a splat under 0.1 mm for the bundled donut's.
DOT = 0.5 * float(FRACTIONS[0])


def apart_masks(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, points: np.ndarray, piece: np.ndarray,
                reach: float, own: np.ndarray | None = None,
                tree: cKDTree | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Which Gaussians span two pieces and which are specks (module notes).

    Parameters
    ----------
    means : ndarray, shape (n, 3), float
        The drawn Gaussians' centres, world frame, metres.
    rot : ndarray, shape (n, 3, 3), float
        Their rotations, world frame (columns ``r1`` the normal, ``r2``, ``r3``).
    scales : ndarray, shape (n, 3), float
        Their scales along those columns, metres.
    points : ndarray, shape (k, 3), float
        The material points of the pieces, world frame, metres.
    piece : ndarray, shape (k,), int
        Each one's piece.
    reach : float
        Metres, > 0 (:data:`REACH` ``dx``).
    own : ndarray, shape (n,), int, optional
        Each Gaussian's own piece (:func:`gasp_core.run.sides.host_rows`' piece); -1 or None: the side its centre
        lies on.
    tree : cKDTree, optional
        A tree already built over ``points`` (the frame's, shared with :func:`hold_to_pieces`); a
        :class:`gasp_core.run.sides.PieceTree` with an opening counts only what reaches across a gap (the pieces
        apart there, :func:`gasp_core.run.sides.across`).

    Returns
    -------
    spanning, specks : ndarray, shape (n,), bool

    Raises
    ------
    ValueError
        ``reach`` is not positive, or the shapes disagree.
    """
    means, rot, scales = (np.asarray(a, np.float64) for a in (means, rot, scales))
    points, piece = np.asarray(points, np.float64).reshape(-1, 3), np.asarray(piece).ravel()
    own = np.full(len(means), -1, np.int64) if own is None else np.asarray(own).ravel()
    if not reach > 0 or len(points) != len(piece) or rot.shape != (len(means), 3, 3) or scales.shape != means.shape \
            or len(own) != len(means):
        raise ValueError(f"apart_masks: reach {reach} must be > 0, points {points.shape} and piece {piece.shape} "
                         f"agree, rot {rot.shape}, scales {scales.shape} and own {own.shape} fit means {means.shape}")
    n = len(means)
    if n == 0 or len(points) == 0:
        return np.zeros(n, bool), np.ones(n, bool) if len(points) == 0 else np.zeros(n, bool)
    tree = cKDTree(points) if tree is None else tree
    ring = ellipse_points(means, rot, scales, TIPS, np.ones(1))
    lab = side_of(np.concatenate([means[:, None], ring[:, :, 0]], 1), tree, piece, reach)
    centre = lab[:, 0]
    first = np.where(lab >= 0, lab, np.iinfo(np.int64).max).min(axis=1)      # without an own piece: a side it takes
    mine = np.where(own >= 0, own, np.where(centre >= 0, centre, first))
    spanning = across(means, mine, tree, piece, reach) | across_rays(means, ring, mine, tree, piece,
                                                                      reach).any(axis=(1, 2))
    return spanning, centre < 0


def apart_row(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, x_fill: np.ndarray, lab_fill: np.ndarray,
              mass_fill: np.ndarray, pieces: np.ndarray | None, reach: float, tree: cKDTree | None = None,
              own: np.ndarray | None = None, shown: np.ndarray | None = None) -> dict:
    """One object's ``run.json`` figures of a frame: ``{"spanning", "specks"}`` (counts, :func:`apart_masks`) of its
    drawn Gaussians (``means``, ``rot``, ``scales`` as there) against its material points: ``x_fill`` (k, 3) world
    metres, ``lab_fill`` (k,) their labels (:meth:`gasp_core.run.pieces.PieceTracker.labels`), ``mass_fill`` (k,) kg
    (0: passive, not material), ``pieces`` (per label, bool: :attr:`~gasp_core.run.pieces.PieceTracker.pieces`; None:
    every label a piece), ``reach`` metres; ``tree`` (optional) one built over those of its points in a piece, in
    their order (:func:`piece_points`); ``own`` (n,) each Gaussian's own piece (as :func:`apart_masks`); ``shown``
    (n,) bool, the Gaussians drawn (None: all; the capture's hidden inside, :mod:`gasp_core.gs.unseen`, is not)."""
    lab = np.asarray(lab_fill)
    keep = np.asarray(mass_fill) > 0
    if pieces is not None:
        keep &= np.asarray(pieces, bool)[lab]
    if tree is not None and tree.n != int(keep.sum()):
        raise ValueError(f"apart_row: the tree holds {tree.n} points, the pieces {int(keep.sum())}")
    spanning, specks = apart_masks(means, rot, scales, np.asarray(x_fill)[keep], lab[keep], reach, own, tree)
    if shown is not None:
        spanning, specks = spanning & shown, specks & shown
    return {"spanning": int(spanning.sum()), "specks": int(specks.sum())}


def piece_rotations(p_rest: np.ndarray, p_t: np.ndarray, piece: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                                       np.ndarray]:
    """The best-fit rotation of each piece from rest to now (Kabsch 1976, "A solution for the best rotation to
    relate two sets of vectors", Acta Cryst. A32: ``H = sum (p_rest - c_rest)(p_t - c_t)^T = U S V^T``,
    ``R = V diag(1, 1, det(V U^T)) U^T``).

    Parameters
    ----------
    p_rest, p_t : ndarray, shape (k, 3), float
        The same points at rest and now, metres.
    piece : ndarray, shape (k,), int
        Each point's piece.

    Returns
    -------
    pieces : ndarray, shape (q,), int64
        The pieces, sorted.
    rot : ndarray, shape (q, 3, 3), float64
        Each one's rotation, rest to now (``p_t - c_t ~ R (p_rest - c_rest)``).
    ok : ndarray, shape (q,), bool
        Whether it is defined: at least 3 points, not all on one line (second singular value of ``H`` above
        ``1e-9`` times the first).
    """
    pieces, inv, count = np.unique(np.asarray(piece), return_inverse=True, return_counts=True)
    q = len(pieces)
    c0 = np.stack([np.bincount(inv, p_rest[:, d], q) for d in range(3)], 1) / count[:, None]
    c1 = np.stack([np.bincount(inv, p_t[:, d], q) for d in range(3)], 1) / count[:, None]
    a, b = p_rest - c0[inv], p_t - c1[inv]
    H = np.stack([np.bincount(inv, a[:, i] * b[:, j], q) for i in range(3) for j in range(3)], 1).reshape(q, 3, 3)
    U, S, Vt = np.linalg.svd(H)
    V, Ut = Vt.transpose(0, 2, 1), U.transpose(0, 2, 1)
    D = np.broadcast_to(np.eye(3), (q, 3, 3)).copy()
    D[:, 2, 2] = np.sign(np.linalg.det(V @ Ut))
    D[D[:, 2, 2] == 0, 2, 2] = 1.0
    ok = (count >= 3) & (S[:, 1] > 1e-9 * np.maximum(S[:, 0], 1e-300))
    return pieces, V @ D @ Ut, ok


class PieceContext(NamedTuple):
    """What :func:`gasp_core.run.frames.rebuild` needs of a frame's pieces beside the point labels.

    Attributes
    ----------
    p_mass : ndarray, shape (n_points,), float64
        Point masses, kg (0: passive).
    pieces : ndarray or None
        Per label, whether it is a piece (False: a crumb; :attr:`gasp_core.run.pieces.PieceTracker.pieces`); None:
        every label a piece.
    reach : float
        Metres (:data:`REACH` times the setup's ``dx``).
    x_rest : ndarray, shape (n_points, 3), float64
        Rest positions, world frame, metres.
    hold : bool
        Put the Gaussians of crumbs and the specks on their pieces (:func:`hold_to_pieces`); False draws them where
        the map puts them (the rule before issue 66's round 31, kept to show what it drew).
    trim : bool
        Keep each Gaussian on its own side of every crack (:func:`gasp_core.run.sides.keep_to_side`); False draws
        them as the map and ``hold`` do (the rule before round 32, kept to show what it drew).
    pull : bool
        Pull a centre that the hold leaves on another piece's side towards its host (:func:`gasp_core.run.sides.
        pull_to_side`); False leaves it there, shrunk to a dot (the trim rule, kept to show what it drew).
    p_vol : ndarray, shape (n_points,), float64, optional
        Point volumes, m^3 (the fill spacing of :func:`gasp_core.run.sides.opening`).
    gap : float, optional
        Metres (the piece tracker's: the setup's ``dx``): a Gaussian is kept to its side only where the pieces are
        apart by it there (:class:`gasp_core.run.sides.PieceTree`); None (or no ``p_vol``): wherever another
        piece's side is (the pull rule, kept to show what it drew).
    """

    p_mass: np.ndarray
    pieces: np.ndarray | None
    reach: float
    x_rest: np.ndarray
    hold: bool = True
    trim: bool = True
    pull: bool = True
    p_vol: np.ndarray | None = None
    gap: float | None = None


def piece_points(o, labels: np.ndarray, ctx: PieceContext) -> np.ndarray:
    """The setup rows of object ``o``'s material points that lie in a piece (not a crumb), shape (k,), int64."""
    rows = np.arange(len(ctx.p_mass))[o.fill_slice]
    rows = rows[np.asarray(ctx.p_mass)[rows] > 0]
    if ctx.pieces is not None:
        rows = rows[np.asarray(ctx.pieces, bool)[np.asarray(labels)[rows]]]
    return rows


class HostMotion:
    """Each Gaussian's host and the rigid motion of its piece, for one object and frame (:func:`hold_to_pieces`,
    :func:`gasp_core.run.sides.keep_to_side`).

    Parameters
    ----------
    o : PreparedObject
    x : ndarray, shape (n_points, 3), float
        World positions now, metres.
    labels : ndarray, shape (n_points,), int
        The point labels.
    ctx : PieceContext
    prev_rot : ndarray, shape (n, 3, 3), float
        The object's Gaussians' rotations of the frame before (world).
    pts : ndarray, shape (k,), int
        The setup rows of its material points in a piece (:func:`piece_points`), not empty.

    Attributes
    ----------
    host : ndarray, shape (n,), int64
        Each Gaussian's host: the material point of a piece nearest its centre at rest (setup rows;
        :func:`gasp_core.run.sides.host_rows`).
    own : ndarray, shape (n,), int64
        The host's piece: the Gaussian's own piece.
    """

    def __init__(self, o, x: np.ndarray, labels: np.ndarray, ctx: PieceContext, prev_rot: np.ndarray,
                 pts: np.ndarray):
        self.o, self.x, self.lab, self.ctx, self.prev_rot, self.pts = o, x, np.asarray(labels), ctx, prev_rot, pts
        self.host = host_rows(o.surface.tri_rest[:, 0], ctx.x_rest[pts], pts)
        self.own = self.lab[self.host]
        self._fit: tuple | None = None

    def move(self, idx: np.ndarray, means: np.ndarray, rot: np.ndarray, scales: np.ndarray) -> None:
        """Move the Gaussians ``idx`` (int array) rigidly with their host's piece, in place: ``m = x_host + R (m_rest
        - x_host,rest)``, ``R_g = R R_rest``, their rest scales, ``R`` the piece's best-fit rotation since rest
        (:func:`piece_rotations` over its material points; where undefined, the Gaussian's previous rotation)."""
        if len(idx) == 0:
            return
        o, ctx, pts = self.o, self.ctx, self.pts
        if self._fit is None:
            self._fit = piece_rotations(ctx.x_rest[pts], self.x[pts], self.lab[pts])
        pieces, R, ok = self._fit
        host = self.host[idx]
        m_rest = o.surface.tri_rest[idx, 0]
        at = np.searchsorted(pieces, self.lab[host])
        Rg = np.where(ok[at][:, None, None], R[at], self.prev_rot[idx] @ o.surface.rot_rest[idx].transpose(0, 2, 1))
        means[idx] = self.x[host] + np.einsum("kij,kj->ki", Rg, m_rest - ctx.x_rest[host])
        rot[idx] = Rg @ o.surface.rot_rest[idx]
        scales[idx] = o.surface.scales_rest[idx]


def hold_to_pieces(o, x: np.ndarray, labels: np.ndarray, ctx: PieceContext, prev_rot: np.ndarray,
                   means: np.ndarray, rot: np.ndarray, scales: np.ndarray, pts: np.ndarray | None = None,
                   tree: cKDTree | None = None, motion: HostMotion | None = None) -> np.ndarray:
    """Put object ``o``'s Gaussians that its pieces would not show back on them, in place; which, shape (n,), bool.

    A Gaussian is held to a piece when its anchor point (:meth:`~gasp_core.maps.surface.SurfaceMap.anchors`) is in a
    crumb (a part under the tracker's debris share: the crack band's broken material, not a fragment a user would
    count), or when the map draws it further than ``ctx.reach`` from every material point of every piece (its
    surface point left behind where the material flowed away, or carried off with a crumb). Its *host* is the
    material point of a piece nearest its anchor at rest (for a crumb's Gaussian: the piece the crumb was part of,
    by rest adjacency). It moves rigidly with the host's piece (:meth:`HostMotion.move`), as a straddling Gaussian
    turns (:func:`gasp_core.run.frames.turn_with_pieces`). So it is drawn within its rest distance from its host, a
    material point of the piece. One whose rest centre lay further than ``ctx.reach`` from its host (so from every
    point still in a piece: the material under it has all crumbled) is drawn as a dot at its host
    (:data:`CRUMBLED_DOT`, round 60): it has no piece to be the skin of, and at its rest offset it was a speck.

    ``x`` (n_points, 3) world positions, ``labels`` (n_points,) the point labels, ``prev_rot`` (n, 3, 3) the last
    frame's rotations; ``means`` (n, 3), ``rot`` (n, 3, 3), ``scales`` (n, 3): the Gaussians (world frame, metres),
    changed in place; ``pts`` (:func:`piece_points`), ``tree`` (over ``x[pts]``) and ``motion`` (a
    :class:`HostMotion` of this frame), when the caller has them.
    """
    pts = piece_points(o, labels, ctx) if pts is None else pts
    n = len(means)
    if len(pts) == 0 or n == 0:
        return np.zeros(n, bool)
    lab = np.asarray(labels)
    anchor = np.arange(len(ctx.p_mass))[o.vertex_slice][o.surface.anchors()]
    crumb = np.zeros(n, bool) if ctx.pieces is None else ~np.asarray(ctx.pieces, bool)[lab[anchor]]
    tree = cKDTree(x[pts]) if tree is None else tree
    away = tree.query(means, distance_upper_bound=ctx.reach)[0] > ctx.reach
    held = np.flatnonzero(crumb | away)
    if len(held) == 0:
        return np.zeros(n, bool)
    motion = HostMotion(o, x, labels, ctx, prev_rot, pts) if motion is None else motion
    motion.move(held, means, rot, scales)
    if CRUMBLED_DOT:   # no piece under it at rest: the skin of crumbled material, a dot at its host
        host = motion.host[held]
        gone = np.linalg.norm(o.surface.tri_rest[held, 0] - ctx.x_rest[host], axis=1) > ctx.reach
        means[held[gone]] = x[host[gone]]
        scales[held[gone]] *= DOT
    out = np.zeros(n, bool)
    out[held] = True
    return out
