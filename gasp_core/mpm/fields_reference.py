"""The NumPy references of the two-field contact's node maths (:mod:`gasp_core.mpm.fields`, whose module notes give
the equations; each grid engine's ``fields.py`` spells the same steps in kernels): a node's correction, field B's mass
with its ground mirror, and the normals; also the flowing body's touch level (:func:`flow_touch_level`) and a pair's
Coulomb coefficient (:func:`combine_friction`). The tests compare the engines against these; ``gasp_core.mpm.fields``
re-exports them (and calls ``combine_friction`` through its own name, which tests may patch)."""
from __future__ import annotations

import functools
import math

import numpy as np

#: A node is shared when each field holds at least this fraction of its mass (below it the fields move as one).
MIN_FRACTION = 1e-6
#: The flowing body's touch distance (cells), ``gasp_core.mpm.fields.FLOW_TOUCH_DELTA``'s value.
FLOW_TOUCH_DELTA = 0.25


def field_offsets(m: np.ndarray, m_a: np.ndarray, p: np.ndarray, p_a: np.ndarray, n: np.ndarray, mu: float):
    """The NumPy reference of a node's correction (the equations of :mod:`gasp_core.mpm.fields`), vectorised over nodes.

    Parameters
    ----------
    m, m_a : (k,) float
        The node's whole mass and field A's, kg.
    p, p_a : (k, 3) float
        The whole momentum and field A's, kg m/s (after P2G, before gravity).
    n : (k, 3) float
        The unnormalised normal ``grad m_B`` (kg/m).
    mu : float
        The Coulomb coefficient (:func:`gasp_core.mpm.fields.field_friction`).

    Returns
    -------
    dv_a, dv_b : (k, 3) float
        Each field's velocity offset from the whole grid's (m/s); zero where the node is not shared.
    """
    m_b = m - m_a
    shared = (m_a > MIN_FRACTION * m) & (m_b > MIN_FRACTION * m)
    safe_a, safe_b = np.where(shared, m_a, 1.0), np.where(shared, m_b, 1.0)
    u = p_a / safe_a[:, None] - (p - p_a) / safe_b[:, None]
    ln = np.linalg.norm(n, axis=1)
    has_n = ln > 0.0
    nh = n / np.where(has_n, ln, 1.0)[:, None]
    un = np.einsum("ij,ij->i", u, nh)
    ut = u - un[:, None] * nh
    lt = np.linalg.norm(ut, axis=1)
    slide = lt > mu * un
    t_part = np.where(slide[:, None], (mu * un / np.where(lt > 0, lt, 1.0))[:, None] * ut, ut)
    q = np.where(((un > 0) & has_n)[:, None], un[:, None] * nh + t_part, 0.0)
    u2 = np.where(shared[:, None], u - q, 0.0)
    return (m_b / m)[:, None] * u2, -(m_a / m)[:, None] * u2


def ground_mirror(m_b: np.ndarray, tops=()) -> np.ndarray:
    """B's node masses as the normal sees them (``gasp_core.mpm.fields.GROUND_MIRROR``): at a node layer ``k <= top`` of a ground
    whose top node layer is ``top`` (the plane on that layer: ``gasp_core.mpm.grid_origin``), ``m_B`` plus the mass
    at layer ``2 top - k`` (the mirror image of B's mass above the plane; on the top layer itself, twice it).
    ``m_b`` shape (n, n, n), kg, z the last axis; ``tops`` the grounds' top node layers (ints). Returns a new array
    of the same shape. Without it the middle layer of a support 2 cells thick on the ground sees B's mass equal above
    and below (``docs/contact.md`` "Round 41")."""
    out = np.array(m_b, dtype=float)
    n = out.shape[2]
    for top in tops:
        for k in range(max(0, 2 * top - n + 1), min(top, n - 1) + 1):
            out[:, :, k] += m_b[:, :, 2 * top - k]
    return out


def mass_normals(m: np.ndarray, m_a: np.ndarray, dx: float, tops=()) -> np.ndarray:
    """The NumPy reference of the normals: ``grad m_B`` (field B's surface normal, into B) by central differences of
    the node masses (shape (n, n, n) each, kg) at the inner nodes, B's mass seen through :func:`ground_mirror` of the
    grounds' top node layers ``tops`` (none: the nodes' own); shape (n, n, n, 3), kg/m, zero on the grid's outer
    layer."""
    d = ground_mirror(m - m_a, tops)
    out = np.zeros(m.shape + (3,))
    for ax in range(3):
        sl_c, sl_p, sl_m = [slice(1, -1)] * 3, [slice(1, -1)] * 3, [slice(1, -1)] * 3
        sl_p[ax], sl_m[ax] = slice(2, None), slice(None, -2)
        out[tuple(sl_c) + (ax,)] = (d[tuple(sl_p)] - d[tuple(sl_m)]) / (2.0 * dx)
    return out


@functools.cache
def flow_touch_level(delta: float = FLOW_TOUCH_DELTA) -> float:
    """Field B's volume fraction ``phi_B(x) = sum_i w_i(x) V_B(i) / dx^3`` (P2G's volume scatter gathered back with the
    quadratic B-spline) at ``delta`` cells outside a flat face of a filled body, averaged over the face's place in its
    cell (eight offsets; 0.366 at 0.25 cells, from 0.347 to 0.385 with the offset; 0.5 on the face): a point of A
    where ``phi_B`` reaches it lies within ``delta`` cells of B's surface. Dimensionless."""
    def w(r):
        r = np.abs(r)
        return np.where(r < 0.5, 0.75 - r ** 2, np.where(r < 1.5, 0.5 * (1.5 - r) ** 2, 0.0))
    ys = np.linspace(-2.0, 2.0, 8001)
    ks = np.arange(-4, 5)
    out = []
    for s in np.arange(8) / 8.0:   # B fills y < s; V_B(k) / dx^3 the kernel's integral over it
        vf = np.array([np.trapezoid(w(ys) * (ys + k < s), ys) for k in ks])
        out.append(float(w(s + delta - ks) @ vf))
    return float(np.mean(out))


def combine_friction(mu_a: float, mu_b: float) -> float:
    """A pair's Coulomb coefficient from its two bodies': the geometric mean ``sqrt(mu_a mu_b)``, Bullet's rule
    (``btManifoldResult::calculateCombinedFriction``, the friction counterpart of the product that
    ``gasp_core.mpm.restitution.combine`` takes from ``calculateCombinedRestitution``; Bullet clamps it to 10).
    Chosen as the restitution rule is: a body on a body of the same material keeps its own coefficient (an average
    does too), and a frictionless body (0) slides on anything (an average would not: ice on rubber would take half
    rubber's coefficient). Other engines average or take the larger; ``docs/rigid.md`` "A block on a block" compares
    the rules."""
    return min(math.sqrt(max(float(mu_a), 0.0) * max(float(mu_b), 0.0)), 10.0)
