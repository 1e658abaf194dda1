"""Forces and impulses (docs/colliders.md) on a grid node's velocity, and the struct of the colliders', forces'
and impulses' tables (:func:`gasp_core.mpm.grid_tables.grid_tables`), as Warp code per scalar type
(:mod:`gasp_warp_mpm.precision`).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.grid_tables import (COL_POSE, FALLOFF_INVERSE_SQUARE, FORCE_ROW, FORCE_WIND, FR_C, FR_DRAG,
                                           FR_FALLOFF, FR_KIND, FR_MODE_COUNT, FR_MODE_START, FR_RADIUS, FR_STRENGTH,
                                           FT_POSES, IM_A, IM_B, IM_DV, IM_MODE, IM_SHAPE, IMPULSE_ADD, IMPULSE_BOX,
                                           IMPULSE_ROW, IMPULSE_SET_ALONG, MD_A, MD_K, MD_OMEGA, MD_PHASE, MODE_ROW,
                                           SET_ON)

from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_extras_struct(Ft):
    """``Extras``: the struct of colliders, forces and impulses (:func:`gasp_core.mpm.grid_tables.grid_tables`,
    ``frame_table``) of scalar type ``Ft``."""

    @wp.struct
    class Extras:
        # gasp_core.mpm.grid_tables.grid_tables / frame_table (docs/colliders.md)
        sdf: wp.array(dtype=Ft)
        grad: wp.array(dtype=Ft)
        meta: wp.array(dtype=Ft)
        forces: wp.array(dtype=Ft)
        modes: wp.array(dtype=Ft)
        imps: wp.array(dtype=Ft)
        tab: wp.array(dtype=Ft)
        step: wp.array(dtype=wp.int32)
        n_col: int
        col_deep: Ft   # m: the colliders' grid rule acts where phi <= -col_deep (colliders.build_collider_func)
        col_full: Ft   # m: and fully where phi <= -col_full (deeper with the contact chosen per body, else col_deep)
        n_force: int
        n_imp: int
        width: int
        # the rigid bodies' restitution (gasp_core.mpm.restitution, contact.build_unloading): per body its e (-1:
        # none), the approach speed of its ongoing contact, this substep's (atomic max), a touch flag; per plane its e
        rb_e: wp.array(dtype=Ft)
        rb_vin: wp.array(dtype=Ft)
        rb_vin_next: wp.array(dtype=Ft)
        rb_touch: wp.array(dtype=wp.int32)
        rb_jn: wp.array(dtype=build_types(Ft)[0])   # the contact's sum j n, sum j e_sup and sum j (rigid.py)
        rb_je: wp.array(dtype=Ft)
        rb_j: wp.array(dtype=Ft)
        rb_nface: wp.array(dtype=Ft)   # gasp_core.mpm.rigid.face_counts; the points touching now and last
        rb_count: wp.array(dtype=wp.int32)
        rb_nlast: wp.array(dtype=wp.int32)
        rb_ndepth: wp.array(dtype=wp.int32)   # the points in a plane at the pose the next P2G takes (rigid.py)
        rb_cx: wp.array(dtype=wp.types.vector(3, wp.float64))   # the rigid bodies' centres (rigid.py's rb_c)
        rb_twist: wp.array(dtype=wp.float64)   # this substep's sum mu j |r_perp| per body (rigid.py's twist brake)
        rb_fx: wp.array(dtype=wp.vec4d)   # this substep's sum mu j x, sum mu j (slide brake)
        rb_fv: wp.array(dtype=wp.types.vector(3, wp.float64))   # this substep's sum mu j v_sup (slide brake)
        # this substep's normal impulses, 10 a body: sum j, sum j x, sum j x x^T (xx, xy, xz, yy, yz, zz)
        rb_jx: wp.array(dtype=wp.float64)
        # this substep's deepest touching point (m); the last substep's patch flatness and centre; the bodies' spin
        # (rigid.py's rb_w): a rolling body's settling damping (contact.build_contact_impulse)
        rb_deep: wp.array(dtype=wp.float64)
        rb_flat: wp.array(dtype=wp.float64)
        rb_xf: wp.array(dtype=wp.types.vector(3, wp.float64))
        rb_wx: wp.array(dtype=wp.types.vector(3, wp.float64))
        rb_rad: wp.array(dtype=wp.float64)   # round 88: a rigid sphere's radius, m (0: none; contact.build_plane_point)
        rb_ax: wp.array(dtype=wp.types.vector(3, wp.float64))   # round 88: a cylinder's axis at rest (0: a sphere)
        rb_band: wp.array(dtype=wp.float64)   # round 88: a cylinder's level band on |n . e| (round_ground.level_band)
        rb_rot: wp.array(dtype=wp.types.matrix((3, 3), wp.float64))   # the rigid bodies' rotations (rigid.py's rb_R)
        rb_col: int   # round 89: 1, a round body meets the colliders on its shape (round_ground.ROUND_COLLIDER)
        rb_w2: Ft   # round 88: (RIGID_OMEGA_DT / dt)^2, 1/s^2: a sphere's stiffness per kg (contact.build_plane_point)
        plane_e: wp.array(dtype=Ft)
        v_rest: Ft   # m/s: a rebound below it is none
    return Extras


@functools.cache
def build_set_velocity(Ft):
    """``set_velocity(ex, q, w) -> vec3``: the velocity (m/s) a set impulse ``q`` of time-table weight ``w > 0``
    imposes, its ramp factor ``w - SET_ON`` times its ``velocity_change`` (``grid_tables.SET_ON``); taichi_mpm's
    ``Forces.set_velocity``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)

    @wp.func
    def set_velocity(ex: Extras, q: int, w: Ft):
        r = q * IMPULSE_ROW
        return (w - Ft(SET_ON)) * vec3(ex.imps[r + IM_DV], ex.imps[r + IM_DV + 1], ex.imps[r + IM_DV + 2])

    return set_velocity


