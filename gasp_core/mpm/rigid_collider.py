"""Round 63 (issue 67 item 4, ``docs/rigid.md`` "Round 63: the rigid body as a moving collider of the soft field"):
a rigid body beside a soft one (:func:`gasp_core.mpm.fields.mixed_pair`) meets it as a moving collider of the soft
field, two-way by impulses on the body's momentum, instead of round 29's node-mean exchange between the two fields.
Round 64 (``docs/rigid.md`` "Round 64"): the same for every rigid body of a scene of three or more bodies with a
soft one (:func:`collider_multi`, the section "Three or more bodies" below).

Per substep, with :data:`RIGID_COLLIDER` on:

1. After P2G, at every node the two fields share (off the grounds' and walls' node layers), each field keeps its own
   velocity (no exchange: the rigid field's nodes never see the soft body's stress or approach). A node is in the
   body's band where both fields have mass there and it lies within :data:`BAND` cells of the body's points' box in
   the body's frame (``rigid_pairs.body_boxes``; 0.5: the body's surface, a quarter cell beyond its outer points, plus
   a quarter cell; round 96: :data:`FACE_BAND` where the rigid body is field B, a node there taken only where its
   mass falls towards the soft body, :mod:`gasp_core.mpm.face_share`); its normal ``n`` is field B's surface normal
   (the first pass's, round 22: the larger body's face), turned to point out of the rigid body.
2. After the grid update (gravity, the particle contact's impulses, the boundaries), the body's velocity this substep
   ``V* = sum_i m_R v_R / sum_i m_R`` over the rigid field's nodes (what its points' G2P and projection would give
   it: its update and its ground contact of this substep); its spin ``w`` from its state.
3. The band's nodes that approach the body (``u . n < 0``, ``u = v_S - V* - w x r``, ``r = x_i - c``) and the body
   are solved together, implicitly (:func:`body_solve`): first along the normals, ``A x = b`` with ``x = (dV, dw)``,
   ``A = diag(M, I) + sum m_S G^T P G``, ``b = sum m_S G^T P u``, ``G = [1, -[r]x]``, ``P = n n^T``; then along the
   surfaces with ``P = 1 - n n^T`` (the nodes stuck) against the first solve's body. Each node's change is its
   normal relative velocity against the first solve's body removed and its tangential one against the second's,
   the tangential part scaled so that its sum is at most ``mu`` times the layer's normal impulse (Coulomb's on the
   body as one, as the rigid pairs' law; round 65: on each pair of the body and a soft body as one). The soft
   field's nodes take it; the body takes ``J_i = -m_S dv_i`` into the sums of its next projection (``acc_p += J_i``,
   ``acc_l += x_i x J_i``), float64 atomics over the nodes.

Why implicit and why Coulomb per body (measured, ``docs/rigid.md`` "Round 63"): a per-node collider whose summed
reaction is given to the body explicitly floated the 6 x 6 x 3 cm block on jelly at 5.7 mm/s (its band's soft mass
0.08 kg against its 0.108 kg: each substep's reaction a bounce, the jelly's ringing rectified) and rocked it (spin
0.15-0.22 rad/s); a cap of ``mu`` times each node's own normal change stopped a block thrown at 0.5 m/s in one frame
(the nodes' normal changes of both signs summed in magnitude: friction 0.72 of the normal impulse at ``mu`` 0.3).

**Three or more bodies** (round 64, :data:`MULTI`; round 61/62's colouring: each field may hold several bodies, no
two of one field within 3 cells of each other). Every rigid body is a *slot* (:func:`collider_data`): its own ``V*``,
its own 6 x 6 solve, its own Coulomb caps (round 65, "The pair's friction" below), its impulses to its own projection
sums. Which slot a shared node serves (:func:`collider_owner`, the engines' ``owner``): round 62's lookup
(``rigid_pairs.node_bodies``: per field the nearest rigid body whose box, in its frame, the node lies within
``NODE_PAD`` = 1.5 cells of). Where one field has a rigid body there and the other none, the other field's mass there
is soft (the colouring keeps a field's bodies apart, so a node's mass of one field is one body's): the node takes the
rule of that body (no exchange; the band and the solve where within ``BAND``). Where both fields have one, the node
is a rigid pair's (``rigid_pairs``: its sums and the pairs' solve, unchanged); where neither, soft on soft (round
29's exchange, unchanged). So no node is in two slots' bands: two rigid bodies of one field are too far apart, and a
node near rigid bodies of both fields is the pair's. ``V*`` is summed from each slot body's points' G2P of its field
(``m_p v(x_p)``; the pair's node sums give the same, but a node's rigid-field mass cannot be told apart from another
body's of that field without a per-node owner of every node). The pair (two bodies) keeps its one slot and node sums,
bit for bit.

**The pair's friction** (round 65, :data:`PAIR_MU`; ``docs/rigid.md`` "Round 65"). The cap is per contact pair
(rigid body, soft body): a band node's soft-field mass is one soft body's (the colouring, above), and the engines
learn which from the soft points themselves (each writes its body at the nodes its stencil weights, in the point
pass of ``V*``: ``rc_sb``, an int per node and field, cleared by the mark pass; an atomic max, so a field the
colouring shares (an odd cycle) gives its largest body index, deterministically). Each pair ``(slot, soft body)``
sums its own normal impulse ``N_q`` and stuck tangential impulse ``T_q`` over its nodes, and its tangential part is
scaled to at most ``mu_q N_q``, ``mu_q`` the ``combine_friction`` of the two bodies' ``friction``
(:func:`pair_frictions`; ``fields_reference.combine_friction``: the geometric mean, Bullet's
``btManifoldResult::calculateCombinedFriction``). The solves along the normals and the surfaces stay one a rigid
body. Before (round 64, ``PAIR_MU`` False: :func:`slot_frictions`) one cap a rigid body with the smallest ``mu`` of
its pairs with every soft body of the scene: a block on a jelly of 0.5 slid +215 % long when an icy jelly (0.05)
lay elsewhere in the scene. The two-body pair is one pair a slot (no write: its one soft body), bit for bit.

No constant but the pairs' ``mu`` and ``BAND``. Work: eight node passes (the pair) or seven and a point pass (round 64),
two one-thread-a-slot updates (``rc_body``, ``rc_solve``: a slot's few dozen flops each; the slots are the scene's rigid
bodies), ``rc_coulomb`` one thread a pair (round 65: slots times bodies; a dozen flops each), the soft points' writes of
``rc_sb`` in the point pass (27 reads a point, an atomic only where the node's value differs), and at each shared node a
loop over the slots (``owner``; round 62's ``node_slot`` loops over the bodies the same way).
"""
from __future__ import annotations

