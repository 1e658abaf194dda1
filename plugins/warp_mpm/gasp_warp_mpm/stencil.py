"""The stencil of a point (docs/mpm.md "Grid": the grid-stencil test and the quadratic B-spline weights) and the
scatter of a vector over it and the gather of the grid's velocity, as Warp functions per scalar type
(:mod:`gasp_warp_mpm.precision`), shared by the transfers (:mod:`gasp_warp_mpm.transfers`) and the brittle held
rule's image gradient (:mod:`gasp_warp_mpm.held_rule`).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from .fields import build_field_reads
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
def build_stencil_at(Ft):
    """``stencil_at(X, n_grid)``: ``(W, idx0, fx)`` of a point at grid coordinates ``X`` (``(x - lo) inv_dx``, in
    cells): its quadratic B-spline weights (:func:`build_stencil`'s ``weights``), the flat index of its stencil's
    first node ``base = floor(X - 0.5)`` and its offset from it ``fx = X - base`` (cells); the caller tests
    ``in_grid`` first. Shared by the contacts' kernels
    (``point_contact.py``, ``point_grid.py``, ``rigid_collider.py``), scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)
    weights = build_stencil(Ft)[1]

    @wp.func
    def stencil_at(X: vec3, n_grid: int):
        b0 = wp.floor(X[0] - Ft(0.5))
        b1 = wp.floor(X[1] - Ft(0.5))
        b2 = wp.floor(X[2] - Ft(0.5))
        fx = X - vec3(b0, b1, b2)
        return weights(fx), (int(b0) * n_grid + int(b1)) * n_grid + int(b2), fx

    return stencil_at


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


@functools.cache
def build_gather(Ft):
    """``gather(grid_v, grid_dv, off, W, idx0, n_grid)``: ``(v, B)`` over a point's 27 nodes from flat index ``idx0``
    with its weights ``W`` (:func:`build_stencil`): ``v = sum w g`` (m/s) and ``B = sum w g (i, j, k)^T`` (m/s), ``g``
    each node's velocity plus its field's offset (``fields.build_field_reads``, ``off`` -1: the grid's alone), summed
    over node planes; G2P's ``C = 4 inv_dx (B - v fx^T)`` (APIC, Jiang et al. 2015)."""
    vec3, vec4, mat33 = build_types(Ft)
    field_node_v = build_field_reads(Ft)[1]

    @wp.func
    def gather(grid_v: wp.array(dtype=vec3), grid_dv: wp.array(dtype=vec3), off: int, W: mat33, idx0: int,
               n_grid: int):
        nn = n_grid * n_grid
        new_v = vec3(Ft(0.0))
        si1 = vec3(Ft(0.0))
        si2 = vec3(Ft(0.0))
        sj1 = vec3(Ft(0.0))
        sj2 = vec3(Ft(0.0))
        sk1 = vec3(Ft(0.0))
        sk2 = vec3(Ft(0.0))
        for i in range(3):
            vi = vec3(Ft(0.0))
            for j in range(3):
                wij = W[i, 0] * W[j, 1]
                row = idx0 + i * nn + j * n_grid
                vj = vec3(Ft(0.0))
                for k in range(3):
                    wg = (wij * W[k, 2]) * field_node_v(grid_v, grid_dv, off, row + k)
                    vj = vj + wg
                    if k == 1:
                        sk1 = sk1 + wg
                    if k == 2:
                        sk2 = sk2 + wg
                vi = vi + vj
                if j == 1:
                    sj1 = sj1 + vj
                if j == 2:
                    sj2 = sj2 + vj
            new_v = new_v + vi
            if i == 1:
                si1 = si1 + vi
            if i == 2:
                si2 = si2 + vi
        c0 = si1 + Ft(2.0) * si2
        c1 = sj1 + Ft(2.0) * sj2
        c2 = sk1 + Ft(2.0) * sk2
        return new_v, wp.matrix_from_cols(c0, c1, c2)

    return gather
