"""A rigid body's support table (issue 67 items 2 and 4, round 65): how round or flat the body is where it meets
another rigid body, read from its own points (``docs/rigid.md`` "Round 65: rolling between rigid bodies").

The ground's law tells a ball from a face by the contact's patch (``rigid_friction.contact_flatness``: the normal
impulses' spread ``s^2`` along the slip against the deepest point's depth ``d``, ``rho = 3 s^2 / d``). Two rigid
bodies meet through the grid's nodes, which hold no such patch; the body's own points do. Pressed a depth ``delta``
into a plane of outward normal ``d``, a solid body of radius of curvature ``rho`` there overlaps it on a cap whose
points (a column ``delta - r^2 / (2 rho)`` high at the distance ``r`` from its centre) spread along a line in it with
variance ``rho delta / 3`` (the ground's reading, ``rho = 3 s^2 / delta``), and the points' depth grows as ``q^2 /
(2 rho)`` with their offset ``q`` across the normal. So,
once per body at build time (:func:`support_table`), over a set of unit directions ``d`` in its rest frame: the
support ``h(d)`` (its farthest point along ``d`` from its mass centre, plus half a point spacing: the lattice's
surface) and the curvature of its surface there, fitted to its points within ``delta`` of that plane
(:func:`band_curvature`: their depth against their offset across ``d``; the band's spread ``3 s^2 / delta`` read a
narrow lattice face as partly round); and in the pair law (:func:`pair_flatness`): each body's direction towards
the other, its nearest table direction, the curvature ``1 / rho`` along the slip ``t``, and the body's flatness
``clip((rho / h - FLAT_FROM) / (FLAT_TO - FLAT_FROM), 0, 1)`` (:func:`flatness`). A pair is a face on a face (its
tipping moment held, ``f`` 1) only when both bodies are flat there: the smaller of the two.
"""
from __future__ import annotations

import numpy as np

from .rigid_fit import HOLLOW_POWER_STEPS, HOLLOW_REACH, HOLLOW_WINDOW, hollow_normal  # noqa: F401 (re-exported)
from .rigid_friction import FLAT_FROM, FLAT_TO

#: Round 91: :func:`round_normal` trusts the other body's supports only where the separating axis puts the round body
#: less than this share of its own support deep in the other's hull: a table is the hull's, so a ball in a bowl (a
#: concave part) reads as deep inside it, while a real contact, found by the touching nodes, is within a fraction of a
#: cell (a resting 10 cm ball 0.2 mm). Deeper, the nodes' normal stands.
ROUND_DEEP = 0.25
#: Round 93 (``docs/rigid.md`` "Round 93: a ball over a dome"): 1: where the other body is not a plane at the
#: separating axis's row (:func:`curved_rows`), a round body's normal is the plane fit to that body's outer points
#: nearest it (:func:`hollow_normal`, as in a hollow) and the pair's gap is not known; 0: the row (round 91's, the
#: broken variant: a table's rows are about 12 degrees apart, and on a curved face the nearest one stood).
CURVED = 1
#: Round 93: the band's curvature times the support (dimensionless) under which a row is an exact plane's (a lattice's
#: face reads about 1e-16, round-off; :func:`curved_rows`).
FACE_ROUNDOFF = 1.0e-9
#: The number of Fibonacci directions of a table (the rest-frame axes and the body's principal axes are added).
N_DIRS = 256
#: The band's depth in point spacings: the fit's points (a lattice ball of radius 3-9 spacings read round along
#: 81-92 % of its table's directions and slips at 1.5 spacings, 95-98 % at 2.5, 99.4-100 % at 3.5; R 3 and 4.5 cm
#: at dx 1-2 cm; a box's faces read flat at each).
BAND = 3.5


def table_directions(X0: np.ndarray, n: int = N_DIRS) -> np.ndarray:
    """``(n + 12, 3)`` unit directions: ``n`` on a Fibonacci sphere, the rest frame's six axes and the six of the
    points' principal axes (a box's face normals wherever it was set down)."""
    k = np.arange(n) + 0.5
    z = 1.0 - 2.0 * k / n
    phi = np.pi * (1.0 + 5.0 ** 0.5) * k
    rxy = np.sqrt(1.0 - z * z)
    fib = np.stack([rxy * np.cos(phi), rxy * np.sin(phi), z], axis=1)
    X0 = np.asarray(X0, np.float64)
    _, vecs = np.linalg.eigh(X0.T @ X0 if len(X0) else np.eye(3))
    return np.concatenate([fib, np.eye(3), -np.eye(3), vecs.T, -vecs.T])