import numpy as np

#: Round 63: True runs the collider rule for a mixed pair (module notes); False: round 29's node-mean exchange (the
#: rule before: a jelly on a rigid slab sank -1.0 dx in 0.7 s, a rigid block on jelly -0.17 dx).
RIGID_COLLIDER = True
#: Round 64: True runs the rule in scenes of three or more bodies with a rigid one and a soft one (module notes "Three
#: or more bodies"); False: there round 29's node-mean exchange at the soft/rigid nodes (the rule before: the
#: sandwich's jelly sank into its bottom block, its thrown top block slid +4.15 % long).
MULTI = True
#: The band: a node within this many cells of the rigid body's points' box, in its frame (Chebyshev): its surface, a
#: quarter cell beyond its outer points, plus a quarter cell (measured at 0.5 only, ``docs/rigid.md`` "Round 63").
BAND = 0.5
#: Round 96 (``docs/contact.md`` "Round 96"): where the rigid body is field B (a soft body on a larger rigid one), the
#: band reaches this many cells past its points' box, 0.75 past its surface, and takes only the nodes where its mass
#: falls towards the soft body (:mod:`gasp_core.mpm.face_share`'s test). The node layer nearest its face lies within
#: half a cell of it wherever the grid lies; 0.5 missed it half a cell off (a jelly block on a rigid slab 1 cell thick
#: then met only the slab's middle layer, its normal noise: +50.9 % of Coulomb's slide), and at 0.75 exactly one case
#: fell out by roundoff, hence the quarter cell more.
FACE_BAND = 1.0
#: Round 65: True caps each contact pair (rigid body, soft body) at its own ``mu`` times its own normal impulse (module
#: notes "The pair's friction"); False: round 64's one cap a rigid body with the smallest of its pairs' ``mu`` (main's
#: rule before: a block on a jelly of mu 0.5 slid with the ``mu`` of an icy jelly elsewhere in the scene).
PAIR_MU = True
#: A deliberately broken variant for the checks (``tests/test_pair_friction.py``): True gives each soft body the next
#: soft body's ``friction`` in its pairs (:func:`pair_frictions`).
PAIR_SWAP = False


def collider_on(setup) -> bool:
    """Whether a setup runs the collider rule: :data:`RIGID_COLLIDER` and a rigid body beside a soft one on the
    particle contact with two fields (:func:`gasp_core.mpm.fields.mixed_pair`)."""
    from gasp_core.mpm.fields import mixed_pair, uses_fields
    return bool(RIGID_COLLIDER) and mixed_pair(setup) and uses_fields(setup)


