"""Round 63 (``docs/rigid.md`` "Round 63: the cost of rigid pairs"): the two-field contact's node kernels over the
nodes where both fields meet, not the whole grid. ``field_shared`` (one thread a node, a few loads) writes every
node's offsets ``grid_dv`` to zero and lists the inner nodes where both fields hold more than ``MIN_FRACTION`` of the
node's mass (an atomic counter; on the CPU the list is in node order); ``fields.field_contact`` then runs over that
list only, ``shared_threads`` threads each a run of it in the list's order (on the CPU, the order the whole-grid
kernel visited them: the same sums, the same bits). ``field_clear`` clears the fields' channels after the contact,
and the list's count.

Before, ``field_contact`` ran one thread a node over the whole grid (96^3 = 884,736 nodes for the cup of
``examples/cup_drop.toml``) at about 17 ns a node on warp_mpm's CPU whatever the node held (its 45 arguments): on the
cup's 47 fragments 68 s of 247 (``benchmarks/rigid_pairs_cost.py --cup 20 --profile``).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closures below as
type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.fields import MIN_FRACTION

from .precision import MODULE_OPTIONS, build_types

#: ``field_contact``'s threads over the list of shared nodes (each a run of ``ceil(n / threads)`` of them): few on
#: the CPU, whose threads run in turn (each costs its argument block), enough for a GPU's cores on CUDA.
THREADS_CPU = 1024
THREADS_CUDA = 65536


def shared_threads(eng) -> int:
    """``field_contact``'s launch size (:data:`THREADS_CPU` or :data:`THREADS_CUDA`, at most the nodes)."""
    return int(min(eng.n_grid ** 3, THREADS_CUDA if eng.device.is_cuda else THREADS_CPU))


@functools.cache
def build_field_shared(Ft):
    """``field_shared(grid_mv, grid_sv, grid_dv, n_grid, shared, n_shared)``: node ``tid``'s offsets (``grid_dv``:
    field A's at ``node``, B's at ``n_grid^3 + node``) to zero, and the node appended to ``shared`` (its count
    ``n_shared[0]``) where it is inner and both fields hold more than ``MIN_FRACTION`` of its mass (``grid_mv``'s
    fourth entry, A's ``grid_sv``'s), as ``fields.field_contact`` asks."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_shared(grid_mv: wp.array(dtype=vec4), grid_sv: wp.array(dtype=vec4), grid_dv: wp.array(dtype=vec3),
                     n_grid: int, shared: wp.array(dtype=wp.int32), n_shared: wp.array(dtype=wp.int32)):
        node = wp.tid()
        nn = n_grid * n_grid
        grid_dv[node] = vec3(Ft(0.0))
        grid_dv[nn * n_grid + node] = vec3(Ft(0.0))
        m = grid_mv[node][3]
        m_a = grid_sv[node][3]
        m_b = m - m_a
        if m_a > Ft(MIN_FRACTION) * m and m_b > Ft(MIN_FRACTION) * m:
            i = node / nn
            j = (node / n_grid) % n_grid
            k = node % n_grid
            if i > 0 and j > 0 and k > 0 and i < n_grid - 1 and j < n_grid - 1 and k < n_grid - 1:
                shared[wp.atomic_add(n_shared, 0, 1)] = node

    return field_shared


@functools.cache
def build_field_clear(Ft):
    """``field_clear(grid_sv, grid_vf, n_shared)``: ``grid_sv`` and the fields' ``grid_vf`` channels (both fields'
    volume, and the friction channels, its third and fourth parts where there are) back to zero for the next P2G;
    thread 0 resets the shared nodes' count. (Written only where not zero already, it took twice as long on the
    cup: 22.7 s against 11.7, round 63.)"""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def field_clear(grid_sv: wp.array(dtype=vec4), grid_vf: wp.array(dtype=Ft), n_shared: wp.array(dtype=wp.int32)):
        node = wp.tid()
        if node == 0:
            n_shared[0] = 0
        grid_sv[node] = vec4(Ft(0.0))
        for part in range(grid_vf.shape[0] / grid_sv.shape[0]):
            grid_vf[part * grid_sv.shape[0] + node] = Ft(0.0)

    return field_clear
