"""The contact's balance (``gasp_core.mpm.contact.contact_balance``, ``docs/contact.md``, issue 38), as Warp
kernels per scalar type: each body's net contact force and torque made those of a smooth contact.

Per substep, with the particle contact. A *support* is one body against the grounds (support 0), against one
``[[collider]]`` (support ``1 + c``) or against one face of the walls (after the colliders,
``gasp_core.mpm.contact.contact_planes``); its row is ``body n_sup + support`` (``n_sup`` = 1 + the colliders
with the particle contact + the walls' faces):

- ``contact_moments`` (before P2G, one thread a point): its body's mass, first and second mass moments, momentum
  and angular momentum into ``sums`` (float64, shape (n_bodies, 16), columns
  :data:`gasp_core.mpm.contact.SUMS`); each support's normal impulse on it (along the support's normal),
  the impulse's moments and the support's velocity there, and the box of the pushed points, into ``jsums`` (shape
  (n_bodies n_sup, 20), :data:`gasp_core.mpm.contact.JSUMS`; the pushed points' mass among them);
- ``contact_shift`` (one thread a body): the body's mass centre ``c``, rigid velocity ``V`` and spin ``omega`` into
  ``shift`` (shape (n_bodies, 12): with its angular momentum about ``c``); ``sums`` cleared;
- in P2G, a point with a normal impulse marks its 27 nodes with the row of the support that pushes it most
  (``grid_fbody``; a node marked by several rows keeps the row of the point that pushes it most, an atomic max of
  ``gasp_core.mpm.contact_mark``'s key, so the same on any point order or device);
- ``balance_node`` (a function of the grid update, at each marked node after its friction): the node's friction
  impulse, its moment, the node's mass and moments and its friction budget, into ``fr_sums`` (shape
  (n_bodies n_sup, FR_COLUMNS)); the node listed in ``fr_nodes`` (``fr_nodes[0]`` counts them);
- ``contact_fix`` (the cpu schedule's one thread, :mod:`gasp_warp_mpm.schedule.ordered`; the gpu schedule's
  ``fix_supports``, ``fix_nodes``, ``fix_clear``, :mod:`gasp_warp_mpm.schedule.gpu_balance`): per support, with its
  mean normal ``n`` (``sum j n`` normalised), the change ``dv + alpha x (X - x_m)`` of its listed nodes' velocities
  that makes the friction's net force (in the plane normal to ``n``) Coulomb's on the body's rigid motion relative
  to the support at its centre of pressure, and takes back the contact's torque (normal and friction, less its twist
  about ``n``) about ``c`` up to ``J reach``, unless the line through ``c`` along ``n`` passes more than ``reach``
  beyond the pushed points' box (a body over its edge tips over); the sums and lists cleared. On the ground
  (``n = +z``) these are the steps before issue 38 item 2. With the two-field contact, a listed node where the
  fields keep their offsets gives the change to field B alone (``gasp_core.mpm.fields.B_BALANCE``, round 43).
  A body whose material flows (sand, snow, liquid) has no rigid motion: its mass here is 0 and ``body_fix`` leaves
  it alone (``gasp_core.mpm.contact.balance_mass``, docs/contact.md "Round 59: the balance on a flowing body").

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below
as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.contact import REACH as REACH_SPACINGS, TORQUE_REACH
from gasp_core.mpm.contact_mark import MARK_OCTAVES_BELOW, MARK_Q_MAX, MARK_ROW_BITS, MARK_ROW_MASK, MARK_STEPS

from .contact import build_collider_contact, build_contact, build_contact_impulse, build_plane_point
from .forces import build_extras_struct
from .precision import MODULE_OPTIONS, build_types
from .take_back import PLANE_RULE, unresolved_fraction

#: Columns of ``fr_sums``: friction force (3), contact nodes' mass (1), mass moments (3 + 6), friction's moment
#: about the origin (3), friction budget (1), then the per-body results dv (3), alpha (3), x_m (3).
FR_COLUMNS = 26
#: ``gasp_core.mpm.contact.TORQUE_REACH`` for the kernels.
TORQUE_CLIP = wp.constant(TORQUE_REACH)
REACH_H = wp.constant(REACH_SPACINGS)


f64 = wp.float64
v64 = wp.types.vector(3, f64)
m64 = wp.types.matrix((3, 3), f64)
ROW_BITS, ROW_MASK = wp.constant(MARK_ROW_BITS), wp.constant(MARK_ROW_MASK)


@wp.func
def mark_key(push: f64, row: int):
    # a contact node's key for a point of the balance's row pushing it with w |j| (gasp_core.mpm.contact_mark)
    q = int(0)
    if push > f64(0.0):
        lq = wp.floor((wp.log2(push) + f64(MARK_OCTAVES_BELOW)) * f64(MARK_STEPS))
        q = int(wp.clamp(lq, f64(0.0), f64(MARK_Q_MAX)))
    return (q << ROW_BITS) | row


@functools.cache
def build_mark(Ft):
    """``mark_nodes(grid_fbody, idx0, n_grid, W, imp, row)`` of scalar type ``Ft``, in P2G: a point of the balance's
    ``row`` with contact impulse ``imp`` marks its 27 nodes from flat index ``idx0`` (weights ``W``) with
    :func:`mark_key`, an atomic max: a node keeps the row of the point that pushes it most."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def mark_nodes(grid_fbody: wp.array(dtype=wp.int32), idx0: int, n_grid: int, W: mat33, imp: vec3, row: int):
        jm = f64(wp.length(imp))
        for q in range(27):
            wq = f64(W[q / 9, 0] * W[(q / 3) % 3, 1] * W[q % 3, 2])
            wp.atomic_max(grid_fbody, idx0 + (q / 9) * n_grid * n_grid + ((q / 3) % 3) * n_grid + q % 3,
                          mark_key(wq * jm, row))

    return mark_nodes


