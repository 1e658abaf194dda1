"""The particle contact with the grounds, walls and colliders (engine option ``contact = "particle"``, ``gasp_core.mpm.contact``,
``docs/contact.md``), as Warp functions per scalar type (:mod:`gasp_warp_mpm.precision`); taichi_mpm's
``contact.py`` spells the same steps.

- :func:`build_contact` ``plane_contact``: in P2G, a point's normal impulse ``j_n = max(0, dt (k depth - c v . n))``
  from each plane (the grounds and the walls' faces, ``gasp_core.mpm.contact.contact_planes``) less than its skin
  from its centre (``depth = offset + skin - n . x``), along its normal ``n``, and its friction budget
  ``sum mu j_n``, which P2G adds to its nodes with its weights (``transfers.scatter_scalar``);
- ``node_friction``: in the grid update, the node's tangential (x, y) velocity loses ``min(budget / m, |v_t|)``
  (the grounds alone; with walls or colliders ``surface_friction``, in the plane normal to the nodes' normal);
- :func:`build_collider_contact`: the same against the ``[[collider]]``s' signed distances (``depth = skin - phi``,
  the impulse along the outward normal, friction relative to the collider in the plane normal to the nodes'
  budget-weighted normal), with the particle contact and colliders;
- :func:`build_passive_hold` ``hold_passive``: after a passive point's update, the point put back in the box the
  boundaries keep it in (``gasp_core.mpm.points.passive_bounds``, ``hold_passive``).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.contact import DAMPING
from gasp_core.mpm.rigid import RIGID_LEVER
from gasp_core.mpm.grid_tables import CM_FRICTION, COL_META

from .colliders import build_collider_at
from .forces import build_extras_struct
from .precision import build_types
from .round_collider import build_round_collider, round_point


@functools.cache
def build_contact(Ft):
    """``(plane_contact, node_friction)`` Warp functions of the scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def plane_contact(n: vec3, row: vec3, kcs: vec3, x: vec3, v: vec3, dt: Ft):
        # plane n . x = row[0] (row = (offset, friction, support)); kcs = (k, c, skin) of the point: its j_n along n
        jq = Ft(0.0)
        depth = row[0] + kcs[2] - wp.dot(n, x)
        if depth > Ft(0.0):
            jq = wp.max(dt * (kcs[0] * depth - kcs[1] * wp.dot(n, v)), Ft(0.0))
        return jq

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
def build_contact_impulse(Ft):
    """``contact_impulse(ex, b, e_sup, vn, mark, n, depth, kcs, dt, x, own) -> j_n``, a Warp function of the scalar type
    ``Ft``: a point of body ``b`` at ``depth`` (m, > 0) in a support of restitution ``e_sup``, ``vn`` its normal
    velocity relative to it (m/s), ``n`` the normal, ``kcs = (k, c, skin)``: ``max(0, dt (k depth - c vn))``; a
    rigid body's point with restitution (``ex.rb_e[b]`` >= 0, ``gasp_core.mpm.restitution``) while its body
    bounces: ``dt k depth`` while it approaches (``vn`` < 0), ``e^2 dt k depth`` while it recedes (the hysteresis of
    Walton & Braun 1986), ``e = ex.rb_e[b] e_sup``; once ``e`` times the approach speed of the body's ongoing contact
    (``ex.rb_vin[b]``) is below ``ex.v_rest``, a damped law set by the body (``c = 2 DAMPING dt k``); its ``k``
    times ``N / max(N, N_touch)`` (``ex.rb_nface``, ``ex.rb_nlast``:
    ``gasp_core.mpm.rigid.face_counts``; ``own`` 1: unscaled, a rigid sphere's share on a plane, round 88); its damping on the normal velocity of its patch's centre on a rounded
    body (``x`` the point, m; ``ex.rb_flat``, issue 67). With ``mark`` (in P2G) it records the touch, the
    approach speed and ``dt k depth`` along ``n`` and times ``e_sup`` for ``rigid.rigid_update``'s lift-off;
    taichi_mpm's ``Rigid.contact_impulse`` spells the same."""
    vec3 = build_types(Ft)[0]
    Extras = build_extras_struct(Ft)

    @wp.func
    def contact_impulse(ex: Extras, b: int, e_sup: Ft, vn: Ft, mark: int, n: vec3, depth: Ft, kcs: vec3, dt: Ft,
                        x: vec3, own: int):
        jq = wp.max(dt * (kcs[0] * depth - kcs[1] * vn), Ft(0.0))
        if ex.rb_e[b] >= Ft(0.0):
            n_t = wp.max(Ft(wp.max(ex.rb_nlast[b], ex.rb_ndepth[b])), Ft(1.0))
            sk = ex.rb_nface[b] / wp.max(ex.rb_nface[b], n_t)
            if own != 0:   # round 88: a rigid sphere's share of its body's stiffness (plane_point), not scaled
                sk = Ft(1.0)
            elif ex.rb_ndepth[b] > 0:
                # the points this P2G finds in the planes counted (rigid.py's rigid_depth): N / max(n_t, min(N,
                # LEVER n_t)), Omega dt 1 on more than N points, at most 1 on a few (gasp_core.mpm.rigid.
                # support_scale; taichi_mpm's contact_impulse)
                sk = ex.rb_nface[b] / wp.max(n_t, wp.min(ex.rb_nface[b], Ft(RIGID_LEVER) * n_t))
            jk = dt * kcs[0] * sk * depth
            # settling: per point c = 2 zeta dt k', at most 2 zeta of the body's normal speed a substep
            # (taichi_mpm's contact_impulse)
            c = Ft(2.0 * DAMPING) * dt * kcs[0] * sk
            # on a rounded body the patch centre's normal velocity, not the point's (taichi_mpm's rolling_vn):
            # blended by the last substep's flatness
            xd = wp.vec3d(wp.float64(x[0]), wp.float64(x[1]), wp.float64(x[2]))
            nd = wp.vec3d(wp.float64(n[0]), wp.float64(n[1]), wp.float64(n[2]))
            roll = (wp.float64(1.0) - ex.rb_flat[b]) * wp.dot(nd, wp.cross(ex.rb_wx[b], ex.rb_xf[b] - xd))
            jq = wp.max(jk - dt * c * (vn + Ft(roll)), Ft(0.0))
            if mark != 0:
                wp.atomic_max(ex.rb_deep, b, wp.float64(depth))
                wp.atomic_add(ex.rb_count, b, 1)
                ex.rb_touch[b] = 1
                wp.atomic_add(ex.rb_jn, b, jk * n)
                wp.atomic_add(ex.rb_je, b, jk * e_sup)
                wp.atomic_add(ex.rb_j, b, jk)
                if vn < Ft(0.0):
                    wp.atomic_max(ex.rb_vin_next, b, -vn)
            e = ex.rb_e[b] * e_sup
            if e * ex.rb_vin[b] >= ex.v_rest:
                jq = jk
                if vn >= Ft(0.0):
                    jq = e * e * jk
        return jq

    return contact_impulse