def support_table(X0: np.ndarray, spacing: float, n: int = N_DIRS):
    """A body's support table (module notes).

    Parameters
    ----------
    X0 : ndarray, shape (k, 3)
        The body's points about its mass centre in its rest frame, m.
    spacing : float
        The points' spacing, m (``p_vol ** (1/3)``).
    n : int
        The number of Fibonacci directions.

    Returns
    -------
    dirs : ndarray, shape (n + 12, 3)
        Unit directions in the rest frame.
    h : ndarray, shape (n + 12,)
        The support along each, m (the farthest point plus ``spacing / 2``).
    curv : ndarray, shape (n + 12, 6)
        The surface's curvature tensor there (1/m; ``xx, xy, xz, yy, yz, zz`` in the rest frame, across ``d``):
        :func:`band_curvature` of the points within ``BAND * spacing`` of the support plane.
    delta : float
        That band, m.
    """
    X0 = np.asarray(X0, np.float64)
    dirs = table_directions(X0, n)
    delta = BAND * float(spacing)
    h = np.zeros(len(dirs))
    curv = np.zeros((len(dirs), 6))
    for i, d in enumerate(dirs):
        q = X0 @ d
        top = float(q.max())
        K = band_curvature(X0[q >= top - delta], d, top)
        h[i] = top + 0.5 * spacing
        curv[i] = K[0, 0], K[0, 1], K[0, 2], K[1, 1], K[1, 2], K[2, 2]
    return dirs, h, curv, delta


