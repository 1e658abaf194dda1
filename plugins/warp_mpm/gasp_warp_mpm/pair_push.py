"""Round 62's push (``gasp_core.mpm.gap_push``, docs/contact.md "Round 62: letting an overlap out"), taichi_mpm's
``gasp_taichi_mpm.pair_push`` in Warp: points kernels that sum, per soft body, the overlap of its points past their
touch level (the half-space profile inverted at the other field's gathered volume fraction, along the normal out of
the other body) and translate each body by its share of the mean, no velocity changed. Launched after the contact,
before the clear of the fields' volumes (:func:`with_push`, from the engine's launch list).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import warp as wp

from .pair_touch import build_curvature, build_gather_two
from .precision import MODULE_OPTIONS, build_types


@functools.cache
def build_table_distance(Ft):
    """``table_distance(params, phi, table_n, step)``: the distance (cells) at which the half-space profile
    (``params[:table_n]``, step ``step`` cells) reads ``phi``, odd about the face (``gasp_core.mpm.gap_push.
    table_distance``: a bisection over the table, then its linear piece)."""

    @wp.func
    def table_distance(params: wp.array(dtype=Ft), phi: Ft, table_n: int, step: Ft):
        # the distance (cells) at which the half-space profile reads phi, odd about the face (a bisection)
        q = phi
        sign = Ft(1.0)
        if phi > params[0]:
            q = Ft(1.0) - phi
            sign = Ft(-1.0)
        s = Ft(0.0)
        if q <= params[table_n - 1]:
            s = Ft(table_n - 1) * step
        elif q < params[0]:
            lo = int(0)
            hi = table_n - 1
            while hi - lo > 1:
                mid = (lo + hi) / 2
                if params[mid] > q:
                    lo = mid
                else:
                    hi = mid
            s = (Ft(lo) + (params[lo] - q) / (params[lo] - params[hi])) * step
        return sign * s

    return table_distance


@functools.cache
def build_gap_push(Ft):
    """``(gap_overlap, gap_move, gap_acc_clear)``: the reference's ``gasp_core.mpm.gap_push.gap_push``.
    ``gap_overlap`` (points; ``params``: the half-space table (``table_n`` entries, step ``step`` cells), each body's
    reach, then each body's share; ``curve`` 1 with ``gap_touch.CURVATURE``: the reach plus ``sigma2`` times the least
    curvature the two fields share) adds each overlapping point's ``d n`` (cells) and 1 to its body's ``acc``
    (atomic); ``gap_move`` (points) adds to ``x`` its body's share of the mean, at most ``cap`` cells (times ``dx_m``,
    m); ``gap_acc_clear`` zeroes ``acc`` (one entry per body) first."""
    from .stencil import build_stencil
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)
    least_curvature = build_curvature(Ft)
    gather_two = build_gather_two(Ft)
    table_distance = build_table_distance(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_overlap(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), in_a: wp.array(dtype=wp.int32),
                    grid_vf: wp.array(dtype=Ft), lo: vec3, inv_dx: Ft, cell: Ft, params: wp.array(dtype=Ft),
                    n_grid: int, table_n: int, n_bodies: int, step: Ft, sigma2: Ft, curve: int,
                    acc: wp.array(dtype=vec4)):
        p = wp.tid()
        share = params[table_n + n_bodies + body[p]]
        if share <= Ft(0.0):
            return
        X = (x[p] - lo) * inv_dx
        if not in_grid(X, n_grid):
            return
        phi, g_o, g_s, h_o, h_s = gather_two(X, grid_vf, in_a[body[p]], n_grid, cell)
        reach = params[table_n + body[p]]
        if curve != 0:
            kap = wp.max(wp.min(least_curvature(g_o, h_o), least_curvature(g_s, h_s)), Ft(0.0))
            reach = reach + sigma2 * kap
        d = reach - table_distance(params, phi, table_n, step)
        gn = wp.length(g_o)
        if d > Ft(0.0) and gn > Ft(1e-6):   # its overlap along the unit normal out of the other body
            dn = (-d / gn) * g_o
            wp.atomic_add(acc, body[p], vec4(dn[0], dn[1], dn[2], Ft(1.0)))

    gap_move, gap_acc_clear = build_gap_move(Ft)
    return gap_overlap, gap_move, gap_acc_clear


@functools.cache
def build_gap_move(Ft):
    """``(gap_move, gap_acc_clear)`` of :func:`build_gap_push`."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_move(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), params: wp.array(dtype=Ft),
                 table_n: int, n_bodies: int, acc: wp.array(dtype=vec4), dx_m: Ft, cap: Ft):
        # each soft body translated by its share of its overlapping points' mean d n, at most cap cells
        p = wp.tid()
        a = acc[body[p]]
        if a[3] > Ft(0.0):
            t = (params[table_n + n_bodies + body[p]] / a[3]) * vec3(a[0], a[1], a[2])
            lt = wp.length(t)
            if lt > cap:
                t = (cap / lt) * t
            x[p] = x[p] + dx_m * t

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_acc_clear(acc: wp.array(dtype=vec4)):
        acc[wp.tid()] = vec4(Ft(0.0))

    return gap_move, gap_acc_clear


