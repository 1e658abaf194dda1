"""Rigid bodies among three or more (round 62; the NumPy reference and the design are
:mod:`gasp_core.mpm.rigid_pairs`, taichi_mpm's ``rigid_pairs.py`` spells the same steps): ``node_slot``, the pair of
rigid bodies a node between the two fields serves (``fields.field_contact`` sums the touching nodes per pair), and
``rigid_pairs``, the touching pairs solved together by projected Gauss-Seidel once a substep after the rigid update.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import numpy as np
import warp as wp

from .precision import MODULE_OPTIONS, build_types
from .foot import foot_approach, foot_arms, foot_mass, foot_point
from .rigid_support import (Hollow, allowed_approach, body_row, pair_gap, roll_flat_at, roll_point_at, round_normal,
                            slip_at, tip)

vec3d = wp.types.vector(3, wp.float64)
mat33d = wp.types.matrix((3, 3), wp.float64)


@functools.cache
def build_node_slot(Ft):
    """``node_slot``: 1 + ``a * nb + b`` for the rigid body ``a`` of field A and ``b`` of field B whose boxes (in their
    frames, ``gasp_core.mpm.rigid_pairs.node_bodies``) the node ``xn`` lies within ``pad`` (m) of, the nearest of each
    field; 0 where a field has none there (a soft body: the nodes' Coulomb correction, which round 64's rigid
    collider, ``rigid_collider.py``, replaces at the rigid body's nodes)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def node_slot(xn: vec3, in_a: wp.array(dtype=wp.int32), rigid: wp.array(dtype=wp.int32),
                  centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), box: wp.array(dtype=vec3d), nb: int,
                  pad: wp.float64):
        best_a = int(-1)
        best_b = int(-1)
        da = wp.float64(1.0e30)
        db = wp.float64(1.0e30)
        x = vec3d(wp.float64(xn[0]), wp.float64(xn[1]), wp.float64(xn[2]))
        for k in range(nb):
            if rigid[k] != 0:
                q = wp.transpose(rot[k]) * (x - centre[k])
                lo = box[2 * k]
                hi = box[2 * k + 1]
                d = wp.float64(0.0)
                for ax in range(3):
                    d = wp.max(d, wp.max(lo[ax] - q[ax], q[ax] - hi[ax]))
                if d <= pad:
                    if in_a[k] != 0:
                        if d < da:
                            da = d
                            best_a = k
                    elif d < db:
                        db = d
                        best_b = k
        out = int(0)
        if best_a >= 0 and best_b >= 0:
            out = 1 + best_a * nb + best_b
        return out

    return node_slot


