"""The particle contact with the grounds (engine option ``contact = "particle"``, ``gasp_core.toolkit.contact``,
``docs/contact.md``), as Warp functions per scalar type (:mod:`gasp_warp_mpm.precision`); taichi_mpm's
``contact.py`` spells the same steps.

- :func:`build_contact` ``plane_contact``: in P2G, a point's normal impulse ``j_n = max(0, dt (k depth - c v_z))``
  summed over the planes less than its skin below its centre (``depth = height + skin - z``), and its friction
  budget ``sum mu j_n``, which P2G adds to its nodes with its weights (``transfers.scatter_scalar``);
- ``node_friction``: in the grid update, the node's tangential (x, y) velocity loses ``min(budget / m, |v_t|)``;
- :func:`build_passive_hold` ``hold_passive``: after a passive point's update, the point put back in the box the
  boundaries keep it in (``gasp_core.toolkit.points.passive_bounds``, ``hold_passive``).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_contact(Ft):
    """``(plane_contact, node_friction)`` Warp functions of the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    vec2 = wp.types.vector(2, Ft)

    @wp.func
    def plane_contact(planes: wp.array(dtype=vec3), kcs: vec3, z: Ft, vz: Ft, dt: Ft):
        # planes[q] = (height, friction, unused); kcs = (k, c, skin) of the point: returns (j_n, budget)
        jn = Ft(0.0)
        budget = Ft(0.0)
        for q in range(planes.shape[0]):
            depth = planes[q][0] + kcs[2] - z
            if depth > Ft(0.0):
                jq = wp.max(dt * (kcs[0] * depth - kcs[1] * vz), Ft(0.0))
                jn = jn + jq
                budget = budget + planes[q][1] * jq
        return vec2(jn, budget)

    @wp.func
    def node_friction(vel: vec3, m: Ft, fb: Ft):
        # Coulomb friction of the budget fb (kg m/s) on a node of mass m: stops, never reverses, v_t
        vt = vec3(vel[0], vel[1], Ft(0.0))
        lt = wp.length(vt)
        out = vel
        if fb > Ft(0.0) and lt > Ft(0.0):
            out = vel - (wp.min(fb / m, lt) / lt) * vt
        return out

    return plane_contact, node_friction


@functools.cache
def build_friction_balance(Ft):
    """``balance_friction``, a Warp function of scalar type ``Ft`` called by the grid update at a node with friction:
    adds to its body's row of ``fr_sums`` (float64, shape (n_bodies, 25)) the node's friction impulse less the one
    its body's rigid motion alone would get there (kg m/s, x y z), that excess's moment about the origin, and the
    node's mass and its first and second moments, and lists the node in ``fr_nodes`` (``fr_nodes[0]`` counts them);
    ``friction_fix`` then moves the listed nodes so that the excess's force and torque sum to zero over each body
    (``gasp_core.toolkit.contact.friction_balance``)."""
    vec3, vec4, mat33 = build_types(Ft)
    node_friction = build_contact(Ft)[1]

    @wp.func
    def balance_friction(node: int, v_in: vec3, v_out: vec3, m: Ft, fb: Ft, X: vec3, g_dt: vec3,
                         shift: wp.array2d(dtype=wp.float64), grid_fbody: wp.array(dtype=wp.int32),
                         fr_sums: wp.array2d(dtype=wp.float64), fr_nodes: wp.array(dtype=wp.int32)):
        b = grid_fbody[node]
        if b >= 0:
            c = vec3(Ft(shift[b, 3]), Ft(shift[b, 4]), Ft(shift[b, 5]))
            u = vec3(Ft(shift[b, 6]), Ft(shift[b, 7]), Ft(shift[b, 8])) + g_dt \
                + wp.cross(vec3(Ft(shift[b, 9]), Ft(shift[b, 10]), Ft(shift[b, 11])), X - c)
            df = m * ((v_out - v_in) - (node_friction(u, m, fb) - u))
            tq = wp.cross(X, df)
            m64 = wp.float64(m)
            for q in range(3):
                wp.atomic_add(fr_sums, b, q, wp.float64(df[q]))
                wp.atomic_add(fr_sums, b, 13 + q, wp.float64(tq[q]))
                wp.atomic_add(fr_sums, b, 4 + q, m64 * wp.float64(X[q]))
            wp.atomic_add(fr_sums, b, 3, m64)
            wp.atomic_add(fr_sums, b, 7, m64 * wp.float64(X[0] * X[0]))
            wp.atomic_add(fr_sums, b, 8, m64 * wp.float64(X[0] * X[1]))
            wp.atomic_add(fr_sums, b, 9, m64 * wp.float64(X[0] * X[2]))
            wp.atomic_add(fr_sums, b, 10, m64 * wp.float64(X[1] * X[1]))
            wp.atomic_add(fr_sums, b, 11, m64 * wp.float64(X[1] * X[2]))
            wp.atomic_add(fr_sums, b, 12, m64 * wp.float64(X[2] * X[2]))
            slot = wp.atomic_add(fr_nodes, 0, 1) + 1
            if slot < fr_nodes.shape[0]:
                fr_nodes[slot] = node

    return balance_friction


