"""Each Gaussian of a broken body drawn on its own side of every crack (issue 66, "What a user sees": no Gaussian
stretched across a gap, none spanning two pieces).

**Its piece.** A Gaussian's *own piece* is the piece of its *host*, the material point of a piece (the piece
tracker's pieces, crumbs not) nearest its centre at rest (:func:`host_rows`): the piece whose skin it was. For a
Gaussian whose anchor point is in a piece that is the anchor's piece (the tracker gives a passive point the piece of
its nearest material point at rest).

**Its side.** The material points of the pieces split space into sides: a point in space lies on the side of the
piece of its nearest material point, if that is within the reach (:data:`gasp_core.run.apart.REACH` ``dx``), or on
no side (in the air). The border between two pieces' sides is the mid-surface of the crack between them, whatever
its width: a crack half a cell wide has its border a quarter of a cell from each piece.

**Spanning two pieces** (:func:`gasp_core.run.apart.apart_masks`): a Gaussian whose drawn ellipse reaches another
piece's side: its centre, or one of :data:`SIDES` points on its ``TIPS``-sigma in-plane ellipse, on the side of a
piece not its own. A Gaussian lying wholly on its piece beside a narrow crack stops short of the crack's mid-surface
and is not counted; one stretched from its piece over a gap onto another piece is.

**The rule** (:func:`keep_to_side`, called by :func:`gasp_core.run.frames.rebuild` for every broken body): a
Gaussian whose centre the map puts on another piece's side is held by its host's piece (moved rigidly with it from
rest, :func:`gasp_core.run.apart.hold_to_pieces`'s motion); a Gaussian whose ellipse reaches another piece's side is
trimmed: its two in-plane scales are shrunk (never grown) until every point at the :data:`FRACTIONS` of the way along
each of the :data:`SIDES` rays from its centre to its ellipse lies on its own side (or on none). Nothing else changes: a
Gaussian that reaches no other piece's side is drawn as the map (paper Eq. ``T^-1``) and the alpha rule draw it, so an
unbroken body (one piece) is drawn exactly as before.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: Points on each Gaussian's ellipse that the counter and the trim look at, evenly spaced in angle (module notes).
SIDES = 8
#: Steps along each ray from the centre to the ellipse at which the trim checks the side (module notes), and before
#: the first of them (``1 / STEPS``) three more, halving towards the centre, so that a Gaussian whose centre lies
#: near a border keeps a small part of itself rather than its whole first step.
STEPS = 8
FRACTIONS = np.concatenate([[1 / 64, 1 / 32, 1 / 16], np.arange(1, STEPS + 1) / STEPS])


def ellipse_points(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, tips: float,
                   frac: np.ndarray) -> np.ndarray:
    """Points on each Gaussian's in-plane rays: ``m + f tips (cos a s2 r2 + sin a s3 r3)`` for the :data:`SIDES`
    angles ``a = 2 pi k / SIDES`` and each fraction ``f`` of ``frac``.

    Parameters
    ----------
    means : ndarray, shape (n, 3), float
        Centres, metres.
    rot : ndarray, shape (n, 3, 3), float
        Rotations (columns ``r1`` the normal, ``r2``, ``r3``).
    scales : ndarray, shape (n, 3), float
        Scales along those columns, metres.
    tips : float
        Standard deviations to the ellipse.
    frac : ndarray, shape (f,), float
        Fractions of the way from the centre to the ellipse.

    Returns
    -------
    ndarray, shape (n, SIDES, f, 3), float64
    """
    a = 2 * np.pi * np.arange(SIDES) / SIDES
    arm2 = tips * np.asarray(scales, np.float64)[:, 1, None] * np.asarray(rot, np.float64)[:, :, 1]
    arm3 = tips * np.asarray(scales, np.float64)[:, 2, None] * np.asarray(rot, np.float64)[:, :, 2]
    ray = np.cos(a)[None, :, None] * arm2[:, None] + np.sin(a)[None, :, None] * arm3[:, None]      # (n, SIDES, 3)
    return np.asarray(means, np.float64)[:, None, None] + np.asarray(frac)[None, None, :, None] * ray[:, :, None]


def side_of(samples: np.ndarray, tree: cKDTree, piece: np.ndarray, reach: float) -> np.ndarray:
    """The side each point of ``samples`` (shape (..., 3), metres) lies on: the piece (of ``piece``, shape (k,), one
    per point of ``tree``) of its nearest point in ``tree`` within ``reach`` metres, else -1; shape (...), int64."""
    shape = samples.shape[:-1]
    if tree.n == 0:
        return np.full(shape, -1, np.int64)
    dist, near = tree.query(samples.reshape(-1, 3), distance_upper_bound=reach)
    lab = np.where(np.isfinite(dist), np.asarray(piece)[np.minimum(near, tree.n - 1)], -1)
    return lab.reshape(shape).astype(np.int64)


def host_rows(m_rest: np.ndarray, x_rest_pts: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Each Gaussian's host (module notes): the row of ``pts`` (the setup rows of the material points in a piece,
    shape (k,)) whose rest position (``x_rest_pts``, shape (k, 3), metres) is nearest its rest centre (``m_rest``,
    shape (n, 3), metres); shape (n,), int64 (setup rows)."""
    if len(pts) == 0:
        return np.zeros(len(m_rest), np.int64)
    return np.asarray(pts)[cKDTree(x_rest_pts).query(m_rest)[1]]