@functools.cache
def build_pair_update(Ft):
    """``pair_update`` (float64; ``gasp_core.mpm.rigid_pairs._pair_update``): slot ``s``'s normal impulse ``lam[4 s]``
    >= 0 (on its approach less round 91's ``allow``; round 94: at a cylinder's foot), friction ``lam[4 s + 1 : 4 s +
    4]`` in the disk, ``f`` held. It is long because the update's steps (the normal impulse, the rolling, the
    friction, the held tipping spin) share one function's locals, as the NumPy reference's do."""

    @wp.func
    def pair_update(s: int, nb: int, half: wp.float64, mass: wp.array(dtype=wp.float64),
                    inertia0: wp.array(dtype=mat33d), centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d),
                    vel: wp.array(dtype=vec3d), spin: wp.array(dtype=vec3d), mu: wp.array(dtype=wp.float64),
                    acc: wp.array(dtype=wp.float64), lam: wp.array(dtype=wp.float64), rows: wp.array(dtype=wp.int32),
                    t_h: wp.array(dtype=wp.float64), t_curv: wp.array(dtype=mat33d), t_delta: wp.array(dtype=wp.float64),
                    t_round: wp.array(dtype=wp.float64), allow: wp.array(dtype=wp.float64), hol: Hollow):
        a = s / nb
        b = s - a * nb
        n = vec3d(acc[7 * s + 4], acc[7 * s + 5], acc[7 * s + 6])
        ln = wp.length(n)
        if ln > wp.float64(0.0):
            n = n / ln
            x_c = vec3d(acc[7 * s + 1], acc[7 * s + 2], acc[7 * s + 3]) / acc[7 * s]
            MA = mass[a]
            MB = mass[b]
            eye = wp.identity(n=3, dtype=wp.float64)
            IA = rot[a] * inertia0[a] * wp.transpose(rot[a]) + half * MA * eye
            IB = rot[b] * inertia0[b] * wp.transpose(rot[b]) + half * MB * eye
            iA = wp.inverse(IA)
            iB = wp.inverse(IB)
            # round 94 (foot.py): at a cylinder's foot (allow[3 s + 1], pair_normal's; x_c moved onto it there)
            armA, armB = foot_arms(t_round, hol, a, b, rot[a], rot[b], allow[3 * s + 1])
            un = foot_approach(vel[a], spin[a], vel[b], spin[b], armA, armB, n)
            P = wp.max(lam[4 * s] + (un - allow[3 * s]) / foot_mass(MA, MB, iA, iB, armA, armB, n),
                       wp.float64(0.0))
            dP = P - lam[4 * s]
            lam[4 * s] = P
            vel[a] = vel[a] - (dP / MA) * n
            vel[b] = vel[b] + (dP / MB) * n
            spin[a] = spin[a] - dP * (iA * wp.cross(armA, n))
            spin[b] = spin[b] + dP * (iB * wp.cross(armB, n))
            rA = x_c - centre[a]
            rB = x_c - centre[b]
            u = vel[a] + wp.cross(spin[a], rA) - vel[b] - wp.cross(spin[b], rB)
            ut = u - wp.dot(u, n) * n
            lt = wp.length(ut)
            # round 65: a round body rolls (rigid_pairs._pair_update's flat and plane)
            f = roll_flat_at(t_h, t_curv, t_delta, a, b, rows[2 * s], rows[2 * s + 1], rot[a], rot[b], n, ut, lt,
                             spin[a] - spin[b])
            if allow[3 * s + 2] == wp.float64(1.0):   # round 94: a point at a cylinder's foot holds no tipping moment
                f = wp.float64(0.0)
            if f < wp.float64(1.0):
                x_c = roll_point_at(t_h, t_round, a, b, rows[2 * s], rows[2 * s + 1], centre[a], centre[b], n, x_c)
                rA, rB, ut = slip_at(x_c, vel[a], spin[a], centre[a], vel[b], spin[b], centre[b], n)
                lt = wp.length(ut)
            nIA = wp.dot(n, IA * n)
            nIB = wp.dot(n, IB * n)
            J0 = vec3d(lam[4 * s + 1], lam[4 * s + 2], lam[4 * s + 3])
            J = J0
            m_s = mu[s]
            if m_s > wp.float64(0.0) and lt > wp.float64(0.0) and P > wp.float64(0.0):
                t = ut / lt
                sA = wp.dot(wp.cross(rA, t), n)   # the twist arms about n
                sB = wp.dot(wp.cross(rB, t), n)
                k = wp.float64(1.0) / MA + wp.float64(1.0) / MB + sA * sA / nIA + sB * sB / nIB
                if f < wp.float64(1.0):   # (1 - f) of the tipping moment turns each body: in the effective mass
                    k = k + (wp.dot(tip(f, wp.inverse(IA), wp.cross(rA, t), n), wp.cross(rA, t))
                             + wp.dot(tip(f, wp.inverse(IB), wp.cross(rB, t), n), wp.cross(rB, t)))
                J = J + (lt / k) * t
            lJ = wp.length(J)
            if lJ > m_s * P:   # Coulomb's disk of the pair's normal impulse: stick within, else slide on it
                J = J * (wp.max(m_s, wp.float64(0.0)) * P / lJ)
            dJ = J - J0
            lam[4 * s + 1] = J[0]
            lam[4 * s + 2] = J[1]
            lam[4 * s + 3] = J[2]
            vel[a] = vel[a] - dJ / MA
            vel[b] = vel[b] + dJ / MB
            spin[a] = spin[a] - (wp.dot(wp.cross(rA, dJ), n) / nIA) * n
            spin[b] = spin[b] + (wp.dot(wp.cross(rB, dJ), n) / nIB) * n
            if f < wp.float64(1.0):
                spin[a] = spin[a] - tip(f, iA, wp.cross(rA, dJ), n)
                spin[b] = spin[b] + tip(f, iB, wp.cross(rB, dJ), n)
            if P > wp.float64(0.0):   # the faces hold (f of) the relative tipping spin (rigid_pairs._pair_update)
                dw = spin[a] - spin[b]
                L = wp.inverse(iA + iB) * (dw - wp.dot(dw, n) * n)
                if f < wp.float64(1.0):
                    L = f * L
                spin[a] = spin[a] - iA * L
                spin[b] = spin[b] + iB * L

    return pair_update


