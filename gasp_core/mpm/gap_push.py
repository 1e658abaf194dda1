"""A measured overlap of two soft bodies let out along the contact normal (round 62, issue 67 / 66, ``docs/contact.md``
"Round 62: letting an overlap out"; the switch :data:`PUSH`).

The two-field contact (``gasp_core.mpm.fields``) projects the two fields' relative normal VELOCITY at the marked nodes
(:mod:`gasp_core.mpm.gap_touch`); nothing acts on a position, so an overlap once made (a landing's, or one the
friction holds) stays, and two soft balls' rest depends on the path (``docs/contact.md`` "Round 61: the stacked balls'
sink"). This is the position term of a split impulse (E. Catto, "Iterative dynamics with temporal coherence", GDC
2005; Bullet's ``btSequentialImpulseConstraintSolver`` with ``m_splitImpulse``: a pseudo-velocity that corrects the
positions and is never added to the velocity state): each material point of a soft body already gathers the OTHER
field's volume fraction ``phi`` at its position (the touch's marks); the half-space profile
(:func:`gasp_core.mpm.gap_touch.half_space_table`, ``flow_touch_level``'s function of the distance) inverted at
``phi`` gives the distance ``s`` (cells) at which a filled half-space's face reads as ``phi``; the point's overlap
past its touch level is ``d = D - s`` with ``D`` the distance at which it marks (``delta_b``, plus ``SIGMA2 k`` with
:data:`gasp_core.mpm.gap_touch.CURVATURE`). Each soft body then translates, once a substep, by its share
(:func:`push_params`: :data:`BETA` times the other body's fraction of the pair's mass) of the mean of ``d n`` over its
points with ``d > 0``, ``n = -grad phi / |grad phi|`` (out of the other body), at most :data:`CAP` cells: a rigid
shift of the body, not of its overlapping points (moving those alone compresses them against their neighbours, a
strain the deformation gradient does not record; measured: the stacked balls sank deeper, ``docs/contact.md``). A
rigid body's points never move. The velocities, deformation gradients and the grid are not changed, so the momentum,
the contact's ledger and the restitution are what they were. Parallel loops over the points (an atomic sum per
body, then each point its own position), after the contact and before the grid's volumes are cleared (so before G2P,
which then gathers at the moved position); no ordered loop.

The half-space profile is odd about its face (``phi(-s) = 1 - phi(s)`` for the symmetric B-spline's smoothing), so
``phi > 1/2`` (the point's centre past the face) reads ``s = -s(1 - phi)``; ``s`` is clamped to the table's range
(+-1.5 cells).
"""
from __future__ import annotations

import numpy as np

import gasp_core.mpm.gap_touch as G

#: Off: the contact acts on velocities alone (the rule of rounds 60-61).
PUSH = False
#: The broken variant of the checks (built in one engine, ``tests/test_gap_push.py``): the push made a velocity (each point's move times its mass over
#: the substep scattered to the grid's momentum, Baumgarte's bias), not a move of the positions. Never on in a run.
KICK = False
#: The fraction of a measured overlap released a substep (split equally between the two soft bodies): Baumgarte's
#: error-reduction factor as Catto sets it (GDC 2005; Box2D's ``b2_baumgarte`` 0.2): a geometric release (0.8 of the
#: overlap left after each substep), never past the touch level, whose time constant (5 substeps) is short against
#: the contact's own response (a soft body's wave crosses a cell in several substeps at the CFL step).
BETA = 0.2
#: The most a point moves a substep by the push, cells: a quarter of the default CFL bound (``cfl`` 0.4 of a cell a
#: substep for the fastest point), so a pushed point still moves within that bound's reach; it binds only where a
#: body's share times its mean overlap passes it: past a mean overlap of CAP / BETA = 0.5 cell (measured inert at rest
#: at 0.05, 0.1 and 0.2: ``docs/contact.md``).
CAP = 0.1


def push_params(setup) -> np.ndarray:
    """The push's parameters (shape (TABLE_N + 2 n_materials,), float64): :func:`gap_touch.half_space_table`, each
    body's reach ``delta_b`` (cells, :func:`gap_touch.body_delta`), each body's share of :data:`BETA`: of two soft
    bodies the other's fraction of the pair's mass ``m_other / (m_a + m_b)`` (the pair's centre of mass does not move,
    as an impulse's split would leave it), of a soft body beside a rigid one all of it, of three or more soft bodies
    (fields by colouring) half; 0 for a rigid body (its points are its state's)."""
    from gasp_core.mpm.rigid import rigid_mask
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    n = len(setup.materials)
    vol = np.broadcast_to(np.asarray(setup.p_vol, float), (len(setup.x),))
    body = np.asarray(setup.body_id)[:len(setup.x)]
    mass = np.array([float(getattr(setup.materials[b], "rho", 1000.0)) * vol[body == b].sum() for b in range(n)])
    share = np.full(n, 0.5 * float(BETA))
    if n == 2 and not rigid.any():
        share = float(BETA) * mass[::-1] / max(float(mass.sum()), 1e-30)
    elif rigid.any():
        share = np.full(n, float(BETA))
    share[rigid] = 0.0
    return np.concatenate([G.half_space_table(), G.body_delta(setup), share]).astype(np.float64)


