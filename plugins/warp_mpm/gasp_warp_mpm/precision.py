"""Warp types and module options per scalar type, shared by every kernel file of this plugin.

Every builder of ``transfers``, ``constitutive``, ``grid``, ``colliders`` and ``forces`` is a closure over
the scalar type ``Ft`` (``wp.float32`` or ``wp.float64``), cached per type, so the same source serves both
precisions (Warp compiles one instantiation per type). Taichi needs no such module: its kernels take the
working precision from ``ti.init(default_fp=...)`` and the solver's ``real``.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

#: Warp compiles CPU code at -O2 by default; -O3 is several times faster on these kernels.
MODULE_OPTIONS = {"optimization_level": 3}


@functools.cache
def build_types(Ft):
    """``(vec3, vec4, mat33)``: Warp vector and matrix types of the scalar type ``Ft``."""
    return wp.types.vector(3, Ft), wp.types.vector(4, Ft), wp.types.matrix((3, 3), Ft)
