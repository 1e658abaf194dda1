"""The NumPy references of a rigid body's contact with a plane (``docs/rigid.md``), beside
:mod:`gasp_core.mpm.rigid`: :func:`settle_projection` (the position-level non-penetration of a resting body,
issue 53) and :func:`coulomb_friction` (its friction decided by force balance, issue 67), transcribed by both MPM
plugins' kernels.
"""
from __future__ import annotations

import math

import numpy as np

#: The patch's radius of curvature over the mass centre's height above it (``contact_flatness``) at which the normal
#: contact starts to hold the friction's tipping moment (as a face) and holds all of it, J a. A ball's cap reads 0.9-1.3
#: (a sphere rolls on it: the radius of curvature is its height), the 6 x 6 x 2 cell block's face about 1,500 (issue
#: 67, ``docs/rigid.md`` "Rolling").
FLAT_FROM, FLAT_TO = 2.0, 4.0
#: Round 85: the normal impulses' own moment about the mass centre counts toward what the contact holds. A face holds
#: the friction's tipping moment up to ``J a`` in all (its centre of pressure moves at most to the patch's edge); where
#: the normal impulses already lean to the downhill edge (the body has started to turn onto it), their moment is
#: part of that hold, and only the rest of ``J a`` is held by the rule. Before, the rule held ``J a`` on top of the
#: normal impulses' own moment: a rigid tall block stood 3-4 degrees past ``atan(w / h)`` and crept instead of tipping
#: (``tests/test_rigid_tip.py``). False: the rule before (the catch).
TIP_SHARED = True


def contact_flatness(s3: float, deep: float, h: float) -> float:
    """How much of a face a rigid body's contact patch is, in [0, 1]: 0 on a rounded body (it rolls), 1 on a face
    (its tipping moment held, :func:`coulomb_friction`).

    A rounded body of radius of curvature ``rho`` pressed ``deep`` into a plane touches on a cap of half-width ``a``,
    ``a^2 = 2 rho deep``, whose impulses (its depths) spread along a line in it with variance ``a^2 / 6 = rho deep /
    3`` (``a^2 / 5`` on a cylinder's strip), so ``rho = s3 / deep``, ``s3`` three times that variance. A body turns
    on the cap without changing it when ``rho`` is its mass centre's height ``h`` over the contact (a ball, a
    cylinder on its side: rolling, which no normal force resists); a face (``rho`` infinite) holds the friction's
    moment by moving its centre of pressure. The fraction ``(rho / h - FLAT_FROM) / (FLAT_TO - FLAT_FROM)``, clipped:
    a ball's cap measured ``rho / h`` 0.9-1.3, a block's face about 1,500.

    Parameters
    ----------
    s3 : float
        Three times the normal impulses' variance along the slip, m^2.
    deep : float
        The deepest touching point's penetration, m (0: unknown, the patch taken for a face).
    h : float
        The mass centre's height over the contact, m.

    Returns
    -------
    float
    """
    if deep <= 0.0 or h <= 0.0:
        return 1.0
    return min(max((s3 / (deep * h) - FLAT_FROM) / (FLAT_TO - FLAT_FROM), 0.0), 1.0)