@wp.func
def keep_row(grid_fbody: wp.array(dtype=wp.int32), node: int):
    # the grid update: a marked node's key becomes its row (gasp_core.mpm.contact_mark)
    if grid_fbody.shape[0] > 1:
        k = grid_fbody[node]
        if k >= 0:
            grid_fbody[node] = k & ROW_MASK


@wp.func
def inertia_of(m: f64, first: v64, xx: f64, xy: f64, xz: f64, yy: f64, yz: f64, zz: f64):
    # the inertia tensor about the mass centre from the mass, first and second moments
    c = first / m
    S = m64(xx, xy, xz, xy, yy, yz, xz, yz, zz) / m - wp.outer(c, c)
    return m * (wp.trace(S) * wp.identity(3, dtype=f64) - S)


@wp.func
def add_second_moments(sums: wp.array2d(dtype=f64), b: int, col: int, m: f64, r: v64):
    # m r r^T's six entries (xx, xy, xz, yy, yz, zz) into sums[b, col:col + 6]
    wp.atomic_add(sums, b, col, m * r[0] * r[0])
    wp.atomic_add(sums, b, col + 1, m * r[0] * r[1])
    wp.atomic_add(sums, b, col + 2, m * r[0] * r[2])
    wp.atomic_add(sums, b, col + 3, m * r[1] * r[1])
    wp.atomic_add(sums, b, col + 4, m * r[1] * r[2])
    wp.atomic_add(sums, b, col + 5, m * r[2] * r[2])


@functools.cache
def build_balance(Ft):
    """``(contact_moments, contact_shift, balance_node)`` of scalar type ``Ft`` (module docstring; ``contact_fix``,
    the cpu schedule's one-thread kernel, is :func:`gasp_warp_mpm.schedule.ordered.build_contact_fix`)."""
    contact_moments, contact_shift = build_moments(Ft)
    return contact_moments, contact_shift, build_balance_node(Ft)