def body_solve(M: float, inertia: np.ndarray, m_s: np.ndarray, r: np.ndarray, u: np.ndarray, n: np.ndarray,
               tangential: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """``(dV, dw)`` (m/s, rad/s; (3,) each): the body (mass ``M`` kg, inertia ``inertia`` (3, 3) kg m^2 about its
    centre) and the nodes (soft masses ``m_s`` (N,) kg, arms ``r`` (N, 3) m, relative velocities ``u = v_S - v_b``
    (N, 3) m/s, unit normals ``n`` (N, 3) out of the body) brought to one velocity along the normals
    (``tangential`` False) or along the surfaces (True): ``A x = b`` of the module notes."""
    A = np.zeros((6, 6))
    A[:3, :3], A[3:, 3:] = M * np.eye(3), inertia
    b = np.zeros(6)
    for mi, ri, ui, ni in zip(np.asarray(m_s, float), np.asarray(r, float), np.asarray(u, float),
                              np.asarray(n, float)):
        P = np.outer(ni, ni)
        P = np.eye(3) - P if tangential else P
        S = np.array([[0.0, -ri[2], ri[1]], [ri[2], 0.0, -ri[0]], [-ri[1], ri[0], 0.0]])
        G = np.hstack([np.eye(3), -S])
        A += mi * G.T @ P @ G
        b += mi * G.T @ P @ ui
    x = np.linalg.solve(A, b)
    return x[:3], x[3:]


def collide(M: float, inertia: np.ndarray, V: np.ndarray, w: np.ndarray, m_s: np.ndarray, r: np.ndarray,
            v_s: np.ndarray, n: np.ndarray, mu, soft=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One substep's collider (module notes, step 3) for the body at ``V*`` = ``V``, spin ``w`` ((3,) each) and the
    band's nodes (``m_s`` (N,), ``r`` (N, 3), soft velocities ``v_s`` (N, 3), normals ``n`` (N, 3)): ``(dv, J, L)``,
    the nodes' velocity changes (N, 3; 0 at the nodes that do not approach), the body's impulse (3,) and its moment
    about the body's centre (3,). ``mu``: the pair's coefficient (a float: one soft body); round 65, ``soft`` (N,)
    int, the soft body each node's soft mass is of, and ``mu`` (K,) each soft body's pair coefficient (indexed by
    ``soft``): each pair's tangential sum capped at its own ``mu`` times its own normal impulse."""
    m_s, r, v_s, n = (np.asarray(a, float) for a in (m_s, r, v_s, n))
    V, w = np.asarray(V, float), np.asarray(w, float)
    soft = np.zeros(len(m_s), int) if soft is None else np.asarray(soft, int)
    mu = np.atleast_1d(np.asarray(mu, float))
    u = v_s - V - np.cross(w, r)
    on = np.sum(u * n, axis=1) < 0.0
    dv = np.zeros_like(v_s)
    if not on.any():
        return dv, np.zeros(3), np.zeros(3)
    m, r, n, k = m_s[on], r[on], n[on], soft[on]
    dV, dw = body_solve(M, inertia, m, r, u[on], n)
    V1, w1 = V + dV, w + dw
    u1 = v_s[on] - V1 - np.cross(w1, r)
    dvn = -np.sum(u1 * n, axis=1, keepdims=True) * n
    tV, tw = body_solve(M, inertia, m, r, u1, n, tangential=True)
    u2 = v_s[on] - (V1 + tV) - np.cross(w1 + tw, r)
    dvt = -(u2 - np.sum(u2 * n, axis=1, keepdims=True) * n)
    scale = np.ones(len(m))
    for q in np.unique(k):   # each pair (the body, soft body q): Coulomb's on its own sums
        sel = k == q
        N = float(np.sum(m[sel, None] * dvn[sel] * n[sel]))
        T = np.linalg.norm((m[sel, None] * dvt[sel]).sum(0))
        cap = mu[q] * max(N, 0.0)
        scale[sel] = 1.0 if T <= cap else cap / T
    dv[on] = dvn + scale[:, None] * dvt
    J = -(m[:, None] * dv[on])
    return dv, J.sum(0), np.cross(r, J).sum(0)


def collider_multi(setup) -> bool:
    """Round 64: whether a scene of three or more bodies (round 61/62's colouring, ``colouring.coloured``) with a rigid
    body and a soft one runs the rule for each rigid body (:data:`MULTI`, module notes "Three or more bodies")."""
    from gasp_core.mpm.colouring import coloured
    from gasp_core.mpm.fields import uses_fields
    from gasp_core.mpm.rigid import rigid_mask
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    return (bool(RIGID_COLLIDER) and bool(MULTI) and coloured(setup) and uses_fields(setup) and bool(rigid.any())
            and bool((~rigid).any()))


def slot_frictions(materials, rigid_bodies) -> np.ndarray:
    """Round 64's rule (main's before round 65; :data:`PAIR_MU` False): each rigid body's one collider coefficient
    (shape (len(rigid_bodies),)): the smallest ``combine_friction`` of its ``friction`` with a soft body's."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    from gasp_core.mpm.rigid import rigid_mask
    rigid = np.asarray(rigid_mask(materials), bool)
    soft = [body_friction(m) for m, r in zip(materials, rigid) if not r]
    return np.array([min(combine_friction(body_friction(materials[k]), s) for s in soft) for k in rigid_bodies],
                    np.float64)


def pair_frictions(materials, rigid_bodies, swap: bool = False) -> np.ndarray:
    """Round 65: each contact pair's coefficient, shape (len(rigid_bodies), n_bodies): ``[s, b]`` the
    ``combine_friction`` of slot ``s``'s rigid body's ``friction`` with body ``b``'s (``fields_reference``: the
    geometric mean, Bullet's ``btManifoldResult::calculateCombinedFriction``); 0 where ``b`` is rigid (no soft mass
    of it). ``swap`` (a broken variant, :data:`PAIR_SWAP`): each soft body takes the next soft body's ``friction``."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    from gasp_core.mpm.rigid import rigid_mask
    rigid = np.asarray(rigid_mask(materials), bool)
    mu = np.array([body_friction(m) for m in materials], float)
    soft = np.flatnonzero(~rigid)
    if swap:
        mu[soft] = mu[np.roll(soft, -1)]
    out = np.zeros((len(rigid_bodies), len(materials)))
    for s, k in enumerate(rigid_bodies):
        out[s, soft] = [combine_friction(body_friction(materials[k]), mu[b]) for b in soft]
    return out


def collider_owner(xn, in_a, bodies, centre, rot, boxes, pad: float) -> int:
    """Round 64: the slot (an index of ``bodies``, the rigid bodies with a slot) whose rule a shared node at ``xn``
    (m, (3,)) takes, or -1 (module notes "Three or more bodies"): ``rigid_pairs.node_bodies``' lookup of the slot bodies
    (``in_a`` (n_bodies,) bool, ``centre`` (n, 3) m, ``rot`` (n, 3, 3), ``boxes`` (n, 2, 3) m, ``pad`` m); the one
    found where one field has a rigid body there and the other none (its mass there soft); -1 where both (a rigid
    pair: ``rigid_pairs``) or neither (soft on soft: round 29's exchange). The engines' ``owner`` spells it."""
    best = [(-1, np.inf), (-1, np.inf)]   # per field (A, B): the nearest slot body within pad
    for s, k in enumerate(np.asarray(bodies, int)):
        q = np.asarray(rot[k]).T @ (np.asarray(xn, float) - centre[k])
        d = float(np.max(np.maximum(np.maximum(boxes[k, 0] - q, q - boxes[k, 1]), 0.0)))
        f = 0 if in_a[k] else 1
        if d <= pad and d < best[f][1]:
            best[f] = (s, d)
    if (best[0][0] >= 0) == (best[1][0] >= 0):
        return -1
    return max(best[0][0], best[1][0])


def collider_data(setup) -> dict | None:
    """What an engine's collider reads, or None where the rule is off: ``{"bodies": (n_slots,) int, the rigid body of
    each slot; "cols": (n_bodies,) int, each body's column of the pairs' table (round 65: the soft body at a node
    picks its pair ``slot * n_cols + cols[body]``); "mus": (n_slots, n_cols) the pairs' ``mu`` (None for the two-body
    pair: one column, the pair's, the engines' field friction); "multi": bool}`` (round 63's pair: one slot,
    ``multi`` False; round 64: every rigid body a slot; round 65, :data:`PAIR_MU`: a column a body, each pair its own
    ``mu`` (:func:`pair_frictions`); without it one column, :func:`slot_frictions`).
    ``gasp_core.mpm.rigid_pairs.pair_data`` adds ``"boxes"`` ((n_bodies, 2, 3) m, ``body_boxes`` of the step
    view)."""
    from gasp_core.mpm.rigid import rigid_mask, step_view
    view = step_view(setup)
    rigid = np.flatnonzero(np.asarray(rigid_mask(view.materials)))
    nb = len(view.materials)
    out = None
    if collider_on(view):
        out = {"bodies": rigid[:1].astype(np.int32), "cols": np.zeros(nb, np.int32), "mus": None, "multi": False}
    elif collider_multi(view):
        if PAIR_MU:
            out = {"bodies": rigid.astype(np.int32), "cols": np.arange(nb, dtype=np.int32),
                   "mus": pair_frictions(view.materials, rigid, bool(PAIR_SWAP)), "multi": True}
        else:
            out = {"bodies": rigid.astype(np.int32), "cols": np.zeros(nb, np.int32),
                   "mus": slot_frictions(view.materials, rigid)[:, None], "multi": True}
    return out