def table_distance(table: np.ndarray, phi):
    """The inverse of :func:`gap_touch.table_level`: the distance (cells, in [-1.5, 1.5]) at which the half-space
    profile reads ``phi`` (array or scalar; the profile decreasing from 0.5 at the face), odd about the face. What
    the engines' kernels compute (a bisection over the table, then the same linear piece)."""
    phi = np.asarray(phi, float)
    inside = phi > table[0]
    q = np.where(inside, 1.0 - phi, phi)
    n = len(table)
    s = np.empty_like(q)
    for idx, v in np.ndenumerate(q):
        if v >= table[0]:
            s[idx] = 0.0
        elif v <= table[n - 1]:
            s[idx] = (n - 1) * G.TABLE_STEP
        else:
            lo, hi = 0, n - 1   # table[lo] > v >= table[hi]
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if table[mid] > v:
                    lo = mid
                else:
                    hi = mid
            s[idx] = (lo + (table[lo] - v) / (table[lo] - table[hi])) * G.TABLE_STEP
    return np.where(inside, -s, s)


def point_overlap(own: np.ndarray, other: np.ndarray, fx: np.ndarray, delta: float, table: np.ndarray,
                  curvature: bool) -> tuple[float, np.ndarray]:
    """A point's overlap past its touch level and the direction out of the other body: ``(d, n)``, ``d`` in cells
    (positive: overlapping), ``n`` (3,) the unit ``-grad phi_other`` (zero where ``|grad phi|`` <= 1e-6). ``own``,
    ``other``: the stencil's node volume fractions (3, 3, 3) of its own field and the other's; ``fx`` its offset from
    its base node (cells); ``delta`` its body's reach (cells); ``curvature`` :data:`gap_touch.CURVATURE`."""
    phi, go, ho = G.gather_derivatives(other, fx)
    reach = float(delta)
    if curvature:
        _, gs, hs = G.gather_derivatives(own, fx)
        k = G.least_curvature(np.stack([go, gs]), np.stack([ho, hs]))
        reach += G.SIGMA2 * max(0.0, float(k.min()))
    gn = float(np.linalg.norm(go))
    return reach - float(table_distance(table, phi)), (-go / gn if gn > 1e-6 else np.zeros(3))


def gap_push(x: np.ndarray, in_a: np.ndarray, body: np.ndarray, vf: np.ndarray, lo, dx: float, params: np.ndarray,
             curvature: bool) -> np.ndarray:
    """The NumPy reference of the push: ``x`` (n, 3) material points, m; ``in_a`` (n_bodies,) the bodies' fields
    (1: A); ``body`` (n,) each point's body; ``vf`` (2, ng, ng, ng) the fields' node volumes (A's, B's), m^3; ``lo``
    the grid's origin, m; ``params`` :func:`push_params`. Each soft body translates by its share of the mean of ``d
    n`` (:func:`point_overlap`) over its points that overlap (``d > 0``), at most :data:`CAP` cells. Returns (n, 3),
    m: what each point's position gains this substep."""
    ng, tn = vf.shape[1], G.TABLE_N
    nb = (len(params) - tn) // 2
    table, delta, share = params[:tn], params[tn:tn + nb], params[tn + nb:]
    X = (np.asarray(x, float) - np.asarray(lo, float)) / dx
    base = np.floor(X - 0.5).astype(int)
    acc = np.zeros((nb, 4))
    for p in range(len(X)):
        b = base[p]
        if share[body[p]] <= 0.0 or b.min() < 0 or b.max() > ng - 3:
            continue
        box = vf[:, b[0]:b[0] + 3, b[1]:b[1] + 3, b[2]:b[2] + 3] / dx ** 3
        own, other = (box[0], box[1]) if bool(in_a[body[p]]) else (box[1], box[0])
        d, n = point_overlap(own, other, X[p] - b, delta[body[p]], table, curvature)
        if d > 0.0:
            acc[body[p]] += np.r_[d * n, 1.0]
    move = np.zeros((nb, 3))
    for b in range(nb):
        if acc[b, 3] > 0:
            t = share[b] * acc[b, :3] / acc[b, 3]
            move[b] = t * min(1.0, CAP / max(float(np.linalg.norm(t)), 1e-30))
    return dx * move[np.asarray(body)]
