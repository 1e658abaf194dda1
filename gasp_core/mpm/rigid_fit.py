"""Round 92 (issue 67 items 2 and 4; ``docs/rigid.md`` "Round 92: a ball in a hollow", "Round 93: a ball over a
dome"): the normal of a round rigid body's contact with another rigid body from that body's own outer points nearest
it, a plane fit, where its support table cannot give it (a hollow: the table is the hull; a curved face: its rows
are about 12 degrees apart). :mod:`gasp_core.mpm.rigid_support` decides where (and re-exports these names);
:mod:`gasp_core.mpm.hollow` keeps the points.
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


def hollow_normal(X_f, s_f: float, R_f, c_f, c_r, n, axis=(0.0, 0.0, 0.0), half: float = 0.0,
                  radius: float = np.inf) -> np.ndarray:
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
    ndarray, shape (3,)
        The unit normal out of ``f``; ``n`` where ``f`` has no outer points within the reach.
    """
    X_f = np.asarray(X_f, np.float64)
    if not len(X_f) or not s_f > 0.0:
        return np.asarray(n, np.float64)
    R_f = np.asarray(R_f, np.float64)
    q = R_f.T @ (np.asarray(c_r, np.float64) - np.asarray(c_f, np.float64))
    Y = X_f - q
    e = R_f.T @ np.asarray(axis, np.float64)   # a cylinder's axis in f's frame (zeros: a sphere)
    d = np.linalg.norm(Y - np.clip(Y @ e, -half, half)[:, None] * e[None, :], axis=1)
    near = d <= radius + HOLLOW_REACH * s_f
    if not near.any():
        return np.asarray(n, np.float64)
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
    return R_f @ m
