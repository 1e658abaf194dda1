"""The flowing body's touch in the two-field contact (issue 67, round 37; ``gasp_core.mpm.fields.flow_touch``,
docs/contact.md "Round 37: the flowing body's touch"), taichi_mpm's ``gasp_taichi_mpm.pair_touch`` in Warp.

In a ``"mixed"`` scene, after P2G and before :func:`gasp_warp_mpm.fields.build_fields`' ``field_contact``:
``flow_mark`` (a points kernel, atomic max) marks the 27 stencil nodes of every point of field A (the flowing bodies)
where field B's gathered volume fraction reaches its body's level (``gasp_core.mpm.flow_reach.flow_levels``, round 75: the
point's surface, half its body's point spacing out, lies within ``FLOW_TOUCH_DELTA`` cells of B's surface); ``field_contact`` takes those nodes as where the bodies touch, and at a touching node on A's
side of the surface (``m_A > m_B``) sets A against B's mass at that node and the node behind it moving as one
(Coulomb's rule on A's velocity less B's mean over the two), adding the share of the node behind it (along the
normal, into B) to ``flow_push`` there; after it ``flow_apply`` (a node kernel) adds that
momentum to B's offset there and clears the marks and the pushes (round 64: over the field box, ``field_nodes.py``).

Round 60 (``gasp_core.mpm.gap_touch``, docs/contact.md "Round 60: a touch by geometry"): for two bodies on the
particle contact every material point of either field marks its stencil where the OTHER field's gathered
volume fraction reaches its body's level (its surface within ``SEPARATION`` of the other's), ``build_gap_touch``.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import warp as wp

from .field_nodes import build_sweep
from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_pair_funcs(Ft):
    """``(coulomb, flow_layer)`` of scalar type ``Ft``, the contact's functions: ``coulomb(u, nh, mu)`` the part ``q``
    of the relative velocity ``u`` (m/s) Coulomb's contact along the unit normal ``nh`` removes (0 where ``u . nh <=
    0``); ``flow_layer(grid_mv, grid_sv, flow_push, node, nh, nn, n_grid, pa, v_b, m_b, mu, u2)`` at a contact node
    on A's side (``pa`` A's momentum and mass, ``v_b`` and ``m_b`` B's velocity and mass there, ``u2`` the relative
    velocity after the node's own rule): ``(u - q, M_B)``, Coulomb's ``q`` on A's velocity less B's mean over this
    node and the node behind it (``behind``), ``M_B`` their B mass, the reaction's share of the node behind added to
    ``flow_push``; ``(u2, 0)`` (nothing done) where the node behind holds no more of B."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def coulomb(u: vec3, nh: vec3, mu: Ft):
        un = wp.dot(u, nh)
        q = vec3(Ft(0.0))
        if un > Ft(0.0):
            ut = u - un * nh
            lt = wp.length(ut)
            q = un * nh + ut
            if lt > mu * un:
                q = un * nh + (mu * un / lt) * ut
        return q

    @wp.func
    def behind(node: int, nh: vec3, nn: int, n_grid: int):
        # the node next to this one along the grid axis nearest the normal nh, into B
        a = int(0)
        if wp.abs(nh[1]) > wp.abs(nh[a]):
            a = int(1)
        if wp.abs(nh[2]) > wp.abs(nh[a]):
            a = int(2)
        stride = nn
        if a == 1:
            stride = n_grid
        if a == 2:
            stride = int(1)
        if nh[a] < Ft(0.0):
            stride = -stride
        return node + stride

    @wp.func
    def flow_layer(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), flow_push: wp.array(dtype=vec3),
                   node: int, nh: vec3, nn: int, n_grid: int, pa: vec4, v_b: vec3, m_b: Ft, mu: Ft, u2: vec3):
        out = vec4(u2[0], u2[1], u2[2], Ft(0.0))
        m_a = pa[3]
        p_a = vec3(pa[0], pa[1], pa[2])
        u = p_a / m_a - v_b
        j = behind(node, nh, nn, n_grid)
        gj = grid_mv[j]
        pj = grid_sv[j]
        m_bj = gj[3] - pj[3]
        if m_bj > m_b:   # A against B's mass at both nodes, moving as one
            mb_eff = m_b + m_bj
            v_bj = vec3(gj[0] - pj[0], gj[1] - pj[1], gj[2] - pj[2]) / m_bj
            q = coulomb(p_a / m_a - (m_b * v_b + m_bj * v_bj) / mb_eff, nh, mu)
            wp.atomic_add(flow_push, j, (m_bj * m_a / (m_a + mb_eff)) * q)
            out = vec4(u[0] - q[0], u[1] - q[1], u[2] - q[2], mb_eff)
        return out

    return coulomb, flow_layer


