"""A slot's lattice read and the nearest round body, shared by round 66's ``point_contact.py`` and round 67's
``point_grid.py``.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import functools

import warp as wp

from .collider_pair import NA
from .rigid_pairs import mat33d, vec3d


@functools.cache
def build_sdf_at(Ft):
    """``sdf_at(q, s, phi, grad, org, hs, dims)``: (phi, grad) of slot ``s``'s lattice at body-frame ``q``,
    trilinear; (1e30, 0) outside it (``point_contact.py``'s read; ``Ft`` unused: the lattices are float32/64)."""

    @wp.func
    def sdf_at(q: vec3d, s: int, phi: wp.array(dtype=wp.float32), grad: wp.array(dtype=wp.vec3f),
               org: wp.array(dtype=vec3d), hs: wp.array(dtype=wp.float64), dims: wp.array(dtype=wp.int32)):
        f = (q - org[s]) / hs[s]
        nx = dims[4 * s]
        ny = dims[4 * s + 1]
        nz = dims[4 * s + 2]
        base = dims[4 * s + 3]
        i = int(wp.floor(f[0]))
        j = int(wp.floor(f[1]))
        k = int(wp.floor(f[2]))
        p = wp.float64(1.0e30)
        g = vec3d(wp.float64(0.0))
        if i >= 0 and j >= 0 and k >= 0 and i < nx - 1 and j < ny - 1 and k < nz - 1:
            tx = f[0] - wp.float64(i)
            ty = f[1] - wp.float64(j)
            tz = f[2] - wp.float64(k)
            p = wp.float64(0.0)
            for a in range(2):
                for b in range(2):
                    for c in range(2):
                        w = wp.float64(1.0)
                        if a == 1:
                            w = w * tx
                        else:
                            w = w * (wp.float64(1.0) - tx)
                        if b == 1:
                            w = w * ty
                        else:
                            w = w * (wp.float64(1.0) - ty)
                        if c == 1:
                            w = w * tz
                        else:
                            w = w * (wp.float64(1.0) - tz)
                        at = base + ((i + a) * ny + (j + b)) * nz + (k + c)
                        p = p + w * wp.float64(phi[at])
                        gg = grad[at]
                        g = g + w * vec3d(wp.float64(gg[0]), wp.float64(gg[1]), wp.float64(gg[2]))
        return p, g

    return sdf_at


@functools.cache
def build_nearest(Ft):
    """``nearest(xp, best0, ns, rc_pt, bodies, centre, rot, acc, ahead, phi, grad, org, hs, dims)``: ``(d, s, n)``,
    the slot whose round body (``rc_pt`` 1) is nearest the point ``xp`` (m, float64) by its lattice's distance
    :func:`build_sdf_at`, under ``best0``: ``s`` -1 none, ``n`` the unit normal out of the body (world frame);
    ``ahead`` 1: each body's centre moved over the substep ``dt`` by the velocity in ``acc`` (round 66's mark,
    ``point_contact.py``), 0: where it is (round 67's, ``point_grid.py``)."""
    sdf_at = build_sdf_at(Ft)

    @wp.func
    def nearest(xp: vec3d, best0: wp.float64, ns: int, rc_pt: wp.array(dtype=wp.int32),
                bodies: wp.array(dtype=wp.int32), centre: wp.array(dtype=vec3d), rot: wp.array(dtype=mat33d),
                acc: wp.array(dtype=wp.float64), ahead: int, dt: wp.float64, phi: wp.array(dtype=wp.float32),
                grad: wp.array(dtype=wp.vec3f), org: wp.array(dtype=vec3d), hs: wp.array(dtype=wp.float64),
                dims: wp.array(dtype=wp.int32)):
        best = best0
        sb = int(-1)
        nb = vec3d(wp.float64(0.0))
        for s in range(ns):
            if rc_pt[s] != 0:
                rb = bodies[s]
                c = centre[rb]
                if ahead != 0:
                    c = c + dt * vec3d(acc[NA * s + 4], acc[NA * s + 5], acc[NA * s + 6])
                R = rot[rb]
                d, g = sdf_at(wp.transpose(R) * (xp - c), s, phi, grad, org, hs, dims)
                if d < best and wp.length(g) > wp.float64(0.0):
                    best = d
                    sb = s
                    nb = wp.normalize(R * g)
        return best, sb, nb

    return nearest
