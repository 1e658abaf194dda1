"""The rigid bodies' hold on the flowing points (``gasp_core.mpm.rigid_hold``, docs/contact.md; taichi_mpm's
``rigid_hold.py`` spells the same steps): after each substep's G2P and the rigid projection, a point of a body of the
grid contact found inside a holding rigid body (its distance field at the body's pose of that substep, read as a
collider's, ``colliders.build_field_at``) is put back on its surface, its approach relative to the body removed and
its slip reduced by Coulomb's friction (``colliders.build_collide``); its momentum change is given back to the body
through the sums of its next projection (``acc_p``, ``acc_l``, which ``rigid_update`` has just cleared).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import numpy as np
import warp as wp

from gasp_core.colliders.model import COL_META
from gasp_core.mpm.grid_tables import CM_FRICTION

from .colliders import build_collide, build_field_at
from .precision import MODULE_OPTIONS, build_types
from .rigid import mat33d, vec3d


@functools.cache
def build_rigid_hold(Ft):
    """``rigid_hold``, one thread a material point, scalar type ``Ft``; its ``pair_mu`` the coefficient per (point's
    body, holding body) (``gasp_core.mpm.fields.hold_pairs``, round 43), one entry: each holding body's row's."""
    vec3, vec4, mat33 = build_types(Ft)
    field_at = build_field_at(Ft)
    collide = build_collide(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rigid_hold(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), p_mass: wp.array(dtype=Ft),
                   body: wp.array(dtype=wp.int32), flows: wp.array(dtype=wp.int32), row: wp.array(dtype=wp.int32),
                   meta: wp.array(dtype=Ft), sdf: wp.array(dtype=Ft), grad: wp.array(dtype=Ft),
                   centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d), vel: wp.array(dtype=vec3d),
                   spin: wp.array(dtype=vec3d), acc_p: wp.array(dtype=vec3d), acc_l: wp.array(dtype=vec3d),
                   n_bodies: int, pair_mu: wp.array(dtype=Ft)):
        p = wp.tid()
        if flows[body[p]] == 0:
            return
        xp = x[p]
        vp = v[p]
        for b in range(n_bodies):
            r = row[b]
            if r >= 0:
                Rd = rot[b]
                R = mat33(Ft(Rd[0, 0]), Ft(Rd[0, 1]), Ft(Rd[0, 2]), Ft(Rd[1, 0]), Ft(Rd[1, 1]), Ft(Rd[1, 2]),
                          Ft(Rd[2, 0]), Ft(Rd[2, 1]), Ft(Rd[2, 2]))
                T = vec3(Ft(centre[b][0]), Ft(centre[b][1]), Ft(centre[b][2]))
                phi, n = field_at(xp, R, T, meta, r * COL_META, sdf, grad, Ft(0.0))
                if phi < Ft(0.0):
                    w = vec3(Ft(spin[b][0]), Ft(spin[b][1]), Ft(spin[b][2]))
                    vc = vec3(Ft(vel[b][0]), Ft(vel[b][1]), Ft(vel[b][2])) + wp.cross(w, xp - T)
                    xp = xp - phi * n
                    mu = meta[r * COL_META + CM_FRICTION]
                    if pair_mu.shape[0] > 1:   # A's sands' several angles: the point's body's pair (round 43)
                        mu = pair_mu[body[p] * n_bodies + b]
                    vn = vc + collide(vp - vc, n, mu)
                    dv = vn - vp
                    m = wp.float64(p_mass[p])
                    J = vec3d(-m * wp.float64(dv[0]), -m * wp.float64(dv[1]), -m * wp.float64(dv[2]))
                    xd = vec3d(wp.float64(xp[0]), wp.float64(xp[1]), wp.float64(xp[2]))
                    wp.atomic_add(acc_p, b, J)   # Newton's third law: to the body's next projection
                    wp.atomic_add(acc_l, b, wp.cross(xd, J))
                    vp = vn
        x[p] = xp
        v[p] = vp

    return rigid_hold


def rigid_hold_launches(eng, Ft) -> list:
    """The recorded launch of the rigid bodies' hold after their projection (:func:`build_rigid_hold`) for the engine
    ``eng``, where a rigid body shares its scene with a body of the grid contact
    (``gasp_core.mpm.rigid_hold.rigid_hold_tables``); else none: such scenes run the code before."""
    if not eng.any_rigid:
        return []
    from gasp_core.mpm.rigid_hold import hold_setup
    tables, pairs = hold_setup(eng.setup, float(eng.dx), eng.flows.numpy().astype(bool))
    if tables is None:
        return []
    row, sdf, grad, meta = tables
    d, dt_np = eng.device, eng._np_dtype
    eng.rh_row = wp.array(row.astype(np.int32), dtype=wp.int32, device=d)
    eng.rh_meta, eng.rh_sdf, eng.rh_grad = (wp.array(a.astype(dt_np), dtype=Ft, device=d) for a in (meta, sdf, grad))
    eng.rh_pairs = wp.array((np.zeros(1) if pairs is None else pairs.ravel()).astype(dt_np), dtype=Ft, device=d)
    return [wp.launch(build_rigid_hold(Ft), dim=eng.n_material, device=d, record_cmd=True, inputs=[
        eng.x, eng.v, eng.p_mass, eng.body, eng.flows, eng.rh_row, eng.rh_meta, eng.rh_sdf, eng.rh_grad, eng.rb_c,
        eng.rb_R, eng.rb_V, eng.rb_w, eng.acc_p, eng.acc_l, len(eng.setup.materials), eng.rh_pairs])]