def settle_projection(depth: float, n, x_c, c, V, w, inertia, M: float, mu: float, slop: float):
    """The position-level non-penetration of a resting rigid body against one plane (issue 53, the NumPy reference
    of each grid plugin's ``rigid_lift``): after its velocity update, a body whose deepest contact point is
    ``depth`` (m) into a support of normal ``n`` is moved out along ``n`` by ``depth - slop`` (``slop`` =
    :data:`gasp_core.mpm.rigid.RIGID_SLOP` cells), its velocity untouched by the move (Bullet's split impulse: the position error is
    not turned into speed, Catto 2006 / Coumans, "Bullet 2.x physics SDK manual", "split impulse"; no Baumgarte
    term). The centre's approach along ``n`` is then removed by an impulse through the centre (the inelastic velocity
    constraint of a sequential-impulse solver; the penalty alone left the body that deep; through the centre, as an
    impulse at ``x_c``, the penetration-weighted centre of a few lattice points, set a resting ball rolling 0.2 mm/s),
    and Coulomb's friction of that impulse (at most ``mu`` times it, never reversing the slip) applied at ``x_c``.

    The engines (each grid plugin's ``rigid_depth`` and ``rigid_lift``, after the rigid update of every substep, per
    plane of the particle contact) apply it to a body with the restitution law (``gasp_core.mpm.restitution``)
    that is not bouncing: ``e`` (the body's times the plane's) times its approach speed (its ongoing contact's
    ``v_in``, or its centre's ``-V . n`` now) under the rest speed; a bounce keeps its hysteresis and lift-off.
    Issue 53 measured what held a body at depth: a fill-only slab put 0.2 dx in the ground stayed there because the
    particle contact took its start clearance (0.05 dx) as its skin (:func:`rigid_contact` now gives a fill alone
    half a spacing wherever it is put, and :func:`lift_setup` lifts it out); the wooden donut's lowest Gaussian
    rested 0.46-0.59 dx deep because 5-13 hanging Gaussians held its weight at the stiffness of its 487 face points
    (:func:`gasp_core.mpm.rigid.support_scale`).

    Parameters
    ----------
    depth : float
        The deepest point's penetration ``offset + skin - n . x``, m.
    n : array_like, shape (3,)
        The support's unit normal.
    x_c, c : array_like, shape (3,)
        The contact centre and the body's mass centre before the move, m.
    V, w : array_like, shape (3,)
        Velocity (m/s) and spin (rad/s).
    inertia : array_like, shape (3, 3)
        The body's inertia at its pose, kg m^2.
    M, mu, slop : float
        Mass (kg), the support's friction, the allowance (m).

    Returns
    -------
    shift : ndarray, shape (3,)
        The move of the centre, m (zero when ``depth <= slop``).
    V, w : ndarray, shape (3,)
        After the approach is removed (unchanged when nothing approaches or ``depth <= slop``).
    """
    n, x_c, c, V, w = (np.asarray(a, np.float64) for a in (n, x_c, c, V, w))
    if depth <= slop:
        return np.zeros(3), V, w
    inv = np.linalg.inv(np.asarray(inertia, np.float64))
    r = x_c - c
    u_n = float(np.dot(V, n))
    if u_n < 0.0:
        P = -u_n * M
        V = V - u_n * n
        u = V + np.cross(w, r)
        ut = u - np.dot(u, n) * n
        lt = float(np.linalg.norm(ut))
        if lt > 0.0 and mu > 0.0:
            t = ut / lt
            rt = np.cross(r, t)
            Pt = -min(mu * P, lt / (1.0 / M + rt @ inv @ rt)) * t
            V = V + Pt / M
            w = w + inv @ np.cross(r, Pt)
    return (depth - slop) * n, V, w


