"""The stencil of a point (docs/mpm.md "Grid": the grid-stencil test and the quadratic B-spline weights) and the
scatter of a vector over it, as Warp functions per scalar type (:mod:`gasp_warp_mpm.precision`), shared by the
transfers (:mod:`gasp_warp_mpm.transfers`) and the brittle held rule's image gradient
(:mod:`gasp_warp_mpm.held_rule`).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from .precision import build_types


@functools.cache
def build_stencil(Ft):
    """``(in_grid, weights)``: the grid-stencil test and the quadratic B-spline weights of a point (docs/mpm.md
    "Grid"), shared by the transfers of scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def in_grid(X: vec3, n_grid: int):
        # base = floor(X - 0.5) must lie in [0, n_grid - 3] on every axis; compared as floats so
        # that NaN and inf positions are out of the grid (never converted to an index).
        lim = Ft(n_grid - 3)
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        ok = b0 >= Ft(0.0) and b0 <= lim and b1 >= Ft(0.0) and b1 <= lim
        return ok and b2 >= Ft(0.0) and b2 <= lim

    @wp.func
    def weights(fx: vec3):
        # Quadratic B-spline weights, row r = weights of node offset r on each axis.
        t0 = vec3(Ft(1.5)) - fx
        t1 = fx - vec3(Ft(1.0))
        t2 = fx - vec3(Ft(0.5))
        w0 = Ft(0.5) * wp.cw_mul(t0, t0)
        w1 = vec3(Ft(0.75)) - wp.cw_mul(t1, t1)
        w2 = Ft(0.5) * wp.cw_mul(t2, t2)
        return wp.matrix_from_rows(w0, w1, w2)

    return in_grid, weights


@functools.cache
def build_scatter_vec(Ft):
    """``scatter_vec(grid_s, idx0, n_grid, W, value)``: a vector added to a point's 27 nodes with its weights (P2G),
    scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def scatter_vec(grid_s: wp.array(dtype=vec3), idx0: int, n_grid: int, W: mat33, value: vec3):
        # grid_s += w value over the 27 nodes from flat index idx0
        nn = n_grid * n_grid
        for i in range(3):
            for j in range(3):
                row = idx0 + i * nn + j * n_grid
                for k in range(3):
                    grid_s[row + k] += (W[i, 0] * W[j, 1] * W[k, 2]) * value

    return scatter_vec
