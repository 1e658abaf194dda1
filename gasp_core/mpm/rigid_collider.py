"""Round 63 (issue 67 item 4, ``docs/rigid.md`` "Round 63: the rigid body as a moving collider of the soft field"):
a rigid body beside a soft one (:func:`gasp_core.mpm.fields.mixed_pair`) meets it as a moving collider of the soft
field, two-way by impulses on the body's momentum, instead of round 29's node-mean exchange between the two fields.

Per substep, with :data:`RIGID_COLLIDER` on:

1. After P2G, at every node the two fields share (off the grounds' and walls' node layers), each field keeps its own
   velocity (no exchange: the rigid field's nodes never see the soft body's stress or approach). Where the first
   pass's test finds a contact node (both fields' mass, the touch, a mass gradient), the node is marked and the rigid
   field's outward normal kept: ``n = -grad m_R / |grad m_R|`` (``m_R`` the rigid field's node mass; central
   differences).
2. After the grid update (gravity, the particle contact's impulses, the boundaries), the body's velocity this substep
   ``V* = sum_i m_R v_R / sum_i m_R`` over the rigid field's nodes (what its points' G2P and the projection would give
   it: its update and its ground contact of this substep); its spin ``w`` and centre ``c`` from its state.
3. At each marked node, :func:`collide` of the soft field's velocity against the body's ``v_b = V* + w x (x_i - c)``:
   the approach along ``n`` removed (separation allowed), Coulomb's friction at most ``mu`` times that normal change
   (the node's own, not its gravity), as a ground's node contact. The soft field's node takes ``dv``; the body takes
   ``J_i = -m_S dv`` into the sums of its next projection (``acc_p += J_i``, ``acc_l += x_i x J_i``: its momentum and
   angular momentum about the origin), summed over the nodes in float64 atomics.

The rigid field's own nodes are left as they are; G2P gives the body its velocity, the reaction joins it in the
projection's sums (as ``rigid_hold``'s hold does). No constant but the pair's ``mu``.
"""
from __future__ import annotations

import numpy as np

#: Round 63: True runs the collider rule for a mixed pair (module notes); False: round 29's node-mean exchange (the
#: rule before: a jelly on a rigid slab sank -1.0 dx in 0.7 s, a rigid block on jelly -0.17 dx).
RIGID_COLLIDER = False


def collider_on(setup) -> bool:
    """Whether a setup runs the collider rule: :data:`RIGID_COLLIDER` and a rigid body beside a soft one on the
    particle contact with two fields (:func:`gasp_core.mpm.fields.mixed_pair`)."""
    from gasp_core.mpm.fields import mixed_pair, uses_fields
    return bool(RIGID_COLLIDER) and mixed_pair(setup) and uses_fields(setup)


def collide(v_s: np.ndarray, v_b: np.ndarray, n: np.ndarray, mu: float) -> np.ndarray:
    """The soft node's velocity change ``dv`` (m/s, shape (..., 3)) against the body's velocity ``v_b`` there
    (shape (..., 3)), ``n`` the body's unit outward normal (shape (..., 3)), ``mu`` the pair's Coulomb coefficient:
    ``u = v_s - v_b``, ``u_n = u . n``; where ``u_n < 0`` (approach) ``dv = -u_n n - min(|u_t|, mu (-u_n)) t``
    (``u_t = u - u_n n``, ``t = u_t / |u_t|``); else 0."""
    v_s, v_b, n = (np.asarray(a, float) for a in (v_s, v_b, n))
    u = v_s - v_b
    un = np.sum(u * n, axis=-1, keepdims=True)
    ut = u - un * n
    lt = np.linalg.norm(ut, axis=-1, keepdims=True)
    slip = np.minimum(lt, mu * np.maximum(-un, 0.0)) * np.divide(ut, lt, out=np.zeros_like(ut), where=lt > 0)
    return np.where(un < 0.0, -un * n - slip, 0.0)


def body_velocity(m_r: np.ndarray, v_r: np.ndarray) -> np.ndarray:
    """``V* = sum m_R v_R / sum m_R`` (m/s, (3,)) of the rigid field's node masses (kg, (N,)) and velocities (m/s,
    (N, 3)) after the grid update."""
    m_r = np.asarray(m_r, float)
    return (m_r[:, None] * np.asarray(v_r, float)).sum(0) / max(float(m_r.sum()), 1e-300)


def reaction(m_s: np.ndarray, dv: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The body's impulse ``J = -sum m_S dv`` (kg m/s, (3,)) and its moment about the origin ``sum x_i x J_i``
    (kg m^2/s, (3,)) from the soft node masses (kg, (N,)), their changes (m/s, (N, 3)) and positions (m, (N, 3))."""
    J = -np.asarray(m_s, float)[:, None] * np.asarray(dv, float)
    return J.sum(0), np.cross(np.asarray(x, float), J).sum(0)
