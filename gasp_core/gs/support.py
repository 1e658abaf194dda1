"""Gravity and support from the scan: the dominant support plane of a Gaussian Splatting file, in any direction.

:mod:`gasp_core.gs.up_axis` snaps to one of six axes; a capture's gravity is any direction. Here the up vector is
the normal of the **support plane**, found without reference to the file's axes (so it follows the geometry under
any rotation):

1. **Flat Gaussians** (min / max scale < :data:`gasp_core.gs.flat.FLAT_RATIO`, floaters left out,
   :func:`gasp_core.maps.floaters.find_floaters`) each give a point (``means``) and a normal (the thin axis).
2. **Planes, by a seeded vote** (RANSAC with one-point hypotheses, Fischler & Bolles 1981): each of
   :data:`N_SEEDS` flat Gaussians, drawn with a fixed seed, proposes the plane through its mean along its normal;
   its score is the opacity-weighted share of flat Gaussians within :data:`PLANE_TOL` times the object's robust
   diagonal of the plane whose normal is within :data:`NORMAL_TOL` degrees of it.
3. **Support**: a plane is a support when the object lies on one side: at most :data:`MAX_BELOW` of the
   Gaussians (floaters left out) lie beyond it by more than the tolerance. Up is its normal turned to the side
   the object lies on; the plane is refined by a weighted least-squares fit to its inliers.
4. **Cameras**, where a ``cameras.json`` lies beside the file (:func:`with_cameras`): their mean up confirms
   the plane, vetoes it, or decides alone when every camera is upright.
5. **Confidence** ``(1 - s2 / s1) * (1 - below / MAX_BELOW)``: ``s1`` the best support's score, ``s2`` the best
   other support's whose normal is more than :data:`DISTINCT` degrees away (an object that could stand two ways
   is ambiguous), ``below`` the best one's share beyond it. Below :data:`UP_SURE` (or with no support, or a
   support holding less than :data:`MIN_SHARE`) the answer is **unsure**: ``up`` is None and ``lean`` the best
   candidate.

6. **The object's own axes** (issue 68; :func:`gasp_core.gs.object_up.object_up`): an object capture without a floor (SuperSplat,
   Polycam, Scaniverse) still has a base. Each end of each principal axis is a candidate, moved to the plane of
   the flat splats it would stand on (the support polygon's plane, :func:`~gasp_core.gs.object_up.base_plane`); the object turned so that
   the candidate is +z, the cues of :mod:`gasp_core.gs.up_axis` (flat base facing down, support slab at one end,
   the long axis of an upright figure) must say +z, the support slab and another cue among them. Where the
   support plane of step 3 is sure too, the two must agree within ``AGREE`` (10) degrees, else unsure.

A scene slice (a room seen from inside: content on both sides of every plane) has no support and comes out
unsure. A standing guitar, whose largest planes are its faces, has no sure support plane but its own axes find
its base (1.9 degrees off under any rotation). Figures on the bundled files: ``docs/info.md``.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from gasp_core.gs.flat import flat_normals
from gasp_core.gs.gaussians import Gaussians

#: Plane tolerance: inlier distance, times the robust diagonal (1st to 99th percentile box of the means).
PLANE_TOL = 0.005
#: Inlier normals within this many degrees of the plane's.
NORMAL_TOL = 10.0
#: Plane hypotheses (flat Gaussians drawn with :data:`SEED`); flat Gaussians scored against, at most.
N_SEEDS = 256
N_SCORED = 30000
SEED = 0
#: A support has at most this share of the object's Gaussians beyond it.
MAX_BELOW = 0.05
#: A support's opacity-weighted share of the flat Gaussians must reach this to be claimed.
MIN_SHARE = 0.005
#: Two supports count as different stances when their normals differ by more than this (degrees).
DISTINCT = 20.0
#: Below this confidence no up vector is claimed.
UP_SURE = 0.5
#: Cameras (a ``cameras.json`` beside the file): a plane this many degrees from their mean up stands; with no
#: sure plane, cameras this upright (their mean up's length) decide alone.
CAMERA_AGREE = 15.0
CAMERA_SURE = 0.9


@dataclass(frozen=True)
class SupportPlane:
    """A plane ``{x : normal . x = offset}`` in the file frame (file units); ``normal`` (3,) unit, pointing up
    (to the side the object lies on); ``share`` the opacity-weighted share of flat Gaussians on it; ``below``
    the share of the object's Gaussians beyond it."""

    normal: np.ndarray
    offset: float
    share: float
    below: float

    def as_dict(self) -> dict:
        """JSON form: ``normal`` (list of 3 floats), ``offset`` (file units), ``share``, ``below``."""
        return {"normal": [round(float(v), 6) for v in self.normal], "offset": round(float(self.offset), 6),
                "share": round(self.share, 4), "below": round(self.below, 4)}


