"""Where a tension specimen's crack is: its layer, read on the free layers only (issue 66, round 45 follow-up;
docs/fracture.md "Round 45: the step-started pull").

A ``fixed_region``'s held points near its face are strained by the brittle held rule and their damage mirrors the
real crack by design (docs/fracture.md "The held region"): a clamp's held layer can reach ``d = 1`` tens of frames
after the free layer past its face did. The measures of before took the most damaged layer at the end
(``argmax`` over every layer, the first of those tied at ``d = 1``), so a held layer, lower in x than the crack,
could be named: the step-started bar a0.30 at n_grid 48 was read as breaking at x 0.267, inside the clamp, where its
crack formed at x 0.330.

So the crack's layer is taken among the free layers (no point held by a ``fixed_region`` or a set box,
:func:`free_layers`), and where several are tied at the most damage at the end, the one that got there first over its
whole rise (:func:`crack_layer`).
"""
from __future__ import annotations

import numpy as np

#: the damage within which layers count as tied at the most damage (a layer's mean ``d`` is a volume average of
#: points at ``d = 1``, equal to 1 to rounding)
TIE = 1e-6


def held_points(x0: np.ndarray, boundaries, impulses=()) -> np.ndarray:
    """The points held by the scene (n,) bool: inside a ``fixed_region`` (the engines' own rule,
    ``gasp_core.mpm.points.fixed_mask``) or inside a box impulse of ``mode = "set"`` (the pulled grip: its points
    move with the box). ``x0``: (n, 3) rest positions (m); ``boundaries``, ``impulses``: the setup's."""
    from gasp_core.mpm.points import fixed_mask
    x0 = np.asarray(x0, np.float64)
    held = fixed_mask(x0, boundaries)
    for imp in impulses:
        if imp.shape == "box" and imp.mode == "set":
            held |= np.all((x0 >= np.asarray(imp.lo, float)) & (x0 <= np.asarray(imp.hi, float)), axis=1)
    return held


def free_layers(layer: np.ndarray, held: np.ndarray, nl: int) -> np.ndarray:
    """The layers (nl,) bool with points and none of them held: ``layer`` (n,) int each point's layer (-1: none),
    ``held`` (n,) bool (:func:`held_points`)."""
    on = layer >= 0
    li = layer[on]
    n = np.bincount(li, minlength=nl)
    n_held = np.bincount(li, held[on].astype(np.int64), nl)
    return (n > 0) & (n_held == 0)


def crack_layer(dmean: np.ndarray, free: np.ndarray) -> int:
    """The crack's layer: among the ``free`` layers (k,) bool, the most damaged at the end of ``dmean`` (frames, k),
    each layer's mean damage per frame; of those within :data:`TIE` of it, the first to get there, read over the
    whole rise: the least mean over the levels ``0 < l <= 1`` of the frame at which ``d`` first reached ``l`` (for a
    rising ``d`` over ``T`` frames that mean is ``T`` less the sum of ``d`` over the frames, so: the greatest sum);
    still tied, the lowest index. Not the frame at which ``d`` reached 1 alone: two layers of one crack band
    finish their last few per cent in either order (the step-started bar a0.30 at n_grid 48: the layer at x 0.330 led
    its neighbour at 0.346 to every level up to 0.95, 71 frames against 11, and reached 1 four frames after it).
    Raises ValueError without a free layer."""
    dmean = np.atleast_2d(np.asarray(dmean, np.float64))
    free = np.asarray(free, bool)
    if not free.any():
        raise ValueError("no free layer to hold the crack")
    end = dmean[-1]
    tied = np.flatnonzero(free & (end >= float(end[free].max()) - TIE))
    return int(tied[np.argmax(dmean[:, tied].sum(axis=0))])