@functools.cache
def build_plane_point(Ft):
    """``plane_point(ex, b, x, v, n, kcs, m) -> (x*, v*, kcs*, own)``, a Warp function of the scalar type ``Ft``:
    where a point of body ``b`` at ``x`` with velocity ``v``, contact row ``kcs`` and mass ``m`` meets a plane of
    normal ``n``. A rigid sphere (``ex.rb_rad[b]`` > 0, round 88, ``gasp_core.mpm.round_ground``) meets it at its
    exact contact point ``x* = c - R n`` (``c = ex.rb_cx[b]``); a solid cylinder (its rest axis ``ex.rb_ax[b]``, turned
    by ``ex.rb_rot[b]`` to ``e``) at the point of the line under its axis at the point's slice, ``c + (e . (x - c)) e -
    R n_perp`` (``n_perp`` the normal across the axis; within ``round_ground.CYL_LINE`` of standing on an end, its
    points); moving at ``v + w x (x* - x)`` (``w = ex.rb_wx[b]``),
    with its mass's share of the body's stiffness, ``kcs* = (w2 m, 2 DAMPING sqrt(w2) m, 0)`` (``w2 = ex.rb_w2 =
    (RIGID_OMEGA_DT / dt)^2``), its own (``own`` 1: ``contact_impulse`` does not scale it); every other point at
    itself with its row (``own`` 0). taichi_mpm's ``RigidLift.plane_point``."""
    vec3 = build_types(Ft)[0]
    Extras = build_extras_struct(Ft)

    @wp.func
    def plane_point(ex: Extras, b: int, x: vec3, v: vec3, n: vec3, kcs: vec3, m: Ft):
        xq = x
        vq = v
        kq = kcs
        own = int(0)
        xd = wp.vec3d(wp.float64(x[0]), wp.float64(x[1]), wp.float64(x[2]))
        c = xd
        on = int(0)
        if ex.rb_rad[b] > wp.float64(0.0):   # the rigid bodies' arrays are read for a round body alone
            c, on = round_point(ex.rb_cx[b], ex.rb_rad[b], ex.rb_ax[b], ex.rb_rot[b], xd,
                                wp.vec3d(wp.float64(n[0]), wp.float64(n[1]), wp.float64(n[2])), ex.rb_band[b])
        if on != 0:
            xq = vec3(Ft(c[0]), Ft(c[1]), Ft(c[2]))
            dv = wp.cross(ex.rb_wx[b], c - xd)
            vq = v + vec3(Ft(dv[0]), Ft(dv[1]), Ft(dv[2]))
            k = ex.rb_w2 * m
            kq = vec3(k, Ft(2.0 * DAMPING) * wp.sqrt(k * m), Ft(0.0))
            own = 1
        return xq, vq, kq, own

    return plane_point