@functools.cache
def build_pair_touch(Ft):
    """``(flow_mark, flow_apply)`` of scalar type ``Ft`` (module docstring)."""
    vec3, vec4, mat33 = build_types(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)   # round 64: flow_apply over the field box

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def flow_mark(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                  grid_vf: wp.array(dtype=Ft), flow_touch: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft,
                  cell: Ft, levels: wp.array(dtype=Ft), n_grid: int, p_pic: wp.array(dtype=wp.int32)):
        p = wp.tid()
        if in_a[body[p]] == 0:
            return
        pic = p_pic.shape[0] > 1   # PIC_AT_B: a touching point's next P2G without its affine momentum
        if pic:
            p_pic[p] = 0
        X = (x[p] - lo) * inv_dx
        lim = Ft(n_grid - 3)
        b = vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
        if not (b[0] >= Ft(0.0) and b[0] <= lim and b[1] >= Ft(0.0) and b[1] <= lim and b[2] >= Ft(0.0)
                and b[2] <= lim):
            return
        fx = X - b
        W = mat33()
        for d in range(3):
            W[0, d] = Ft(0.5) * (Ft(1.5) - fx[d]) * (Ft(1.5) - fx[d])
            W[1, d] = Ft(0.75) - (fx[d] - Ft(1.0)) * (fx[d] - Ft(1.0))
            W[2, d] = Ft(0.5) * (fx[d] - Ft(0.5)) * (fx[d] - Ft(0.5))
        nn = n_grid * n_grid
        n_nodes = nn * n_grid
        idx0 = int(b[0]) * nn + int(b[1]) * n_grid + int(b[2])
        phi = Ft(0.0)
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    phi += W[i, 0] * W[j, 1] * W[k, 2] * grid_vf[n_nodes + idx0 + i * nn + j * n_grid + k]
        if phi >= levels[body[p]] * cell:   # its surface within FLOW_TOUCH_DELTA cells of B's (flow_reach.flow_levels)
            if pic:
                p_pic[p] = 1
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        wp.atomic_max(flow_touch, idx0 + i * nn + j * n_grid + k, 1)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def flow_apply(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), grid_dv: wp.array(dtype=vec3),
                   flow_push: wp.array(dtype=vec3), flow_touch: wp.array(dtype=wp.int32), n_grid: int,
                   box: wp.array(dtype=wp.int32), threads: int, along: int):
        n = box_units(box, along)   # round 64: over the field box (field_nodes.py)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    push = flow_push[node]
                    m_b = grid_mv[node][3] - grid_sv[node][3]
                    if m_b > Ft(0.0) and wp.length(push) > Ft(0.0):
                        grid_dv[grid_sv.shape[0] + node] = grid_dv[grid_sv.shape[0] + node] + push / m_b
                    flow_push[node] = vec3(Ft(0.0))
                    flow_touch[node] = 0

    return flow_mark, flow_apply


