"""Round 92 (issue 67 items 2 and 4; ``docs/rigid.md`` "Round 92: a ball in a hollow"): the normal of a round body's
contact with a rigid body where that body is concave (a ball rolling in a bowl cut into a block, a cylinder in a
trough), from the body's own outer points, not from its hull or from the touching nodes.

Round 91 took a round body's contact normal with a body that is not round from the two bodies' support tables (the
separating axis, :func:`gasp_core.mpm.rigid_support.round_normal`). A table is the body's hull: a ball inside a hollow
reads as deep inside it, and there (:data:`gasp_core.mpm.rigid_support.ROUND_DEEP`) the touching nodes' normal stood.
Measured (``benchmarks/studies/roll_bowl92.py``): a 5 cm ball in a hollow of radius 25 cm cut into a heavy rigid block
swung 4.1-6.3 % fast on it, rolling or sliding, the miss growing with the grid (a 5 cm cylinder in a trough as much
on the finer grid); with the hollow's exact radial normal put in its place it swung within 0.07 %. The touching
nodes' normal of a concave contact leans towards the hollow's bottom.

**The rule.** For a sphere, the normal at its contact passes through its centre, whatever the other body's shape; for
a solid cylinder's side, through its axis. So each rigid body that is not round, in a scene with a rigid sphere or
solid cylinder (``round_ground.ground_shapes``) and another rigid body, keeps its outer points in
its rest frame (:func:`outer_points`: those with an empty neighbour along one of the six axes, at most
:data:`MAX_POINTS`). Where the separating axis is refused as too deep (``ROUND_DEEP``), the sphere (centre ``c``)
takes the normal of the plane fitted to the body's outer points nearest its centre (a cylinder's: nearest its axis's
segment, the distances taken to it): with ``d_min`` the least distance from ``c`` to them, the points within ``d_min + HOLLOW_WINDOW s`` (``s`` the body's point spacing) weigh ``(1 - (d -
d_min) / (HOLLOW_WINDOW s))^2``, and the normal is the direction of least spread of those weighted points (the
smallest eigenvector of their covariance, by ``HOLLOW_POWER_STEPS`` power steps of ``tr(C) I - C`` from the nodes'
normal), turned towards ``c``. A sampled surface's nearest points lie about the foot of the normal from ``c`` on both
sides, so that direction is the normal, and the points' scatter along it (a scan's) moves the fit little. Measured on
the 25 cm hollow: within 0.04 degrees rms of the radial on a Fibonacci sampling; on a scan-like one (jittered a
quarter spacing along the normal) 0.25-0.46 degrees rms, where the mean of the nearest points' directions was 1.2-1.5
degrees. The gap stays the hull's (deep: no approach allowed, as before). The engines read only the outer points in
the cells (:func:`cell_index`, :data:`CELL` spacings) within the round body's radius and
``rigid_support.HOLLOW_REACH`` spacings of its centre or axis, a few hundred, once a concave pair and substep.

:func:`hollow_normal` (in :mod:`gasp_core.mpm.rigid_fit`, re-exported here and by ``rigid_support``) is the NumPy reference both engines
follow; docs/rigid.md "Round 92" names their functions.
"""
from __future__ import annotations

import numpy as np

import gasp_core.mpm.rigid_fit as rigid_fit
from gasp_core.mpm.rigid_fit import HOLLOW_POWER_STEPS, HOLLOW_WINDOW, hollow_normal  # noqa: F401 (re-exported)

#: 1: the rule above; 0: the touching nodes' normal in a concave part (round 91's, the broken variant).
HOLLOW = 1
#: Most outer points of one body (a larger body's are thinned evenly).
MAX_POINTS = 200_000
#: The cells of a body's outer points, in its point spacings: a contact's normal reads the cells within its round
#: body's reach (``rigid_support.HOLLOW_REACH``), a few hundred points, not the body's all.
CELL = 4.0
#: Most cells of one body (a larger body's are wider).
MAX_CELLS = 1_000_000


