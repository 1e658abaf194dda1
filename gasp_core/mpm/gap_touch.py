"""The touch of two solid bodies decided by geometry (round 60, issue 67/66, ``docs/contact.md`` "Round 60: a touch by
geometry"; the switch :data:`gasp_core.mpm.fields.GAP_TOUCH`).

Two bodies on the particle contact (``gasp_core.mpm.fields.body_pair``: two soft ones, two rigid ones, or one of each)
take a grid velocity field each. Before round 60 a node was a contact node where the two fields' gathered volumes
reached a fraction of a cell (``SOFT_TOUCH_FRACTION`` 0.7): node co-occupancy, which the quadratic B-spline's 1.5-cell
reach satisfies across a gap (a jelly ball 10 mm, 0.53 dx, above a jelly box), and whose Coulomb projection, once a
substep, then brakes the falling body at a rate that grows as 1 / dt.

The rule here is the flowing body's touch of round 37 (``FLOW_TOUCH``, ``gasp_core.mpm.fields_reference.
flow_touch_level``) made symmetric for two solids: after P2G every material point of either field gathers the OTHER
field's volume fraction at its position, ``phi(x_p) = sum_i w_i(x_p) V_other(i) / dx^3``; where it reaches
``level_b`` of the point's body the 27 nodes of its stencil are contact nodes (a parallel loop over the points, atomic
max; no ordered loop). ``level_b`` = :func:`flow_touch_level` ``(delta_b)``: the volume fraction a filled half-space's
volumes, scattered and gathered back with the quadratic B-spline, give at ``delta_b`` cells outside its face (a
half-space integral, averaged over the face's place in its cell), with ``delta_b`` half the body's point spacing
(``0.5 V_p^(1/3) / dx``, the body's median point volume): a point whose centre lies ``delta_b`` outside the other body's
surface has its own material's surface ON that surface. So the touch fires when the two lattices' surfaces meet (zero
separation, a geometric fact independent of the step), not when their stencils overlap; a gap of any size keeps each
body's own velocity. This is NairnMPM's second contact criterion in spirit (its "displacement check", added because the
approach criterion alone "detects contact when surfaces are approaching each other but are still separated":
https://osupdocs.forestry.oregonstate.edu/index.php/Detecting_Contact; J. A. Nairn, "Modeling imperfect interfaces in
the material point method using multimaterial methods", CMES 92 (2013) 271-299): the separation of the two materials
is measured and contact needs it to close; here the separation is read per point from the other field's volumes
instead of from the mass-weighted positions extrapolated to the node (``docs/contact.md`` says why).
"""
from __future__ import annotations

import numpy as np

from gasp_core.mpm.fields_reference import flow_touch_level

#: The separation (in the body's point spacings) within which two surfaces touch: half a spacing. At zero (the level
#: of the surfaces exactly meeting) two convex bodies touch late: the scatter and gather's smoothing (variance
#: ``dx^2 / 2``) moves a ball's surface level inward, 0.18 dx at R 2 dx (``docs/contact.md`` "Round 60"), and the
#: stacked balls rested 0.27 dx inside each other (0.22 under the rule before; at half a spacing -0.01 dx); flat faces
#: then rest that separation apart (a cube on a box +0.27 dx; +0.06 at zero; +0.42 under the rule before).
SEPARATION = 0.5
#: The point's reach (cells) is rounded to this before its level is computed (``flow_touch_level`` is cached).
DELTA_ROUND = 1e-3


def body_delta(setup) -> np.ndarray:
    """Per body (shape (n_materials,), cells) how far outside the other body's surface its point's centre marks: half
    its point spacing (its own surface on the other's) plus :data:`SEPARATION` spacings, ``(0.5 + SEPARATION)
    median(V_p)^(1/3) / dx`` over its material points (``setup.p_vol``, m^3; ``setup.dx``, m), rounded to
    :data:`DELTA_ROUND`; as for points at dx / 2 for a body without points."""
    n_mat = getattr(setup, "n_material", None)
    n = len(setup.x) if n_mat is None else int(n_mat)
    vol = np.asarray(setup.p_vol, float)[:n]
    body = np.asarray(setup.body_id)[:n]
    reach = 0.5 + float(SEPARATION)
    out = np.full(len(setup.materials), 0.5 * reach)
    for b in range(len(setup.materials)):
        v = vol[body == b]
        if len(v):
            out[b] = reach * float(np.median(v)) ** (1.0 / 3.0) / float(setup.dx)
    return np.round(np.clip(out, 0.0, 1.5) / DELTA_ROUND) * DELTA_ROUND


def gap_levels(setup, on: bool = True) -> np.ndarray | None:
    """The touch by geometry's level per body (shape (n_materials,), dimensionless: a volume fraction of a cell), or
    None where ``on`` is false (``gasp_core.mpm.fields.field_setup``: :data:`gasp_core.mpm.fields.GAP_TOUCH` and a
    ``body_pair``): :func:`flow_touch_level` at :func:`body_delta`. A point of body b marks where the other field's
    gathered volume fraction at it reaches ``level[b]``."""
    if not on:
        return None
    return np.array([flow_touch_level(float(d)) for d in body_delta(setup)], np.float64)


def gap_marks(x: np.ndarray, in_a: np.ndarray, vf: np.ndarray, lo, dx: float, level: np.ndarray) -> np.ndarray:
    """The NumPy reference of the marks: ``x`` (n, 3) material points, m; ``in_a`` (n,) bool, the point's field;
    ``vf`` (2, ng, ng, ng) the fields' node volumes (A's, B's), m^3; ``lo`` the grid's origin, m; ``level`` (n,) the
    point's body's level. Returns (ng, ng, ng) bool: the stencil nodes of every point where the other field's
    gathered volume fraction reaches its level."""
    ng = vf.shape[1]
    out = np.zeros((ng,) * 3, bool)
    X = (np.asarray(x, float) - np.asarray(lo, float)) / dx
    base = np.floor(X - 0.5).astype(int)
    fx = X - base
    w = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2], 1)   # (n, 3, 3)
    for p in range(len(X)):
        b = base[p]
        if b.min() < 0 or b.max() > ng - 3:
            continue
        other = vf[0 if not in_a[p] else 1][b[0]:b[0] + 3, b[1]:b[1] + 3, b[2]:b[2] + 3]
        wp3 = np.einsum("i,j,k->ijk", w[p, :, 0], w[p, :, 1], w[p, :, 2])
        if float((wp3 * other).sum()) >= level[p] * dx ** 3:
            out[b[0]:b[0] + 3, b[1]:b[1] + 3, b[2]:b[2] + 3] = True
    return out
