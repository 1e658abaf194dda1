"""The particle contact's impulses and friction in NumPy (split from ``gasp_core.mpm.contact``, round 58): the
reference the grid engine plugins' kernels implement step for step (:func:`plane_impulse`, :func:`surface_impulse`,
:func:`node_friction`; ``docs/contact.md``). Re-exported by ``gasp_core.mpm.contact``.
"""
from __future__ import annotations

import numpy as np


def plane_impulse(z: np.ndarray, v_z: np.ndarray, coeffs: np.ndarray, height: float, mu: float,
                  dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Normal impulse and friction budget of each point from one ground plane over a substep (the kernels' reference).

    Parameters
    ----------
    z, v_z : ndarray, shape (n,)
        Point heights (m) and vertical velocities (m/s).
    coeffs : ndarray, shape (n, 3)
        ``gasp_core.mpm.contact.contact_coefficients``.
    height, mu : float
        The plane's height (m) and Coulomb friction coefficient.
    dt : float
        Substep, s.

    Returns
    -------
    j_n : ndarray, shape (n,)
        ``max(0, dt (k_p depth - c_p v_z))`` where ``depth = height + s_p - z > 0``, else 0 (kg m/s, along +z).
    budget : ndarray, shape (n,)
        ``mu j_n``: what the point gives its nodes' friction budgets (scattered with its weights).
    """
    k, c, s = coeffs[:, 0], coeffs[:, 1], coeffs[:, 2]
    depth = height + s - z
    jn = np.where(depth > 0.0, np.maximum(0.0, dt * (k * depth - c * v_z)), 0.0)
    return jn, mu * jn


def surface_impulse(phi: np.ndarray, n: np.ndarray, v: np.ndarray, v_col: np.ndarray, coeffs: np.ndarray,
                    mu: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Normal impulse and friction budget of each point from one ``[[collider]]`` over a substep (the kernels'
    reference; :func:`plane_impulse` is its case ``phi = z - height``, ``n = +z``, ``v_col = 0``).

    Parameters
    ----------
    phi : ndarray, shape (n,)
        The collider's signed distance at the points (m, negative inside; the trilinear lookup of its field in its
        pose of the substep, as the grid rule's).
    n : ndarray, shape (n, 3)
        Its unit outward normal there (the field's gradient, normalised, turned by the pose).
    v, v_col : ndarray, shape (n, 3)
        The points' velocities and the collider's at the points (``v + w x (x - T)``), m/s.
    coeffs : ndarray, shape (n, 3)
        ``gasp_core.mpm.contact.contact_coefficients``.
    mu, dt : float
        The collider's friction and the substep (s).

    Returns
    -------
    j_n : ndarray, shape (n,)
        ``max(0, dt (k_p depth - c_p (v - v_col) . n))`` where ``depth = s_p - phi > 0``, else 0 (kg m/s, along
        ``n``).
    budget : ndarray, shape (n,)
        ``mu j_n``.
    """
    k, c, s = coeffs[:, 0], coeffs[:, 1], coeffs[:, 2]
    depth = s - phi
    vn = np.einsum("ij,ij->i", np.asarray(v, float) - np.asarray(v_col, float), n)
    jn = np.where(depth > 0.0, np.maximum(0.0, dt * (k * depth - c * vn)), 0.0)
    return jn, mu * jn


def node_friction(v: np.ndarray, m: np.ndarray, budget: np.ndarray) -> np.ndarray:
    """Node velocities (m/s, shape (n, 3)) after the particle contact's Coulomb friction: the tangential
    (x, y) part loses ``min(budget / m, |v_t|)`` (``m`` node mass, kg; ``budget`` kg m/s, shape (n,))."""
    vt = np.array(v, dtype=np.float64)
    vt[:, 2] = 0.0
    lt = np.linalg.norm(vt, axis=1)
    cut = np.where((budget > 0.0) & (lt > 0.0), np.minimum(budget / np.maximum(m, 1e-300), lt) / np.maximum(lt, 1e-300), 0.0)
    return v - cut[:, None] * vt
