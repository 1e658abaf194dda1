"""Round 89: a rigid sphere or solid cylinder meets a ``[[collider]]`` on its exact shape (``gasp_core.mpm.round_ground.
collider_reach``, ``docs/rigid.md`` "Round 89"), as a Warp function per scalar type; taichi_mpm's
``RigidLift.round_collider`` spells the same.

A sphere of centre ``c`` and radius ``R`` meets a surface of signed distance ``phi`` at the depth ``R - phi(c)``, along
the field's unit gradient ``n`` at ``c``, at the point ``c - R n``. Every point of the sphere reads the field at ``c``
(the field is padded out to ``R``: ``gasp_core.colliders.sdf.padded``), so they all take the same depth and, with
their mass's share of the body's stiffness (as on the planes, round 88), the sphere's force through its centre. A
cylinder's point reads the field at its slice of the axis, ``y = c + (e . (x - c)) e``, and meets the surface on the
line under the axis (:func:`round_point`). Where the field is not held at ``y`` (off its grid) or a cylinder stands
within ``CYL_LINE`` of an end, the point keeps its own contact.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.contact import DAMPING
from gasp_core.mpm.grid_tables import COL_POSE, FT_POSES, PO_W
from gasp_core.mpm.round_ground import CYL_LINE

from .colliders import build_collider_at
from .forces import build_extras_struct
from .precision import build_types


@wp.func
def round_point(c: wp.vec3d, R: wp.float64, ax: wp.vec3d, rot: wp.types.matrix((3, 3), wp.float64), x: wp.vec3d,
                n: wp.vec3d, band: wp.float64):
    # round 88 (gasp_core.mpm.round_ground): where a rigid body's point x meets a plane of normal n on the body's exact
    # shape, and 1; (x, 0) where it has none (R 0) or a cylinder stands within CYL_LINE of an end (its points); a
    # cylinder's line taken level while |n . e| is within band (round_ground.level_band), tilted by the rest beyond
    out = x
    on = int(0)
    if R > wp.float64(0.0):
        u = n
        q = c
        on = 1
        if wp.length(ax) > wp.float64(0.0):   # a cylinder: the line under its axis, at the point's slice
            e = rot * ax
            ne = wp.dot(n, e)
            if wp.abs(ne) < wp.float64(CYL_LINE):
                sl = wp.dot(x - c, e)
                q = c + sl * e - sl * (ne - wp.sign(ne) * wp.max(wp.abs(ne) - band, wp.float64(0.0))) * n
                u = (n - ne * e) / wp.sqrt(wp.float64(1.0) - ne * ne)
            else:
                on = 0
        if on != 0:
            out = q - R * u
    return out, on


#: A signed distance at or above this (m) is off the field's grid (``colliders.build_field_at`` gives 1e30 there).
OFF_GRID = 1.0e29


@functools.cache
def build_round_collider(Ft):
    """``round_collider(ex, base, cc, x, v, m, b) -> (on, depth, n, v_c, x*, v*, kcs*)``, a Warp function of the scalar
    type ``Ft``: where a point of round rigid body ``b`` (``ex.rb_rad[b]`` > 0) at ``x`` with velocity ``v`` and mass
    ``m`` meets collider ``cc`` (its pose at the time-table row ``base``) on the body's exact shape: ``on`` 1 with the
    depth (m, > 0 inside), the unit normal out of the collider, the collider's velocity at the contact point ``x*``,
    the point's velocity moved there (``v + w x (x* - x)``) and its row ``(w2 m, 2 DAMPING sqrt(w2) m, 0)``
    (``ex.rb_w2``: its mass's share of the body's stiffness, not scaled by the touching count); ``on`` 0 where the point
    keeps its own contact (the field off its grid at the read point, a cylinder near standing on an end)."""
    vec3 = build_types(Ft)[0]
    Extras = build_extras_struct(Ft)
    collider_at = build_collider_at(Ft)

    @wp.func
    def round_collider(ex: Extras, base: int, cc: int, x: vec3, v: vec3, m: Ft, b: int):
        c = ex.rb_cx[b]
        R = ex.rb_rad[b]
        xd = wp.vec3d(wp.float64(x[0]), wp.float64(x[1]), wp.float64(x[2]))
        y = c
        if wp.length(ex.rb_ax[b]) > wp.float64(0.0):   # a cylinder: its slice of the axis
            e = ex.rb_rot[b] * ex.rb_ax[b]
            y = c + wp.dot(xd - c, e) * e
        yf = vec3(Ft(y[0]), Ft(y[1]), Ft(y[2]))
        # the normal wherever the shape may touch: within 2 R (a cylinder's slice within its level band reads up to
        # R + h band = R + slop / 2; gated at R, a cylinder on a fitted axis 0.02 degrees off lost the contact on half
        # its slices and bounced at the start)
        phi, n, vcy = collider_at(yf, cc, base, ex, Ft(wp.float64(2.0) * R))
        on = int(0)
        depth = Ft(0.0)
        xq = x
        vq = v
        vc = vcy
        kq = vec3(Ft(0.0))
        if phi < Ft(OFF_GRID):
            on = 1   # held: the exact shape decides, touching or not
            if phi <= Ft(wp.float64(2.0) * R):
                nd = wp.vec3d(wp.float64(n[0]), wp.float64(n[1]), wp.float64(n[2]))
                q, at = round_point(c, R, ex.rb_ax[b], ex.rb_rot[b], xd, nd, ex.rb_band[b])
                on = at
                if at != 0:
                    depth = -(phi + Ft(wp.dot(nd, q - y)))
                    xq = vec3(Ft(q[0]), Ft(q[1]), Ft(q[2]))
                    dv = wp.cross(ex.rb_wx[b], q - xd)
                    vq = v + vec3(Ft(dv[0]), Ft(dv[1]), Ft(dv[2]))
                    p0 = base + FT_POSES + COL_POSE * cc
                    om = vec3(ex.tab[p0 + PO_W], ex.tab[p0 + PO_W + 1], ex.tab[p0 + PO_W + 2])
                    vc = vcy + wp.cross(om, xq - yf)
                    k = ex.rb_w2 * m
                    kq = vec3(k, Ft(2.0 * DAMPING) * wp.sqrt(k * m), Ft(0.0))
            else:
                depth = Ft(R) - phi   # apart: no contact
        return on, depth, n, vc, xq, vq, kq

    return round_collider
