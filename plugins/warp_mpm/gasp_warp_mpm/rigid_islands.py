"""Round 81: the touching pairs of rigid bodies solved island by island on the gpu schedule
(``gasp_core.mpm.rigid_pairs.ISLANDS``; taichi_mpm's ``RigidPairs.rigid_pairs_gpu``): :func:`build_rigid_pairs_gpu`,
the seven kernels, and :func:`islands_launches`, their recorded launches (``rigid_pairs.pairs_launches`` calls it).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import warp as wp

from .precision import MODULE_OPTIONS
from .rigid_pairs import build_pair_update, mat33d, pair_normal, vec3d
from .rigid_support import Hollow, body_row


@functools.cache
def build_rigid_pairs_gpu(Ft):
    """Round 81: ``rigid_pairs`` on the gpu schedule, as taichi_mpm's ``RigidPairs.rigid_pairs_gpu`` (its docstring
    has the steps): the same updates in the same order on each body, so the same bits, in seven launches: ``prep``
    (one thread a listed slot: rows, impulses cleared, height), ``bodies`` (one a body: ``V0``, the islands' tables
    reset), ``rank`` (one a listed slot: its place in the order by (height, slot), the insertion sort's), ``islands``
    (one thread: union-find over the ordered pairs, each island's pairs listed in order, ``count`` kept in
    ``n_keep`` and zeroed), ``sweep`` (one thread an island: ``sweeps`` sweeps over its pairs in order), ``advance``
    (one a body: the centres) and ``clear`` (one a listed slot: its sums). Returns those seven kernels. Long because
    the seven kernels share the closure's ``pair_update`` and types."""
    pair_update = build_pair_update(Ft)

    @wp.func
    def height(acc: wp.array(dtype=wp.float64), s: int, gravity: vec3d):
        return -wp.dot(gravity, vec3d(acc[7 * s + 1], acc[7 * s + 2], acc[7 * s + 3])) / acc[7 * s]

    @wp.func
    def find(root: wp.array(dtype=wp.int32), x: int):
        r = x
        while root[r] != r:
            root[r] = root[root[r]]
            r = root[r]
        return r

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def prep(rot: wp.array(dtype=mat33d), nb: int, acc: wp.array(dtype=wp.float64), lam: wp.array(dtype=wp.float64),
             gravity: vec3d, slots: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32),
             t_dirs: wp.array(dtype=vec3d), nd: int, rows: wp.array(dtype=wp.int32), key: wp.array(dtype=wp.float64),
             t_h: wp.array(dtype=wp.float64), t_round: wp.array(dtype=wp.float64), cos_cone: wp.float64, hol: Hollow,
             centre: wp.array(dtype=vec3d), vel: wp.array(dtype=vec3d), dt: wp.float64,
             allow: wp.array(dtype=wp.float64)):
        q = wp.tid()
        if q >= count[0]:
            return
        s = slots[q]
        nn = pair_normal(acc, s, nb, t_dirs, t_h, t_round, nd, cos_cone, hol, rot, centre, vel, dt, allow)   # round 91
        rows[2 * s] = body_row(t_dirs, nd, s / nb, rot[s / nb], nn)
        rows[2 * s + 1] = body_row(t_dirs, nd, s - (s / nb) * nb, rot[s - (s / nb) * nb], -nn)
        for c in range(4):
            lam[4 * s + c] = wp.float64(0.0)
        key[q] = height(acc, s, gravity)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def bodies(vel: wp.array(dtype=vec3d), V0: wp.array(dtype=vec3d), root: wp.array(dtype=wp.int32),
               isl_of: wp.array(dtype=wp.int32), isl_count: wp.array(dtype=wp.int32),
               isl_fill: wp.array(dtype=wp.int32)):
        b = wp.tid()
        V0[b] = vel[b]
        root[b] = b
        isl_of[b] = -1
        isl_count[b] = 0
        isl_fill[b] = 0

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def rank(slots: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32), key: wp.array(dtype=wp.float64),
             order: wp.array(dtype=wp.int32)):
        q = wp.tid()
        n_on = count[0]
        if q >= n_on:
            return
        s = slots[q]
        h = key[q]
        r = int(0)
        for j in range(n_on):
            if key[j] < h or (key[j] == h and slots[j] < s):
                r = r + 1
        order[r] = s

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def islands(nb: int, order: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32),
                root: wp.array(dtype=wp.int32), isl_of: wp.array(dtype=wp.int32), isl: wp.array(dtype=wp.int32),
                isl_count: wp.array(dtype=wp.int32), isl_start: wp.array(dtype=wp.int32),
                isl_fill: wp.array(dtype=wp.int32), isl_list: wp.array(dtype=wp.int32),
                isl_n: wp.array(dtype=wp.int32), n_keep: wp.array(dtype=wp.int32)):
        n_on = count[0]
        for q in range(n_on):
            s = order[q]
            ra = find(root, s / nb)
            rb = find(root, s - (s / nb) * nb)
            if ra != rb:
                root[wp.max(ra, rb)] = wp.min(ra, rb)
        n_isl = int(0)
        for q in range(n_on):
            r = find(root, order[q] / nb)
            if isl_of[r] < 0:
                isl_of[r] = n_isl
                n_isl = n_isl + 1
            i = isl_of[r]
            isl[q] = i
            isl_count[i] = isl_count[i] + 1
        start = int(0)
        for i in range(n_isl):
            isl_start[i] = start
            start = start + isl_count[i]
        isl_start[n_isl] = start
        for q in range(n_on):
            i = isl[q]
            isl_list[isl_start[i] + isl_fill[i]] = order[q]
            isl_fill[i] = isl_fill[i] + 1
        isl_n[0] = n_isl
        n_keep[0] = n_on
        count[0] = 0

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def sweep(mass: wp.array(dtype=wp.float64), inertia0: wp.array(dtype=mat33d), centre: wp.array(dtype=vec3d),
              rot: wp.array(dtype=mat33d), vel: wp.array(dtype=vec3d), spin: wp.array(dtype=vec3d), dx: wp.float64,
              nb: int, mu: wp.array(dtype=wp.float64), acc: wp.array(dtype=wp.float64),
              lam: wp.array(dtype=wp.float64), sweeps: int, rows: wp.array(dtype=wp.int32),
              t_h: wp.array(dtype=wp.float64), t_curv: wp.array(dtype=mat33d), t_delta: wp.array(dtype=wp.float64),
              t_round: wp.array(dtype=wp.float64), isl_start: wp.array(dtype=wp.int32),
              isl_list: wp.array(dtype=wp.int32), isl_n: wp.array(dtype=wp.int32), allow: wp.array(dtype=wp.float64),
              hol: Hollow):
        i = wp.tid()
        if i >= isl_n[0]:
            return
        half = wp.float64(0.5) * dx * dx
        for _sweep in range(sweeps):
            for k in range(isl_start[i], isl_start[i + 1]):
                pair_update(isl_list[k], nb, half, mass, inertia0, centre, rot, vel, spin, mu, acc, lam, rows, t_h,
                            t_curv, t_delta, t_round, allow, hol)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def advance(centre: wp.array(dtype=vec3d), vel: wp.array(dtype=vec3d), V0: wp.array(dtype=vec3d),
                dt: wp.float64):
        b = wp.tid()
        centre[b] = centre[b] + dt * (vel[b] - V0[b])

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def clear(acc: wp.array(dtype=wp.float64), slots: wp.array(dtype=wp.int32), n_keep: wp.array(dtype=wp.int32),
              seen: wp.array(dtype=wp.int32)):
        q = wp.tid()
        if q >= n_keep[0]:
            return
        s = slots[q]
        for c in range(7):
            acc[7 * s + c] = wp.float64(0.0)
        seen[s] = 0

    return prep, bodies, rank, islands, sweep, advance, clear