@functools.cache
def build_constrain(Ft):
    """``(constrain, along_matrix)``, a set impulse's ``constrain`` key (docs/colliders.md; taichi_mpm's
    ``Forces.constrain`` and ``along_flip``). ``constrain(ex, q, v_free, v_held) -> vec3``: the velocity (m/s) set
    impulse ``q`` leaves at a node whose velocity is ``v_free`` where its rule (the impulse, a ghost's mirror, a held
    face) gives ``v_held``: ``v_held`` (``"all"``), ``(I - a a^T) v_free + a a^T v_held`` with ``a = dv / |dv|``
    (``"along"``, ``grid_tables.IMPULSE_SET_ALONG``). ``along_matrix(ex, q, M, M_flip) -> mat33``: a held point's
    gradient or stress ``M_flip`` (the held rule's mirror of ``M``) in set box ``q`` (-1: none): ``M + a a^T (M_flip -
    M)`` for ``"along"`` (its rows along the pull the mirror's, across it its own), else ``M_flip``."""
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)

    @wp.func
    def along_dir(ex: Extras, q: int):
        r = q * IMPULSE_ROW
        return wp.normalize(vec3(ex.imps[r + IM_DV], ex.imps[r + IM_DV + 1], ex.imps[r + IM_DV + 2]))

    @wp.func
    def constrain(ex: Extras, q: int, v_free: vec3, v_held: vec3):
        out = v_held
        if ex.imps[q * IMPULSE_ROW + IM_MODE] == Ft(IMPULSE_SET_ALONG):
            a = along_dir(ex, q)
            out = v_free + wp.dot(v_held - v_free, a) * a
        return out

    @wp.func
    def along_matrix(ex: Extras, q: int, M: mat33, M_flip: mat33):
        out = M_flip
        if q >= 0:
            if ex.imps[q * IMPULSE_ROW + IM_MODE] == Ft(IMPULSE_SET_ALONG):
                a = along_dir(ex, q)
                out = M + wp.outer(a, a) * (M_flip - M)
        return out

    return constrain, along_matrix