@wp.func
def pair_normal(acc: wp.array(dtype=wp.float64), s: int, nb: int, t_dirs: wp.array(dtype=vec3d),
                t_h: wp.array(dtype=wp.float64), t_round: wp.array(dtype=wp.float64), nd: int, cos_cone: wp.float64,
                hol: Hollow, rot: wp.array(dtype=mat33d), centre: wp.array(dtype=vec3d), vel: wp.array(dtype=vec3d),
                dt: wp.float64, allow: wp.array(dtype=wp.float64)):
    # slot s's unit normal from its nodes' sum, round 91's from the shapes (rigid_support.round_normal), written back
    # to the sum for pair_update (its table rows are then read from it), and the approach the slot may keep this
    # substep (allowed_approach: 0 where no gap is known)
    a = s / nb
    b = s - a * nb
    nn = vec3d(acc[7 * s + 4], acc[7 * s + 5], acc[7 * s + 6])
    nn = nn / wp.max(wp.length(nn), wp.float64(1.0e-300))
    nn, foot, side = round_normal(t_dirs, t_h, t_round, nd, cos_cone, a, b, rot[a], rot[b], centre[a], centre[b], nn, hol)
    armA, armB = foot_arms(t_round, hol, a, b, rot[a], rot[b], foot)   # round 94: x_c onto a cylinder's foot
    x_c = foot_point(vec3d(acc[7 * s + 1], acc[7 * s + 2], acc[7 * s + 3]) / acc[7 * s], centre[a], centre[b], armA,
                     armB)
    for ax in range(3):
        acc[7 * s + 4 + ax] = nn[ax]
        acc[7 * s + 1 + ax] = x_c[ax] * acc[7 * s]
    gap = pair_gap(t_dirs, t_h, t_round, nd, cos_cone, a, b, rot[a], rot[b], centre[a], centre[b], nn, hol)
    allow[3 * s] = allowed_approach(gap, wp.dot(vel[a] - vel[b], nn), dt)
    allow[3 * s + 1] = foot
    allow[3 * s + 2] = side
    return nn


