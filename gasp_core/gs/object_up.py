"""Up of an object capture without a floor (issue 68): its base found from its own axes, whatever the rotation of
the file (step 6 of :mod:`gasp_core.gs.support`, which calls :func:`object_up` from
:func:`~gasp_core.gs.support.estimate_up`). Figures on the bundled files: ``docs/info.md``."""
from __future__ import annotations

import dataclasses

import numpy as np

from gasp_core.gs.gaussians import Gaussians, quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.flat import flat_normals

#: The cues read at most this many Gaussians, drawn with :data:`SEED` (shares and quantiles: a sample reads the same).
N_SCORED = 30000
SEED = 0

#: Object captures (issue 68): a canonical frame's cues must agree with the support plane within this many degrees,
#: else the answer is unsure; the base-plane refinement may move the frame's axis at most :data:`REFINE_MAX` degrees.
AGREE = 10.0
REFINE_MAX = 20.0
#: Base-plane refinement: the bottom slab (times the extent along the axis), the normals' tolerance (degrees),
#: the fewest flat Gaussians it fits a plane to, and its rounds.
BASE_SLAB = 0.05
BASE_NORMAL_TOL = 20.0
BASE_MIN = 20
BASE_ROUNDS = 4


def principal_frame(x: np.ndarray) -> np.ndarray:
    """The principal axes of the points ``x`` (n, 3) as the rows of a proper rotation (3, 3), largest variance
    first: ``x @ F.T`` are the points in the object's own frame, whatever the file's axes."""
    c = x - x.mean(axis=0)
    evecs = np.linalg.eigh(c.T @ c)[1][:, ::-1].T
    if np.linalg.det(evecs) < 0:
        evecs[2] = -evecs[2]
    return evecs


def base_plane(g: Gaussians, up: np.ndarray, keep: np.ndarray | None = None):
    """The plane of the base of ``g`` seen from ``up`` (unit (3,)): the flat Gaussians (``keep`` rows) within
    :data:`BASE_SLAB` times the extent along ``up`` of its lowest end (0.2 % quantile), their normals within
    :data:`BASE_NORMAL_TOL` degrees of ``up``, fitted by opacity-weighted least squares, the axis moved to the fit's
    normal and the slab taken again, :data:`BASE_ROUNDS` times (the support polygon's plane: an object standing on
    its base, legs or a rim, rests on the plane through its lowest flat splats, whatever their own tilt). Returns
    the unit normal (towards ``up``), the count fitted and the plane's offset (``normal . x`` on it), or
    (None, count, 0.0) with fewer than :data:`BASE_MIN`."""
    _, p, n, w = flat_normals(g, keep)
    d, k, offset = np.asarray(up, dtype=np.float64), 0, 0.0
    for _ in range(BASE_ROUNDS):
        h = p @ d
        lo, hi = np.quantile(h, [0.002, 0.998]) if len(h) else (0.0, 0.0)
        m = (h <= lo + BASE_SLAB * (hi - lo)) & (np.abs(n @ d) >= np.cos(np.radians(BASE_NORMAL_TOL)))
        k = int(m.sum())
        if k < BASE_MIN:
            return None, k, 0.0
        c = np.average(p[m], axis=0, weights=w[m])
        q = p[m] - c
        new = np.linalg.eigh((q * w[m, None]).T @ q)[1][:, 0]
        d = new * np.sign(new @ d)
        offset = float(d @ c)
    return d, k, offset


def object_up(g: Gaussians, keep: np.ndarray | None = None):
    """Up of an object capture without a floor (issue 68), whatever the rotation of the file: each end of each
    principal axis of the object (:func:`principal_frame`) is a candidate, moved to the plane of the base it would
    stand on (:func:`base_plane`; a candidate whose base holds too few flat Gaussians, or lies more than
    :data:`REFINE_MAX` degrees away, is dropped); the object is then turned so that the candidate is +z, its other
    axes its own principal axes across it, and the cues of :mod:`gasp_core.gs.up_axis` are read there (the flat
    area facing down, the support slab at one end, the long axis of an upright figure: :func:`gasp_core.gs.up_axis.
    combine`). A candidate holds when they say +z, the support slab among them (a flat base under it), and at least
    one other cue with it: in a frame turned to the candidate one cue alone is not enough (Spot, laid on its mesh,
    has a slab base at its rump; the flat area alone is meaningless on a non-convex object). Two that hold more than
    :data:`AGREE` degrees apart make the answer unsure.

    Returns
    -------
    tuple
        ``(up, confidence, lean, figures)``: ``up`` a unit (3,) or None (unsure), ``lean`` the best candidate
        even when unsure (None when there is none), ``figures`` in words.
    """
    from gasp_core.gs.up_axis import combine, flat_area_asymmetry, longest_axis, support_plane
    keep = np.ones(g.n, dtype=bool) if keep is None else keep
    sub = np.flatnonzero(keep)
    if len(sub) > N_SCORED:                  # the cues are shares and quantiles: a fixed sample reads the same
        sub = np.sort(np.random.default_rng(SEED).choice(sub, N_SCORED, replace=False))
    h = g.subset(sub) if len(sub) < g.n else g
    x = h.means.astype(np.float64)
    F = principal_frame(x)
    cands = []
    for c in (*F, *(-F)):
        d, k, _ = base_plane(h, c)
        if d is not None and float(d @ c) >= np.cos(np.radians(REFINE_MAX)) and \
                not any(float(d @ e) >= np.cos(np.radians(AGREE / 2)) for e, _ in cands):
            cands.append((d, k))
    held, lines, lean = [], [], None
    for d, k in cands:
        across = x - x.mean(axis=0)
        across = across - np.outer(across @ d, d)
        a = np.linalg.eigh(across.T @ across)[1][:, -1]          # the longest direction across d
        G = np.stack([a, np.cross(d, a), d])
        turned = dataclasses.replace(h, means=x @ G.T, rotations=_turn_quats(h.rotations, G))
        cues = [flat_area_asymmetry(turned), support_plane(turned), longest_axis(turned.means)]
        u = combine(cues)
        based = cues[1].votes.get("+z", 0.0) > 0     # a flat base under it, and another cue that agrees: in a
        others = [c for c in (cues[0], cues[2]) if c.votes.get("+z", 0.0) > 0 or c.votes.get("z", 0.0) > 0]
        based = based and bool(others)               # frame turned to the candidate, one cue alone is not enough
        said = f"{np.round(d, 3).tolist()} (base of {k} flat Gaussians): {u.up} ({u.confidence:.2f}, {u.method})"
        if u.up == "+z" and based:
            held.append((u.confidence, d))
            lines.append(said + ": holds")
        else:
            lines.append(said + (": needs a flat base under it and another cue" if u.up == "+z" else ""))
        if u.lean == "+z" and (lean is None or u.confidence > lean[0]):
            lean = (u.confidence, d)
    figures = f"{len(cands)} candidate bases from the principal axes; " + "; ".join(lines)
    if not held:
        return None, 0.0, None if lean is None else lean[1], figures + ": unsure"
    held.sort(key=lambda t: -t[0])
    conf, best = held[0]
    if any(float(best @ d) < np.cos(np.radians(AGREE)) for _, d in held[1:]):
        return None, 0.0, best, figures + f": two bases more than {AGREE:g} deg apart hold, unsure"
    return best, conf, best, figures


def _turn_quats(q: np.ndarray, F: np.ndarray) -> np.ndarray:
    return rotmat_to_quat(F @ quat_to_rotmat(q))