@dataclass(frozen=True)
class UpEstimate:
    """:func:`estimate_up`'s answer: ``up`` a unit vector (3,) in the file frame, or None when unsure;
    ``confidence`` in [0, 1]; ``plane`` the support plane (None when unsure); ``lean`` the best candidate plane
    even when unsure (None when there is none); ``figures`` what was measured, in words."""

    up: np.ndarray | None
    confidence: float
    plane: SupportPlane | None
    lean: SupportPlane | None
    figures: str


def _hypotheses(p, n, w, tol):
    """Score of each seed plane (through ``p[j]`` along ``n[j]``): opacity-weighted inlier share."""
    rng = np.random.default_rng(SEED)
    seeds = rng.choice(len(p), min(len(p), N_SEEDS), replace=False)
    aligned = np.abs(n[seeds] @ n.T) >= np.cos(np.radians(NORMAL_TOL))           # (k, m)
    near = np.abs(p @ n[seeds].T - np.sum(p[seeds] * n[seeds], axis=1)) <= tol   # (m, k)
    score = ((aligned & near.T) @ w) / w.sum()
    return seeds, score


def _refine(p, n, w, normal, offset, tol):
    """Weighted least-squares plane through the inliers of ``(normal, offset)``; twice."""
    for _ in range(2):
        inl = (np.abs(n @ normal) >= np.cos(np.radians(NORMAL_TOL))) & (np.abs(p @ normal - offset) <= tol)
        if inl.sum() < 3:
            break
        c = np.average(p[inl], axis=0, weights=w[inl])
        d = p[inl] - c
        evals, evecs = np.linalg.eigh((d * w[inl, None]).T @ d)
        new = evecs[:, 0] * np.sign(evecs[:, 0] @ normal)
        normal, offset = new, float(new @ c)
    return normal, offset


def estimate_up(g: Gaussians) -> UpEstimate:
    """The up vector and support plane of ``g`` (module notes), frame-free: the support plane of the scan
    (:func:`support_up`) and, for an object capture without a floor, its base found from its own axes
    (:func:`gasp_core.gs.object_up.object_up`, issue 68). Where both are sure they must agree within ``AGREE``
    degrees (the support plane's answer stands), else the answer is unsure; where only one is sure, it decides.

    Parameters
    ----------
    g : Gaussians
        Any file's Gaussians, file frame and units.

    Returns
    -------
    UpEstimate
        ``up`` unit (3,) float64 or None (unsure), ``confidence``, ``plane``, ``lean``, ``figures``.
    """
    from gasp_core.gs.object_up import AGREE, base_plane, object_up
    from gasp_core.maps.floaters import find_floaters
    body = ~find_floaters(g.means, g.scales.max(axis=1)) if g.n > 1 else np.ones(g.n, dtype=bool)
    e = support_up(g, body)
    if e.figures.endswith("too few to fit a plane"):
        return e
    try:
        up, conf, _, said = object_up(g, body)
    except (np.linalg.LinAlgError, ValueError) as err:     # degenerate geometry (all on a line, non-finite)
        up, conf, said = None, 0.0, f"none ({err})"
    figures = e.figures + "; object axes: " + said
    if up is None:
        return dataclasses.replace(e, figures=figures)
    if e.up is not None:
        angle = float(np.degrees(np.arccos(np.clip(e.up @ up, -1.0, 1.0))))
        if angle <= AGREE:
            return dataclasses.replace(e, figures=figures + f"; the two agree ({angle:.1f} deg)")
        return UpEstimate(None, 0.0, None, e.lean, figures + f"; the support plane and the object's base disagree "
                          f"by {angle:.1f} deg: unsure")
    d, k, offset = base_plane(g, up, body)
    if d is None:
        d, offset = up, float(np.min(g.means[body] @ up))
    xb = g.means[body].astype(np.float64)
    lo, hi = np.quantile(xb, [0.01, 0.99], axis=0)
    tol = PLANE_TOL * float(np.linalg.norm(hi - lo))
    below = float(np.mean(xb @ d - offset < -tol))
    plane = SupportPlane(d, offset, k / max(len(flat_normals(g, body)[0]), 1), below)
    return UpEstimate(d, conf, plane, plane, figures + ": the object's base decides")