@wp.func
def add_contact(jsums: wp.array2d(dtype=f64), s: int, j: f64, r: v64, n: v64, vc: v64, m: f64):
    # a point's normal impulse j along n (its support's velocity vc there) and its mass m into support s's row (JSUMS)
    jn = j * n
    mn = wp.cross(r, jn)
    wp.atomic_add(jsums, s, 0, j)
    wp.atomic_add(jsums, s, 13, m)   # the pushed points' mass (round 59: closing_bound)
    for q in range(3):
        wp.atomic_add(jsums, s, 1 + q, j * r[q])
        wp.atomic_add(jsums, s, 4 + q, jn[q])
        wp.atomic_add(jsums, s, 7 + q, mn[q])
        wp.atomic_add(jsums, s, 10 + q, j * vc[q])
        wp.atomic_min(jsums, s, 14 + 2 * q, r[q])
        wp.atomic_max(jsums, s, 15 + 2 * q, r[q])
    add_second_moments(jsums, s, 20, j, r)
    wp.atomic_add(jsums, s, 26, j * j)


@functools.cache
def build_moments(Ft):
    """``(contact_moments, contact_shift)`` of scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    collider_contact = build_collider_contact(Ft)[0]
    contact_impulse, plane_point = build_contact_impulse(Ft), build_plane_point(Ft)
    Extras = build_extras_struct(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def contact_moments(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), C: wp.array(dtype=mat33),
                        p_mass: wp.array(dtype=Ft), body: wp.array(dtype=wp.int32), p_contact: wp.array(dtype=vec3),
                        planes: wp.array(dtype=vec3), plane_n: wp.array(dtype=vec3), dt: Ft, dx: Ft,
                        sums: wp.array2d(dtype=f64),
                        jsums: wp.array2d(dtype=f64), ex: Extras, colc: int, n_sup: int):
        p = wp.tid()
        b = body[p]
        xp = x[p]
        vp = v[p]
        m = f64(p_mass[p])
        r = v64(f64(xp[0]), f64(xp[1]), f64(xp[2]))
        mv = m * v64(f64(vp[0]), f64(vp[1]), f64(vp[2]))
        # angular momentum: m x x v and APIC's spin m D (C_zy - C_yz, C_xz - C_zx, C_yx - C_xy), D = dx^2 / 4
        Cp = C[p]
        spin = (f64(0.25) * f64(dx) * f64(dx)) * v64(f64(Cp[2, 1] - Cp[1, 2]), f64(Cp[0, 2] - Cp[2, 0]),
                                                     f64(Cp[1, 0] - Cp[0, 1]))
        lr = wp.cross(r, mv) + m * spin
        wp.atomic_add(sums, b, 0, m)
        for q in range(3):
            wp.atomic_add(sums, b, 1 + q, m * r[q])
            wp.atomic_add(sums, b, 10 + q, mv[q])
            wp.atomic_add(sums, b, 13 + q, lr[q])
        add_second_moments(sums, b, 4, m, r)
        kcs = p_contact[p]
        for q in range(planes.shape[0]):   # support 0: the grounds; a wall's face: its own (planes[q][2])
            jq = Ft(0.0)
            xq, vq, kq, own = plane_point(ex, b, xp, vp, plane_n[q], kcs, p_mass[p])   # round 88: a rigid sphere
            depth = planes[q][0] + kq[2] - wp.dot(plane_n[q], xq)   # plane_contact, with the rigid bodies' law
            if depth > Ft(0.0):
                jq = contact_impulse(ex, b, ex.plane_e[q], wp.dot(plane_n[q], vq), 0, plane_n[q], depth, kq, dt, xq,
                                     own)
            if jq > Ft(0.0):
                nq = plane_n[q]
                add_contact(jsums, b * n_sup + int(planes[q][2]), f64(jq), v64(f64(xq[0]), f64(xq[1]), f64(xq[2])),
                            v64(f64(nq[0]), f64(nq[1]), f64(nq[2])), v64(f64(0.0)), m)
        if colc != 0:   # support 1 + cc: collider cc
            base = ex.step[0] * ex.width
            for cc in range(ex.n_col):
                jq, n, vc, xq = collider_contact(ex, base, cc, xp, vp, kcs, dt, b, 0, p_mass[p])
                if jq > Ft(0.0):
                    add_contact(jsums, b * n_sup + 1 + cc, f64(jq), v64(f64(xq[0]), f64(xq[1]), f64(xq[2])),
                                v64(f64(n[0]), f64(n[1]), f64(n[2])), v64(f64(vc[0]), f64(vc[1]), f64(vc[2])), m)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def contact_shift(sums: wp.array2d(dtype=f64), shift: wp.array2d(dtype=f64)):
        b = wp.tid()
        M = sums[b, 0]
        c = v64(f64(0.0))
        V = v64(f64(0.0))
        omega = v64(f64(0.0))
        Lc = v64(f64(0.0))
        if M > f64(0.0):
            c = v64(sums[b, 1], sums[b, 2], sums[b, 3]) / M
            V = v64(sums[b, 10], sums[b, 11], sums[b, 12]) / M
            inertia = inertia_of(M, v64(sums[b, 1], sums[b, 2], sums[b, 3]), sums[b, 4], sums[b, 5], sums[b, 6],
                                 sums[b, 7], sums[b, 8], sums[b, 9])
            Lc = v64(sums[b, 13], sums[b, 14], sums[b, 15]) - M * wp.cross(c, V)
            if wp.determinant(inertia) > f64(0.0):
                omega = wp.inverse(inertia) * Lc
        for q in range(3):
            shift[b, q] = c[q]
            shift[b, 3 + q] = V[q]
            shift[b, 6 + q] = omega[q]
            shift[b, 9 + q] = Lc[q]
        for q in range(16):
            sums[b, q] = f64(0.0)

    return contact_moments, contact_shift


@functools.cache
def build_balance_node(Ft):
    """``balance_node``, the grid update's function of scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def balance_node(node: int, v_in: vec3, v_out: vec3, m: Ft, fb: Ft, X: vec3,
                     grid_fbody: wp.array(dtype=wp.int32), fr_sums: wp.array2d(dtype=f64),
                     fr_nodes: wp.array(dtype=wp.int32), fr_dv: wp.array(dtype=vec4), fr_fb: wp.array(dtype=Ft)):
        # fr_dv, fr_fb: one entry per node on the gpu schedule (the node's friction change, mass and budget kept for
        # its block reduction, gasp_warp_mpm.schedule.gpu), one unused entry on the cpu schedule (the atomics below)
        b = grid_fbody[node]
        if b >= 0 and fr_dv.shape[0] > 1:
            dvg = v_out - v_in
            fr_dv[node] = vec4(dvg[0], dvg[1], dvg[2], m)
            fr_fb[node] = fb
        elif b >= 0:
            r = v64(f64(X[0]), f64(X[1]), f64(X[2]))
            dvf = v_out - v_in
            f = f64(m) * v64(f64(dvf[0]), f64(dvf[1]), f64(dvf[2]))
            tq = wp.cross(r, f)
            mm = f64(m)
            for q in range(3):
                wp.atomic_add(fr_sums, b, q, f[q])
                wp.atomic_add(fr_sums, b, 4 + q, mm * r[q])
                wp.atomic_add(fr_sums, b, 13 + q, tq[q])
            wp.atomic_add(fr_sums, b, 3, mm)
            add_second_moments(fr_sums, b, 7, mm, r)
            wp.atomic_add(fr_sums, b, 16, f64(fb))
            slot = wp.atomic_add(fr_nodes, 0, 1) + 1
            if slot < fr_nodes.shape[0]:
                fr_nodes[slot] = node
            else:
                grid_fbody[node] = -1

    return balance_node


