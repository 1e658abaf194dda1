"""Rigid bodies among three or more bodies (round 62, issue 67 item 4 "between bodies", ``docs/rigid.md`` "Round 62:
rigid bodies among three or more"; the switch ``colouring.RIGID_PAIRS``).

**Fields.** A scene of three or more bodies on the particle contact, rigid or soft in any mix, takes round 61's
colouring (:mod:`gasp_core.mpm.colouring`): the bodies within reach of each other take different fields, so every
touching pair meets across the two fields as a pair of two bodies does. Before round 62 a scene with a rigid body
among three or more kept one field for all: its bodies stuck wherever they shared nodes.

**Which pair a node serves.** Where the two fields meet at a node, the node kernel asks which rigid body of field A
and which of field B are there (:func:`node_bodies`): the rigid body of that field whose box (its points' extent in
its own frame, :func:`body_boxes`) the node lies within :data:`NODE_PAD` cells of (Chebyshev, in the body's frame;
the nearest when several). The colouring keeps bodies of one field more than 3 cells apart, so a node that holds a
field's mass is within 1.5 cells of one body of it only. A node between two rigid bodies adds its reduced mass,
position and normal to that pair's sums (the pair law's own touch: ``fields.field_contact``'s, the two-body case's);
a node between a rigid body and a soft one (no rigid body of one field there) takes the rigid collider of that body
(round 64, ``gasp_core.mpm.rigid_collider``'s "Three or more bodies", as the two-body mixed pair does since round
63; with ``rigid_collider.MULTI`` off, the nodes' Coulomb correction, round 29's exchange).

**The pairs solved together** (:func:`solve_pairs`, the NumPy reference of each grid plugin's ``rigid_pairs``): each
touching pair takes the two-body pair law (``rigid_friction.pair_contact``: the centres' approach removed along the
contact normal, inelastic; Coulomb's friction of that impulse, stick within ``mu P`` else slide at ``mu P``), the pairs
swept :data:`SWEEPS` times in the order of their contact's height along gravity, bottom up, with accumulated impulses
(projected Gauss-Seidel, Catto, "Iterative dynamics with temporal coherence", GDC 2005, and "Fast and simple physics
using sequential impulses", GDC 2006; Box2D's ``b2ContactSolver``): a pair's total normal impulse stays >= 0 and its
total friction impulse within ``mu`` times it (the disk), so a later sweep can take back what an earlier one pushed.
Where the pair presses (``P > 0``) its faces also hold the two bodies' relative spin about the axes across ``n``
(an equal and opposite torque impulse: a face on a face does not roll; the two-body law leaves it, and a block pushed
high by an ``[[impulse]]`` rolled on the block under it at 0.17 m/s). Without a relative tipping spin one sweep of one
pair is the two-body law exactly. The solve runs once a substep after the bodies' rigid update (as
the two-body law does), on the device in one thread: ``SWEEPS x n_pairs`` pair updates of a few dozen flops for a
handful of bodies, where a host solve would stop the recorded substep for a copy each way. Since round 63 the node
kernel lists each touching pair the first time it adds to it (an atomic counter), and the solve visits, sorts (by
height, then slot: the order of round 62's scan) and clears only those, never the ``n_bodies^2`` table
(``docs/rigid.md`` "Round 63: the cost of rigid pairs").

**Islands on the GPU schedule** (round 81, :data:`ISLANDS`). Measured on an H200, the one-thread solve was 34-75 %
of the CUDA kernel time of a heap of 12-108 rigid blocks, 10x its time on one CPU core (``docs/performance.md``
"Round 81"). The GPU schedule therefore splits the listed pairs into islands (the bodies joined by touching pairs,
union-find, :func:`islands`) and sweeps each island on its own thread, its pairs in the global order. No two islands
share a body and a pair's update touches only its two bodies, so every body sees the same updates in the same order:
the same bits as the one-thread solve. The order's sort is a rank per pair (one thread a pair). A heap whose bodies all
touch is one island and gains nothing. The CPU schedule keeps the one-thread solve.

**Left out.** Bodies that an odd cycle puts in one field (three bodies touching each other) share it where they
touch (the engines warn, ``shared_fields``); the ground is not in the sweep (its contact runs before, as for one
body); no warm start across substeps (each substep starts its pairs at zero; the bottom-up order carries the weight
down in the first sweep); a body's box stands for its shape in the node's lookup (a node in a ring's hole is the
ring's).
"""
from __future__ import annotations

import numpy as np