def round_table(dirs: np.ndarray, shape: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A round rigid body's exact support and curvature over ``dirs`` (round 90: a ball or cylinder on another rigid
    body meets it on its exact shape, as on the ground, ``gasp_core.mpm.round_ground``).

    Parameters
    ----------
    dirs : ndarray, shape (n, 3)
        Unit directions in the body's rest frame.
    shape : ndarray, shape (5,)
        ``gasp_core.mpm.round_ground.ground_shapes``'s row: ``[R, h, e0]`` (m, m, unit axis; ``h`` 0 a sphere).

    Returns
    -------
    h, curv : ndarray, shapes (n,) m and (n, 6) 1/m
        :func:`support_table`'s columns: a sphere's support ``R`` and curvature ``(1 - d d^T) / R``; a solid
        cylinder's support the larger of its side's ``R |d - (d . e) e|`` and its end's ``h |d . e|`` and curvature
        ``q q^T / R`` for ``q = e x d`` around its side (0 towards an end, a face). The pair law reads the table at its
        direction nearest the contact's normal: a cylinder on its side, turned as it rolls, reads a direction a few
        degrees off its side, where the exact support ``R cos + h sin`` (its rim's) would put the contact ``h sin``
        (7 mm for a 10 cm half-length 4 degrees off) beyond its side; the side's and the end's alone are exact for
        contacts on the side or an end, not on the rim.
    """
    R, hh, e = float(shape[0]), float(shape[1]), np.asarray(shape[2:5], np.float64)
    d = np.asarray(dirs, np.float64)
    if hh <= 0.0:
        h = np.full(len(d), R)
        K = (np.eye(3)[None] - d[:, :, None] * d[:, None, :]) / R
    else:
        de = d @ e
        h = np.maximum(R * np.sqrt(np.clip(1.0 - de * de, 0.0, 1.0)), hh * np.abs(de))   # its side's, its end's
        q = np.cross(e[None], d)
        K = q[:, :, None] * q[:, None, :] / R   # |q| = sin: the side's curvature fades to the end's face
    return h, K[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]


def band_curvature(P: np.ndarray, d: np.ndarray, top: float) -> np.ndarray:
    """The curvature tensor (3, 3), 1/m, of the surface of outward normal ``d`` (unit) whose points within the band
    are ``P`` (k, 3), m (``top`` the farthest's ``d . x``): the least-squares fit of their depth ``z = top - d . x``
    to ``b + g . q + q^T A q / 2`` over their offsets ``q`` across ``d``, ``A`` embedded in 3D. A solid body's
    surface of radius of curvature ``rho`` fills the band with points whose depth grows as ``q^2 / (2 rho)``; a
    face's lattice layers (the same points across ``d`` at each depth) give ``A`` 0 whatever the face's width, and a
    face the table's direction misses by a few degrees a tilt ``g``, not a curvature. (The band's spread, ``rho = 3
    s^2 / delta``, the ground's reading, is a face's lower bound: a 6 x 6 x 3 cm block at n_grid 24 read 0.95.)"""
    e1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    r = P - P.mean(axis=0)
    a, b = r @ e1, r @ e2
    F = np.stack([np.ones_like(a), a, b, 0.5 * a * a, a * b, 0.5 * b * b], axis=1)
    c = np.linalg.lstsq(F, top - P @ d, rcond=1e-12)[0]
    T = np.stack([e1, e2], axis=1)
    return T @ np.array([[c[3], c[4]], [c[4], c[5]]]) @ T.T


def _row(table, R, d_world) -> int:
    """The table's direction nearest to the world direction ``d_world`` for the body at rotation ``R``."""
    return int(np.argmax(table[0] @ (np.asarray(R, np.float64).T @ np.asarray(d_world, np.float64))))


def support(table, R, d_world) -> float:
    """The body's support towards the world direction ``d_world`` (unit), m: its nearest table direction's."""
    return float(table[1][_row(table, R, d_world)])


def contact_plane(table_a, R_a, c_a, table_b, R_b, c_b, n, round_a: bool = False, round_b: bool = False) -> float:
    """Where two touching bodies' surfaces meet along ``n`` (unit, from A into B), as ``n . x`` (m): midway between
    A's support plane towards ``n`` and B's towards ``-n`` (``c_a``, ``c_b`` their mass centres, m). A round body
    rolls on its surface: the lever of the friction's tipping moment reaches it (the touching nodes' centre, where
    the pair law takes the contact, lay 2 mm (0.13 dx) above a ball's surface at n_grid 32). Round 90
    (``rigid_pairs.ROUND_PAIR``, the engines' rule): where one body alone is round (``round_a`` or ``round_b``, its
    table :func:`round_table`'s), the plane is that body's own support plane."""
    n = np.asarray(n, np.float64)
    w = 0.5 + 0.5 * (float(bool(round_a)) - float(bool(round_b)))
    return (w * (float(np.dot(c_a, n)) + support(table_a, R_a, n))
            + (1.0 - w) * (float(np.dot(c_b, n)) - support(table_b, R_b, -n)))


def curved_rows(h, curv) -> np.ndarray:
    """Round 93: per table row, 1.0 where the body is not an exact plane there, else 0.0: the band's curvature tensor
    (:func:`band_curvature`, 1/m) times the support (m) over :data:`FACE_ROUNDOFF` in its Frobenius norm. A lattice's
    face reads 1e-16 and keeps its row, its exact normal; a dome, a mound of 5 m radius (0.09 1/m) or a scan's jittered
    face (0.06 1/m) reads curved and takes the plane fit to its outer points (:func:`round_normal`), since the nearest
    of rows 12 degrees apart is up to 6 degrees off a curved surface's normal however gentle. All 0.0 when
    :data:`CURVED` is 0 or there is no curvature (``curv`` None).

    Parameters
    ----------
    h : array_like, shape (n,)
        The rows' supports, m (:func:`support_table`).
    curv : array_like, shape (n, 6) or (n, 3, 3), or None
        Their curvature tensors, 1/m (the table's six components, or ``rigid_pairs.support_data``'s matrices).

    Returns
    -------
    ndarray, shape (n,), float64
    """
    h = np.asarray(h, np.float64)
    if not CURVED or curv is None:
        return np.zeros(len(h))
    K = np.asarray(curv, np.float64)
    if K.ndim == 2:
        K = K[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3)
    return (np.sqrt((K * K).sum(axis=(1, 2))) * np.abs(h) > FACE_ROUNDOFF).astype(np.float64)


def _curved_at(table, i: int) -> bool:
    """:func:`curved_rows` of row ``i`` of a table (False for a table without curvatures)."""
    return len(table) > 2 and bool(curved_rows(table[1][i:i + 1], table[2][i:i + 1])[0])


def round_normal(table_f, R_f, c_f, table_r, R_r, c_r, n, cos_cone: float, outer=None) -> np.ndarray:
    """Round 91: the normal of a round body's contact with a body that is not round, from their supports (the
    separating axis), not from the touching nodes (``docs/rigid.md`` "Round 91: the normal of a round body's contact").

    For convex bodies the signed distance is ``max_d [d . (c_r - c_f) - h_f(d) - h_r(-d)]`` over unit ``d``, and the
    maximiser is the contact's normal out of ``f`` (Gilbert, Johnson & Keerthi 1988; the separating-axis theorem). The
    search runs over ``f``'s own table directions within the cone ``d . n >= cos_cone`` of the nodes' normal ``n``
    (where ``f``'s support is its table's, exact: a box's face normals are rows), the round body's support read at its
    nearest row (a sphere's is ``R`` in every row). A table is the body's hull: where the best axis still puts the round
    body more than :data:`ROUND_DEEP` of its support inside it, the contact is in a concave part (a ball in a bowl)
    and the nodes' ``n`` stands, or, for a sphere or a cylinder, round 92's normal from ``f``'s outer points nearest its centre
    (``outer``, :func:`hollow_normal`). Round 93: where ``f``'s table reads its surface curved at the chosen row
    (:func:`curved_rows`: a dome, a rock, a box's rounded edge), that row is only the nearest of rows about 12 degrees
    apart (7.5 degrees off on a 20 cm dome), and the normal is the same fit to ``outer``, started from the row. The
    nodes' normal (field B's mass gradient) leaned 1-2
    degrees ahead of a rolling 10 cm cylinder and its contact centre lagged 7 mm behind: the approach removed along
    the leaning normal let the body sink 1.7 mm into a slab in 0.3 s and roll 3.4 % fast.

    Parameters
    ----------
    table_f, table_r : tuple
        :func:`support_table`'s ``(dirs, h, ...)`` of the body that is not round and of the round body
        (:func:`round_table`'s rows).
    R_f, R_r : array_like, shape (3, 3)
        Their rotations.
    c_f, c_r : array_like, shape (3,)
        Their mass centres, m.
    n : array_like, shape (3,)
        The nodes' unit normal, out of ``f`` towards the round body.
    cos_cone : float
        The cosine of the search cone's half-angle (:data:`gasp_core.mpm.rigid_pairs.NORMAL_CONE`); above 1: ``n``.
    outer : tuple, optional
        Round 92: ``(X_f, s_f)``, ``f``'s outer points ((k, 3) m, rest frame) and spacing (m),
        :func:`gasp_core.mpm.hollow.hollow_data`'s, and for a cylinder its world axis and half-length (m) after them
        (:func:`hollow_normal`); None: the nodes' ``n`` in a concave part.

    Returns
    -------
    ndarray, shape (3,)
        The unit normal out of ``f`` (``n`` itself when no table direction lies in the cone).
    """
    n = np.asarray(n, np.float64)
    E = np.asarray(table_f[0], np.float64) @ np.asarray(R_f, np.float64).T   # f's directions in the world
    inside = np.flatnonzero(E @ n >= cos_cone)
    if not len(inside):
        return n
    dc = np.asarray(c_r, np.float64) - np.asarray(c_f, np.float64)
    h_r = [support(table_r, R_r, -E[i]) for i in inside]
    gaps = [float(E[i] @ dc) - float(table_f[1][i]) - hr for i, hr in zip(inside, h_r)]
    k = int(np.argmax(gaps))
    if gaps[k] < -ROUND_DEEP * h_r[k]:   # deeper in the hull than a contact can be: a concave part of it
        if outer is None:
            return n
        return hollow_normal(outer[0], outer[1], R_f, c_f, c_r, n, *outer[2:])
    i = inside[k]
    if outer is not None and _curved_at(table_f, i):
        return hollow_normal(outer[0], outer[1], R_f, c_f, c_r, E[i], *outer[2:])
    return E[i].copy()


def pair_normal(table_a, R_a, c_a, kind_a: float, table_b, R_b, c_b, kind_b: float, n, cos_cone: float,
                outer_a=None, outer_b=None) -> np.ndarray:
    """Round 91, the rule both engines' pair laws follow for a pair's normal (unit, from A into B): two spheres (kind
    1, ``rigid_pairs.support_data``'s round column) take their line of centres (exact: the struck ball of an oblique
    frictionless impact moved 5.5 degrees off it on the nodes' normal); one round body and one that is not take
    :func:`round_normal`; every other pair (none round, a cylinder with another round body) the nodes' ``n``. A
    ``cos_cone`` above 1 (the switch off) keeps ``n`` for all.

    Parameters
    ----------
    table_a, table_b : tuple
        The bodies' :func:`support_table` (a round body's rows :func:`round_table`'s).
    R_a, R_b : array_like, shape (3, 3)
        Their rotations.
    c_a, c_b : array_like, shape (3,)
        Their mass centres, m.
    kind_a, kind_b : float
        0 not round, 1 a sphere, 2 a solid cylinder.
    n : array_like, shape (3,)
        The touching nodes' unit normal, from A into B.
    cos_cone : float
        :func:`round_normal`'s cone.
    outer_a, outer_b : tuple, optional
        Round 92: each body's ``(outer points, spacing)`` (:func:`gasp_core.mpm.hollow.hollow_data`; with the
        other's axis and half-length after them where the other is a cylinder), read for the body that is not round
        when the other, round, lies in a concave part of it.

    Returns
    -------
    ndarray, shape (3,)
    """
    n = np.asarray(n, np.float64)
    if cos_cone > 1.0:
        return n
    if kind_a == 1.0 and kind_b == 1.0:
        d = np.asarray(c_b, np.float64) - np.asarray(c_a, np.float64)
        return d / np.linalg.norm(d)
    if (kind_a > 0.0) != (kind_b > 0.0):
        if kind_b > 0.0:
            return round_normal(table_a, R_a, c_a, table_b, R_b, c_b, n, cos_cone, outer_a)
        return -round_normal(table_b, R_b, c_b, table_a, R_a, c_a, -n, cos_cone, outer_b)
    return n


def pair_gap(table_a, R_a, c_a, kind_a: float, table_b, R_b, c_b, kind_b: float, n, cos_cone: float) -> float:
    """Round 91: where :func:`pair_normal` takes the normal from the shapes and a sphere's support is exact in every
    row (two spheres, or a sphere and a body that is not round), the gap between the two bodies' supports along ``n``
    (unit, from A into B), ``n . (c_b - c_a) - h_a(n) - h_b(-n)`` (m, < 0 where they overlap); -1e30 elsewhere (no gap
    known). A cylinder's nearest row lies up to half the rows' spacing off its side, where :func:`round_table` puts
    its support ``R cos`` (0.5 mm short for R 10 cm): a rolling cylinder sank by that much on the gap, so it keeps the
    nodes' touch. Round 93: none known either where the body that is not round reads curved at its row towards the
    sphere (:func:`curved_rows`; the normal is then a plane fit, not a row, and its row's support is not the surface's
    there). Arguments as :func:`pair_normal`'s."""
    sphere_one = {float(kind_a), float(kind_b)} == {0.0, 1.0}
    if cos_cone > 1.0 or not (sphere_one or (kind_a == 1.0 and kind_b == 1.0)):
        return -1.0e30
    n = np.asarray(n, np.float64)
    for table, R, kind, d in ((table_a, R_a, kind_a, n), (table_b, R_b, kind_b, -n)):
        if kind == 0.0 and _curved_at(table, _row(table, R, d)):
            return -1.0e30
    return (float(n @ (np.asarray(c_b, np.float64) - np.asarray(c_a, np.float64))) - support(table_a, R_a, n)
            - support(table_b, R_b, -n))


def body_flatness(table, R: np.ndarray, d_world: np.ndarray, t_world: np.ndarray) -> float:
    """One body's flatness (module notes) towards the world direction ``d_world`` (unit, out of the body towards the
    other) along the slip ``t_world`` (unit), the body at rotation ``R`` (3, 3); ``table`` :func:`support_table`'s."""
    dirs, h, curv, delta = table
    R = np.asarray(R, np.float64)
    i = _row(table, R, d_world)
    t = R.T @ np.asarray(t_world, np.float64)
    c = curv[i]
    kappa = float(t @ np.array([[c[0], c[1], c[2]], [c[1], c[3], c[4]], [c[2], c[4], c[5]]]) @ t)
    return flatness(kappa, float(h[i]))


def flatness(kappa: float, h: float) -> float:
    """``clip((rho / h - FLAT_FROM) / (FLAT_TO - FLAT_FROM), 0, 1)`` for the curvature ``kappa = 1 / rho`` (1/m) along
    the slip and the support ``h`` (m): 1 where ``kappa h`` is at most ``1 / FLAT_TO`` (a face, ``kappa`` 0)."""
    if kappa * h * FLAT_TO <= 1.0:
        return 1.0
    return min(max((1.0 / (kappa * h) - FLAT_FROM) / (FLAT_TO - FLAT_FROM), 0.0), 1.0)


def pair_flatness(table_a, R_a, table_b, R_b, n, t) -> float:
    """The flatness of a pair's contact: the smaller of body A's towards ``n`` (from A into B) and body B's towards
    ``-n``, along the slip ``t``; 1.0 when either table is None (the law before round 65: a face on a face)."""
    if table_a is None or table_b is None:
        return 1.0
    n = np.asarray(n, np.float64)
    return min(body_flatness(table_a, R_a, n, t), body_flatness(table_b, R_b, -n, t))
