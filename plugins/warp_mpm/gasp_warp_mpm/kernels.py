"""Warp kernels of the MLS-MPM solver specified in ``docs/mpm.md``, assembled per scalar type.

:func:`build_kernels` gathers the kernels of the files by concern (the same files as the Taichi plugin):
:mod:`~gasp_warp_mpm.transfers` (stencil, P2G, G2P, passive G2P), :mod:`~gasp_warp_mpm.constitutive`
(stresses and return mappings), :mod:`~gasp_warp_mpm.grid` (the grid update and its boundaries),
:mod:`~gasp_warp_mpm.colliders` (the collider rule, signed-distance colliders) and
:mod:`~gasp_warp_mpm.forces` (forces, impulses, their tables); :mod:`~gasp_warp_mpm.precision` holds the
types per scalar type. Each builder is a closure over the scalar type ``Ft``, cached per type, so the
functions they share are built once.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools
import types

import warp as wp

from .balance import build_balance
from .forces import build_tick
from .grid import build_extras, build_grid_update
from .precision import MODULE_OPTIONS, build_types
from .transfers import build_g2p, build_g2p_passive, build_p2g


@functools.cache
def build_checks(Ft):
    """``(check, svd)``: the finite-state kernel and ``wp.svd3`` on the CPU (for the tests), scalar type ``Ft``."""
    vec3, vec4, mat33 = build_types(Ft)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def check(x: wp.array(dtype=vec3), v: wp.array(dtype=vec3), flags: wp.array(dtype=wp.int32)):
        # flags[1] counts points whose x or v is not finite.
        p = wp.tid()
        xp = x[p]
        vp = v[p]
        ok = wp.isfinite(xp[0]) and wp.isfinite(xp[1]) and wp.isfinite(xp[2])
        ok = ok and wp.isfinite(vp[0]) and wp.isfinite(vp[1]) and wp.isfinite(vp[2])
        if not ok:
            wp.atomic_add(flags, 1, 1)

    @wp.kernel(enable_backward=False, module="unique", module_options=MODULE_OPTIONS)
    def svd_kernel(A: wp.array(dtype=mat33), U: wp.array(dtype=mat33), sig: wp.array(dtype=vec3),
                   V: wp.array(dtype=mat33)):
        i = wp.tid()
        u = mat33()
        s = vec3()
        w = mat33()
        wp.svd3(A[i], u, s, w)
        U[i] = u
        sig[i] = s
        V[i] = w

    def svd(A):
        """``wp.svd3`` of each matrix of ``A`` (shape (n, 3, 3)) on the CPU: (U, sig, V) as ndarrays."""
        import numpy as np
        n = len(A)
        a = wp.array(np.asarray(A, dtype=np.float32 if Ft == wp.float32 else np.float64), dtype=mat33, device="cpu")
        U = wp.zeros(n, dtype=mat33, device="cpu")
        sig = wp.zeros(n, dtype=vec3, device="cpu")
        V = wp.zeros(n, dtype=mat33, device="cpu")
        wp.launch(svd_kernel, dim=n, inputs=[a, U, sig, V], device="cpu")
        return U.numpy(), sig.numpy(), V.numpy()

    return check, svd


@functools.cache
def build_kernels(Ft):
    """The solver's kernels for the scalar type ``Ft`` (``wp.float32`` or ``wp.float64``).

    Returns
    -------
    types.SimpleNamespace
        ``vec3, vec4, mat33`` (types), ``Extras`` (struct) and the kernels ``p2g, grid_update, g2p,
        g2p_passive, check, tick``, and ``svd`` (a function).
    """
    vec3, vec4, mat33 = build_types(Ft)
    Extras, _ = build_extras(Ft)
    tick = build_tick(Ft)
    g2p, g2p_passive = build_g2p(Ft), build_g2p_passive(Ft)
    check, svd = build_checks(Ft)
    contact_moments, contact_shift, _ = build_balance(Ft)
    return types.SimpleNamespace(contact_moments=contact_moments, contact_shift=contact_shift,
                                 vec3=vec3, vec4=vec4, mat33=mat33, p2g=build_p2g(Ft), Extras=Extras, tick=tick,
                                 grid_update=build_grid_update(Ft), g2p=g2p, g2p_passive=g2p_passive, check=check,
                                 svd=svd)