def islands_launches(eng, Ft) -> list:
    """Round 81's seven recorded launches (:func:`build_rigid_pairs_gpu`): over the slots (``n_bodies^2``, the listed
    ones at work), the bodies, one thread, the bodies (an island each at most)."""
    from gasp_core.mpm.rigid import affine_dx
    from gasp_core.mpm.rigid_pairs import SWEEPS
    prep, bodies, rank, islands, sweep, advance, clear = build_rigid_pairs_gpu(Ft)
    d, nb = eng.device, len(eng.setup.materials)
    ns = eng.pair_slots.shape[0]
    t_dirs, t_h, t_curv, t_delta, nd, t_round, cos_cone, hol = eng.rb_tables
    g = vec3d(*[float(x) for x in eng.setup.gravity])
    return [
        wp.launch(prep, dim=ns, device=d, record_cmd=True, inputs=[
            eng.rb_R, nb, eng.pair_acc, eng.pair_lam, g, eng.pair_slots, eng.pair_n, t_dirs, nd, eng.pair_rows,
            eng.pair_key, t_h, t_round, cos_cone, hol, eng.rb_c, eng.rb_V, float(eng.dt), eng.pair_allow]),
        wp.launch(bodies, dim=nb, device=d, record_cmd=True, inputs=[
            eng.rb_V, eng.pair_V0, eng.pair_root, eng.pair_isl_of, eng.pair_isl_count, eng.pair_isl_fill]),
        wp.launch(rank, dim=ns, device=d, record_cmd=True, inputs=[
            eng.pair_slots, eng.pair_n, eng.pair_key, eng.pair_order]),
        wp.launch(islands, dim=1, device=d, record_cmd=True, inputs=[
            nb, eng.pair_order, eng.pair_n, eng.pair_root, eng.pair_isl_of, eng.pair_isl, eng.pair_isl_count,
            eng.pair_isl_start, eng.pair_isl_fill, eng.pair_isl_list, eng.pair_isl_n, eng.pair_n_keep]),
        wp.launch(sweep, dim=nb, device=d, record_cmd=True, inputs=[
            eng.rb_M, eng.rb_I0, eng.rb_c, eng.rb_R, eng.rb_V, eng.rb_w, affine_dx(eng.dx), nb, eng.pair_mu,
            eng.pair_acc, eng.pair_lam, int(SWEEPS), eng.pair_rows, t_h, t_curv, t_delta, t_round, eng.pair_isl_start,
            eng.pair_isl_list, eng.pair_isl_n, eng.pair_allow, hol]),
        wp.launch(advance, dim=nb, device=d, record_cmd=True, inputs=[eng.rb_c, eng.rb_V, eng.pair_V0, float(eng.dt)]),
        wp.launch(clear, dim=ns, device=d, record_cmd=True, inputs=[
            eng.pair_acc, eng.pair_slots, eng.pair_n_keep, eng.pair_seen])]