@functools.cache
def build_add_twist(Ft):
    """``add_twist(ex, b, x, mu, jq, n, vc)``, a Warp function of the scalar type ``Ft``: a rigid body's point at ``x``
    with the normal impulse ``jq`` from a support of friction ``mu``, normal ``n`` and velocity ``vc`` adds its budget
    ``mu jq`` times its lever about the normal through its body's centre to ``ex.rb_twist[b]``, the budget's moments
    to ``ex.rb_fx[b]`` and ``ex.rb_fv[b]``, the impulse's to ``ex.rb_jx`` (``rigid.py``'s twist and slide brakes;
    taichi_mpm's ``Rigid.add_twist``)."""
    vec3 = build_types(Ft)[0]
    Extras = build_extras_struct(Ft)

    @wp.func
    def add_twist(ex: Extras, b: int, x: vec3, mu: Ft, jq: Ft, n: vec3, vc: vec3):
        # a rigid body's point: its friction budget times its lever about the normal through the body's centre, the
        # most angular momentum about the normal Coulomb's friction can take this substep (taichi_mpm's add_twist)
        if ex.rb_e[b] >= Ft(0.0):
            c = ex.rb_cx[b]
            xd = wp.vec3d(wp.float64(x[0]), wp.float64(x[1]), wp.float64(x[2]))
            r = xd - c
            nd = wp.vec3d(wp.float64(n[0]), wp.float64(n[1]), wp.float64(n[2]))
            j = wp.float64(jq)
            f = wp.float64(mu) * j
            wp.atomic_add(ex.rb_twist, b, f * wp.length(r - wp.dot(r, nd) * nd))
            wp.atomic_add(ex.rb_fx, b, wp.vec4d(f * xd[0], f * xd[1], f * xd[2], f))
            wp.atomic_add(ex.rb_fv, b, f * wp.vec3d(wp.float64(vc[0]), wp.float64(vc[1]), wp.float64(vc[2])))
            k = 10 * b
            wp.atomic_add(ex.rb_jx, k, j)
            wp.atomic_add(ex.rb_jx, k + 1, j * xd[0])
            wp.atomic_add(ex.rb_jx, k + 2, j * xd[1])
            wp.atomic_add(ex.rb_jx, k + 3, j * xd[2])
            wp.atomic_add(ex.rb_jx, k + 4, j * xd[0] * xd[0])
            wp.atomic_add(ex.rb_jx, k + 5, j * xd[0] * xd[1])
            wp.atomic_add(ex.rb_jx, k + 6, j * xd[0] * xd[2])
            wp.atomic_add(ex.rb_jx, k + 7, j * xd[1] * xd[1])
            wp.atomic_add(ex.rb_jx, k + 8, j * xd[1] * xd[2])
            wp.atomic_add(ex.rb_jx, k + 9, j * xd[2] * xd[2])

    return add_twist