@functools.cache
def build_force_funcs(Ft):
    """``(apply_forces, apply_impulses)``: forces and impulses on a grid node's velocity, scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    set_velocity = build_set_velocity(Ft)
    constrain = build_constrain(Ft)[0]
    Extras = build_extras_struct(Ft)

    @wp.func
    def apply_forces(v_in: vec3, X: vec3, dt: Ft, m: Ft, gsurf: vec3, t: Ft, ex: Extras):
        # Wind (docs/colliders.md): quadratic drag on the windward surface, F = 1/2 rho_air C_d A |w| w,
        # w = u - v, A = max(0, gsurf . w / |w|) (gsurf = sum_p p_vol grad N_ip, m^2: the node's share
        # of the area the body shows the relative wind); applied implicitly in the drag rate
        # k = 1/2 rho_air C_d A |w| / m: v += w dt k / (1 + dt k), so it never overshoots the wind.
        # Point forces: acceleration "strength" along centre - X, linear in r inside the radius, constant
        # (or falling as 1/r^2) outside.
        v = v_in
        for f in range(ex.n_force):
            r = f * FORCE_ROW
            a = vec3(Ft(0.0))
            if ex.forces[r + FR_KIND] == Ft(FORCE_WIND):
                u = vec3(ex.forces[r + FR_C], ex.forces[r + FR_C + 1], ex.forces[r + FR_C + 2])
                m0 = int(ex.forces[r + FR_MODE_START])
                for mm in range(m0, m0 + int(ex.forces[r + FR_MODE_COUNT])):
                    q = mm * MODE_ROW
                    kv = vec3(ex.modes[q + MD_K], ex.modes[q + MD_K + 1], ex.modes[q + MD_K + 2])
                    A = vec3(ex.modes[q + MD_A], ex.modes[q + MD_A + 1], ex.modes[q + MD_A + 2])
                    u = u + A * wp.sin(wp.dot(kv, X) + ex.modes[q + MD_OMEGA] * t + ex.modes[q + MD_PHASE])
                wrel = u - v
                wn = wp.length(wrel)
                if wn > Ft(0.0):
                    area = wp.max(Ft(0.0), wp.dot(gsurf, wrel) / wn)
                    kdt = dt * ex.forces[r + FR_DRAG] * area * wn / m
                    v = v + (kdt / (Ft(1.0) + kdt)) * wrel
            else:
                d = vec3(ex.forces[r + FR_C], ex.forces[r + FR_C + 1], ex.forces[r + FR_C + 2]) - X
                rr = wp.length(d)
                strength = ex.forces[r + FR_STRENGTH]
                radius = ex.forces[r + FR_RADIUS]
                mag = strength * rr / radius
                if rr >= radius:
                    mag = strength
                    if ex.forces[r + FR_FALLOFF] == Ft(FALLOFF_INVERSE_SQUARE):
                        mag = strength * (radius / rr) * (radius / rr)
                if rr > Ft(0.0):
                    a = d * (mag / rr)
            v = v + dt * a
        return v

    @wp.func
    def apply_impulses(v_in: vec3, X: vec3, base: int, ex: Extras):
        # impulses over a box or a sphere, weighted by the substep's time-table entry: add w dv, or set v to the
        # ramp factor times dv (set_velocity; with constrain = "along" its component along dv alone: constrain)
        v = v_in
        for q in range(ex.n_imp):
            r = q * IMPULSE_ROW
            c = vec3(ex.imps[r + IM_A], ex.imps[r + IM_A + 1], ex.imps[r + IM_A + 2])
            b = vec3(ex.imps[r + IM_B], ex.imps[r + IM_B + 1], ex.imps[r + IM_B + 2])
            inside = False
            if ex.imps[r + IM_SHAPE] == Ft(IMPULSE_BOX):
                inside = (X[0] >= c[0] and X[1] >= c[1] and X[2] >= c[2] and X[0] <= b[0] and X[1] <= b[1]
                          and X[2] <= b[2])
            else:
                inside = wp.length(X - c) <= b[0]
            w = ex.tab[base + FT_POSES + COL_POSE * ex.n_col + q]
            if inside and w > Ft(0.0):
                dv = vec3(ex.imps[r + IM_DV], ex.imps[r + IM_DV + 1], ex.imps[r + IM_DV + 2])
                if ex.imps[r + IM_MODE] == Ft(IMPULSE_ADD):
                    v = v + w * dv
                else:
                    v = constrain(ex, q, v, set_velocity(ex, q, w))
        return v

    return apply_forces, apply_impulses


@functools.cache
def build_tick(Ft):
    """``tick``: the kernel advancing the time table's substep (``Extras.step``)."""

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def tick(step: wp.array(dtype=wp.int32)):
        step[0] = step[0] + 1

    return tick