def coulomb_friction(V, w, inertia, M: float, c, n, x_f, v_sup, budget: float, J: float, spread: np.ndarray,
                     deep: float = 0.0, x_j=None):
    """Coulomb's friction on a rigid body as one, decided by force balance (issue 67; the NumPy reference of each grid
    plugin's ``slide_brake``): the substep's one tangential impulse at the contact point.

    ``(V, w)`` hold the substep's gravity and normal contact impulses, so the impulse ``P = -p t`` (``t`` the direction
    of the tangential velocity ``u_t`` of ``V + w x (x_f - c) - v_sup``) that stops ``u_t`` is the impulse the body
    needs to stay: within the budget ``mu J`` it sticks (``p`` that impulse), else it slides at the kinetic rate
    (``p`` the budget). Not a speed threshold: a body at any speed sticks when Coulomb's cone holds what it needs.

    The impulse's moment about the mass centre ``r x P`` (``r = x_f - c``) has a part about the normal (a twist) and
    a part that would tip the body; the normal contact takes that one back up to ``J a`` (a torque impulse, N m s),
    ``a = sqrt(3 t.S t)`` the half-width along ``t`` of a uniform patch of the normal impulses' covariance ``S``
    (``spread``, m^2): the statics of a block, whose centre of pressure moves within its face to hold the friction's
    tipping moment; ``a`` times :func:`contact_flatness`, 0 on a rounded body's cap (issue 67: the cap a ball's
    penetration makes, a few mm across, held the moment as a face and slowed its rolling by 23 %). A block on its face
    so slides as a particle (effective mass ``M``: ``a = g (sin theta - mu cos theta)`` on a slope), and a ball (``a``
    0) takes the impulse through its effective mass at the
    contact, ``1 / (1/M + (r x t) . I^-1 (r x t))``: it rolls (``a = g sin theta / (1 + I / (M R^2))``, 5/7 of
    ``g sin theta`` for a solid ball) while ``p`` is within the budget, and slips beyond it. The impulse through the
    full effective mass on a face (the slide brake of issue 53) left the block a spin that its normal contact then
    took back without the speed that came with it: a creep of 1.05 mm/s on a 15 degree slope at mu 0.4.

    Parameters
    ----------
    V, w : array_like, shape (3,)
        Velocity (m/s) and spin (rad/s) before the friction.
    inertia : array_like, shape (3, 3)
        The body's inertia at its pose, kg m^2.
    M : float
        Mass, kg.
    c, x_f : array_like, shape (3,)
        The mass centre and the contact point (the friction budget's centre), m.
    n : array_like, shape (3,)
        The contact's unit normal.
    v_sup : array_like, shape (3,)
        The supports' velocity at the contact, m/s.
    budget, J : float
        ``sum mu j`` and ``sum j`` of the substep's normal impulses, kg m/s.
    spread : array_like, shape (3, 3)
        The normal impulses' covariance about their centre, m^2.
    deep : float
        The deepest touching point's penetration, m; with ``x_j`` (the normal impulses' centre, m) the patch's
        :func:`contact_flatness` scales ``a`` (a rounded body holds no tipping moment: it rolls; issue 67). 0: a face.
        ``x_j`` also gives the normal impulses' own moment about ``c``, which counts toward ``J a`` (:data:`TIP_SHARED`).

    Returns
    -------
    V, w : ndarray, shape (3,)
    """
    V, w, c, n, x_f, v_sup = (np.asarray(a, np.float64) for a in (V, w, c, n, x_f, v_sup))
    inv = np.linalg.inv(np.asarray(inertia, np.float64))
    r = x_f - c
    u = V + np.cross(w, r) - v_sup
    ut = u - np.dot(u, n) * n
    lt = float(np.linalg.norm(ut))
    if budget <= 0.0 or lt <= 0.0:
        return V, w
    t = ut / lt
    rt = np.cross(r, t)
    rh = rt - np.dot(rt, n) * n                      # the tipping part of the moment arm
    k_a = 1.0 / M + rt @ inv @ rt                    # free to turn: 1 / the effective mass at x_f along t
    m = rt @ inv @ rh
    k_b = max(k_a - m, 1.0 / M)                      # its tipping moment held by the normal contact
    s3 = max(3.0 * float(t @ np.asarray(spread, np.float64) @ t), 0.0)
    h = abs(float(np.dot(np.asarray(x_f if x_j is None else x_j, np.float64) - c, n)))
    a = math.sqrt(s3) * contact_flatness(s3, deep, h)
    lh = float(np.linalg.norm(rh))
    hold = J * a   # the tipping moment the contact holds in all, less what its normal impulses already hold
    if TIP_SHARED and x_j is not None and lh > 0.0:
        hold = max(hold - max(J * float(np.dot(np.cross(np.asarray(x_j, np.float64) - c, n), rh)) / lh, 0.0), 0.0)
    p_hold = hold / lh if lh > 0.0 else math.inf   # the impulse whose tipping moment the contact can hold
    p = lt / k_b if p_hold * k_b >= lt else (lt + p_hold * m) / k_a
    p = min(p, budget)
    held = min(p, p_hold)
    return V - (p / M) * t, w + inv @ (-p * rt + held * rh)


