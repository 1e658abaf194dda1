"""Round 92 (issue 67 items 2 and 4; ``docs/rigid.md`` "Round 92: a ball in a hollow", "Round 93: a ball over a
dome"): the normal of a round rigid body's contact with another rigid body from that body's own outer points nearest
it, a plane fit, where its support table cannot give it (a hollow: the table is the hull; a curved face: its rows
are about 12 degrees apart). :mod:`gasp_core.mpm.rigid_support` decides where (and re-exports these names);
:mod:`gasp_core.mpm.hollow` keeps the points. Round 94 (``docs/rigid.md`` "Round 94: a cylinder's foot"): where a
solid cylinder's side touches, its foot along its axis (:func:`side_foot`), and the pair law's push there
(:func:`foot_approach`, :func:`foot_mass`, :func:`foot_point`; the engines' ``foot.py``).
"""
from __future__ import annotations

import numpy as np

#: Round 92 (:mod:`gasp_core.mpm.hollow`): the plane fit's reach beyond the nearest outer point, in the body's point
#: spacings (:func:`hollow_normal`).
HOLLOW_WINDOW = 2.0
#: Round 92: the outer points read, within the round body's radius and this many of the other body's point spacings
#: of its centre or axis (the window's 2 and one for the overlap): the engines' cells within it.
HOLLOW_REACH = 3.0
#: Round 92: power steps of the fit's least-spread direction (the eigenvalues' ratio is about 1/2 on a surface patch).
HOLLOW_POWER_STEPS = 24
#: Round 94 (``docs/rigid.md`` "Round 94: a cylinder's foot"): 1: where a solid cylinder's side touches a fitted
#: surface, its normal is taken across its axis and the pair's normal impulse acts at its foot (:func:`side_foot`),
#: with that point's moment about the axis's middle; 0: the fit's normal as it is, pushed through the centres (round
#: 92-93's, the broken variant: a cylinder across a 1 m mound tipped sideways and arrived 15 % slow).
CYL_SIDE = 1
#: Round 94: 1: where a cylinder's side bears at its foot, the pair's contact is a point there, holding no tipping
#: moment of its friction (the pair's flatness 0: ``rigid_friction.pair_contact``'s ``arms``); 0: the pair's flatness
#: as before (the broken variant: a face's hold on the friction's moment across the axis, so that a cylinder rocking
#: on a sphere swung as if its contact slid freely along its axis, its period 30 % short).
FOOT_POINT = 1
#: Round 94: :func:`side_foot`'s band, in the other body's point spacings: the cylinder's line bears where its gap is
#: within it of the least (0.1 spacings, ``RIGID_SLOP dx`` for the fill's spacing ``dx / 2``, as a cylinder's line
#: on a plane is level while its ends are within that slop, ``round_ground.level_band``).
FOOT_BAND = 0.1
#: Round 94: the points along the cylinder's segment at which :func:`side_foot` reads the gap.
FOOT_SAMPLES = 16


def hollow_normal(X_f, s_f: float, R_f, c_f, c_r, n, axis=(0.0, 0.0, 0.0), half: float = 0.0,
                  radius: float = np.inf) -> np.ndarray:
    """:func:`hollow_contact`'s normal (same parameters)."""
    return hollow_contact(X_f, s_f, R_f, c_f, c_r, n, axis, half, radius)[0]


def hollow_contact(X_f, s_f: float, R_f, c_f, c_r, n, axis=(0.0, 0.0, 0.0), half: float = 0.0,
                   radius: float = np.inf) -> tuple[np.ndarray, float | None]:
    """Round 92: the unit normal out of body ``f`` towards a sphere's centre ``c_r`` (m), or a cylinder's axis, the
    plane fitted to ``f``'s outer points nearest it (:mod:`gasp_core.mpm.hollow`'s notes: within ``d_min +
    HOLLOW_WINDOW s_f``, weighted, the least spread by power steps from ``n``, turned towards ``c_r``), of the points
    within ``radius + HOLLOW_REACH s_f``. A cylinder's distances are to its axis's segment (``c_r +- t axis``, ``|t|
    <= half``), where its side's normal meets it.

    Parameters
    ----------
    X_f : array_like, shape (k, 3)
        ``f``'s outer points in its rest frame, m (:func:`gasp_core.mpm.hollow.outer_points`).
    s_f : float
        Its point spacing, m.
    R_f : array_like, shape (3, 3)
        Its rotation.
    c_f, c_r : array_like, shape (3,)
        Its mass centre and the sphere's centre, m.
    n : array_like, shape (3,)
        The touching nodes' unit normal, out of ``f``: the power steps' start.
    axis : array_like, shape (3,), optional
        A cylinder's unit axis in the world (zeros: a sphere).
    half : float, optional
        Its half-length, m.
    radius : float, optional
        The round body's radius, m (the reach's; infinite: every point).

    Returns
    -------
    (ndarray, shape (3,), float or None)
        The unit normal out of ``f`` (``n`` where ``f`` has no outer points within the reach) and, round 94
        (:data:`CYL_SIDE`), where a cylinder's side touches (the patch's weighted centre along its segment,
        ``|y . axis| < half``) its foot (:func:`side_foot`, m along ``axis`` from ``c_r``), its normal then taken
        across the axis (a side's normal is, whatever it touches); None otherwise (no side contact).
    """
    X_f = np.asarray(X_f, np.float64)
    if not len(X_f) or not s_f > 0.0:
        return np.asarray(n, np.float64), None
    R_f = np.asarray(R_f, np.float64)
    q = R_f.T @ (np.asarray(c_r, np.float64) - np.asarray(c_f, np.float64))
    Y = X_f - q
    e = R_f.T @ np.asarray(axis, np.float64)   # a cylinder's axis in f's frame (zeros: a sphere)
    d = np.linalg.norm(Y - np.clip(Y @ e, -half, half)[:, None] * e[None, :], axis=1)
    near = d <= radius + HOLLOW_REACH * s_f
    if not near.any():
        return np.asarray(n, np.float64), None
    Y, d = Y[near], d[near]
    w = np.clip(1.0 - (d - d.min()) / (HOLLOW_WINDOW * s_f), 0.0, None) ** 2
    y = (w[:, None] * Y).sum(0) / w.sum()
    C = np.einsum("n,ni,nj->ij", w, Y, Y) / w.sum() - np.outer(y, y)
    M = np.trace(C) * np.eye(3) - C
    m = R_f.T @ np.asarray(n, np.float64)
    for _ in range(HOLLOW_POWER_STEPS):
        m = M @ m
        m = m / np.linalg.norm(m)
    if m @ y > 0.0:   # towards the sphere's centre, away from the points' mean
        m = -m
    foot = None
    if CYL_SIDE and half > 0.0 and abs(float(y @ e)) < half:   # round 94: a cylinder's side
        m = m - (m @ e) * e
        m = m / np.linalg.norm(m)
        foot = side_foot(Y, w, m, e, half, FOOT_BAND * s_f)
    return R_f @ m, foot


