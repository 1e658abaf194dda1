"""Round 96 (``gasp_core.mpm.face_share``, ``docs/contact.md`` "Round 96: a soft block on a thin soft support"): the
two-field contact's test of B's face towards A at a node, as a Warp function for ``fields.build_fields``.

This module must not use ``from __future__ import annotations``: Warp reads the annotations of
the closures below as type objects.
"""
import functools

import warp as wp

from gasp_core.mpm.fields import MIN_GRADIENT

from .precision import build_types


@functools.cache
def build_faced(Ft):
    """``(faced, a_face)``. ``faced(grid_sv, node, n_grid, grad_b, m_b, face) -> bool``, scalar type ``Ft``: whether B's mass falls towards
    A at the inner ``node``, ``-grad_b . grad m_A > face m_b |grad m_A|`` (``grad_b`` B's central differences of its
    node masses, kg; ``grad m_A`` A's, of ``grid_sv``'s masses; ``m_b`` B's mass there); True where ``face`` is 0 or
    less (the rule off: every node, as before round 96)."""
    vec3, vec4, _ = build_types(Ft)

    @wp.func
    def grad_a(grid_sv: wp.array(dtype=vec4), node: int, n_grid: int):
        """``grad m_A`` at the inner ``node``: central differences of ``grid_sv``'s masses (kg)."""
        nn = n_grid * n_grid
        return vec3(grid_sv[node + nn][3] - grid_sv[node - nn][3], grid_sv[node + n_grid][3] - grid_sv[node - n_grid][3],
                    grid_sv[node + 1][3] - grid_sv[node - 1][3])

    @wp.func
    def faced(grid_sv: wp.array(dtype=vec4), node: int, n_grid: int, grad_b: vec3, m_b: Ft, face: Ft):
        if face <= Ft(0.0):
            return True
        ga = grad_a(grid_sv, node, n_grid)
        return -wp.dot(grad_b, ga) > face * m_b * wp.length(ga)

    @wp.func
    def a_face(grid_sv: wp.array(dtype=vec4), node: int, n_grid: int, m: Ft, face: Ft):
        """Where B shows no normal at all (``grad m_B`` under ``MIN_GRADIENT m``): whether the rule is on and A shows
        a face (``|grad m_A| > MIN_GRADIENT m``), so that the fields keep their offsets there instead of moving as
        one (a support's middle layer at its first substep, its lattice exactly symmetric)."""
        ga = grad_a(grid_sv, node, n_grid)
        return face > Ft(0.0) and wp.length(ga) > Ft(MIN_GRADIENT) * m

    return faced, a_face
