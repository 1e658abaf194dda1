"""A slot's lattice read, shared by round 66's ``point_contact.py`` and round 67's ``point_grid.py``.

This module must not use ``from __future__ import annotations`` (the warp modules' rule).
"""
import functools

import warp as wp

from .rigid_pairs import vec3d


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