def support_up(g: Gaussians, body: np.ndarray) -> UpEstimate:
    """The up vector and support plane of ``g`` from the support plane of the scan alone (module notes, steps 1-3
    and 5), frame-free; ``body`` (bool, (n,)) the rows that are not floaters."""
    rows, p, n, w = flat_normals(g, body)
    if len(rows) < 10:
        return UpEstimate(None, 0.0, None, None, f"{len(rows)} flat Gaussians: too few to fit a plane")
    xb = g.means[body].astype(np.float64)
    lo, hi = np.quantile(xb, [0.01, 0.99], axis=0)
    tol = PLANE_TOL * float(np.linalg.norm(hi - lo))
    rng = np.random.default_rng(SEED)
    if len(p) > N_SCORED:
        pick = np.sort(rng.choice(len(p), N_SCORED, replace=False))
        p, n, w = p[pick], n[pick], w[pick]
    if len(xb) > N_SCORED:
        xb = xb[np.sort(rng.choice(len(xb), N_SCORED, replace=False))]
    seeds, score = _hypotheses(p, n, w, tol)
    supports, lean = [], None
    for k in np.argsort(-score):
        normal, offset = n[seeds[k]], float(p[seeds[k]] @ n[seeds[k]])
        h = xb @ normal - offset
        plus, minus = float(np.mean(h > tol)), float(np.mean(h < -tol))
        if minus > plus:
            normal, offset, plus, minus = -normal, -offset, minus, plus
        cand = SupportPlane(normal, offset, float(score[k]), minus)
        lean = lean or cand
        if minus <= MAX_BELOW and not any(abs(normal @ s.normal) > np.cos(np.radians(DISTINCT)) for s in supports):
            supports.append(cand)
        if len(supports) == 2:
            break
    if not supports:
        return UpEstimate(None, 0.0, None, lean, f"no support: every candidate plane (best holds "
                          f"{lean.share:.3f} of the flat Gaussians) has more than {MAX_BELOW:g} of the Gaussians "
                          f"on both sides (a scene seen from inside, or an object standing on no flat base)")
    best = supports[0]
    normal, offset = _refine(p, n, w, best.normal, best.offset, tol)
    below = float(np.mean(xb @ normal - offset < -tol))
    best = SupportPlane(normal, offset, best.share, below)
    s2 = supports[1].share if len(supports) > 1 else 0.0
    conf = max(0.0, (1.0 - s2 / best.share) * (1.0 - below / MAX_BELOW))
    figures = (f"support plane holds {best.share:.3f} of the flat Gaussians, {below:.3f} of the Gaussians beyond "
               f"it; the next stance's support holds {s2:.3f}")
    if conf < UP_SURE or best.share < MIN_SHARE:
        return UpEstimate(None, conf, None, best, figures + f" (unsure: needs confidence >= {UP_SURE} and a "
                          f"support holding >= {MIN_SHARE})")
    return UpEstimate(normal, conf, best, best, figures)