@functools.cache
def build_collider_contact(Ft):
    """``(collider_contact, point_contact, surface_friction)`` Warp functions of the scalar type ``Ft``: the particle
    contact against the ``[[collider]]``s' signed distances (``gasp_core.mpm.contact.surface_impulse``).
    It is long because the three are closures of the scalar type, built together.

    - ``collider_contact(ex, base, cc, x, v, kcs, dt, b, mark, m) -> (j_n, n, v_c, x*)``: collider ``cc``'s normal
      impulse on a point of body ``b`` of mass ``m`` (``build_contact_impulse``), ``depth = skin - phi``, along its
      outward normal ``n``, acting at ``x*``: the point itself, or a rigid sphere's or cylinder's contact point on its
      exact shape (round 89, ``round_collider.build_round_collider``; ``ex.rb_col``);
    - ``point_contact(...) -> (impulse, budget, budget n, budget v_c, support)``: the planes' and the colliders'
      impulses on a point summed, its friction budget, the budget-weighted normal and collider velocity (for the
      nodes' friction) and the support that pushes it most (0: the grounds, 1 + cc: collider cc, then the walls'
      faces, ``planes[q][2]``; -1: none);
    - ``surface_friction(vel, m, fb, fn, fv)``: a node's Coulomb friction in the plane normal to its budget-weighted
      normal ``fn``, on its velocity relative to the supports' ``fv / fb``.
    """
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    collider_at = build_collider_at(Ft)
    contact_impulse, add_twist = build_contact_impulse(Ft), build_add_twist(Ft)
    plane_point, round_collider = build_plane_point(Ft), build_round_collider(Ft)

    @wp.func
    def collider_contact(ex: Extras, base: int, cc: int, x: vec3, v: vec3, kcs: vec3, dt: Ft, b: int, mark: int,
                         pm: Ft):
        on = int(0)
        depth = Ft(0.0)
        n = vec3(Ft(0.0))
        vc = vec3(Ft(0.0))
        xq = x
        vq = v
        kq = kcs
        if ex.rb_col != 0 and ex.rb_rad[b] > wp.float64(0.0):   # round 89: a rigid sphere or cylinder on its shape
            on, depth, n, vc, xq, vq, kq = round_collider(ex, base, cc, x, v, pm, b)
        if on == 0:
            phi, n0, vc0 = collider_at(x, cc, base, ex, kcs[2])
            depth = kcs[2] - phi
            n = n0
            vc = vc0
            xq = x
            vq = v
            kq = kcs
        jq = Ft(0.0)
        if depth > Ft(0.0) and (kq[0] > Ft(0.0) or on == 0):
            jq = contact_impulse(ex, b, Ft(1.0), wp.dot(vq - vc, n), mark, n, depth, kq, dt, xq, on)
        return jq, n, vc, xq

    @wp.func
    def point_contact(planes: wp.array(dtype=vec3), plane_n: wp.array(dtype=vec3), kcs: vec3, x: vec3, v: vec3,
                      dt: Ft, colc: int, ex: Extras, b: int, pm: Ft):
        imp = vec3(Ft(0.0))
        bud = Ft(0.0)
        fn = vec3(Ft(0.0))
        fv = vec3(Ft(0.0))
        sup = int(-1)
        jbest = Ft(0.0)
        for q in range(planes.shape[0]):   # the grounds (support 0) and the walls' faces (each its own)
            jq = Ft(0.0)
            # round 88: a rigid sphere at its contact point, its points with mass each its share
            xq, vq, kq, own = plane_point(ex, b, x, v, plane_n[q], kcs, pm)
            depth = planes[q][0] + kq[2] - wp.dot(plane_n[q], xq)   # build_contact's plane_contact, with the law
            if depth > Ft(0.0) and (kq[0] > Ft(0.0) or own == 0):
                jq = contact_impulse(ex, b, ex.plane_e[q], wp.dot(plane_n[q], vq), 1, plane_n[q], depth, kq, dt,
                                     xq, own)
            if jq > Ft(0.0):
                mu = planes[q][1]
                imp = imp + jq * plane_n[q]
                bud = bud + mu * jq
                add_twist(ex, b, xq, mu, jq, plane_n[q], vec3(Ft(0.0)))
                fn = fn + (mu * jq) * plane_n[q]
                if jq > jbest:
                    sup = int(planes[q][2])
                    jbest = jq
        if colc != 0:
            base = ex.step[0] * ex.width
            for cc in range(ex.n_col):
                jq, n, vc, xq = collider_contact(ex, base, cc, x, v, kcs, dt, b, 1, pm)
                if jq > Ft(0.0):
                    mu = ex.meta[cc * COL_META + CM_FRICTION]
                    imp = imp + jq * n
                    bud = bud + mu * jq
                    add_twist(ex, b, xq, mu, jq, n, vc)
                    fn = fn + (mu * jq) * n
                    fv = fv + (mu * jq) * vc
                    if jq > jbest:
                        sup = 1 + cc
                        jbest = jq
        if ex.rb_e[b] >= Ft(0.0):
            # a rigid body with restitution: its friction acts on the body as one (rigid.py's slide brake, issue 67),
            # its points give the nodes no budget (taichi_mpm's Rigid.node_budget)
            bud = Ft(0.0)
        return imp, bud, fn, fv, sup

    @wp.func
    def surface_friction(vel: vec3, m: Ft, fb: Ft, fn: vec3, fv: vec3):
        out = vel
        ln = wp.length(fn)
        if fb > Ft(0.0) and ln > Ft(0.0):
            n = fn / ln
            u = vel - fv / fb
            ut = u - wp.dot(u, n) * n
            lt = wp.length(ut)
            if lt > Ft(0.0):
                out = vel - (wp.min(fb / m, lt) / lt) * ut
        return out

    return collider_contact, point_contact, surface_friction


