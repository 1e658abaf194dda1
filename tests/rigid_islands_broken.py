"""A deliberately broken island kernel for warp_mpm (``tests/test_rigid_islands.py``'s catch): every listed pair an
island of its own, so two pairs that share a body are swept one after the other rather than in turn.

This module must not use ``from __future__ import annotations``: Warp reads the kernel's annotations as types.
"""
import warp as wp


@wp.kernel(enable_backward=False)
def lone_pairs(nb: int, order: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32),
               root: wp.array(dtype=wp.int32), isl_of: wp.array(dtype=wp.int32), isl: wp.array(dtype=wp.int32),
               isl_count: wp.array(dtype=wp.int32), isl_start: wp.array(dtype=wp.int32),
               isl_fill: wp.array(dtype=wp.int32), isl_list: wp.array(dtype=wp.int32),
               isl_n: wp.array(dtype=wp.int32), n_keep: wp.array(dtype=wp.int32)):
    n_on = count[0]
    for q in range(n_on):
        isl_start[q] = q
        isl_list[q] = order[q]
    isl_start[n_on] = n_on
    isl_n[0] = n_on
    n_keep[0] = n_on
    count[0] = 0
