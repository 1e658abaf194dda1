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

from .precision import build_types


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