@functools.cache
def build_passive_hold(Ft):
    """``hold_passive(x, v, lo, hi, stranded, mu) -> (x, v)``, a Warp function of the scalar type ``Ft``: on each axis
    a passive point below ``lo[d]`` is put at ``lo[d]`` with ``v[d] = max(v[d], 0)``, above ``hi[d]`` at ``hi[d]`` with
    ``v[d] = min(v[d], 0)``; a ``stranded`` one (nonzero: no node with mass in its stencil) held on the floor ``lo[2]``
    loses ``mu`` times the speed into it removed from its horizontal speed, Coulomb friction
    (``gasp_core.mpm.points.hold_passive``: a massless surface marker cannot be inside the ground or the walls,
    nor slide on the ground for ever)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def hold_passive(x: vec3, v: vec3, lo: vec3, hi: vec3, stranded: int, mu: Ft):
        xo = x
        vo = v
        for d in range(3):
            if xo[d] < lo[d]:
                xo[d] = lo[d]
                vo[d] = wp.max(vo[d], Ft(0.0))
            if xo[d] > hi[d]:
                xo[d] = hi[d]
                vo[d] = wp.min(vo[d], Ft(0.0))
        if stranded != 0 and x[2] < lo[2]:
            vt = wp.sqrt(vo[0] * vo[0] + vo[1] * vo[1])
            if vt > Ft(0.0):
                keep = Ft(1.0) - wp.min(vt, mu * (vo[2] - v[2])) / vt
                vo = vec3(vo[0] * keep, vo[1] * keep, vo[2])
        return xo, vo

    return hold_passive