@wp.func
def support_frame(jsums: wp.array2d(dtype=f64), s: int):
    # support s's mean contact normal (sum j n normalised; +z without one), the impulses' centre and the support's
    # mean velocity there
    J = jsums[s, 0]
    jn = v64(jsums[s, 4], jsums[s, 5], jsums[s, 6])
    ln = wp.length(jn)
    nb = v64(f64(0.0), f64(0.0), f64(1.0))
    if ln > f64(0.0):
        nb = jn / ln
    xb = v64(f64(0.0))
    vb = v64(f64(0.0))
    if J > f64(0.0):
        xb = v64(jsums[s, 1], jsums[s, 2], jsums[s, 3]) / J
        vb = v64(jsums[s, 10], jsums[s, 11], jsums[s, 12]) / J
    return nb, xb, vb


@wp.func
def beyond_box(jsums: wp.array2d(dtype=f64), s: int, c: v64, nb: v64, reach: f64):
    # whether the line through c along nb misses the pushed points' box grown by reach (slab test): the mass
    # centre beyond its support, which then tips (on the ground, nb = +z: c's x or y beyond the box's)
    tmin = f64(-1.0e30)
    tmax = f64(1.0e30)
    out = False
    for d in range(3):
        lo = jsums[s, 14 + 2 * d] - reach
        hi = jsums[s, 15 + 2 * d] + reach
        if wp.abs(nb[d]) < f64(1.0e-9):
            if c[d] < lo or c[d] > hi:
                out = True
        else:
            t1 = (lo - c[d]) / nb[d]
            t2 = (hi - c[d]) / nb[d]
            tmin = wp.max(tmin, wp.min(t1, t2))
            tmax = wp.min(tmax, wp.max(t1, t2))
    return out or tmin > tmax