@functools.cache
def build_rigid_pairs(Ft):
    """``rigid_pairs`` (float64 whatever ``Ft``): ``gasp_core.mpm.rigid_pairs.solve_pairs`` in one thread after
    ``rigid_update``: the touching pairs' sums ``acc`` (7 per slot: sum m_red, sum m_red x, sum m_red n) give each its
    centre and normal; the pairs are ordered by height along gravity (``order``), swept ``sweeps`` times
    (``rigid_pairs.SWEEPS``) with accumulated impulses (``lam``: 4 per slot, P and J; ``build_pair_update``), then
    the centres' advance of the substep follows the new velocities. Round 63: only the touching slots are visited,
    the ``count[0]`` first of ``slots``, which the node kernel listed the first time each got mass (``seen``, 1 per
    slot listed); their ``acc`` and ``seen`` are cleared, and ``count``."""
    pair_update = build_pair_update(Ft)

    @wp.func
    def height(acc: wp.array(dtype=wp.float64), s: int, gravity: vec3d):
        return -wp.dot(gravity, vec3d(acc[7 * s + 1], acc[7 * s + 2], acc[7 * s + 3])) / acc[7 * s]

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_pairs(mass: wp.array(dtype=wp.float64), inertia0: wp.array(dtype=mat33d),
                    centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), vel: wp.array(dtype=vec3d),
                    spin: wp.array(dtype=vec3d), V0: wp.array(dtype=vec3d), dt: wp.float64, dx: wp.float64, nb: int,
                    mu: wp.array(dtype=wp.float64), acc: wp.array(dtype=wp.float64), lam: wp.array(dtype=wp.float64),
                    order: wp.array(dtype=wp.int32), gravity: vec3d, sweeps: int, slots: wp.array(dtype=wp.int32),
                    count: wp.array(dtype=wp.int32), seen: wp.array(dtype=wp.int32), t_dirs: wp.array(dtype=vec3d),
                    t_h: wp.array(dtype=wp.float64), t_curv: wp.array(dtype=mat33d),
                    t_delta: wp.array(dtype=wp.float64), nd: int, t_round: wp.array(dtype=wp.float64),
                    cos_cone: wp.float64, hol: Hollow, rows: wp.array(dtype=wp.int32),
                    allow: wp.array(dtype=wp.float64)):
        n_on = count[0]
        for q in range(n_on):   # the touching pairs, insertion-sorted by (-g . x_c, slot): bottom up, ties by slot
            s = slots[q]
            nn = pair_normal(acc, s, nb, t_dirs, t_h, t_round, nd, cos_cone, hol, rot, centre, vel, dt, allow)
            rows[2 * s] = body_row(t_dirs, nd, s / nb, rot[s / nb], nn)
            rows[2 * s + 1] = body_row(t_dirs, nd, s - (s / nb) * nb, rot[s - (s / nb) * nb], -nn)
            for c in range(4):
                lam[4 * s + c] = wp.float64(0.0)
            h = height(acc, s, gravity)
            j = q
            while j > 0 and (height(acc, order[j - 1], gravity) > h or (
                    height(acc, order[j - 1], gravity) == h and order[j - 1] > s)):
                order[j] = order[j - 1]
                j = j - 1
            order[j] = s
        for b in range(nb):
            V0[b] = vel[b]
        half = wp.float64(0.5) * dx * dx
        for _sweep in range(sweeps):
            for q in range(n_on):
                pair_update(order[q], nb, half, mass, inertia0, centre, rot, vel, spin, mu, acc, lam, rows, t_h,
                            t_curv, t_delta, t_round, allow, hol)
        for b in range(nb):
            centre[b] = centre[b] + dt * (vel[b] - V0[b])
        for q in range(n_on):   # the touching slots back to zero for the next substep
            s = slots[q]
            for c in range(7):
                acc[7 * s + c] = wp.float64(0.0)
            seen[s] = 0
        count[0] = 0

    return rigid_pairs