#: The sweeps over the touching pairs each substep (projected Gauss-Seidel). ``docs/rigid.md`` "Round 62" measures
#: 1, 2, 4, 8 and 16.
SWEEPS = 8
#: A node serves a rigid body of its field when it lies within this many cells of the body's box (in the body's frame,
#: Chebyshev): the B-spline's reach, 1.5 cells.
NODE_PAD = 1.5
#: Round 81: the GPU schedules sweep each island of touching rigid bodies on its own thread (the same bits as one
#: thread over all the pairs); False: the one-thread solve on both schedules. Read when an engine is built.
ISLANDS = True


def pair_frictions(setup) -> np.ndarray:
    """Each pair's Coulomb coefficient, ``combine_friction`` of the two bodies' (shape (n_bodies * n_bodies,), the
    slot ``a * n_bodies + b`` for body ``a`` in field A and ``b`` in B)."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    mus = [body_friction(m) for m in setup.materials]
    return np.array([combine_friction(a, b) for a in mus for b in mus], np.float64)


def pair_mode(setup) -> int:
    """``gasp_core.mpm.fields.pair_mode`` (0, 1 two rigid bodies, 2 rigid bodies among three or more)."""
    from gasp_core.mpm.fields import pair_mode as mode
    return mode(setup)


def pair_data(setup) -> tuple:
    """``(body_boxes, pair_frictions, collider_data)`` of a setup, what an engine's pairs' solve reads (round 63: and
    the rigid collider's slots, ``gasp_core.mpm.rigid_collider.collider_data``, or None)."""
    from gasp_core.mpm.rigid import step_view
    from gasp_core.mpm.rigid_collider import collider_data
    rc = collider_data(setup)
    if rc is not None:
        rc["boxes"] = body_boxes(step_view(setup))
    if rc is not None:   # round 66: the round bodies' point contact (gasp_core.mpm.rigid_sdf)
        from gasp_core.mpm.rigid_sdf import POINT_CONTACT, point_data
        from gasp_core.mpm.roll_contact import on as roll_on   # round 70: the engine option roll_contact
        rc["points"] = point_data(setup, rc["bodies"]) if POINT_CONTACT or roll_on(setup) else None
    return body_boxes(setup), pair_frictions(setup), rc


#: Round 90: a round rigid body (``gasp_core.mpm.round_ground.ground_shapes``) meets another rigid body on its exact
#: shape: its support table rows are the shape's, and the pair law takes the contact on its surface, not midway between
#: the two bodies' supports (``docs/rigid.md`` "Round 90: a round body on another rigid body"). 0: round 65's tables of
#: its points and the midway plane (the broken variant the catches use; a Python switch, read at build time).
ROUND_PAIR = 1
#: Round 91: the pair's normal from the shapes (``rigid_support.pair_normal``): a pair of one round body and one that is
#: not takes the separating axis of the two supports (``rigid_support.round_normal``) within :data:`NORMAL_CONE`
#: degrees of the touching nodes' normal, two spheres their line of centres, and a sphere's pair keeps the approach
#: that only closes its gap (``rigid_friction.allowed_approach``; ``docs/rigid.md`` "Round 91: the normal of a round
#: body's contact"). 0: the nodes' normal and touch (the broken variant the catches use; read at build time, with
#: ``ROUND_PAIR``).
ROUND_NORMAL = 1
#: The search cone's half-angle, degrees: wider than the tables' Fibonacci spacing (about 13 degrees for 256
#: directions), so a row always lies inside it, and well beyond the nodes' normal's lean measured on a rolling
#: cylinder (1-2 degrees).
NORMAL_CONE = 20.0


def support_data(setup):
    """``(dirs, h, curv, delta, nd, round, cos_cone)``: every rigid body's support table (round 65,
    ``gasp_core.mpm.rigid_support.support_table``, of its points with mass; spacing ``p_vol ** (1/3)``), body ``b``'s
    rows ``b * nd`` to ``(b + 1) * nd``: directions (n, 3), supports (n,) m, curvature tensors (n, 3, 3) 1/m, the
    band per body (m; 0: no table, its contacts taken as a face's) and per body its round shape (round 90: a sphere
    or solid cylinder, ``gasp_core.mpm.round_ground.ground_shapes``; its rows are its exact shape's,
    ``rigid_support.round_table``, and the pair law takes the contact on its surface): 1.0 a sphere, 2.0 a cylinder
    (round 91), 0.0 none; ``cos_cone`` the cosine of :data:`NORMAL_CONE` (round 91: the pair's normal from the
    bodies' shapes, ``rigid_support.pair_normal``), 2.0 when :data:`ROUND_NORMAL` or :data:`ROUND_PAIR` is off (the
    nodes' normal).
    None with fewer than two rigid bodies."""
    from gasp_core.mpm.rigid import body_frames, rigid_mask
    from gasp_core.mpm.rigid_support import round_table, support_table, table_directions
    from gasp_core.mpm.round_ground import ground_shapes
    rigid = rigid_mask(setup.materials)
    if rigid.sum() < 2:
        return None
    n = len(setup.x)
    body = np.broadcast_to(np.asarray(setup.body_id), (n,))
    vol = np.broadcast_to(np.asarray(setup.p_vol, np.float64), (n,))
    mass = np.broadcast_to(np.asarray(setup.p_mass, np.float64), (n,))
    X0 = body_frames(setup.x, mass, body, rigid)[1]
    nb, nd = len(rigid), len(table_directions(np.zeros((1, 3))))
    dirs, h, curv, delta = np.zeros((nb * nd, 3)), np.ones(nb * nd), np.zeros((nb * nd, 3, 3)), np.zeros(nb)
    shapes, rnd = ground_shapes(setup), np.zeros(nb)
    for b in np.flatnonzero(rigid):
        sel = (body == b) & (mass > 0.0)
        if sel.any():
            D, H, C, delta[b] = support_table(X0[sel], float(np.mean(vol[sel])) ** (1.0 / 3.0))
            if ROUND_PAIR and shapes[b, 0] > 0.0:   # round 90: a sphere or cylinder on its exact shape
                H, C = round_table(D, shapes[b])
                rnd[b] = 1.0 if shapes[b, 1] <= 0.0 else 2.0   # round 91: 1 a sphere, 2 a cylinder
            rows = slice(b * nd, (b + 1) * nd)
            dirs[rows], h[rows], curv[rows] = D, H, C[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3)
    cos_cone = float(np.cos(np.radians(NORMAL_CONE))) if ROUND_PAIR and ROUND_NORMAL else 2.0
    return dirs, h, curv, delta, nd, rnd, cos_cone


def body_boxes(setup) -> np.ndarray:
    """Each rigid body's box in its frame at the start: its material points' extent about its mass centre (m), shape
    (n_bodies, 2, 3) (lower, upper; an empty box, lower > upper, for the others)."""
    from gasp_core.mpm.rigid import rigid_mask
    x, m = np.asarray(setup.x, np.float64), np.asarray(setup.p_mass, np.float64)
    body, vol = np.asarray(setup.body_id), np.broadcast_to(np.asarray(setup.p_vol, np.float64), m.shape)
    out = np.zeros((len(setup.materials), 2, 3))
    out[:, 0], out[:, 1] = 1.0, -1.0
    for b in np.flatnonzero(rigid_mask(setup.materials)):
        sel = (body == b) & (vol > 0.0)
        if sel.any() and m[sel].sum() > 0.0:
            r = x[sel] - (m[sel, None] * x[sel]).sum(0) / m[sel].sum()
            out[b] = r.min(0), r.max(0)
    return out


def node_bodies(xn, in_a, rigid, centre, rot, boxes, pad: float):
    """``(a, b)``: the rigid body of field A and of field B a node at ``xn`` (m, (3,)) serves, -1 where none (the
    module notes): per field the rigid body whose box (``boxes`` (n, 2, 3), :func:`body_boxes`) the node lies within
    ``pad`` (m) of in its frame (``centre`` (n, 3), ``rot`` (n, 3, 3)), Chebyshev; the nearest when several."""
    best = [(-1, np.inf), (-1, np.inf)]
    for k in np.flatnonzero(np.asarray(rigid, bool)):
        q = np.asarray(rot[k]).T @ (np.asarray(xn, float) - centre[k])
        d = float(np.max(np.maximum(np.maximum(boxes[k, 0] - q, q - boxes[k, 1]), 0.0)))
        f = 0 if in_a[k] else 1
        if d <= pad and d < best[f][1]:
            best[f] = (int(k), d)
    return best[0][0], best[1][0]


def _pair_update(A, B, x_c, n, mu, lam, flat=1.0, plane=None, allow=0.0, arms=None):
    """One pair's update within a sweep (:func:`solve_pairs`): ``A``, ``B`` lists ``[V, w, I, M, c]`` changed in place;
    ``lam`` ``[P, J (3,)]``, the pair's accumulated normal impulse (kg m/s) and friction impulse on B, changed.
    Round 65: ``flat`` and ``plane`` as ``rigid_friction.pair_contact``'s (the flatness along the slip, or along the
    bodies' relative rolling where they do not slip): ``(1 - f)`` of the friction's tipping moment turns the bodies,
    and the faces hold ``f`` of their relative tipping spin (a ball rolls on a block; a block on a block as before).
    Round 91: ``allow`` the approach speed the pair may keep (m/s, ``rigid_friction.allowed_approach``). Round 94:
    ``arms`` as ``rigid_friction.pair_contact``'s (the normal impulse at a cylinder's foot, ``x_c`` moved onto it, the
    flatness 0: a point there)."""
    from gasp_core.mpm.rigid_fit import FOOT_POINT, foot_approach, foot_mass, foot_point
    VA, wA, IA, MA, cA = A
    VB, wB, IB, MB, cB = B
    iA, iB = np.linalg.inv(IA), np.linalg.inv(IB)
    un, arm_a, arm_b = foot_approach(VA, wA, VB, wB, arms, n)
    P = max(lam[0] + (un - allow) / foot_mass(MA, MB, iA, iB, arm_a, arm_b, n), 0.0)
    dP, lam[0] = P - lam[0], P
    A[0], B[0] = VA - (dP / MA) * n, VB + (dP / MB) * n
    A[1], B[1] = wA - dP * (iA @ np.cross(arm_a, n)), wB + dP * (iB @ np.cross(arm_b, n))
    wA, wB = A[1], B[1]
    x_c = foot_point(x_c, cA, cB, arm_a, arm_b)   # round 94: the contact point on the foot
    rA, rB = x_c - cA, x_c - cB
    u = A[0] + np.cross(wA, rA) - B[0] - np.cross(wB, rB)
    ut = u - np.dot(u, n) * n
    lt = float(np.linalg.norm(ut))
    f = 0.0 if arms is not None and FOOT_POINT else _roll_flatness(flat, ut, lt, wA - wB, n)   # round 94: a point at the foot
    if f < 1.0 and plane is not None:   # a round body rolls on its surface: the contact point moved onto it
        x_c = x_c + (plane - float(np.dot(x_c, n))) * n
        rA, rB = x_c - cA, x_c - cB
        u = A[0] + np.cross(wA, rA) - B[0] - np.cross(wB, rB)
        ut = u - np.dot(u, n) * n
        lt = float(np.linalg.norm(ut))
    J = lam[1].copy()
    if mu > 0.0 and lt > 0.0 and P > 0.0:   # the impulse that stops the slip, added to the pair's
        t = ut / lt
        sA, sB = float(np.dot(np.cross(rA, t), n)), float(np.dot(np.cross(rB, t), n))   # the twist arms about n
        k = 1.0 / MA + 1.0 / MB + sA * sA / float(n @ IA @ n) + sB * sB / float(n @ IB @ n)
        if f < 1.0:   # (1 - f) of the tipping moment turns each body: in the effective mass
            tA, tB = np.cross(rA, t), np.cross(rB, t)
            k = k + (1.0 - f) * (float(tA @ iA @ (tA - np.dot(tA, n) * n)) + float(tB @ iB @ (tB - np.dot(tB, n) * n)))

        J = J + (lt / k) * t
    lJ = float(np.linalg.norm(J))
    if lJ > mu * P:   # within Coulomb's disk of the pair's normal impulse: stick, else slide at mu P
        J = J * (max(mu, 0.0) * P / lJ)
    _friction(A, B, rA, rB, n, J - lam[1])
    if f < 1.0:
        hA, hB = np.cross(rA, J - lam[1]), np.cross(rB, J - lam[1])
        A[1] = A[1] - (1.0 - f) * (iA @ (hA - np.dot(hA, n) * n))
        B[1] = B[1] + (1.0 - f) * (iB @ (hB - np.dot(hB, n) * n))
    lam[1] = J
    if P > 0.0:   # the faces hold the relative tipping spin (about the axes across n): an equal and opposite torque
        dw = A[1] - B[1]
        L = np.linalg.solve(iA + iB, dw - np.dot(dw, n) * n)
        if f < 1.0:   # as far as the contact is a face on a face (round 65)
            L = f * L
        A[1], B[1] = A[1] - iA @ L, B[1] + iB @ L


def _roll_flatness(flat, ut, lt: float, dw, n) -> float:
    """The pair's flatness (``flat``, a number or a function of the unit direction) along the slip ``ut`` (``lt`` its
    length) or, without slip, along the bodies' relative rolling ``(dw x n)`` (``dw`` their relative spin); 1 with
    neither."""
    if not callable(flat):
        return float(flat)
    roll = np.cross(dw - np.dot(dw, n) * n, n)
    lr = float(np.linalg.norm(roll))
    if lt > 0.0:
        return float(flat(ut / lt))
    return float(flat(roll / lr)) if lr > 0.0 else 1.0


def _friction(A, B, rA, rB, n, dJ):
    """A friction impulse ``dJ`` (kg m/s, on B; its opposite on A) at the contact: the centres' velocities and each
    body's twist about ``n`` (its tipping moment held, as ``pair_contact``)."""
    A[0], B[0] = A[0] - dJ / A[3], B[0] + dJ / B[3]
    A[1] = A[1] - (float(np.dot(np.cross(rA, dJ), n)) / float(n @ A[2] @ n)) * n
    B[1] = B[1] + (float(np.dot(np.cross(rB, dJ), n)) / float(n @ B[2] @ n)) * n


def solve_pairs(bodies, contacts, gravity, sweeps: int = SWEEPS):
    """The touching pairs of rigid bodies solved together (module notes; the NumPy reference of the engines').

    Parameters
    ----------
    bodies : list of tuple
        Per body ``(V, w, inertia, M, c)``: velocity (m/s, (3,)), spin (rad/s, (3,)), inertia at its pose (kg m^2,
        (3, 3), APIC's ``M dx^2 / 2`` included), mass (kg), mass centre (m, (3,)).
    contacts : list of tuple
        Per touching pair ``(a, b, x_c, n, mu)``: the body of field A and of B, the contact's centre (m, (3,)), its
        unit normal from A into B and the pair's coefficient; round 65: optionally ``flat`` and ``plane`` after them
        (``rigid_friction.pair_contact``'s; none: a face on a face), round 91: and ``allow``.
    gravity : array_like, shape (3,)
        m/s^2: the pairs are swept in the order of ``-g . x_c``, bottom up.
    sweeps : int

    Returns
    -------
    list of ``(V, w)`` per body, and the pairs' normal impulses (kg m/s, in ``contacts``' order).
    """
    state = [[np.asarray(V, float).copy(), np.asarray(w, float).copy(), np.asarray(I, float), float(M),
              np.asarray(c, float)] for V, w, I, M, c in bodies]
    g = np.asarray(gravity, float)
    order = sorted(range(len(contacts)), key=lambda k: float(-np.dot(g, contacts[k][2])))
    lam = [[0.0, np.zeros(3)] for _ in contacts]
    for _ in range(int(sweeps)):
        for k in order:
            a, b, x_c, n, mu = contacts[k][:5]
            _pair_update(state[a], state[b], np.asarray(x_c, float), np.asarray(n, float), float(mu), lam[k],
                         *contacts[k][5:])
    return [(s[0], s[1]) for s in state], [float(p) for p, _ in lam]


def islands(pairs, n_bodies: int) -> list[list[int]]:
    """The islands of ordered touching pairs (round 81, the GPU schedules' ``rigid_pairs_gpu``, module notes).

    Parameters
    ----------
    pairs : sequence of (int, int)
        The touching pairs' two bodies ``(a, b)``, in the sweep's order (bottom up); each body in ``[0, n_bodies)``.
    n_bodies : int

    Returns
    -------
    list of list of int
        Per island (the bodies joined by the pairs, union-find with the smaller root kept), the positions in ``pairs``
        of its pairs in their order; the islands numbered by their first pair. No two islands share a body, so
        sweeping each alone in this order updates every body as the sweep over all the pairs does.

    Raises
    ------
    ValueError
        A body outside ``[0, n_bodies)``.
    """
    root = list(range(int(n_bodies)))

    def find(x: int) -> int:
        while root[x] != x:
            root[x] = root[root[x]]
            x = root[x]
        return x
    for a, b in pairs:
        if not (0 <= a < n_bodies and 0 <= b < n_bodies):
            raise ValueError(f"pair ({a}, {b}): bodies must lie in [0, {n_bodies})")
        ra, rb = find(a), find(b)
        if ra != rb:
            root[max(ra, rb)] = min(ra, rb)
    index: dict[int, int] = {}
    out: list[list[int]] = []
    for q, (a, _b) in enumerate(pairs):
        i = index.setdefault(find(a), len(out))
        if i == len(out):
            out.append([])
        out[i].append(q)
    return out