@wp.func
def keep_braking(th: v64, omega: v64, L: v64, nb: v64):
    # the torque to take back, less its part that brakes the body's spin about an axis in the contact plane (normal
    # nb), up to stopping it: the balance takes back what would start a spin, never what stops one (docs/contact.md)
    wh = omega - wp.dot(omega, nb) * nb
    lw = wp.length(wh)
    out = th
    if lw > f64(0.0):
        w = wh / lw
        s = wp.dot(th, w)
        Lw = wp.dot(L, w)
        if s < f64(0.0) and Lw > f64(0.0):
            out = th - wp.max(s, -Lw) * w
    return out


@wp.func
def support_dv(fr_sums: wp.array2d(dtype=f64), s: int, X: v64):
    # support s's velocity change at the point X (f64): its dv plus alpha x (X - x_m) (fr_sums[s, 17:26], body_fix)
    return v64(fr_sums[s, 17], fr_sums[s, 18], fr_sums[s, 19]) + wp.cross(
        v64(fr_sums[s, 20], fr_sums[s, 21], fr_sums[s, 22]), X - v64(fr_sums[s, 23], fr_sums[s, 24], fr_sums[s, 25]))


@wp.func
def closing_bound(dF: v64, alpha: v64, inertia: m64, Mc: f64, um: v64, omega: v64, dv_j: f64):
    # the factor (1 at most) on a support's fix that holds it to the pair's closing motion at its listed nodes (round
    # 59; taichi_mpm's balance.closing_bound has the reason): the fix's mass-weighted root mean square velocity change
    # over the listed nodes, sqrt(|dF|^2 / Mc^2 + alpha . I alpha / Mc) (I their inertia about x_m), at most the
    # body's rigid velocity relative to the support there, sqrt(|u_m|^2 + omega . I omega / Mc), plus dv_j, the
    # velocity change the support's normal impulse gives the points it pushes (J / M_p; J / M for a rigid body)
    ms = wp.dot(dF, dF) / (Mc * Mc) + wp.dot(alpha, inertia * alpha) / Mc
    cap = wp.sqrt(wp.dot(um, um) + wp.max(wp.dot(omega, inertia * omega), f64(0.0)) / Mc) + dv_j
    k = f64(1.0)
    if ms > cap * cap:
        k = cap / wp.sqrt(ms)
    return k


