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

**Apart there** (round 32, the gap rule, :class:`PieceTree`): a point on another piece's side lies *across a gap* only where the
two pieces are apart at that place: the other piece's material point nearest it (``b``) has no material point of the
Gaussian's own piece within :func:`opening` (the body's fill spacing, a rest neighbour's distance, plus the gap the
pieces are told apart by: :class:`gasp_core.run.pieces.PieceTracker`'s ``gap``, the setup's ``dx``; issue 66: parts
"separated by a gap of at least 1 dx"). Where the two pieces touch (pressed together after the break, or not yet
parted along part of their crack) there is no gap there for a Gaussian to be stretched across: what overlaps the
neighbour there is left as drawn. A plain ``cKDTree`` (or a :class:`PieceTree` without an opening) keeps the pull rule's
rule: every point on another piece's side is across.

**Spanning two pieces** (:func:`gasp_core.run.apart.apart_masks`): a Gaussian whose drawn ellipse reaches across a
gap onto another piece's side: its centre, or one of :data:`SIDES` points on its ``TIPS``-sigma in-plane ellipse, on
the side of a piece not its own, apart from its own there. A Gaussian lying wholly on its piece beside a narrow crack
stops short of the crack's mid-surface and is not counted; one stretched from its piece over a gap onto another piece
is.

