"""The up axis of a Gaussian Splatting file, guessed from every cue the file (and a ``cameras.json`` beside it)
gives, each cue reported with what it said (``gasp info``).

No layout states an up axis, so :func:`guess_up` weighs five cues, each a vote of a confidence in [0, 1] for a
direction (``"+z"``), or for an axis without its sign (``"z"``):

- **cameras** (``cameras.json``, graphdeco's, camera-to-world ``rotation``): up is minus the mean camera ``y``
  axis, snapped to an axis. They decide when their confidence reaches :data:`UP_SURE`.
- **flat-area asymmetry** ("the flat bottom faces down", :func:`flat_area_asymmetry`).
- **support plane**, the densest flat layer at one end (:func:`support_plane`).
- **longest axis** (:func:`longest_axis`): an upright figure (a person, a guitar on its stand) stands along its
  longest extent. An axis without a sign, and weak (at most :data:`LONGEST_WEIGHT`): a lying object's longest
  axis is horizontal, so it alone never makes the guess sure.
- **floaters** (:func:`floater_sides`): floaters hang in the air, and nothing is captured beneath the ground, so
  along an axis the side beyond which more floaters lie is up. A sign only, weak (at most
  :data:`FLOATER_WEIGHT`).

Combination (:func:`combine`): first the axis, support ``S_a = 1 - prod(1 - c)`` over the cues naming axis ``a``
(signed or not; floaters excluded), axis confidence ``S_best - S_next``; then its sign, support ``S_+`` and
``S_-`` over the signed cues, sign confidence ``|S_+ - S_-|``. The confidence is the smaller of the two; below
:data:`UP_SURE` the guess is ``"unknown"`` and ``gasp info`` gives the height and the scale along every axis.
On the bundled files: donut_v3dg +z (0.84), guitar.compressed -y (0.97); train-1000, pc_short and
spinach_4 (scene slices) unknown.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import Gaussians, quat_to_rotmat

#: Below this confidence no up axis is claimed ("unknown"; ``gasp info`` lists every candidate axis).
UP_SURE = 0.5
#: Flat-area asymmetry: the strongest axis's ``|asymmetry|`` must reach ``UP_MIN_ASYMMETRY`` and exceed the next
#: axis's ``UP_MIN_RATIO`` times, else the cue says nothing. Measured (best / next): donut_v3dg 0.435 / 0.095
#: (+z, as its source states), guitar.compressed 0.415 / 0.061 (-y, as stated); scene slices are ambiguous:
#: train-1000 0.534 / 0.416, pc_short 0.757 / 0.536, spinach_4 (t = 0.5) 0.330 / 0.252.
UP_MIN_ASYMMETRY = 0.2
UP_MIN_RATIO = 2.0
#: Support plane: thickness of the slab at each side's extreme, times the largest extent; the extreme is the
#: 0.1 % quantile (floaters ignored).
SUPPORT_SLAB = 0.02
#: Smallest weighted share of the Gaussians a base must hold to be claimed: a real base holds 0.6-2 % (the
#: guitar, the donut); a scene slice's extremes hold 0-0.02 % (train-1000, pc_short, spinach_4), noise.
SUPPORT_MIN_SHARE = 1e-3
#: Longest axis: says nothing unless the longest robust extent (1st-99th percentile) is at least
#: ``LONGEST_MIN_RATIO`` times the next; confidence ``LONGEST_WEIGHT * (1 - LONGEST_MIN_RATIO / ratio)``
#: (guitar, ratio 3.2: 0.27; a standing person, about 3.4: 0.28; spinach_4, 1.6: 0.03).
LONGEST_MIN_RATIO = 1.5
LONGEST_WEIGHT = 0.5
#: Floaters: fewer than ``FLOATER_MIN`` floaters beyond the object along an axis say nothing about it; the
#: confidence is ``FLOATER_WEIGHT * |n+ - n-| / (n+ + n-)``.
FLOATER_MIN = 10
FLOATER_WEIGHT = 0.3
AXES = "xyz"


@dataclass(frozen=True)
class Cue:
    """One cue's verdict: ``votes`` maps a direction (``"+z"``) or an axis (``"z"``) to a confidence in [0, 1];
    ``figures`` are the numbers it read; ``sign_only``: its votes only choose the sign of an axis."""

    name: str
    votes: dict
    figures: str
    sign_only: bool = False

    def line(self) -> str:
        said = ", ".join(f"{k} ({v:.2f})" for k, v in self.votes.items() if v > 0) or "nothing"
        return f"{self.name}: {self.figures} -> {said}"


@dataclass(frozen=True)
class UpGuess:
    """:func:`guess_up`'s answer: ``up`` (``"+x"`` ... ``"-z"`` or ``"unknown"``), ``confidence`` in [0, 1],
    ``method`` (which cues decided), ``lean`` (the best direction or axis even when unsure, ``""`` for none),
    ``cues`` (every cue consulted)."""

    up: str
    confidence: float
    method: str
    lean: str = ""
    cues: list = field(default_factory=list)


def guess_up(g: Gaussians, cameras: Path | None = None) -> UpGuess:
    """Up axis of ``g`` from every cue (module notes); ``cameras``: a graphdeco ``cameras.json`` path, used when it
    exists. Raises :class:`SceneError` for a ``cameras.json`` that is not one."""
    cues = [flat_area_asymmetry(g), support_plane(g), longest_axis(g.means), floater_sides(g)]
    if cameras is not None and Path(cameras).is_file():
        cam = cameras_cue(Path(cameras))
        up, c = next(iter(cam.votes.items()), ("unknown", 0.0))    # no vote: no finite camera
        if c >= UP_SURE:
            return UpGuess(up, c, f"cameras ({Path(cameras).name})", up, [cam, *cues])
        cues.insert(0, cam)
    else:
        cues.insert(0, Cue("cameras", {}, f"no {Path(cameras).name if cameras else 'cameras.json'} beside the file"))
    return combine(cues)


def combine(cues: list[Cue]) -> UpGuess:
    """The axis, then its sign, from ``cues`` (module notes)."""
    def support(cs):
        return 1.0 - float(np.prod([1.0 - min(c, 1.0) for c in cs])) if cs else 0.0
    s_axis = {a: support([sum(v for k, v in c.votes.items() if k[-1] == a) for c in cues if not c.sign_only])
              for a in AXES}
    order = sorted(AXES, key=s_axis.get, reverse=True)
    a = order[0]
    axis_conf = s_axis[a] - s_axis[order[1]]
    if axis_conf <= 0:
        return UpGuess("unknown", 0.0, "none (no cue singles out an axis)", "", cues)
    s_plus = support([c.votes.get("+" + a, 0.0) for c in cues])
    s_minus = support([c.votes.get("-" + a, 0.0) for c in cues])
    if s_plus == s_minus:
        return UpGuess("unknown", 0.0, f"none (axis {a} ({axis_conf:.2f}), but no cue gives its sign)", a, cues)
    up = ("+" if s_plus > s_minus else "-") + a
    conf = min(axis_conf, abs(s_plus - s_minus))
    used = " and ".join(c.name for c in cues if c.votes.get(up, 0) > 0 or c.votes.get(a, 0) > 0)
    if conf < UP_SURE:
        return UpGuess("unknown", conf, f"unsure: {used} lean to {up}, confidence {conf:.2f} < {UP_SURE}", up, cues)
    return UpGuess(up, conf, used + (" agree" if " and " in used else ""), up, cues)


def flat_area_asymmetry(g: Gaussians) -> Cue:
    """Flat-area asymmetry: take the flattish Gaussians (min/max scale < 0.2; all of them if fewer than 10),
    their normal = the thin local axis flipped away from the median centre, weighted by the area (product of
    the two larger scales). Per axis, the asymmetry ``(A+ - A-) / (A+ + A-)`` of the area facing + and -: the
    axis with the largest ``|asymmetry|`` is vertical and the side with more area the bottom (a base resting
    on a support is reconstructed with a few large flat Gaussians, an observed top with many small ones).
    Votes when the largest reaches :data:`UP_MIN_ASYMMETRY` and :data:`UP_MIN_RATIO` times the next, with
    confidence ``1 - next / largest``. Meaningless for scenes, objects seen from below, hollow or strongly
    non-convex objects (the outward flip assumes a star-shaped object)."""
    s = g.scales
    m = s.min(axis=1) / np.maximum(s.max(axis=1), 1e-300) < 0.2
    if m.sum() < 10:
        m = np.ones(g.n, dtype=bool)
    R = quat_to_rotmat(g.rotations[m])
    normal = R[np.arange(len(R)), :, np.argmin(s[m], axis=1)]
    area = np.prod(np.sort(s[m], axis=1)[:, 1:], axis=1)
    normal = normal * np.sign(np.sum((g.means[m] - np.median(g.means, axis=0)) * normal, axis=1))[:, None]
    pos = (area[:, None] * np.clip(normal, 0, None)).sum(axis=0)
    neg = (area[:, None] * np.clip(-normal, 0, None)).sum(axis=0)
    asym = (pos - neg) / np.maximum(pos + neg, 1e-300)
    order = np.argsort(-np.abs(asym))
    a, best, second = int(order[0]), float(abs(asym[order[0]])), float(abs(asym[order[1]]))
    figures = ("area facing + minus facing -, the side with more is the bottom: "
               + ", ".join(f"{k} {v:+.3f}" for k, v in zip(AXES, asym)))
    if best < UP_MIN_ASYMMETRY or best < UP_MIN_RATIO * second:
        return Cue("flat-area asymmetry", {}, figures + f" (needs one >= {UP_MIN_ASYMMETRY} and "
                   f">= {UP_MIN_RATIO:g}x the next)")
    return Cue("flat-area asymmetry", {("-" if asym[a] > 0 else "+") + AXES[a]: 1.0 - second / best}, figures)


def support_plane(g: Gaussians) -> Cue:
    """Support plane, the densest flat layer at one end: an object standing on a support (or a capture's ground)
    has a base where many flat splats lie in one plane facing along the axis; a top is a cap. Per side
    ``-x ... +z``: the share of flat Gaussians (min/max scale < 0.2) within :data:`SUPPORT_SLAB` times the
    largest extent of that side's extreme (0.1 % quantile), weighted by ``|normal . axis|``, times the stance
    (:func:`_stance`). The best side is the bottom when it holds :data:`SUPPORT_MIN_SHARE`; confidence
    ``1 - next / best``."""
    x, s = g.means, g.scales
    normal = quat_to_rotmat(g.rotations)[np.arange(g.n), :, np.argmin(s, axis=1)]
    flat = s.min(axis=1) / np.maximum(s.max(axis=1), 1e-300) < 0.2
    ext = float(np.max(np.quantile(x, 0.999, axis=0) - np.quantile(x, 0.001, axis=0)))
    score = {}
    for a in range(3):
        for sign, side in ((1.0, "-"), (-1.0, "+")):
            h = sign * x[:, a]
            m = flat & (np.abs(h - float(np.quantile(h, 0.001))) <= SUPPORT_SLAB * ext)
            score[side + AXES[a]] = float(np.abs(normal[m, a]).sum() / g.n) * _stance(x, m, a)
    figures = (f"share of aligned flat splats within {SUPPORT_SLAB:g} x extent of each side's end: "
               + ", ".join(f"{k} {v:.4f}" for k, v in score.items()))
    order = sorted(score, key=score.get, reverse=True)
    if score[order[0]] < SUPPORT_MIN_SHARE:
        return Cue("support plane", {}, figures + f" (a base holds >= {SUPPORT_MIN_SHARE:g})")
    up = ("+" if order[0][0] == "-" else "-") + order[0][1]
    return Cue("support plane", {up: 1.0 - score[order[1]] / score[order[0]]}, figures + f"; bottom {order[0]}")


def _stance(x: np.ndarray, base: np.ndarray, axis: int) -> float:
    """How well the points ``base`` (bool mask) hold the object up along ``axis``: their support polygon's
    area over the object's cross-section (bounding box across ``axis``), 0 when the median point's
    projection falls outside the polygon (the object would tip over that side)."""
    from scipy.spatial import ConvexHull, Delaunay, QhullError
    other = [i for i in range(3) if i != axis]
    p = x[base][:, other]
    if len(p) < 3:
        return 0.0
    try:
        hull = ConvexHull(p)
        inside = Delaunay(p[hull.vertices]).find_simplex(np.median(x[:, other], axis=0)) >= 0
    except QhullError:      # collinear base points: a knife edge
        return 0.0
    box = float(np.prod(np.ptp(x[:, other], axis=0)))
    return float(hull.volume / box) if inside and box > 0 else 0.0


def longest_axis(means: np.ndarray) -> Cue:
    """The longest axis of an upright figure: robust extents (1st to 99th percentile of ``means``, shape (n, 3));
    an axis vote (no sign) when the longest is :data:`LONGEST_MIN_RATIO` times the next."""
    e = np.quantile(means, 0.99, axis=0) - np.quantile(means, 0.01, axis=0)
    order = np.argsort(-e)
    ratio = float(e[order[0]] / max(e[order[1]], 1e-300))
    figures = (f"robust extents {', '.join(f'{k} {v:.4g}' for k, v in zip(AXES, e))}; longest / next {ratio:.2f}"
               f" (an upright figure stands along it; needs >= {LONGEST_MIN_RATIO:g})")
    if ratio < LONGEST_MIN_RATIO:
        return Cue("longest axis", {}, figures)
    return Cue("longest axis", {AXES[order[0]]: LONGEST_WEIGHT * (1.0 - LONGEST_MIN_RATIO / ratio)}, figures)


def floater_sides(g: Gaussians) -> Cue:
    """Where the floaters lie (:func:`gasp_core.maps.floaters.find_floaters`): per axis, the floaters beyond the
    object's bounding box on its - and + side; up is the side with more (floaters hang in the air; nothing is
    captured under the ground). A sign-only vote per axis with :data:`FLOATER_MIN` floaters beyond it."""
    from gasp_core.maps.floaters import find_floaters
    fl = find_floaters(g.means, g.scales.max(axis=1))
    if fl.sum() == 0 or fl.all():
        return Cue("floaters", {}, "no floaters", sign_only=True)
    body, f = g.means[~fl], g.means[fl]
    below, above = (f < body.min(axis=0)).sum(axis=0), (f > body.max(axis=0)).sum(axis=0)
    votes = {}
    for a in range(3):
        n = int(below[a] + above[a])
        if n >= FLOATER_MIN and above[a] != below[a]:
            votes[("+" if above[a] > below[a] else "-") + AXES[a]] = FLOATER_WEIGHT * abs(int(above[a]) - int(below[a])) / n
    figures = (f"{int(fl.sum())} floaters; beyond the object - / +: "
               + ", ".join(f"{k} {int(b)} / {int(t)}" for k, b, t in zip(AXES, below, above))
               + " (more on the up side)")
    return Cue("floaters", votes, figures, sign_only=True)


def cameras_cue(path: Path) -> Cue:
    """Up from a graphdeco ``cameras.json`` (list of {"rotation": 3x3 camera-to-world, ...}): minus the mean
    camera ``y`` axis (OpenCV cameras look along ``+z``, ``y`` down), snapped to the nearest axis; confidence =
    the mean's length times its cosine to that axis (1 when every camera is upright)."""
    try:
        cams = json.loads(path.read_text())
        R = np.array([c["rotation"] for c in cams], dtype=np.float64).reshape(-1, 3, 3)
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as e:
        raise SceneError(f"{path}: not a graphdeco cameras.json (a list of objects with a 3x3 'rotation'): "
                         f"{e}") from None
    if not len(R):
        raise SceneError(f"{path}: no cameras")
    finite = np.isfinite(R).all(axis=(1, 2))      # a camera with NaN or inf is left out (issue 68: one NaN turned
    left = f" ({int((~finite).sum())} with a non-finite rotation left out)" if not finite.all() else ""   # +z to -x)
    R = R[finite]
    if not len(R):
        return Cue("cameras", {}, f"{path.name}: no camera with a finite rotation{left}")
    mean_up = -R[:, :, 1].mean(axis=0)
    a = int(np.argmax(np.abs(mean_up)))
    up = ("+" if mean_up[a] > 0 else "-") + AXES[a]
    return Cue("cameras", {up: float(abs(mean_up[a]))},
               f"{path.name}, {len(R)} cameras{left}, mean camera up {np.round(mean_up, 3).tolist()}")