def outer_points(X0: np.ndarray) -> tuple[np.ndarray, float]:
    """``(outer (k, 3) m, s m)``: the points of ``X0`` ((n, 3) m, a body's rest frame) with no neighbour within
    ``0.75 s`` of ``x +- s e_j`` along one of the three axes ``e_j`` (``s`` the median nearest-neighbour distance),
    every ``ceil(k / MAX_POINTS)``-th of them kept."""
    from scipy.spatial import cKDTree
    from gasp_core.mpm.roll_contact import point_spacing
    X0 = np.asarray(X0, np.float64)
    s = point_spacing(X0)
    tree = cKDTree(X0)
    outer = np.zeros(len(X0), bool)
    for j in range(3):
        for sign in (-1.0, 1.0):
            d, _ = tree.query(X0 + sign * s * np.eye(3)[j], distance_upper_bound=0.75 * s)
            outer |= ~np.isfinite(d)
    keep = X0[outer]
    return keep[::max(1, -(-len(keep) // MAX_POINTS))], s


def cell_index(pts: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
    """``(order, counts, c, (origin, dims))`` of one body's outer points ``pts`` ((k, 3) m) on cells of
    :data:`CELL` point spacings ``s`` (wider where more than :data:`MAX_CELLS`): ``order`` sorts the points by their
    cell (x-major), ``counts`` (nx * ny * nz,) the points a cell holds."""
    lo = pts.min(0)
    span = pts.max(0) - lo
    c = max(CELL * s, float(np.prod(span + CELL * s) / MAX_CELLS) ** (1.0 / 3.0))
    dims = np.floor(span / c).astype(int) + 1
    ijk = np.minimum(np.floor((pts - lo) / c).astype(int), dims - 1)
    flat = (ijk[:, 0] * dims[1] + ijk[:, 1]) * dims[2] + ijk[:, 2]
    return np.argsort(flat, kind="stable"), np.bincount(flat, minlength=int(np.prod(dims))), c, (lo, dims)


def hollow_data(setup, rnd) -> dict:
    """The outer points the engines read (module notes) and their cells, all bodies' in their rest frames:

    - ``"X"`` (k, 3) float64 m: the outer points, each body's sorted by cell;
    - ``"cstart"`` (n_cells + 1,) int32: cell ``g``'s points are ``X[cstart[g]:cstart[g + 1]]``;
    - ``"corg"`` (n_bodies, 3) m, ``"csize"`` (n_bodies,) m, ``"cdims"`` (4 n_bodies,) int32: each body's cells'
      origin, size and ``[nx, ny, nz, first cell]`` (a body without outer points: one empty cell);
    - ``"spacing"`` (n_bodies,) m: each body's point spacing;
    - ``"radius"``, ``"half"`` (n_bodies,) m and ``"axis"`` (n_bodies, 3): each round body's radius, and a
      cylinder's half-length and unit axis in its rest frame (``round_ground.ground_shapes``; zeros: a sphere's
      axis, and the others);
    - ``"side"`` (n_bodies,): round 94, for a cylinder where :data:`gasp_core.mpm.rigid_fit.CYL_SIDE` is on (its
      side's normal across its axis and its foot, ``rigid_fit.hollow_contact``) 1.0, the contact a point there
      (``rigid_fit.FOOT_POINT``), or 2.0 without it; else 0.

    A body has outer points when it is rigid and not round (``rnd`` 0, :func:`gasp_core.mpm.rigid_pairs.
    support_data`'s round column) and a rigid round body (``rnd`` 1 or 2) shares the scene; none otherwise, and none
    at all when :data:`HOLLOW` is 0."""
    from gasp_core.mpm.round_ground import ground_shapes
    from gasp_core.mpm.rigid import body_frames, rigid_mask
    rnd = np.asarray(rnd, np.float64)
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    n, nb = len(setup.x), len(setup.materials)
    body = np.broadcast_to(np.asarray(setup.body_id), (n,))
    mass = np.broadcast_to(np.asarray(setup.p_mass, np.float64), (n,))
    want = bool(HOLLOW) and bool(np.any(rnd > 0.0)) and rigid.any()
    X0 = body_frames(setup.x, mass, body, rigid)[1] if want else None
    parts, counts, spacing = [], [], np.zeros(nb)
    corg, csize, cdims = np.zeros((nb, 3)), np.ones(nb), []
    for b in range(nb):
        sel = (body == b) & (mass > 0.0)
        cdims += [1, 1, 1, len(np.concatenate(counts)) if counts else 0]
        if want and rigid[b] and rnd[b] == 0.0 and sel.sum() >= 8:
            pts, spacing[b] = outer_points(X0[sel])
            order, cnt, csize[b], (corg[b], dims) = cell_index(pts, spacing[b])
            cdims[-4:-1] = [int(d) for d in dims]
            parts.append(pts[order])
            counts.append(cnt)
        else:
            counts.append(np.zeros(1, int))
    counts = np.concatenate(counts)
    shapes = ground_shapes(setup) if want else np.zeros((nb, 5))
    round_ = (rnd > 0.0)
    cyl = (rnd == 2.0)
    return {"X": np.concatenate(parts) if parts else np.zeros((1, 3)),
            "cstart": np.r_[0, np.cumsum(counts)].astype(np.int32), "corg": corg, "csize": csize,
            "cdims": np.asarray(cdims, np.int32), "spacing": spacing,
            "radius": np.where(round_, shapes[:, 0], 0.0), "half": np.where(cyl, shapes[:, 1], 0.0),
            "axis": np.where(cyl[:, None], shapes[:, 2:5], 0.0), "side": np.where(cyl & bool(rigid_fit.CYL_SIDE),
                                                                                1.0 if rigid_fit.FOOT_POINT else 2.0, 0.0)}


def body_points(data: dict, b: int) -> np.ndarray:
    """Body ``b``'s outer points from :func:`hollow_data`'s ``data`` ((k, 3) m, its rest frame)."""
    nx, ny, nz, first = (int(v) for v in data["cdims"][4 * b:4 * b + 4])
    return data["X"][data["cstart"][first]:data["cstart"][first + nx * ny * nz]]
