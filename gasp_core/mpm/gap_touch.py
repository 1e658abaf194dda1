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

Round 61 (:data:`CURVATURE`, ``docs/contact.md`` "Round 61: a touch that reads the curvature"): the level reads the
geometry instead of a separation constant. The scatter and gather smooth the volume with a kernel of variance
``sigma^2 = dx^2 / 4 + dx^2 / 4`` (each quadratic B-spline: three unit boxes, 3 / 12 dx^2); smoothing an indicator
moves its level surface inward by ``sigma^2 / 2 (k1 + k2)`` (diffusion-generated mean curvature motion: B. Merriman,
J. Bence, S. Osher, "Diffusion generated motion by mean curvature", UCLA CAM report 92-18, 1992; L. C. Evans,
Indiana Univ. Math. J. 42 (1993) 533-557), so a ball's field reads as a half-space ``sigma^2 k`` farther away. The
point reads the principal curvatures of BOTH fields' level surfaces at its position (the gathered field's gradient
``g`` and Hessian ``H`` with the B-spline's derivatives; ``k1 + k2 = (g.H.g - |g|^2 tr H) / |g|^3`` and ``k1 k2 =
g.adj(H).g / |g|^4``, R. Goldman, "Curvature formulas for implicit curves and surfaces", CAGD 22 (2005) 632-658) and
marks at the half-space level of ``delta_b + sigma^2 k`` with ``k`` the least principal curvature shared by the two
(``max(0, min(kmin_own, kmin_other))``): a touch needs only one side to mark, and a side facing a flat face reads it
without bias, so only where both surfaces are curved is the reading late (two balls); a flat face's edge or corner,
whose field is curved where its surface is flat, is not corrected (the point's own face is flat there). No separation:
``delta_b`` is half the point spacing (the surfaces meeting).
"""
from __future__ import annotations

import functools

import numpy as np

from gasp_core.mpm.fields_reference import flow_touch_level

#: The separation (in the body's point spacings) within which two surfaces touch: half a spacing. At zero (the level
#: of the surfaces exactly meeting) two convex bodies touch late: the scatter and gather's smoothing (variance
#: ``dx^2 / 2``) moves a ball's surface level inward, 0.18 dx at R 2 dx (``docs/contact.md`` "Round 60"), and the
#: stacked balls rested 0.27 dx inside each other (0.22 under the rule before; at half a spacing -0.01 dx); flat faces
#: then rest that separation apart (a cube on a box +0.27 dx; +0.06 at zero; +0.42 under the rule before).
SEPARATION = 0.5
#: Round 61: the touch reads the curvature of the two fields (module docstring); :data:`SEPARATION` is then 0. Off
#: by default: measured (``docs/contact.md`` "Round 61"), flat faces and a ball on a box rest 0.04-0.09 dx apart
#: (round 60: 0.22-0.32) but the stacked balls 0.06-0.10 dx inside each other (round 60: -0.03 to +0.03), a sink after
#: the first touch that no level removes. Round 62's push (:mod:`gasp_core.mpm.gap_push`) lets a measured overlap out
#: but 6 of the 16 stacked rows still miss 0.05 dx (``docs/contact.md`` "Round 62"): still off.
CURVATURE = False
#: The half-space level's table (:func:`half_space_table`): its step and length, cells (0 to 1.5 cells).
TABLE_STEP, TABLE_N = 0.01, 151
#: The smoothing's variance, cells^2: P2G's quadratic B-spline scatter and the gather's (1/4 each).
SIGMA2 = 0.5
#: The point's reach (cells) is rounded to this before its level is computed (``flow_touch_level`` is cached).
DELTA_ROUND = 1e-3


def body_delta(setup) -> np.ndarray:
    """Per body (shape (n_materials,), cells) how far outside the other body's surface its point's centre marks: half
    its point spacing (its own surface on the other's) plus :data:`SEPARATION` spacings (none with
    :data:`CURVATURE`), ``(0.5 + SEPARATION) median(V_p)^(1/3) / dx`` over its material points (``setup.p_vol``,
    m^3; ``setup.dx``, m), rounded to
    :data:`DELTA_ROUND`; as for points at dx / 2 for a body without points."""
    n_mat = getattr(setup, "n_material", None)
    n = len(setup.x) if n_mat is None else int(n_mat)
    vol = np.asarray(setup.p_vol, float)[:n]
    body = np.asarray(setup.body_id)[:n]
    reach = 0.5 + (0.0 if CURVATURE else float(SEPARATION))
    out = np.full(len(setup.materials), 0.5 * reach)
    for b in range(len(setup.materials)):
        v = vol[body == b]
        if len(v):
            out[b] = reach * float(np.median(v)) ** (1.0 / 3.0) / float(setup.dx)
    return np.round(np.clip(out, 0.0, 1.5) / DELTA_ROUND) * DELTA_ROUND


@functools.cache
def half_space_table() -> np.ndarray:
    """:func:`flow_touch_level` at ``k TABLE_STEP`` cells, k = 0 .. TABLE_N - 1 (shape (TABLE_N,), a volume fraction:
    0.5 on the face, decreasing outward), read by linear interpolation (:func:`table_level`)."""
    return np.array([flow_touch_level(round(k * TABLE_STEP, 3)) for k in range(TABLE_N)], np.float64)


def table_level(table: np.ndarray, delta):
    """The half-space level at ``delta`` cells (array or scalar), linear in ``table`` (:func:`half_space_table`),
    clamped to its range: what the engines' kernels compute."""
    u = np.clip(np.asarray(delta, float) / TABLE_STEP, 0.0, TABLE_N - 1.001)
    i = np.floor(u).astype(int)
    return table[i] + (u - i) * (table[i + 1] - table[i])


def gap_levels(setup, on: bool = True) -> np.ndarray | None:
    """The touch by geometry's parameters, or None where ``on`` is false (``gasp_core.mpm.fields.field_setup``:
    :data:`gasp_core.mpm.fields.GAP_TOUCH` and a ``body_pair``). Without :data:`CURVATURE` (round 60) the level per
    body (shape (n_materials,), a volume fraction of a cell: :func:`flow_touch_level` at :func:`body_delta`; a point
    of body b marks where the other field's gathered volume fraction at it reaches ``level[b]``). With it (round 61)
    :func:`half_space_table` then :func:`body_delta` (shape (TABLE_N + n_materials,): the table, then ``delta_b``
    in cells); the engines read :data:`CURVATURE` when they allocate."""
    if not on:
        return None
    if CURVATURE:
        return np.concatenate([half_space_table(), body_delta(setup)]).astype(np.float64)
    return np.array([flow_touch_level(float(d)) for d in body_delta(setup)], np.float64)


def least_curvature(g: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The smaller principal curvature (1 / cells; positive convex) of the level surface of a field decreasing
    outward, from its gradient ``g`` (n, 3) and Hessian ``h`` (n, 3, 3) in index units: ``k1 + k2 = (g.h.g - |g|^2
    tr h) / |g|^3``, ``k1 k2 = g.adj(h).g / |g|^4`` (Goldman 2005, module docstring); 0 where ``|g|`` < 1e-6."""
    gn = np.linalg.norm(g, axis=1)
    gs = np.maximum(gn, 1e-6)
    tr = np.trace(h, axis1=1, axis2=2)
    t = (np.einsum("ni,nij,nj->n", g, h, g) - gn ** 2 * tr) / gs ** 3
    adj = np.empty_like(h)
    for i in range(3):
        for j in range(3):
            r = [a for a in range(3) if a != j]
            c = [a for a in range(3) if a != i]
            adj[:, i, j] = (-1) ** (i + j) * (h[:, r[0], c[0]] * h[:, r[1], c[1]] - h[:, r[0], c[1]] * h[:, r[1], c[0]])
    k = np.einsum("ni,nij,nj->n", g, adj, g) / gs ** 4
    return np.where(gn > 1e-6, 0.5 * (t - np.sqrt(np.maximum(t * t - 4.0 * k, 0.0))), 0.0)


def gather_derivatives(v: np.ndarray, fx: np.ndarray) -> tuple:
    """The quadratic B-spline gather of a stencil's node values ``v`` (3, 3, 3) at the point's offset ``fx`` (3,)
    (cells from its base node): ``(value, gradient (3,), Hessian (3, 3))`` in index units (per cell)."""
    w = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2])          # (3 nodes, 3 axes)
    d1 = np.stack([fx - 1.5, -2.0 * (fx - 1.0), fx - 0.5])
    d2 = np.stack([np.ones(3), -2.0 * np.ones(3), np.ones(3)])
    g, h = np.zeros(3), np.zeros((3, 3))
    for a in range(3):
        for b in range(3):
            f = [w[:, 0], w[:, 1], w[:, 2]]
            if a == b:
                f[a] = d2[:, a]
            else:
                f[a], f[b] = d1[:, a], d1[:, b]
            h[a, b] = np.einsum("i,j,k,ijk->", f[0], f[1], f[2], v)
        f = [w[:, 0], w[:, 1], w[:, 2]]
        f[a] = d1[:, a]
        g[a] = np.einsum("i,j,k,ijk->", f[0], f[1], f[2], v)
    return float(np.einsum("i,j,k,ijk->", w[:, 0], w[:, 1], w[:, 2], v)), g, h


def curved_level(own: np.ndarray, other: np.ndarray, fx: np.ndarray, delta: float, table: np.ndarray) -> float:
    """Round 61's level of a point (:data:`CURVATURE`): the half-space level at ``delta + SIGMA2 k`` cells, ``k`` the
    least principal curvature the two fields' level surfaces share at the point (``own``, ``other``: the stencil's
    node volumes (3, 3, 3) of its own field and the other's; ``fx`` its offset)."""
    _, go, ho = gather_derivatives(own, fx)
    _, gt, ht = gather_derivatives(other, fx)
    k = least_curvature(np.stack([go, gt]), np.stack([ho, ht]))
    return float(table_level(table, delta + SIGMA2 * max(0.0, float(k.min()))))


def gap_marks(x: np.ndarray, in_a: np.ndarray, vf: np.ndarray, lo, dx: float, level: np.ndarray,
              delta: np.ndarray | None = None, table: np.ndarray | None = None) -> np.ndarray:
    """The NumPy reference of the marks: ``x`` (n, 3) material points, m; ``in_a`` (n,) bool, the point's field;
    ``vf`` (2, ng, ng, ng) the fields' node volumes (A's, B's), m^3; ``lo`` the grid's origin, m; ``level`` (n,) the
    point's body's level (round 60), or, with ``delta`` (n,) (the point's body's reach, cells) and ``table``
    (:func:`half_space_table`), round 61's :func:`curved_level`. Returns (ng, ng, ng) bool: the stencil nodes of
    every point where the other field's gathered volume fraction reaches its level."""
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
        box = vf[:, b[0]:b[0] + 3, b[1]:b[1] + 3, b[2]:b[2] + 3] / dx ** 3
        own, other = (box[0], box[1]) if in_a[p] else (box[1], box[0])
        wp3 = np.einsum("i,j,k->ijk", w[p, :, 0], w[p, :, 1], w[p, :, 2])
        lv = level[p] if table is None else curved_level(own, other, fx[p], float(delta[p]), table)
        if float((wp3 * other).sum()) >= lv:
            out[b[0]:b[0] + 3, b[1]:b[1] + 3, b[2]:b[2] + 3] = True
    return out
