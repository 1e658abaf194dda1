"""Round 52 (issue 67; docs/contact.md "Round 52: one balance carried with the body"): ``touch_bound = "body"``
(``gasp_core.mpm.contact.TOUCH_BOUNDS`` 4), round 51's debt (``gasp_warp_mpm.share.build_column_bound``) kept per
body and ground instead of per column. A column marked 2 belongs to the largest body id of the points of a body
that does not flow that mark it (``touch_body``, ``touch.build_touch``'s ``touch_mark``, atomic max). Three
kernels after the grid update, in place of ``share.build_share``'s ``touch_share``:

- ``body_gather`` (a column a thread): the two dashpots (round 50), and the column's ``mu`` times their signed push,
  its held layers' stops, the friction its held nodes want (each at most its own stop's) and its touched node's
  (``m |v_xy|``), added with float atomics into the pool of its ground and body (:data:`POOL` slots, kg m/s);
- ``body_settle`` (a pool a thread): round 51's bound on the pool: ``r`` = the carried balance plus the pushes,
  ``avail`` = ``r`` plus the stops, ``give`` = ``min(want, max(avail, 0))``, the held nodes first; the fraction of
  each side's want given (slots 6, 7), the balance carried ``min(max(r, 0), avail - give)`` (a debt kept until the
  body's stops pay it, wherever on its footprint); 0 for a pool no column counted this substep;
- ``body_apply`` (a column a thread): each held node's tangential velocity cut by the held fraction of its own want,
  the touched node's by the touched fraction; the column's slots cleared.

Round 53 (docs/contact.md "Round 53: a pull's debt refunded at once"; ``touch_pull``,
``gasp_core.mpm.contact.TOUCH_PULLS``): ``"refund"`` (the default): where ``body_settle`` leaves the body a debt (the
dashpots' pulls beyond the carried balance and the stops) it returns it at once, at most the friction the pool has
given since the body's contact began (slot 8) and at most the wants ``wh + wt``: both fractions ``-back / (wh +
wt)``, so ``body_apply`` scales the contact nodes' tangential velocity up along their own slip, in proportion to the
friction each could take; a debt no slip can take is carried as before. ``"contact"``: a column's dashpots pull at
most their net push since the column's contact began (``pushed``, the engine's ``touch_credits``); ``"none"``: they
do not pull; ``"both"``: round 52's.

taichi_mpm's ``gasp_taichi_mpm.body_bound.BodyBound``, the same rule.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import warp as wp

from .precision import MODULE_OPTIONS, build_types
from .share import SLOTS, build_damp_node

#: A pool's slots (ground ``q``, body ``b`` at ``(q n_bodies + b) POOL``): 0 the balance carried (kept across
#: substeps), 1 ``mu`` times the dashpots' push, 2 the held layers' stops, 3 the held nodes' want, 4 the touched
#: nodes', 5 the columns counted, 6 the held fraction given, 7 the touched fraction given; round 53: 8 the friction
#: given since the body's contact began, less what was refunded (kept across substeps).
POOL = 9


@functools.cache
def build_column_funcs(Ft):
    """``(damp_node, column_of)``, scalar type ``Ft``: ``share.build_damp_node``'s dashpot (its pull at most ``room``,
    round 53); ``column_of(col, n_grid, ground, ground_touch) -> node``, the touched node of column ``col`` (-1 where
    the column is not marked 2 on a ground with friction)."""
    vec3 = build_types(Ft)[0]

    @wp.func
    def column_of(col: int, n_grid: int, ground: wp.array(dtype=vec3), ground_touch: wp.array(dtype=wp.int32)):
        # the touched node of column col (-1 where the column is not marked 2 on a ground with friction)
        q = col / (n_grid * n_grid)
        i = (col / n_grid) % n_grid
        j = col % n_grid
        gr = ground[q]
        kt = int(gr[0]) + 1
        node = int(-1)
        if ground_touch[col] == 2 and gr[1] > Ft(0.0) and kt >= 0 and kt < n_grid:
            node = (i * n_grid + j) * n_grid + kt
        return node

    return build_damp_node(Ft), column_of


@functools.cache
def build_body_bound(Ft):
    """``(body_gather, body_settle, body_apply)``, scalar type ``Ft`` (module docstring). Arguments: ``grid_v`` (vec3,
    m/s), ``slots`` (``share.SLOTS`` a column), ``ground`` (vec3 a ground: top layer, mu), ``ground_touch`` and
    ``touch_body`` (int32, a column), ``n_grid``, ``credit`` (``s dt / dx``, the dashpot), ``pool`` (:data:`POOL` a
    ground and body, ``Ft``), ``n_bodies``; round 53: ``pushed`` (``Ft`` a column, kg m/s, the net push since the
    column's contact began; read with ``pull`` 1) and ``pull`` (``TOUCH_PULLS``; ``body_settle`` takes it too)."""
    vec3 = build_types(Ft)[0]
    damp_node, column_of = build_column_funcs(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def body_gather(grid_v: wp.array(dtype=vec3), slots: wp.array(dtype=Ft), ground: wp.array(dtype=vec3),
                    ground_touch: wp.array(dtype=wp.int32), touch_body: wp.array(dtype=wp.int32), n_grid: int,
                    credit: Ft, pool: wp.array(dtype=Ft), n_bodies: int, pushed: wp.array(dtype=Ft), pull: int):
        col = wp.tid()
        node = column_of(col, n_grid, ground, ground_touch)
        if node < 0:
            if pull == 1:
                pushed[col] = Ft(0.0)   # round 53: the contact ended, its push is not carried
            return
        q = col / (n_grid * n_grid)
        mu = ground[q][1]
        m = slots[col * SLOTS + 3]
        push = Ft(0.0)
        if credit > Ft(0.0):   # round 50's two dashpots; round 53 (pull): a pull at most the contact's net push
            room = Ft(1e30)
            if pull == 2:
                room = Ft(0.0)
            if pull == 1:
                room = pushed[col]
            jn = damp_node(grid_v, node, m, credit, room)
            if node % n_grid + 1 < n_grid:
                jn = jn + damp_node(grid_v, node + 1, slots[col * SLOTS + 4], credit, room + jn)
            if pull == 1:
                pushed[col] = pushed[col] + jn
            push = mu * jn
        stops = Ft(0.0)
        want = Ft(0.0)
        for c in range(3):
            stops = stops + slots[col * SLOTS + c]
            mc = slots[col * SLOTS + 5 + c]
            if mc > Ft(0.0) and node % n_grid - 3 + c >= 0:
                u = grid_v[node - 3 + c]
                want = want + wp.min(mc * wp.sqrt(u[0] * u[0] + u[1] * u[1]), slots[col * SLOTS + c])
        v = grid_v[node]
        e = (q * n_bodies + touch_body[col]) * POOL
        wp.atomic_add(pool, e + 1, push)
        wp.atomic_add(pool, e + 2, stops)
        wp.atomic_add(pool, e + 3, want)
        wp.atomic_add(pool, e + 4, m * wp.sqrt(v[0] * v[0] + v[1] * v[1]))
        wp.atomic_add(pool, e + 5, Ft(1.0))

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def body_apply(grid_v: wp.array(dtype=vec3), slots: wp.array(dtype=Ft), ground: wp.array(dtype=vec3),
                   ground_touch: wp.array(dtype=wp.int32), touch_body: wp.array(dtype=wp.int32), n_grid: int,
                   pool: wp.array(dtype=Ft), n_bodies: int):
        col = wp.tid()
        node = column_of(col, n_grid, ground, ground_touch)
        if node >= 0:
            e = (col / (n_grid * n_grid) * n_bodies + touch_body[col]) * POOL
            fh = pool[e + 6]
            for c in range(3):
                mc = slots[col * SLOTS + 5 + c]
                if mc > Ft(0.0) and node % n_grid - 3 + c >= 0:
                    u = grid_v[node - 3 + c]
                    lu = wp.sqrt(u[0] * u[0] + u[1] * u[1])
                    if lu > Ft(1e-30):
                        s = wp.max(Ft(0.0), Ft(1.0) - fh * wp.min(mc * lu, slots[col * SLOTS + c]) / (mc * lu))
                        grid_v[node - 3 + c] = vec3(u[0] * s, u[1] * s, u[2])
            v = grid_v[node]
            if slots[col * SLOTS + 3] > Ft(0.0):
                s = wp.max(Ft(0.0), Ft(1.0) - pool[e + 7])
                grid_v[node] = vec3(v[0] * s, v[1] * s, v[2])
        for c in range(SLOTS):   # cleared for the next substep
            slots[col * SLOTS + c] = Ft(0.0)

    return body_gather, build_body_settle(Ft), body_apply


@functools.cache
def build_body_settle(Ft):
    """``body_settle(pool, pull)``, scalar type ``Ft``, a pool a thread: round 51's bound on the pool's sums (module
    docstring), the fractions given written to slots 6-7, the balance carried to slot 0, the sums cleared; round 53,
    ``pull`` 3 (``"refund"``): a debt refunded at once (module docstring), the friction given kept in slot 8."""

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def body_settle(pool: wp.array(dtype=Ft), pull: int):
        e = wp.tid() * POOL
        if pool[e + 5] > Ft(0.0):
            r = pool[e] + pool[e + 1]
            avail = r + pool[e + 2]
            wh = pool[e + 3]
            wt = pool[e + 4]
            give = wp.min(wh + wt, wp.max(avail, Ft(0.0)))
            fh = Ft(1.0)
            if give < wh:
                fh = give / wh
            ft = Ft(0.0)
            if wt > Ft(0.0) and give > wh:
                ft = (give - wh) / wt
            bal = wp.min(wp.max(r, Ft(0.0)), avail - give)   # a debt kept until the body's stops pay it
            pool[e + 8] = pool[e + 8] + give
            if pull == 3 and bal < Ft(0.0) and wh + wt > Ft(0.0):   # round 53: the debt refunded at once
                back = wp.min(wp.min(-bal, pool[e + 8]), wh + wt)
                fh = -back / (wh + wt)
                ft = fh
                bal = bal + back
                pool[e + 8] = pool[e + 8] - back
            pool[e] = bal
            pool[e + 6] = fh
            pool[e + 7] = ft
        else:
            pool[e] = Ft(0.0)   # the body touches no column: its balance is not carried
            pool[e + 8] = Ft(0.0)
        for c in range(1, 6):
            pool[e + c] = Ft(0.0)

    return body_settle