def side_foot(Y, w, m, e, half: float, band: float) -> float:
    """Round 94: where along a solid cylinder's segment its side bears on a fitted surface (m from its centre along
    ``e``). The patch's heights along the normal ``m`` are fitted, with the plane fit's weights, by a parabola in the
    axial coordinate ``t = Y . e`` (least squares); the gap from the side to it along the segment ``|t| <= half`` is
    read at :data:`FOOT_SAMPLES` points, and the foot is the mean of ``t`` weighted by ``max(band - (gap - least
    gap), 0)``: on a convex surface the parabola's vertex (the foot of the normal from the surface's centre of
    curvature, so that a tilted cylinder's load moves to its lower side as a board's on a log does), on a surface
    level with the axis the segment's middle (a line contact's resultant), and on one tilted along it the lower end.

    Parameters
    ----------
    Y : array_like, shape (k, 3)
        The patch's points from the cylinder's centre, m (the other body's frame).
    w : array_like, shape (k,)
        Their weights (:func:`hollow_contact`'s).
    m, e : array_like, shape (3,)
        The unit normal (towards the cylinder, across its axis) and the cylinder's unit axis, that frame.
    half, band : float
        The cylinder's half-length and the band (m).

    Returns
    -------
    float
        The foot, m along ``e`` from the centre, within ``[-half, half]``; 0.0 where the patch does not span enough
        of the axis to fit a parabola.
    """
    Y, w = np.asarray(Y, np.float64), np.asarray(w, np.float64)
    tau = (Y @ e) / half
    z = Y @ m
    V = np.vander(tau, 3, increasing=True)   # 1, tau, tau^2
    A = (V * w[:, None]).T @ V / w.sum()
    if not np.linalg.det(A) > 1e-9:
        return 0.0
    a0, a1, a2 = np.linalg.solve(A, (V * w[:, None]).T @ z / w.sum())
    tk = -1.0 + (np.arange(FOOT_SAMPLES) + 0.5) * 2.0 / FOOT_SAMPLES
    gap = tk * half * float(m @ e) - (a1 * tk + a2 * tk * tk)   # the side's height less the surface's, less a constant
    p = np.clip(band - (gap - gap.min()), 0.0, None)
    return float(half * (p * tk).sum() / p.sum())


def foot_approach(VA, wA, VB, wB, arms, n) -> tuple[float, np.ndarray, np.ndarray]:
    """Round 94: the approach along ``n`` (m/s) of A's point at a cylinder's foot to B's, and the two arms (m, world,
    from each body's centre; the round body's ``foot`` times its world axis, zeros for the other): through the
    centres where ``arms`` is None (the pair law before round 94, bit for bit). The engines' ``foot.py``."""
    arm_a, arm_b = (np.zeros(3), np.zeros(3)) if arms is None else (np.asarray(a, np.float64) for a in arms)
    return float(np.dot(VA + np.cross(wA, arm_a) - VB - np.cross(wB, arm_b), n)), arm_a, arm_b


def foot_point(x_c, c_a, c_b, arm_a, arm_b) -> np.ndarray:
    """Round 94: the contact point ``x_c`` (m) moved along the round body's axis onto its foot (its arm's length from
    its centre ``c_a`` or ``c_b``); ``x_c`` without an arm. The engines' ``foot.py``."""
    x_c = np.asarray(x_c, np.float64)
    for arm, c in ((arm_a, c_a), (arm_b, c_b)):
        if np.linalg.norm(arm) > 0.0:
            e = arm / np.linalg.norm(arm)
            x_c = x_c + arm - float(np.dot(x_c - c, e)) * e
    return x_c


def foot_mass(MA: float, MB: float, iA, iB, arm_a, arm_b, n) -> float:
    """Round 94: the inverse of the pair's effective mass along ``n`` at the foot (1/kg; ``1 / MA + 1 / MB`` with zero
    arms; ``iA``, ``iB`` the inverse inertias at the pose, 1/(kg m^2))."""
    gA, gB = np.cross(arm_a, n), np.cross(arm_b, n)
    return 1.0 / MA + 1.0 / MB + float(gA @ iA @ gA) + float(gB @ iB @ gB)