@functools.cache
def build_gap_kick(Ft):
    """``gap_kick``: the broken variant of the checks (``gasp_core.mpm.gap_push.KICK``), the push made a velocity
    (Baumgarte's bias, what the split impulse avoids): each point scatters ``m_p t dx / dt`` (its body's move as a
    momentum) to ``grid_mv``'s momentum before the grid update, instead of moving."""
    from .stencil import build_stencil
    vec3, vec4, mat33 = build_types(Ft)
    in_grid, weights = build_stencil(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def gap_kick(x: wp.array(dtype=vec3), body: wp.array(dtype=wp.int32), p_mass: wp.array(dtype=Ft),
                 params: wp.array(dtype=Ft), table_n: int, n_bodies: int, acc: wp.array(dtype=vec4), lo: vec3,
                 inv_dx: Ft, dx_m: Ft, cap: Ft, inv_dt: Ft, n_grid: int, grid_mv: wp.array(dtype=vec4)):
        p = wp.tid()
        a = acc[body[p]]
        X = (x[p] - lo) * inv_dx
        if a[3] > Ft(0.0) and in_grid(X, n_grid):
            t = (params[table_n + n_bodies + body[p]] / a[3]) * vec3(a[0], a[1], a[2])
            lt = wp.length(t)
            if lt > cap:
                t = (cap / lt) * t
            q = (p_mass[p] * dx_m * inv_dt) * t
            b = vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
            W = weights(X - b)
            nn = n_grid * n_grid
            idx0 = int(b[0]) * nn + int(b[1]) * n_grid + int(b[2])
            for i in range(3):
                for j in range(3):
                    for k in range(3):
                        w = W[i, 0] * W[j, 1] * W[k, 2]
                        wp.atomic_add(grid_mv, idx0 + i * nn + j * n_grid + k, vec4(w * q[0], w * q[1], w * q[2],
                                                                                     Ft(0.0)))

    return gap_kick


def allocate_push(eng, view, Ft) -> None:
    """``eng.gap_push_on`` (round 62: ``gasp_core.mpm.gap_push.PUSH`` with the touch by geometry on),
    ``eng.push_params`` (``gap_push.push_params`` of ``view``; one entry when off) and ``eng.push_acc`` (per body)."""
    import numpy as np
    from gasp_core.mpm import gap_push as GP
    eng.gap_push_on = bool(getattr(eng, "gap_touch_on", False) and GP.PUSH)
    eng.push_params = wp.array(GP.push_params(view) if eng.gap_push_on else np.zeros(1), dtype=Ft, device=eng.device)
    eng.push_acc = wp.zeros(len(view.materials) if eng.gap_push_on else 1, dtype=eng.k.vec4, device=eng.device)


def with_push(eng, Ft, launches: list) -> list:
    """``gasp_warp_mpm.fields.field_launches``' list (``launches``, its last the clear of the fields' volumes) with the
    push's launches (:func:`push_launches`) before that clear when it is on; the list itself when off (or no fields).
    Allocates the push (:func:`allocate_push`) from the engine's setup."""
    from gasp_core.mpm.rigid import step_view
    allocate_push(eng, step_view(eng.setup), Ft)
    if not launches or not eng.gap_push_on:
        return launches
    lo = eng.k.vec3(*[float(c) for c in eng.setup.domain_lo])
    return launches[:-1] + push_launches(eng, Ft, lo) + launches[-1:]


def push_launches(eng, Ft, lo) -> list:
    """The recorded launch of :func:`build_gap_push` over the material points (none when off): after the contact,
    before the clear of ``grid_vf``."""
    if not eng.gap_push_on:
        return []
    from gasp_core.mpm import gap_push as GP, gap_touch as G
    nb = (eng.push_params.shape[0] - G.TABLE_N) // 2
    overlap, move, clear = build_gap_push(Ft)
    d, n = eng.device, eng.n_material
    return [wp.launch(clear, dim=nb, device=d, record_cmd=True, inputs=[eng.push_acc]),
            wp.launch(overlap, dim=n, device=d, record_cmd=True, inputs=[
                eng.x, eng.body, eng.in_a, eng.grid_vf, lo, Ft(eng.inv_dx), Ft(eng.dx ** 3), eng.push_params,
                eng.n_grid, G.TABLE_N, nb, Ft(G.TABLE_STEP), Ft(G.SIGMA2), int(bool(G.CURVATURE)), eng.push_acc]),
            wp.launch(move, dim=n, device=d, record_cmd=True, inputs=[
                eng.x, eng.body, eng.push_params, G.TABLE_N, nb, eng.push_acc, Ft(eng.dx), Ft(GP.CAP)])
            if not GP.KICK else wp.launch(build_gap_kick(Ft), dim=n, device=d, record_cmd=True, inputs=[
                eng.x, eng.body, eng.p_mass, eng.push_params, G.TABLE_N, nb, eng.push_acc, lo, Ft(eng.inv_dx),
                Ft(eng.dx), Ft(GP.CAP), Ft(1.0 / eng.dt), eng.n_grid, eng.grid_mv])]