def allocate_pairs(eng, view) -> None:
    """``eng.pair`` (``gasp_core.mpm.rigid_pairs.pair_mode``: 0, 1 two rigid bodies, 2 rigid bodies among three or
    more), ``eng.pair_acc`` (7 per slot) and, for 2, the solve's arrays: the pairs' ``mu`` per slot, ``lam`` (4 per
    slot), ``order``, each rigid body's box (``body_boxes``, lower and upper per body), ``V0``, and round 63's list of
    the touching slots (``pair_slots``, their count ``pair_n``, ``pair_seen`` 1 per slot listed)."""
    from gasp_core.mpm.rigid_pairs import body_boxes, pair_frictions, pair_mode
    d = eng.device
    eng.pair = int(eng.fields and pair_mode(view)) if eng.fields else 0
    nb = len(view.materials)
    ns = nb * nb if eng.pair == 2 else 1
    eng.pair_acc = wp.zeros(7 * ns, dtype=wp.float64, device=d)
    many = eng.pair == 2
    eng.pair_mu = wp.array(pair_frictions(view) if many else np.zeros(1), dtype=wp.float64, device=d)
    eng.pair_lam = wp.zeros(4 * ns, dtype=wp.float64, device=d)
    eng.pair_order = wp.zeros(ns, dtype=wp.int32, device=d)
    eng.pair_box = wp.array(body_boxes(view).reshape(-1, 3) if many else np.zeros((2, 3)), dtype=vec3d, device=d)
    eng.pair_V0 = wp.zeros(nb if many else 1, dtype=vec3d, device=d)
    eng.pair_slots = wp.zeros(ns, dtype=wp.int32, device=d)   # round 63: the touching slots, listed by the node kernel
    eng.pair_n = wp.zeros(1, dtype=wp.int32, device=d)
    eng.pair_seen = wp.zeros(ns, dtype=wp.int32, device=d)
    eng.pair_rows = wp.zeros(2 * ns, dtype=wp.int32, device=d)   # round 65: each slot's two table rows
    nbi = nb if many else 1   # round 81: the gpu schedule's islands (build_rigid_pairs_gpu)
    eng.pair_key = wp.zeros(ns, dtype=wp.float64, device=d)
    # round 91: the approach each slot may keep; round 94: its cylinder's foot and side flag (3 per slot)
    eng.pair_allow = wp.zeros(3 * ns, dtype=wp.float64, device=d)
    eng.pair_isl = wp.zeros(ns, dtype=wp.int32, device=d)
    eng.pair_isl_list = wp.zeros(ns, dtype=wp.int32, device=d)
    eng.pair_root, eng.pair_isl_of = (wp.zeros(nbi, dtype=wp.int32, device=d) for _ in range(2))
    eng.pair_isl_count, eng.pair_isl_start, eng.pair_isl_fill = (wp.zeros(nbi + 1, dtype=wp.int32, device=d)
                                                                 for _ in range(3))
    eng.pair_isl_n, eng.pair_n_keep = (wp.zeros(1, dtype=wp.int32, device=d) for _ in range(2))


def slot_inputs(eng) -> list:
    """The node kernel's inputs for ``node_slot`` (the rigid bodies' pose) and round 63's list of the touching slots
    (one-entry arrays unless ``eng.pair`` is 2)."""
    from gasp_core.mpm.rigid_pairs import NODE_PAD
    d = eng.device
    listed = [eng.pair_slots, eng.pair_n, eng.pair_seen]   # round 63: the touching slots (one entry unless 2)
    if eng.pair == 2:
        return [eng.rb_rigid, eng.rb_c, eng.rb_R, eng.pair_box, len(eng.setup.materials), float(NODE_PAD * eng.dx),
                *listed]
    return [wp.zeros(1, dtype=wp.int32, device=d), wp.zeros(1, dtype=vec3d, device=d),
            wp.zeros(1, dtype=mat33d, device=d), eng.pair_box, 0, 0.0, *listed]


def pairs_launches(eng, Ft) -> list:
    """The recorded launches of ``rigid_pairs`` (``eng.pair`` 2), after the rigid update, with round 65's support
    tables (``eng.rb_tables``): on the gpu schedule (with ``rigid_pairs.ISLANDS``) round 81's seven launches of
    :func:`build_rigid_pairs_gpu`, else the one-thread kernel; the same bits."""
    from gasp_core.mpm.rigid import affine_dx   # the inertia's M dx^2 / 2: 0 since round 67
    from gasp_core.mpm.rigid_pairs import ISLANDS, SWEEPS, support_data
    from .rigid_support import support_arrays
    eng.rb_tables = support_arrays(support_data(eng.setup), eng.device, len(eng.setup.materials), eng.setup)
    if ISLANDS and eng.schedule == "gpu":
        from .rigid_islands import islands_launches
        return islands_launches(eng, Ft)
    return [wp.launch(build_rigid_pairs(Ft), dim=1, device=eng.device, record_cmd=True, inputs=[
        eng.rb_M, eng.rb_I0, eng.rb_c, eng.rb_R, eng.rb_V, eng.rb_w, eng.pair_V0, float(eng.dt), affine_dx(eng.dx),
        len(eng.setup.materials), eng.pair_mu, eng.pair_acc, eng.pair_lam, eng.pair_order,
        vec3d(*[float(g) for g in eng.setup.gravity]), int(SWEEPS), eng.pair_slots, eng.pair_n, eng.pair_seen,
        *eng.rb_tables, eng.pair_rows, eng.pair_allow])]
