"""The held region before its broken faces (issue 66's run on past the break; docs/fracture.md "The held region"), as
a deliberately broken variant of each MPM engine for the catches of ``tests/test_bending.py``: a brittle held point
keeps its damage always (never broken through, so its ``F`` takes its image's crack as elastic strain) and no fixed
region's node is made a free-slip face (the ghosts reflect the falling piece's velocity).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the closure below as
type objects.
"""
import functools


def held_before_cuts(monkeypatch, name: str) -> None:
    """Patch the engine ``name`` (``taichi_mpm`` or ``warp_mpm``) to the held region before its broken faces. Warp's
    kernel builders are cached per scalar type: their caches are cleared here and must be cleared again after the
    patch is undone (:func:`clear_warp_caches`)."""
    if name == "taichi_mpm":
        import taichi as ti
        from gasp_core.mpm.materials import BRITTLE
        from gasp_taichi_mpm.grid import GridUpdate

        @ti.func
        def held_stress(self, p, tau, a, d_held):
            out = self.image_gradient(tau, a)
            if a >= 0:
                kind = self.kind[self.body[p]]
                if ti.static(not self.multi_kind):
                    kind = ti.static(next(iter(self.kinds)))
                if kind == BRITTLE:
                    self.Jp[p] = d_held
            return out
        monkeypatch.setattr(GridUpdate, "held_stress", held_stress)
        monkeypatch.setattr("gasp_taichi_mpm.grid.cuts_held_faces", lambda kinds, n_regions: False)
    else:
        monkeypatch.setattr("gasp_warp_mpm.transfers.build_held_return", _warp_held_return)
        monkeypatch.setattr("gasp_warp_mpm.held.cuts_held_faces", lambda kinds, n_regions: False)
        clear_warp_caches()


def clear_warp_caches() -> None:
    """Clear the cached builders of warp_mpm's P2G (so a patched or restored ``build_held_return`` is used)."""
    from gasp_warp_mpm import kernels, transfers
    transfers.build_p2g.cache_clear()
    kernels.build_kernels.cache_clear()


@functools.cache
def _warp_held_return(Ft):
    """warp_mpm's ``held_return`` before the broken faces: a brittle held point keeps its damage always (and, as the
    Taichi variant, scatters the stress of its own strain: the brittle held rule's held stress is not in it)."""
    import warp as wp
    from gasp_core.mpm.materials import BRITTLE
    from gasp_warp_mpm.constitutive import build_return_mapping
    from gasp_warp_mpm.forces import build_extras_struct
    from gasp_warp_mpm.held import build_image_flip
    from gasp_warp_mpm.precision import build_types
    vec3, vec4, mat33 = build_types(Ft)
    Extras = build_extras_struct(Ft)
    held_axis, image_flip = build_image_flip(Ft)[:2]
    return_mapping = build_return_mapping(Ft)

    @wp.func
    def held_return(Cp: mat33, Fp: mat33, dt: Ft, p: int, code: int, X: vec3, dx: Ft, ex: Extras,
                    body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32),
                    mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft), rule: int, fx: vec3):
        a = held_axis(code, X, dx, ex)
        band = 0   # the crack band weight (rule's bit 1) on free points, as today's held_return
        if rule >= 2 and a < 0 and code == 0:
            band = 1
        d_held = Jp[p]
        Cf = Cp
        if a >= 0:
            Cf = Cp * image_flip(a)
        if rule % 2 != 0 and a == -2 and mat_kind[body[p]] == BRITTLE:   # as the Taichi variant: the set box rigid deep
            Cf = mat33()
        F_new, tau = return_mapping((wp.identity(3, dtype=Ft) + dt * Cf) * Fp, p, body, mat_kind, mat_par, Jp,
                                    dt, fx, band)
        if a >= 0:
            tau = tau * image_flip(a)
        if a >= 0 and mat_kind[body[p]] == BRITTLE:
            Jp[p] = d_held
        return F_new, tau

    return held_return