def _clear_steps(means, rot, scales, own, tree, piece, reach, tips) -> np.ndarray:
    """Per Gaussian and ray, the share of the way to its ellipse that lies on its own side (or on none): the last of
    :data:`FRACTIONS` before the first on another piece's side (0 if that is the first); shape (n, SIDES), float."""
    lab = side_of(ellipse_points(means, rot, scales, tips, FRACTIONS), tree, piece, reach)   # (n, SIDES, steps)
    bad = (lab >= 0) & (lab != np.asarray(own)[:, None, None])
    first = np.where(bad.any(axis=2), bad.argmax(axis=2), len(FRACTIONS))
    return np.concatenate([[0.0], FRACTIONS])[first]


def trim_to_side(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, own: np.ndarray, tree: cKDTree,
                 piece: np.ndarray, reach: float, tips: float) -> np.ndarray:
    """Shrink the in-plane scales of the Gaussians given (module notes, "The rule") so that their rays stay on their
    own side; returns the factors applied, shape (n, 2) (1: unchanged), and changes ``scales`` (n, 3) in place.

    First each axis by the clear share of its two rays (``r2``: angles 0 and pi; ``r3``: pi/2 and 3 pi/2), then both by
    the least clear share of all :data:`SIDES` rays of the ellipse so shrunk (a uniform shrink keeps each ray's
    direction, so what was clear stays clear). No axis shrinks below half the first of :data:`FRACTIONS` of its scale
    (a centre on another piece's side, which the rule first moves, blocks every ray: such a Gaussian stays
    counted). ``means``, ``rot`` as
    :func:`ellipse_points`; ``own`` (n,) each one's piece; ``tree``, ``piece``, ``reach`` as :func:`side_of`;
    ``tips`` standard deviations to the ellipse."""
    floor = 0.5 * FRACTIONS[0]
    rest = scales[:, 1:].copy()
    clear = _clear_steps(means, rot, scales, own, tree, piece, reach, tips)
    q = SIDES // 4
    f = np.stack([np.minimum(clear[:, 0], clear[:, 2 * q]), np.minimum(clear[:, q], clear[:, 3 * q])], 1)
    f = np.maximum(f, floor)
    scales[:, 1:] = rest * f
    f = np.maximum(f * _clear_steps(means, rot, scales, own, tree, piece, reach, tips).min(axis=1)[:, None], floor)
    scales[:, 1:] = rest * f
    return f


def keep_to_side(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, own: np.ndarray, tree: cKDTree,
                 piece: np.ndarray, reach: float, tips: float, hold) -> tuple[np.ndarray, np.ndarray]:
    """The rule (module notes) on one object's Gaussians, in place.

    Parameters
    ----------
    means, rot, scales : ndarray, shapes (n, 3), (n, 3, 3), (n, 3), float
        The drawn Gaussians, world frame, metres (changed in place).
    own : ndarray, shape (n,), int
        Each one's own piece (its host's, :func:`host_rows`).
    tree : cKDTree
        Over the material points of the pieces, now, metres.
    piece : ndarray, shape (k,), int
        Those points' pieces.
    reach : float
        Metres (> 0).
    tips : float
        Standard deviations to the ellipse (:data:`gasp_core.run.apart.TIPS`).
    hold : callable
        ``hold(idx)`` moves the Gaussians ``idx`` (int array) rigidly with their host's piece, in place
        (:func:`gasp_core.run.apart.hold_to_pieces`'s motion).

    Returns
    -------
    held, trimmed : ndarray, shape (n,), bool
        Those moved to their host's piece (their centre was on another piece's side), and those whose scales shrank.
    """
    n = len(means)
    held, trimmed = np.zeros(n, bool), np.zeros(n, bool)
    if n == 0 or tree.n == 0:
        return held, trimmed
    centre = side_of(np.asarray(means, np.float64), tree, piece, reach)
    idx = np.flatnonzero((centre >= 0) & (centre != own))
    if len(idx):
        hold(idx)
        held[idx] = True
    lab = side_of(ellipse_points(means, rot, scales, tips, np.ones(1))[:, :, 0], tree, piece, reach)
    idx = np.flatnonzero(((lab >= 0) & (lab != np.asarray(own)[:, None])).any(axis=1))
    if len(idx):
        sub = scales[idx].copy()
        f = trim_to_side(means[idx], rot[idx], sub, np.asarray(own)[idx], tree, piece, reach, tips)
        scales[idx] = sub
        trimmed[idx] = (f < 1).any(axis=1)
    return held, trimmed


def keep_split_to_side(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, own: np.ndarray, tree: cKDTree,
                       piece: np.ndarray, reach: float, tips: float) -> np.ndarray:
    """The rule (module notes) on sub-Gaussians of split triangles (:mod:`gasp_core.maps.split`; arguments as
    :func:`keep_to_side`, ``own`` their parent's piece): those whose centre lies on another piece's side are dropped
    (as the split drops those over an opened gap), the others trimmed to their side in place (``scales``). Returns the
    kept ones, shape (n,), bool."""
    if len(means) == 0 or tree.n == 0:
        return np.ones(len(means), bool)
    centre = side_of(np.asarray(means, np.float64), tree, piece, reach)
    keep = (centre < 0) | (centre == own)
    lab = side_of(ellipse_points(means, rot, scales, tips, np.ones(1))[:, :, 0], tree, piece, reach)
    idx = np.flatnonzero(keep & ((lab >= 0) & (lab != np.asarray(own)[:, None])).any(axis=1))
    if len(idx):
        sub = scales[idx].copy()
        trim_to_side(means[idx], rot[idx], sub, np.asarray(own)[idx], tree, piece, reach, tips)
        scales[idx] = sub
    return keep