def plane_rows(g: Gaussians, plane: SupportPlane) -> np.ndarray:
    """Rows (int64, sorted) of the flat Gaussians of ``g`` on ``plane``: within :data:`PLANE_TOL` times the
    robust diagonal of it, normal within :data:`NORMAL_TOL` degrees (floaters included)."""
    rows, p, n, _ = flat_normals(g)
    lo, hi = np.quantile(g.means.astype(np.float64), [0.01, 0.99], axis=0)
    tol = PLANE_TOL * float(np.linalg.norm(hi - lo))
    on = (np.abs(n @ plane.normal) >= np.cos(np.radians(NORMAL_TOL))) & (np.abs(p @ plane.normal - plane.offset) <= tol)
    return rows[on]


def camera_up(path) -> np.ndarray:
    """Minus the mean camera ``y`` axis of a graphdeco ``cameras.json`` (camera-to-world ``rotation``, OpenCV
    cameras: ``y`` down), shape (3,): its length is 1 when every camera is upright, less as they roll or tilt.
    Raises :class:`~gasp_core.errors.SceneError` for a file that is not one
    (:func:`~gasp_core.gs.up_axis.cameras_cue`)."""
    import json
    from pathlib import Path
    from gasp_core.errors import SceneError
    path = Path(path)
    try:
        R = np.array([c["rotation"] for c in json.loads(path.read_text())], dtype=np.float64).reshape(-1, 3, 3)
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise SceneError(f"{path}: not a graphdeco cameras.json (a list of objects with a 3x3 'rotation'): "
                         f"{e}") from None
    if not len(R):
        raise SceneError(f"{path}: no cameras")
    R = R[np.isfinite(R).all(axis=(1, 2))]     # a camera with NaN or inf is left out (issue 68); none left: no cue
    return -R[:, :, 1].mean(axis=0) if len(R) else np.zeros(3)


def with_cameras(e: UpEstimate, cam: np.ndarray) -> UpEstimate:
    """``e`` checked against the cameras' mean up ``cam`` (:func:`camera_up`): a sure plane within
    :data:`CAMERA_AGREE` degrees of it stands; a sure plane further away than that, against cameras at least
    :data:`UP_SURE` upright, becomes unsure; with no sure plane, cameras at least :data:`CAMERA_SURE` upright
    give the up vector (their mean's direction, confidence its length)."""
    c = float(np.linalg.norm(cam))
    if c == 0.0:
        return e
    u = cam / c
    said = f"; cameras' mean up {np.round(u, 3).tolist()} (length {c:.2f})"
    if e.up is not None:
        angle = float(np.degrees(np.arccos(np.clip(e.up @ u, -1.0, 1.0))))
        if angle <= CAMERA_AGREE or c < UP_SURE:
            return UpEstimate(e.up, e.confidence, e.plane, e.lean, e.figures + said + f", {angle:.1f} deg off")
        return UpEstimate(None, 0.0, None, e.lean, e.figures + said + f" disagrees by {angle:.1f} deg: unsure")
    if c >= CAMERA_SURE:
        return UpEstimate(u, c, None, e.lean, e.figures + said + ": the cameras decide")
    return UpEstimate(None, e.confidence, None, e.lean, e.figures + said)


def rotation_to_z(up) -> np.ndarray:
    """The proper rotation (3, 3) taking the unit vector along ``up`` (3,) to +z by the shortest turn
    (Rodrigues' formula); a half turn about x for ``up`` along -z. Raises ValueError for a zero vector."""
    u = np.asarray(up, dtype=np.float64)
    big = float(np.max(np.abs(u))) if u.size else 0.0
    if not np.isfinite(big) or big == 0.0:
        raise ValueError(f"up vector {list(u)} has no direction")
    u = u / big                     # scaled first: [1e308, 1e308, 0] has a direction, its norm overflows (issue 68)
    u = u / float(np.linalg.norm(u))
    c = float(u[2])
    if c < -1.0 + 1e-12:
        return np.diag([1.0, -1.0, -1.0])
    v = np.array([u[1], -u[0], 0.0])             # u x z
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)
