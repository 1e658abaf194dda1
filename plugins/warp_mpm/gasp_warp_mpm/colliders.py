"""Colliders (docs/colliders.md): the Coulomb "separate" collider rule that every boundary applies, and the
signed-distance colliders on a grid node's velocity, as Warp functions per scalar type
(:mod:`gasp_warp_mpm.precision`).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.grid_tables import (CM_FRICTION, CM_H, CM_NX, CM_NY, CM_NZ, CM_OFFSET, CM_ORIGIN, COL_META,
                                           COL_POSE, FT_POSES, PO_R, PO_T, PO_V, PO_W)

from .forces import build_extras_struct
from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_collide(Ft):
    """``collide``: taichi_elements' "separate" collider with Coulomb friction for a unit normal (docs/mpm.md
    step 3), scalar type ``Ft``: the walls, the ground and every signed-distance collider apply it."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def collide(v: vec3, n: vec3, mu_b: Ft):
        # taichi_elements' "separate" collider with Coulomb friction mu_b (docs/mpm.md step 3).
        vn = wp.dot(v, n)
        out = v
        if vn < Ft(0.0):
            vt = v - vn * n
            lt = wp.length(vt)
            if lt > Ft(1e-30):
                out = vt * wp.max(Ft(0.0), Ft(1.0) + mu_b * vn / lt)
            else:
                out = vec3(Ft(0.0))
        return out

    return collide


@functools.cache
def build_blend(Ft):
    """``blend_rule(v, v_rule, w)``, scalar type ``Ft``: a boundary's grid rule applied by the weight ``w``,
    ``v + w (v_rule - v)``; exactly ``v_rule`` at ``w >= 1`` and ``v`` at ``w <= 0`` (the contact chosen per body,
    ``gasp_core.mpm.contact.rule_models``: ``w`` the node's flowing-mass fraction where only the grid contact's
    rule reaches)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def blend_rule(v: vec3, v_rule: vec3, w: Ft):
        out = v_rule
        if w <= Ft(0.0):
            out = v
        elif w < Ft(1.0):
            out = v + w * (v_rule - v)
        return out

    return blend_rule


@functools.cache
def build_field_at(Ft):
    """``field_at(X, R, T, meta, r, sdf, grad, thr) -> (phi, n)``, scalar type ``Ft``: the signed distance (m; ``1e30``
    off its grid or where its gradient vanishes) and unit outward normal (world) at the world point ``X`` of the field
    whose ``COL_META`` row starts at ``r`` of ``meta`` (samples in ``sdf``, gradients in ``grad``), its frame at the
    pose ``x = R X + T``, trilinear; the normal only where ``phi <= thr`` (m; zeros elsewhere: the callers act only
    there). A collider's (:func:`build_collider_at`) and a rigid body's (``rigid_hold``)."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def corner_weight(fx: vec3, di: int, dj: int, dk: int):
        # the trilinear weight of cell corner (di, dj, dk) at the fraction fx
        wx = Ft(1.0) - fx[0]
        if di == 1:
            wx = fx[0]
        wy = Ft(1.0) - fx[1]
        if dj == 1:
            wy = fx[1]
        wz = Ft(1.0) - fx[2]
        if dk == 1:
            wz = fx[2]
        return wx * wy * wz

    @wp.func
    def field_at(X: vec3, R: mat33, T: vec3, meta: wp.array(dtype=Ft), r: int, sdf: wp.array(dtype=Ft),
                 grad: wp.array(dtype=Ft), thr: Ft):
        h = meta[r + CM_H]
        org = vec3(meta[r + CM_ORIGIN], meta[r + CM_ORIGIN + 1], meta[r + CM_ORIGIN + 2])
        nx = int(meta[r + CM_NX])
        ny = int(meta[r + CM_NY])
        nz = int(meta[r + CM_NZ])
        off = int(meta[r + CM_OFFSET])
        u = (wp.transpose(R) * (X - T) - org) / h
        phi = Ft(1.0e30)
        n = vec3(Ft(0.0))
        if (u[0] >= Ft(0.0) and u[1] >= Ft(0.0) and u[2] >= Ft(0.0) and u[0] <= Ft(nx - 1)
                and u[1] <= Ft(ny - 1) and u[2] <= Ft(nz - 1)):
            i0 = wp.min(int(wp.floor(u[0])), nx - 2)
            j0 = wp.min(int(wp.floor(u[1])), ny - 2)
            k0 = wp.min(int(wp.floor(u[2])), nz - 2)
            fx = u - vec3(Ft(i0), Ft(j0), Ft(k0))
            ph = Ft(0.0)
            for q in range(8):
                di = q / 4
                dj = (q / 2) % 2
                dk = q % 2
                idx = off + ((i0 + di) * ny + (j0 + dj)) * nz + (k0 + dk)
                ph = ph + corner_weight(fx, di, dj, dk) * sdf[idx]
            phi = ph
            gr = vec3(Ft(0.0))
            if ph <= thr:   # the gradient only where the caller acts (the lookup's costly part)
                for q in range(8):
                    di = q / 4
                    dj = (q / 2) % 2
                    dk = q % 2
                    idx = off + ((i0 + di) * ny + (j0 + dj)) * nz + (k0 + dk)
                    gr = gr + corner_weight(fx, di, dj, dk) * vec3(grad[3 * idx], grad[3 * idx + 1], grad[3 * idx + 2])
            gl = wp.length(gr)
            if ph > thr:
                phi = ph
            elif gl <= Ft(0.0):
                phi = Ft(1.0e30)
            else:
                n = R * (gr / gl)
        return phi, n

    return field_at