**The rule** (:func:`keep_to_side`, called by :func:`gasp_core.run.frames.rebuild` for every broken body): a
Gaussian whose centre the map puts on another piece's side is held by its host's piece (moved rigidly with it from
rest, :func:`gasp_core.run.apart.hold_to_pieces`'s motion); one whose centre the hold still puts on another piece's
side (where two pieces have come together after the break: its rest offset from its host points into the other
piece) is *pulled* towards its host (:func:`pull_to_side`): to the furthest of :data:`PULL` of the way from its host
to where the hold put it that lies on its own side (or on none), the host itself at worst; a Gaussian whose ellipse
reaches another piece's side is trimmed: its two in-plane scales are shrunk (never grown) until every point at the
:data:`FRACTIONS` of the way along each of the :data:`SIDES` rays from its centre to its ellipse lies on its own side
(or on none); one whose ellipse, so shrunk to its floor, still reaches another side (its centre within a hair of the
border) is put on its host and trimmed again. Nothing else changes: a Gaussian that reaches no other piece's side is
drawn as the map (paper Eq. ``T^-1``) and the alpha rule draw it, so an unbroken body (one piece) is drawn exactly as
before. The crack faces (:mod:`gasp_core.maps.crack_faces`) are drawn Gaussians too: each is its fill point's piece's
and is trimmed the same way (:func:`keep_faces_to_side`).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.run.pieces import SPACING_PERCENTILE

#: Points on each Gaussian's ellipse that the counter and the trim look at, evenly spaced in angle (module notes).
SIDES = 8
#: Steps along each ray from the centre to the ellipse at which the trim checks the side (module notes), and before
#: the first of them (``1 / STEPS``) three more, halving towards the centre, so that a Gaussian whose centre lies
#: near a border keeps a small part of itself rather than its whole first step.
STEPS = 8
FRACTIONS = np.concatenate([[1 / 64, 1 / 32, 1 / 16], np.arange(1, STEPS + 1) / STEPS])
#: Fractions of the way from a Gaussian's host to where the hold put it that the pull tries, furthest first (module
#: notes): :data:`FRACTIONS` reversed, then the host itself.
PULL = np.concatenate([FRACTIONS[::-1], [0.0]])


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


def opening(p_vol: np.ndarray, gap: float) -> float:
    """The distance (metres) past which a material point has no neighbour of another piece at that place (module
    notes, "Apart there"): the body's fill spacing (the :data:`gasp_core.run.pieces.SPACING_PERCENTILE` percentile of
    ``p_vol^(1/3)``, ``p_vol`` (k,) m^3 its material points' volumes, as the piece tracker's links) plus ``gap``
    (metres, the tracker's: the setup's ``dx``). Raises ValueError on no volumes."""
    p_vol = np.asarray(p_vol, np.float64)
    if p_vol.size == 0:
        raise ValueError("opening: no material point volumes")
    return float(np.percentile(np.cbrt(p_vol), SPACING_PERCENTILE)) + float(gap)


class PieceTree(cKDTree):
    """A tree over the pieces' material points (``points`` (k, 3) metres, ``piece`` (k,) int) that also tells
    where two pieces are apart (module notes, "Apart there"): with ``opening`` (metres, :func:`opening`) a point on
    another piece's side is across only where that piece's nearest material point has none of the own piece within
    ``opening``; None: everywhere (the pull rule)."""

    def __init__(self, points: np.ndarray, piece: np.ndarray, opening: float | None = None):
        super().__init__(np.asarray(points, np.float64).reshape(-1, 3))
        self.piece, self.opening = np.asarray(piece).ravel(), opening
        self._trees: dict = {}

    def apart(self, rows: np.ndarray, own: np.ndarray) -> np.ndarray:
        """Whether the material points ``rows`` (k,) of this tree have no point of piece ``own`` (k,) within the
        opening: the two pieces apart there; shape (k,), bool."""
        out = np.ones(len(rows), bool)
        for p in np.unique(own):
            if p not in self._trees:
                mine = self.data[self.piece == p]
                self._trees[p] = cKDTree(mine) if len(mine) else None
            t, k = self._trees[p], np.flatnonzero(own == p)
            if t is not None:
                out[k] = ~np.isfinite(t.query(self.data[rows[k]], distance_upper_bound=self.opening)[0])
        return out


def across(samples: np.ndarray, own: np.ndarray, tree: cKDTree, piece: np.ndarray, reach: float) -> np.ndarray:
    """Which points of ``samples`` (..., 3), metres, lie across a gap from their Gaussian's own piece ``own``
    (broadcast to ``samples.shape[:-1]``): on another piece's side (:func:`side_of`), and, with a :class:`PieceTree`
    that has an opening, that piece apart from the own one there, at the point itself (module notes: a centre); shape
    ``samples.shape[:-1]``, bool."""
    shape = samples.shape[:-1]
    if tree.n == 0:
        return np.zeros(shape, bool)
    lab, near = _side_near(samples, tree, piece, reach)
    mine = np.broadcast_to(np.asarray(own), shape)
    bad = (lab >= 0) & (lab != mine)
    if getattr(tree, "opening", None) is not None and bad.any():
        bad[bad] = tree.apart(near[bad], mine[bad])
    return bad


def _side_near(samples, tree, piece, reach):
    """:func:`side_of` of ``samples`` (..., 3) and each one's nearest point of ``tree`` (rows; any where none)."""
    dist, near = tree.query(np.asarray(samples, np.float64).reshape(-1, 3), distance_upper_bound=reach)
    near = np.minimum(near, tree.n - 1)
    lab = np.where(np.isfinite(dist), np.asarray(piece)[near], -1)
    return lab.reshape(samples.shape[:-1]).astype(np.int64), near.reshape(samples.shape[:-1])


#: Halvings of the step before a ray's first point on another piece's side that find where it crosses the border.
BISECT = 6


def across_rays(means: np.ndarray, pts: np.ndarray, own: np.ndarray, tree: cKDTree, piece: np.ndarray,
                reach: float) -> np.ndarray:
    """Which points ``pts`` (n, r, f, 3) metres, along rays from the centres ``means`` (n, 3) in order of their
    distance, lie across a gap from their Gaussian's own piece ``own`` (n,) (module notes): on another piece's side
    and, with a :class:`PieceTree` that has an opening, that piece apart from the own one *where the ray crosses into
    its side* (the border found by :data:`BISECT` halvings between the point that enters that side and the one before
    it, or the centre): a Gaussian that reaches over a closed part of a crack onto the neighbour is not across, one
    over an opened part is. Shape (n, r, f), bool."""
    pts = np.asarray(pts, np.float64)
    if tree.n == 0:
        return np.zeros(pts.shape[:3], bool)
    own = np.asarray(own)
    lab = _side_near(pts, tree, piece, reach)[0]
    bad = (lab >= 0) & (lab != own[:, None, None])
    if getattr(tree, "opening", None) is None or not bad.any():
        return bad
    entry = np.zeros(lab.shape, np.int64)       # where each run of one side along the ray begins
    for j in range(1, lab.shape[2]):
        entry[:, :, j] = np.where(lab[:, :, j] == lab[:, :, j - 1], entry[:, :, j - 1], j)
    gi, ri, fi = np.nonzero(bad)
    key, inv = np.unique(np.stack([gi, ri, entry[gi, ri, fi]], 1), axis=0, return_inverse=True)
    g, r, e = key.T
    hi = pts[g, r, e]
    lo = np.where((e > 0)[:, None], pts[g, r, np.maximum(e - 1, 0)], np.asarray(means, np.float64)[g])
    target = lab[g, r, e]
    for _ in range(BISECT):
        mid = 0.5 * (lo + hi)
        on = (_side_near(mid, tree, piece, reach)[0] == target)[:, None]
        hi, lo = np.where(on, mid, hi), np.where(on, lo, mid)
    near = _side_near(hi, tree, piece, reach)[1]
    bad[gi, ri, fi] = tree.apart(near, own[g])[np.ravel(inv)]
    return bad


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
    bad = across_rays(means, ellipse_points(means, rot, scales, tips, FRACTIONS), own, tree, piece, reach)
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


def pull_to_side(means: np.ndarray, own: np.ndarray, hosts: np.ndarray, tree: cKDTree, piece: np.ndarray,
                 reach: float) -> None:
    """Pull each centre towards its host (module notes, "The rule"), in place: ``means`` (n, 3) metres becomes
    ``hosts + f (means - hosts)``, ``f`` the first of :data:`PULL` at which it lies on its own side (``own`` (n,)) or
    on none, 0 (the host, ``hosts`` (n, 3) metres, a material point of its piece) at worst; ``tree``, ``piece``,
    ``reach`` as :func:`side_of`."""
    if len(means) == 0:
        return
    hosts = np.asarray(hosts, np.float64)
    cand = hosts[:, None] + PULL[None, :, None] * (np.asarray(means, np.float64) - hosts)[:, None]   # (n, p, 3)
    ok = ~across(cand, np.asarray(own)[:, None], tree, piece, reach)
    ok[:, -1] = True
    means[:] = cand[np.arange(len(means)), ok.argmax(axis=1)]


def _reaching(means, rot, scales, own, tree, piece, reach, tips) -> np.ndarray:
    """Which Gaussians have their centre or a point of their ``tips``-sigma ellipse on another piece's side, (n,)."""
    ring = across_rays(means, ellipse_points(means, rot, scales, tips, np.ones(1)), own, tree, piece, reach)
    return across(np.asarray(means, np.float64), own, tree, piece, reach) | ring.any(axis=(1, 2))


def keep_to_side(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, own: np.ndarray, tree: cKDTree,
                 piece: np.ndarray, reach: float, tips: float, hold,
                 hosts: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    hosts : ndarray, shape (n, 3), float, optional
        Each one's host now, metres: with them a centre the hold leaves on another piece's side is pulled to its
        own (:func:`pull_to_side`); None: it is not (the rule of round 32, kept to show what it drew).

    Returns
    -------
    held, trimmed, pulled : ndarray, shape (n,), bool
        Those moved to their host's piece (their centre was on another piece's side), those whose scales shrank, and
        those pulled towards their host.
    """
    n = len(means)
    held, trimmed, pulled = np.zeros(n, bool), np.zeros(n, bool), np.zeros(n, bool)
    if n == 0 or tree.n == 0:
        return held, trimmed, pulled
    own = np.asarray(own)
    idx = np.flatnonzero(across(np.asarray(means, np.float64), own, tree, piece, reach))
    if len(idx):
        hold(idx)
        held[idx] = True
        if hosts is not None:
            idx = idx[across(np.asarray(means[idx], np.float64), own[idx], tree, piece, reach)]
            sub = means[idx].copy()
            pull_to_side(sub, own[idx], np.asarray(hosts)[idx], tree, piece, reach)
            means[idx], pulled[idx] = sub, True
    idx = np.flatnonzero(_reaching(means, rot, scales, own, tree, piece, reach, tips))
    first, before = idx, scales[idx].copy()
    for last in (False, True):     # the second time: those still reaching another side put on their host
        if len(idx) == 0 or (last and hosts is None):
            break
        sub = scales[idx].copy()
        if last:
            means[idx], pulled[idx], sub = np.asarray(hosts)[idx], True, before[np.isin(first, idx)]
        f = trim_to_side(means[idx], rot[idx], sub, own[idx], tree, piece, reach, tips)
        scales[idx] = sub
        trimmed[idx] |= (f < 1).any(axis=1)
        idx = idx[_reaching(means[idx], rot[idx], scales[idx], own[idx], tree, piece, reach, tips)]
    return held, trimmed, pulled


def keep_split_to_side(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, own: np.ndarray, tree: cKDTree,
                       piece: np.ndarray, reach: float, tips: float) -> np.ndarray:
    """The rule (module notes) on Gaussians that are dropped rather than moved: the sub-Gaussians of split triangles
    (:mod:`gasp_core.maps.split`; ``own`` their parent's piece) and the crack faces (:func:`keep_faces_to_side`).
    Arguments as :func:`keep_to_side`. Those whose centre lies on another piece's side are dropped (as the split
    drops those over an opened gap), the others trimmed to their side in place (``scales``), and those that still
    reach another side (a centre within a hair of the border) dropped. Returns the kept ones, shape (n,), bool."""
    if len(means) == 0 or tree.n == 0:
        return np.ones(len(means), bool)
    own = np.asarray(own)
    keep = ~across(np.asarray(means, np.float64), own, tree, piece, reach)
    idx = np.flatnonzero(keep & _reaching(means, rot, scales, own, tree, piece, reach, tips))
    if len(idx):
        sub = scales[idx].copy()
        trim_to_side(means[idx], rot[idx], sub, own[idx], tree, piece, reach, tips)
        scales[idx] = sub
        keep[idx] = ~_reaching(means[idx], rot[idx], sub, own[idx], tree, piece, reach, tips)
    return keep


def keep_faces_to_side(means: np.ndarray, rot: np.ndarray, scales: np.ndarray, visible: np.ndarray,
                       own: np.ndarray, tree: cKDTree, piece: np.ndarray, reach: float,
                       tips: float) -> tuple[np.ndarray, int]:
    """The rule (module notes) on a body's crack faces (:func:`gasp_core.maps.crack_faces.crack_face_gaussians`:
    ``means`` (m, 3), ``rot`` (m, 3, 3) columns ``(n, t1, t2)``, ``scales`` (m, 3), world metres; ``visible`` (m,)
    bool, the shown ones), each its fill point's piece ``own`` (m,): the shown ones trimmed to their side in place
    (``scales``), those that cannot be hidden (:func:`keep_split_to_side`). ``tree``, ``piece``, ``reach``, ``tips``
    as :func:`keep_to_side`. Returns the faces shown now, (m,) bool, and how many were trimmed or hidden."""
    visible = np.asarray(visible, bool).copy()
    idx = np.flatnonzero(visible)
    if len(idx) == 0 or tree.n == 0:
        return visible, 0
    sub = scales[idx].copy()
    visible[idx] = keep_split_to_side(means[idx], rot[idx], sub, np.asarray(own)[idx], tree, piece, reach, tips)
    changed = (sub < scales[idx]).any(axis=1) | ~visible[idx]
    scales[idx] = sub
    return visible, int(changed.sum())