@wp.func
def body_fix(s: int, b: int, shift: wp.array2d(dtype=f64), jsums: wp.array2d(dtype=f64),
             fr_sums: wp.array2d(dtype=f64), mass: f64, reach: f64, g_dt: v64, rigid: int):
    # support s (of body b): its dv, alpha and x_m into fr_sums[s, 17:26], held to the pair's closing motion
    # (closing_bound; rigid: whether body b is rigid)
    Mc = fr_sums[s, 3]
    if Mc > f64(0.0) and mass > f64(0.0):
        xm = v64(fr_sums[s, 4], fr_sums[s, 5], fr_sums[s, 6]) / Mc
        c = v64(shift[b, 0], shift[b, 1], shift[b, 2])
        J = jsums[s, 0]
        nb, xb, vb = support_frame(jsums, s)
        F = v64(fr_sums[s, 0], fr_sums[s, 1], fr_sums[s, 2])
        # Coulomb on the rigid motion relative to the support at the centre of pressure (the impulses' centre
        # in the contact plane, the contact nodes' along the normal): stop its sliding, at most the budget
        xcp = xb + wp.dot(xm - xb, nb) * nb
        u = v64(shift[b, 3], shift[b, 4], shift[b, 5]) + g_dt \
            + wp.cross(v64(shift[b, 6], shift[b, 7], shift[b, 8]), xcp - c) - vb
        ut = u - wp.dot(u, nb) * nb
        lt = wp.length(ut)
        Fexp = v64(f64(0.0))
        if lt > f64(0.0):
            Fexp = -(wp.min(fr_sums[s, 16], mass * lt) / lt) * ut
        dF = Fexp - (F - wp.dot(F, nb) * nb)
        # the contact's torque about c: normal (sum x x j n - c x sum j n), friction, the force change at x_m
        tn = v64(jsums[s, 7], jsums[s, 8], jsums[s, 9]) - wp.cross(c, v64(jsums[s, 4], jsums[s, 5], jsums[s, 6]))
        tf = v64(fr_sums[s, 13], fr_sums[s, 14], fr_sums[s, 15]) - wp.cross(c, F)
        tq = tn + tf + wp.cross(xm - c, dF)
        th = tq - wp.dot(tq, nb) * nb   # the twist about the normal is kept
        lh = wp.length(th)
        clip = J * reach * f64(TORQUE_CLIP)
        if PLANE_RULE != 0:   # round 86: bounded by the patch's departure from a plane (gasp_core.mpm.take_back)
            clip = clip * unresolved_fraction(jsums, s, nb, reach / f64(REACH_H))
        if lh > clip:
            th = th * (clip / lh)
        th = keep_braking(th, v64(shift[b, 6], shift[b, 7], shift[b, 8]), v64(shift[b, 9], shift[b, 10], shift[b, 11]),
                          nb)
        if beyond_box(jsums, s, c, nb, reach):
            th = v64(f64(0.0))   # the mass centre beyond the pushed points' box: the body tips, keep it all
        inertia = inertia_of(Mc, v64(fr_sums[s, 4], fr_sums[s, 5], fr_sums[s, 6]), fr_sums[s, 7], fr_sums[s, 8],
                             fr_sums[s, 9], fr_sums[s, 10], fr_sums[s, 11], fr_sums[s, 12])
        alpha = v64(f64(0.0))
        tr = wp.trace(inertia)
        if tr > f64(0.0) and wp.determinant(inertia) > f64(1.0e-12) * tr * tr * tr:   # tr > 0: one node, no torque
            alpha = -(wp.inverse(inertia) * th)
        dv_j = f64(0.0)   # J's velocity change on the pushed points (mass jsums[s, 13]); a rigid body's move as one
        if rigid != 0:
            dv_j = J / mass
        elif jsums[s, 13] > f64(0.0):
            dv_j = J / jsums[s, 13]
        omega = v64(shift[b, 6], shift[b, 7], shift[b, 8])
        k = closing_bound(dF, alpha, inertia, Mc, u + wp.cross(omega, xm - xcp), omega, dv_j)   # round 59
        dF = dF * k
        alpha = alpha * k
        for q in range(3):
            fr_sums[s, 17 + q] = dF[q] / Mc
            fr_sums[s, 20 + q] = alpha[q]
            fr_sums[s, 23 + q] = xm[q]