@functools.cache
def build_passive_hold(Ft):
    """``hold_passive(x, v, lo, hi) -> (x, v)``, a Warp function of the scalar type ``Ft``: on each axis a passive
    point below ``lo[d]`` is put at ``lo[d]`` with ``v[d] = max(v[d], 0)``, above ``hi[d]`` at ``hi[d]`` with
    ``v[d] = min(v[d], 0)`` (``gasp_core.toolkit.points.hold_passive``: a massless surface marker cannot be
    inside the ground or the walls)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def hold_passive(x: vec3, v: vec3, lo: vec3, hi: vec3):
        xo = x
        vo = v
        for d in range(3):
            if xo[d] < lo[d]:
                xo[d] = lo[d]
                vo[d] = wp.max(vo[d], Ft(0.0))
            if xo[d] > hi[d]:
                xo[d] = hi[d]
                vo[d] = wp.min(vo[d], Ft(0.0))
        return xo, vo

    return hold_passive


@functools.cache
def build_moments(Ft):
    """``(contact_moments, contact_shift)``, the Warp kernels of the contact's torque regularisation
    (``gasp_core.toolkit.contact.counter_spin``, the reference), scalar type ``Ft``.

    - ``contact_moments`` (one thread a point): adds to its body's row of ``sums`` (float64, shape
      (n_bodies, 13), columns :data:`gasp_core.toolkit.contact.SUMS`) its mass, first and second mass moments and,
      where its planes push it, its normal impulse and the impulse's first moments in x and y;
    - ``contact_shift`` (one thread a body): the body's counter-spin ``d_omega`` (rad/s) and mass centre ``c``
      (m) into ``shift`` (shape (n_bodies, 6)), then ``sums`` cleared for the next substep. P2G adds
      ``m_p d_omega x (x_p - c)`` to each point's momentum.
    """
    vec3, vec4, mat33 = build_types(Ft)
    plane_contact, _ = build_contact(Ft)
    f64 = wp.float64
    v64 = wp.types.vector(3, f64)
    m64 = wp.types.matrix((3, 3), f64)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def contact_moments(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), p_mass: wp.array(dtype=Ft),
                        body: wp.array(dtype=wp.int32), p_contact: wp.array(dtype=vec3),
                        planes: wp.array(dtype=vec3), dt: Ft, sums: wp.array2d(dtype=f64)):
        p = wp.tid()
        b = body[p]
        xp = x[p]
        m = f64(p_mass[p])
        px = f64(xp[0])
        py = f64(xp[1])
        pz = f64(xp[2])
        wp.atomic_add(sums, b, 0, m)
        wp.atomic_add(sums, b, 1, m * px)
        wp.atomic_add(sums, b, 2, m * py)
        wp.atomic_add(sums, b, 3, m * pz)
        wp.atomic_add(sums, b, 4, m * px * px)
        wp.atomic_add(sums, b, 5, m * px * py)
        wp.atomic_add(sums, b, 6, m * px * pz)
        wp.atomic_add(sums, b, 7, m * py * py)
        wp.atomic_add(sums, b, 8, m * py * pz)
        wp.atomic_add(sums, b, 9, m * pz * pz)
        vp = v[p]
        mvx = m * f64(vp[0])
        mvy = m * f64(vp[1])
        mvz = m * f64(vp[2])
        wp.atomic_add(sums, b, 13, mvx)
        wp.atomic_add(sums, b, 14, mvy)
        wp.atomic_add(sums, b, 15, mvz)
        wp.atomic_add(sums, b, 16, py * mvz - pz * mvy)
        wp.atomic_add(sums, b, 17, pz * mvx - px * mvz)
        wp.atomic_add(sums, b, 18, px * mvy - py * mvx)
        jb = plane_contact(planes, p_contact[p], xp[2], vp[2], dt)
        if jb[0] > Ft(0.0):
            j = f64(jb[0])
            wp.atomic_add(sums, b, 10, j)
            wp.atomic_add(sums, b, 11, j * px)
            wp.atomic_add(sums, b, 12, j * py)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def contact_shift(sums: wp.array2d(dtype=f64), reach: wp.array(dtype=f64), shift: wp.array2d(dtype=f64)):
        b = wp.tid()
        M = sums[b, 0]
        J = sums[b, 10]
        w = v64(f64(0.0))
        c = v64(f64(0.0))
        if M > f64(0.0):
            c = v64(sums[b, 1], sums[b, 2], sums[b, 3]) / M
        if M > f64(0.0) and J > f64(0.0):
            dX = c[0] - sums[b, 11] / J
            dY = c[1] - sums[b, 12] / J
            d = wp.sqrt(dX * dX + dY * dY)
            if d > reach[b]:
                dX = dX * reach[b] / d
                dY = dY * reach[b] / d
            S = m64(sums[b, 4], sums[b, 5], sums[b, 6], sums[b, 5], sums[b, 7], sums[b, 8],
                    sums[b, 6], sums[b, 8], sums[b, 9]) / M - wp.outer(c, c)   # covariance of mass, m^2
            inertia = M * (wp.trace(S) * wp.identity(3, dtype=f64) - S)
            if wp.determinant(inertia) > f64(0.0):
                w = wp.inverse(inertia) * (J * v64(dY, -dX, f64(0.0)))
        V = v64(f64(0.0))
        omega = v64(f64(0.0))
        if M > f64(0.0):   # the body's rigid motion: momentum / M, I^-1 (angular momentum about c)
            V = v64(sums[b, 13], sums[b, 14], sums[b, 15]) / M
            S = m64(sums[b, 4], sums[b, 5], sums[b, 6], sums[b, 5], sums[b, 7], sums[b, 8],
                    sums[b, 6], sums[b, 8], sums[b, 9]) / M - wp.outer(c, c)
            inertia = M * (wp.trace(S) * wp.identity(3, dtype=f64) - S)
            if wp.determinant(inertia) > f64(0.0):
                omega = wp.inverse(inertia) * (v64(sums[b, 16], sums[b, 17], sums[b, 18]) - M * wp.cross(c, V))
        for q in range(3):
            shift[b, q] = w[q]
            shift[b, 3 + q] = c[q]
            shift[b, 6 + q] = V[q]
            shift[b, 9 + q] = omega[q]
        for q in range(19):
            sums[b, q] = f64(0.0)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def friction_fix(grid_v: wp.array(dtype=vec3), grid_fbody: wp.array(dtype=wp.int32),
                     fr_sums: wp.array2d(dtype=f64), fr_nodes: wp.array(dtype=wp.int32), lo: vec3, dx: Ft,
                     n_grid: int):
        # one thread: per body, the velocity change dv + alpha x (X - x_bar) of its listed nodes that takes back the
        # friction's excess force and torque; the nodes moved, then everything cleared
        for b in range(fr_sums.shape[0]):
            Mc = fr_sums[b, 3]
            if Mc > f64(0.0):
                xb = v64(fr_sums[b, 4], fr_sums[b, 5], fr_sums[b, 6]) / Mc
                F = v64(fr_sums[b, 0], fr_sums[b, 1], fr_sums[b, 2])
                S = m64(fr_sums[b, 7], fr_sums[b, 8], fr_sums[b, 9], fr_sums[b, 8], fr_sums[b, 10], fr_sums[b, 11],
                        fr_sums[b, 9], fr_sums[b, 11], fr_sums[b, 12]) / Mc - wp.outer(xb, xb)
                inertia = Mc * (wp.trace(S) * wp.identity(3, dtype=f64) - S)
                T = v64(fr_sums[b, 13], fr_sums[b, 14], fr_sums[b, 15]) - wp.cross(xb, F)
                alpha = v64(f64(0.0))
                if wp.determinant(inertia) > f64(1.0e-12) * wp.trace(inertia) * wp.trace(inertia) * wp.trace(inertia):
                    alpha = -(wp.inverse(inertia) * T)
                for q in range(3):
                    fr_sums[b, 16 + q] = -F[q] / Mc
                    fr_sums[b, 19 + q] = alpha[q]
                    fr_sums[b, 22 + q] = xb[q]
        n = wp.min(fr_nodes[0], fr_nodes.shape[0] - 1)
        for s in range(n):
            node = fr_nodes[s + 1]
            b = grid_fbody[node]
            if b >= 0 and fr_sums[b, 3] > f64(0.0):
                i = node / (n_grid * n_grid)
                j = (node / n_grid) % n_grid
                k = node % n_grid
                X = v64(f64(lo[0] + dx * Ft(i)), f64(lo[1] + dx * Ft(j)), f64(lo[2] + dx * Ft(k)))
                dv = v64(fr_sums[b, 16], fr_sums[b, 17], fr_sums[b, 18]) + wp.cross(
                    v64(fr_sums[b, 19], fr_sums[b, 20], fr_sums[b, 21]),
                    X - v64(fr_sums[b, 22], fr_sums[b, 23], fr_sums[b, 24]))
                grid_v[node] = grid_v[node] + vec3(Ft(dv[0]), Ft(dv[1]), Ft(dv[2]))
            grid_fbody[node] = -1
        for s in range(fr_sums.shape[0]):
            for q in range(25):
                fr_sums[s, q] = f64(0.0)
        fr_nodes[0] = 0

    return contact_moments, contact_shift, friction_fix