@functools.cache
def build_gap_touch(Ft):
    """``(gap_mark, gap_clear)`` of scalar type ``Ft``: round 60's touch by geometry (``gasp_core.mpm.gap_touch``,
    taichi_mpm's ``PairTouch.mark_gap``). ``gap_mark`` (a points kernel, atomic max) marks the 27 stencil nodes of
    every material point where the OTHER field's gathered volume fraction (``grid_vf``: A's volume, then B's
    ``n_grid^3`` further) reaches its body's ``level`` (its surface on the other body's); ``gap_clear`` (a node
    kernel; round 64: over the field box, ``field_nodes.py``) clears the marks after the contact."""
    from .stencil import build_stencil   # here: stencil imports fields, which imports this module
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    box_units, unit_first, unit_len, box_q = build_sweep(Ft)   # round 64: gap_clear over the field box

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_mark(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                 grid_vf: wp.array(dtype=Ft), marks: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, cell: Ft,
                 level: wp.array(dtype=Ft), n_grid: int):
        p = wp.tid()
        X = (x[p] - lo) * inv_dx
        if not in_grid(X, n_grid):   # the transfers' stencil test and weights (gasp_warp_mpm.stencil)
            return
        b = vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
        W = weights(X - b)
        nn = n_grid * n_grid
        other = int(0)   # the other field's part of grid_vf: B's for a point of A
        if in_a[body[p]] != 0:
            other = nn * n_grid
        idx0 = int(b[0]) * nn + int(b[1]) * n_grid + int(b[2])
        phi = Ft(0.0)
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    phi += W[i, 0] * W[j, 1] * W[k, 2] * grid_vf[other + idx0 + i * nn + j * n_grid + k]
        if phi >= level[body[p]] * cell:   # its surface on the other body's
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        wp.atomic_max(marks, idx0 + i * nn + j * n_grid + k, 1)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_clear(marks: wp.array(dtype=wp.int32), n_grid: int, box: wp.array(dtype=wp.int32), threads: int,
                  along: int):
        n = box_units(box, along)   # round 64: over the field box (field_nodes.py)
        run = (n + threads - 1) / threads
        for r in range(run):
            q = box_q(wp.tid(), r, run, threads, along)
            if q < n:
                first = unit_first(box, q, n_grid, along)
                for node in range(first, first + unit_len(box, along)):
                    marks[node] = 0

    return gap_mark, gap_clear