def allowed_approach(gap: float, un: float, dt: float) -> float:
    """Round 91's speculative contact (Catto, "Contact manifolds" and speculative contacts, GDC 2013; Box2D's
    ``b2_speculativeDistance``): the approach speed ``u_n`` (m/s, > 0 approaching) a pair of rigid bodies may keep
    over a substep of ``dt`` (s) whose centres were ``gap`` (m) apart along the normal after its advance: ``max(gap /
    dt + u_n, 0)``, so that they close the gap they had at the step's start and no more; 0 where no gap is known
    (``gap`` -1e30: every approach removed, the law before). The touching nodes find a pair up to a third of a cell
    before its surfaces meet: without it, two balls in an oblique frictionless impact met 4.4 mm early and the struck
    one left 1.4 degrees off the line of centres (``docs/rigid.md`` "Round 91").

    Returns
    -------
    float
        m/s, >= 0.
    """
    return max(gap / dt + un, 0.0) if gap > -1.0e29 else 0.0


def pair_contact(A, B, x_c, n, mu: float, flat=1.0, plane=None, allow: float = 0.0, arms=None):
    """The contact of two rigid bodies as one, by force balance (issue 67 item 4; the NumPy reference of each grid
    plugin's ``pair_contact``): the substep's normal impulse, then Coulomb's friction of it, both equal and opposite.

    The two bodies meet through the two-field contact's nodes (:func:`gasp_core.mpm.fields.rigid_pair`), which
    here only find where they touch: ``x_c`` the touching nodes' centre and ``n`` their mean normal (field B's mass
    gradient, from A into B), each node weighted by its reduced mass ``m_A m_B / m`` (the nodes' own correction held
    a block on a block as a soft spring, ``docs/rigid.md``). Here, after both bodies' projection:

    * **normal**: the approach of the two mass centres along ``n``, ``u_n = (V_A - V_B) . n``, is removed by the
      impulse ``P = u_n / (1/M_A + 1/M_B)`` through the centres (none when they separate): the inelastic contact of a
      sequential-impulse solver, through the centres as ``settle_projection`` puts its resting impulse (a face holds
      its moment by moving its centre of pressure);
    * **friction**: the tangential velocity ``u_t`` of A's point ``x_c`` relative to B's takes the impulse that stops
      it, ``|u_t| / k`` with ``k = 1/M_A + 1/M_B + sum (r x t . n)^2 / (n . I n)`` (each body free to twist about
      ``n``, as ``twist_brake`` turns it; its tipping moment held by the contact, as :func:`coulomb_friction` holds
      a face's), when that is within
      ``mu P`` (they stick), else ``mu P`` against it (they slide at the kinetic rate). No speed threshold.
    * **rolling** (round 65): the friction's tipping moment (``r x t`` across ``n``) is held only as far as the
      contact is a face on a face: the pair's flatness ``f`` (``rigid_support.pair_flatness``: 0 when either body is
      round there) leaves ``(1 - f)`` of it to turn each body through its full inverse inertia, and ``k`` takes the
      same ``(1 - f)`` terms (the effective mass at the contact point): a ball thrown sliding on a block spins up and
      rolls, on its surface (``plane``). ``f`` 1 adds exact zeros (a block on a block bit for bit as before).

    Parameters
    ----------
    A, B : tuple
        Each body's ``(V, w, inertia, M, c)``: velocity (m/s, shape (3,)), spin (rad/s, (3,)), inertia at its pose
        (kg m^2, (3, 3)), mass (kg), mass centre (m, (3,)); A the body of field A.
    x_c, n : array_like, shape (3,)
        The contact's centre (m) and unit normal, from A into B.
    mu : float
        The pair's coefficient (:func:`gasp_core.mpm.fields.field_friction`).
    flat : float or callable
        The pair's flatness in [0, 1], or a function of the unit slip ``t`` (shape (3,)) giving it
        (``rigid_support.pair_flatness``); 1: a face on a face (the law before round 65).
    plane : float or None
        Where the bodies' surfaces meet, ``n . x`` (m; ``rigid_support.contact_plane``): with ``f < 1`` the contact
        point is moved along ``n`` onto it (the lever of a rolling body's friction reaches its surface) and the slip
        taken there. None: at ``x_c``.
    allow : float
        Round 91: the approach kept, m/s (:func:`allowed_approach`; 0: all removed).
    arms : tuple or None
        Round 94 (``gasp_core.mpm.rigid_fit.side_foot``): ``(arm_A, arm_B)``, m, world, where a cylinder's side bears
        on a fitted surface: the normal impulse acts at its foot (the approach and the effective mass taken there,
        its moment turning the cylinder), ``x_c`` is moved along the axis onto it, and the contact is a point there:
        the flatness ``f`` is 0 (no tipping moment held; the foot's moment holds what the point can). None: through
        the centres.

    Returns
    -------
    (V_A, w_A), (V_B, w_B), P : ndarray pairs and float
        The bodies' velocities and spins after the contact, and the normal impulse on B (kg m/s, >= 0).

    It is long because this docstring states the whole law the engines follow; the body is 40 lines.
    """
    from gasp_core.mpm.rigid_fit import FOOT_POINT, foot_approach, foot_mass, foot_point
    (VA, wA, IA, MA, cA), (VB, wB, IB, MB, cB) = A, B
    VA, wA, cA, VB, wB, cB, x_c, n = (np.asarray(a, np.float64) for a in (VA, wA, cA, VB, wB, cB, x_c, n))
    nIA, nIB = float(n @ np.asarray(IA, np.float64) @ n), float(n @ np.asarray(IB, np.float64) @ n)
    iA0, iB0 = np.linalg.inv(np.asarray(IA, np.float64)), np.linalg.inv(np.asarray(IB, np.float64))
    un, arm_a, arm_b = foot_approach(VA, wA, VB, wB, arms, n)
    un -= allow
    P = un / foot_mass(MA, MB, iA0, iB0, arm_a, arm_b, n) if un > 0.0 else 0.0
    VA, VB = VA - (P / MA) * n, VB + (P / MB) * n
    wA, wB = wA - P * (iA0 @ np.cross(arm_a, n)), wB + P * (iB0 @ np.cross(arm_b, n))
    x_c = foot_point(x_c, cA, cB, arm_a, arm_b)   # round 94: the contact point on the foot
    rA, rB = x_c - cA, x_c - cB
    u = VA + np.cross(wA, rA) - VB - np.cross(wB, rB)
    ut = u - np.dot(u, n) * n
    lt = float(np.linalg.norm(ut))
    if P <= 0.0 or mu <= 0.0 or lt <= 0.0:
        return (VA, wA), (VB, wB), P
    t = ut / lt
    f = 0.0 if arms is not None and FOOT_POINT else float(flat(t)) if callable(flat) else float(flat)
    if f < 1.0 and plane is not None:   # a round body rolls on its surface: the contact point moved onto it
        x_c = x_c + (plane - float(np.dot(x_c, n))) * n
        rA, rB = x_c - cA, x_c - cB
        u = VA + np.cross(wA, rA) - VB - np.cross(wB, rB)
        ut = u - np.dot(u, n) * n
        lt = float(np.linalg.norm(ut))
        if lt <= 0.0:
            return (VA, wA), (VB, wB), P
        t = ut / lt
    sA, sB = float(np.dot(np.cross(rA, t), n)), float(np.dot(np.cross(rB, t), n))   # the twist arms about n
    tA, tB = np.cross(rA, t), np.cross(rB, t)
    gA = (1.0 - f) * (np.linalg.inv(np.asarray(IA, np.float64)) @ (tA - sA * n))   # the tipping part let turn
    gB = (1.0 - f) * (np.linalg.inv(np.asarray(IB, np.float64)) @ (tB - sB * n))
    k = 1.0 / MA + 1.0 / MB + sA * sA / nIA + sB * sB / nIB + (float(gA @ tA) + float(gB @ tB))
    p = min(lt / k, mu * P)
    return ((VA - (p / MA) * t, wA - (p * sA / nIA) * n - p * gA),
            (VB + (p / MB) * t, wB + (p * sB / nIB) * n + p * gB), P)