@functools.cache
def build_collider_at(Ft):
    """``collider_at(X, cc, base, ex, thr) -> (phi, n, v_c)``, scalar type ``Ft``: collider ``cc``'s signed distance
    and unit outward normal at the world point ``X`` (:func:`build_field_at`) and its velocity there, at the pose of
    the time-table row at ``base``; the normal and velocity only where ``phi <= thr`` (m; zeros elsewhere: the
    callers act only there). The grid rule (:func:`build_collider_func`) and the particle contact
    (``contact.build_collider_contact``) both read it."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    field_at = build_field_at(Ft)

    @wp.func
    def collider_at(X: vec3, cc: int, base: int, ex: Extras, thr: Ft):
        p0 = base + FT_POSES + COL_POSE * cc
        pr = p0 + PO_R
        R = mat33(ex.tab[pr + 0], ex.tab[pr + 1], ex.tab[pr + 2],
                  ex.tab[pr + 3], ex.tab[pr + 4], ex.tab[pr + 5],
                  ex.tab[pr + 6], ex.tab[pr + 7], ex.tab[pr + 8])
        T = vec3(ex.tab[p0 + PO_T], ex.tab[p0 + PO_T + 1], ex.tab[p0 + PO_T + 2])
        phi, n = field_at(X, R, T, ex.meta, cc * COL_META, ex.sdf, ex.grad, thr)
        vc = vec3(Ft(0.0))
        if phi <= thr:
            vl = vec3(ex.tab[p0 + PO_V], ex.tab[p0 + PO_V + 1], ex.tab[p0 + PO_V + 2])
            om = vec3(ex.tab[p0 + PO_W], ex.tab[p0 + PO_W + 1], ex.tab[p0 + PO_W + 2])
            vc = vl + wp.cross(om, X - T)
        return phi, n, vc

    return collider_at


@functools.cache
def build_collider_func(Ft):
    """``apply_colliders``: the colliders' signed distances on a grid node's velocity, scalar type ``Ft``: the grid
    rule where ``phi <= -ex.col_deep`` (0 with ``contact = "grid"``; ``gasp_core.mpm.contact.collider_grid_depth``
    with the particle contact, which meets the points at the surface)."""
    vec3, vec4, mat33 = build_types(Ft)
    collide = build_collide(Ft)
    blend_rule = build_blend(Ft)
    Extras = build_extras_struct(Ft)
    collider_at = build_collider_at(Ft)

    @wp.func
    def apply_colliders(v_in: vec3, X: vec3, base: int, ex: Extras, frac: Ft):
        # each collider: trilinear signed distance and gradient in its frame (pose and velocity from the
        # substep's time-table row); inside (phi <= -col_deep) collide relative to the collider's velocity, by the
        # node's flowing-mass fraction frac where phi > -col_full (the contact chosen per body; blend_rule)
        v = v_in
        for cc in range(ex.n_col):
            phi, n, vc = collider_at(X, cc, base, ex, -ex.col_deep)
            if phi <= -ex.col_deep:
                w = Ft(1.0)
                if phi > -ex.col_full:
                    w = frac
                v = blend_rule(v, vc + collide(v - vc, n, ex.meta[cc * COL_META + CM_FRICTION]), w)
        return v

    return apply_colliders


@functools.cache
def build_collider_hold(Ft):
    """``collider_hold``: the colliders' position-level hold on the points of the bodies that take the grid contact,
    scalar type ``Ft`` (docs/colliders.md "The hold"; taichi_mpm's ``Colliders.collider_hold``): after G2P, a
    point inside a collider (``phi < 0``) is put back on its surface along the outward normal, its approach
    relative to the collider removed and its slip reduced by Coulomb's friction of that approach (``collide``).
    The grid rule alone acts at the nodes, a cell apart, and let sand slip through a thin wall (the kitchen's
    spinach through the pan's, docs/colliders.md); a point held each substep cannot get deeper than one substep's
    travel, so it leaves a thin wall on the side it entered."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    collider_at = build_collider_at(Ft)
    collide = build_collide(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def collider_hold(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32),
                      flows: wp.array(dtype=wp.int32), ex: Extras):
        p = wp.tid()
        if flows[body[p]] == 0:
            return
        base = ex.step[0] * ex.width
        xp = x[p]
        vp = v[p]
        for cc in range(ex.n_col):
            phi, n, vc = collider_at(xp, cc, base, ex, Ft(0.0))
            if phi < Ft(0.0):
                xp = xp - phi * n
                vp = vc + collide(vp - vc, n, ex.meta[cc * COL_META + CM_FRICTION])
        x[p] = xp
        v[p] = vp

    return collider_hold


@functools.cache
def build_box_hold(Ft):
    """``box_hold``: the ground's and walls' position-level hold on the points of the deformable bodies
    (``gasp_core.mpm.box_hold``: the grid contact's, and since round 97 the particle contact's but for its points that
    started behind a plane, ``kcs`` their skin below 0), scalar type ``Ft`` (taichi_mpm's ``Colliders.hold_box``;
    ``gasp_core.mpm.points.hold_passive``'s rule): after G2P, a point outside ``[lo, hi]`` (``gasp_core.mpm.points.passive_bounds``: the ground's plane, the
    walls' last node layers) is put on the face, its velocity into the face removed, and one put on the floor loses
    ``mu`` (the floor's friction, ``gasp_core.mpm.points.passive_floor_friction``) times that removed speed from its
    horizontal speed, Coulomb's friction (``hold_passive``'s rule for a stranded point). The grid rule acts at the
    nodes, and a point between a stopped node layer and a moving one was carried up to 1.25 mm under the ground by a
    landing at 50 m/s (issue 66). The floor's friction: the ground's plane lies up to a cell above its top node layer
    (``gasp_core.mpm.points.ground_top_node``), and a point held on it reads that stopped layer with a weight as low
    as 1/8, so without its own friction a sand column held there slid out flat (``tests/test_runout.py``)."""
    from .contact import build_passive_hold   # (contact.py imports this module)
    vec3, _vec4, _mat33 = build_types(Ft)
    hold_passive = build_passive_hold(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def box_hold(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32),
                 holds: wp.array(dtype=wp.int32), kcs: wp.array(dtype=vec3), lo: vec3, hi: vec3, mu: Ft):
        p = wp.tid()
        h = holds[body[p]]   # gasp_core.mpm.box_hold.box_hold_codes: 1 every point, 2 unless it started behind a plane
        if h == 0:
            return
        if h == 2:
            if kcs[p][2] < Ft(0.0):
                return
        xp, vp = hold_passive(x[p], v[p], lo, hi, 1, mu)   # on the floor with its friction, as a stranded point
        x[p] = xp
        v[p] = vp

    return box_hold


def hold_launches(eng, Ft, has_extras: int, ex) -> list:
    """The recorded launches of the holds on the grid contact's points after G2P for the engine ``eng``: the ground's
    and walls' (:func:`build_box_hold`) where a deformable body takes the grid contact, then the colliders'
    (:func:`build_collider_hold`) where its scene has colliders and a body that takes the grid contact; else none."""
    from gasp_core.mpm.box_hold import box_hold_codes
    from gasp_core.mpm.points import passive_bounds, passive_floor_friction
    out = []
    boxed = box_hold_codes(eng.setup, eng._contact)
    if boxed.any():
        vec3 = build_types(Ft)[0]
        eng.box_holds = wp.array(boxed, dtype=wp.int32, device=eng.device)
        lo, hi = (vec3(*[float(c) for c in b]) for b in passive_bounds(eng.setup, eng._contact))
        out.append(wp.launch(build_box_hold(Ft), dim=eng.n_material, device=eng.device, record_cmd=True,
                             inputs=[eng.x, eng.v, eng.body, eng.box_holds, eng.p_contact, lo, hi,
                                     Ft(passive_floor_friction(eng.setup, eng._contact))]))
    if not (has_extras and eng.setup.colliders and eng.flows.numpy().any()):
        return out
    return out + [wp.launch(build_collider_hold(Ft), dim=eng.n_material, device=eng.device, record_cmd=True,
                            inputs=[eng.x, eng.v, eng.body, eng.flows, ex])]