@functools.cache
def build_curvature(Ft):
    """``least_curvature(g, h)`` of scalar type ``Ft``: the smaller principal curvature (1 / cells, positive convex)
    of the level surface of a field decreasing outward with gradient ``g`` and Hessian ``h`` (index units): ``k1 +
    k2`` and ``k1 k2`` from ``g`` and ``adj(h)`` (Goldman 2005; ``gasp_core.mpm.gap_touch.least_curvature``); 0 where
    ``|g|`` <= 1e-6."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.func
    def least_curvature(g: vec3, h: mat33):
        # the smaller principal curvature of the level surface (Goldman 2005): k1 + k2, k1 k2 from g and adj(h)
        gn = wp.length(g)
        out = Ft(0.0)
        if gn > Ft(1e-6):
            t = (wp.dot(g, h * g) - gn * gn * (h[0, 0] + h[1, 1] + h[2, 2])) / (gn * gn * gn)
            a00 = h[1, 1] * h[2, 2] - h[1, 2] * h[1, 2]
            a11 = h[0, 0] * h[2, 2] - h[0, 2] * h[0, 2]
            a22 = h[0, 0] * h[1, 1] - h[0, 1] * h[0, 1]
            a01 = h[0, 2] * h[1, 2] - h[0, 1] * h[2, 2]
            a02 = h[0, 1] * h[1, 2] - h[0, 2] * h[1, 1]
            a12 = h[0, 1] * h[0, 2] - h[0, 0] * h[1, 2]
            q = (a00 * g[0] * g[0] + a11 * g[1] * g[1] + a22 * g[2] * g[2]
                 + Ft(2.0) * (a01 * g[0] * g[1] + a02 * g[0] * g[2] + a12 * g[1] * g[2]))
            kg = q / (gn * gn * gn * gn)
            out = Ft(0.5) * (t - wp.sqrt(wp.max(t * t - Ft(4.0) * kg, Ft(0.0))))
        return out

    return least_curvature


@functools.cache
def build_gather_two(Ft):
    """``gather_two(X, grid_vf, in_a_body, n_grid, cell)``: at a point ``X`` (index units) of a body whose field is A
    (``in_a_body`` 1) or B, the OTHER field's gathered volume fraction ``phi`` and both fields' gathered gradients and
    Hessians (index units, the quadratic B-spline's derivatives): ``(phi, g_other, g_own, h_other, h_own)``; the
    gather of round 61's curvature touch (``gap_curve``) and round 62's push (``pair_push.gap_overlap``)."""
    from .stencil import build_stencil
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)

    @wp.func
    def gather_two(X: vec3, grid_vf: wp.array(dtype=Ft), in_a_body: int, n_grid: int, cell: Ft):
        b = vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
        fx = X - b
        W = weights(fx)
        D1 = wp.matrix_from_rows(fx - vec3(Ft(1.5)), Ft(-2.0) * (fx - vec3(Ft(1.0))), fx - vec3(Ft(0.5)))
        nn = n_grid * n_grid
        other = int(0)   # the other field's part of grid_vf: B's for a point of A
        own = nn * n_grid
        if in_a_body != 0:
            other = nn * n_grid
            own = int(0)
        idx0 = int(b[0]) * nn + int(b[1]) * n_grid + int(b[2])
        phi = Ft(0.0)
        g_o = vec3(Ft(0.0))
        g_s = vec3(Ft(0.0))
        h_o = mat33()
        h_s = mat33()
        for i in range(3):
            for j in range(3):
                for k in range(3):
                    node = idx0 + i * nn + j * n_grid + k
                    vo = grid_vf[other + node] / cell
                    vs = grid_vf[own + node] / cell
                    wx = W[i, 0]
                    wy = W[j, 1]
                    wz = W[k, 2]
                    dx = D1[i, 0]
                    dy = D1[j, 1]
                    dz = D1[k, 2]
                    ex = Ft(1.0) - Ft(3.0) * Ft(i % 2)   # the second derivative of the weight: 1, -2, 1
                    ey = Ft(1.0) - Ft(3.0) * Ft(j % 2)
                    ez = Ft(1.0) - Ft(3.0) * Ft(k % 2)
                    phi += wx * wy * wz * vo
                    gw = vec3(dx * wy * wz, wx * dy * wz, wx * wy * dz)
                    hw = mat33(ex * wy * wz, dx * dy * wz, dx * wy * dz,
                               dx * dy * wz, wx * ey * wz, wx * dy * dz,
                               dx * wy * dz, wx * dy * dz, wx * wy * ez)
                    g_o += vo * gw
                    g_s += vs * gw
                    h_o += vo * hw
                    h_s += vs * hw
        return phi, g_o, g_s, h_o, h_s

    return gather_two


@functools.cache
def build_gap_curve(Ft):
    """``gap_curve``: round 61's marks (``gasp_core.mpm.gap_touch.CURVATURE``, its ``gap_marks`` with a table): a
    points kernel as ``gap_mark`` whose level is the half-space table's (``params[:table_n]``, step ``step`` cells)
    at ``delta_b + sigma2 k`` (``params[table_n + body]``: the body's reach, cells), ``k`` the least principal
    curvature the two fields' level surfaces share at the point (``least_curvature`` of the gathered gradient and
    Hessian of each field, index units), clamped at 0."""
    from .stencil import build_stencil
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)

    least_curvature = build_curvature(Ft)
    gather_two = build_gather_two(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_curve(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                  grid_vf: wp.array(dtype=Ft), marks: wp.array(dtype=wp.int32), lo: vec3, inv_dx: Ft, cell: Ft,
                  params: wp.array(dtype=Ft), n_grid: int, table_n: int, step: Ft, sigma2: Ft):
        p = wp.tid()
        X = (x[p] - lo) * inv_dx
        if not in_grid(X, n_grid):
            return
        phi, g_o, g_s, h_o, h_s = gather_two(X, grid_vf, in_a[body[p]], n_grid, cell)
        b = vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
        nn = n_grid * n_grid
        idx0 = int(b[0]) * nn + int(b[1]) * n_grid + int(b[2])
        kap = wp.max(wp.min(least_curvature(g_o, h_o), least_curvature(g_s, h_s)), Ft(0.0))
        u = wp.clamp((params[table_n + body[p]] + sigma2 * kap) / step, Ft(0.0), Ft(table_n) - Ft(1.001))
        t = int(wp.floor(u))
        level = params[t] + (u - Ft(t)) * (params[t + 1] - params[t])
        if phi >= level:   # its surface on the other body's, the curvature's smoothing read
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        wp.atomic_max(marks, idx0 + i * nn + j * n_grid + k, 1)

    return gap_curve
