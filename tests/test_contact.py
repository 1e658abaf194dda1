"""The particle contact's reference (gasp_core.mpm.contact, docs/contact.md) and its engine option."""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.seam.options import check_options
from gasp_core.mpm.contact import (CONTACT, collider_grid_depth, contact_coefficients, contact_planes,
                                      ground_node_layer, node_friction, plane_impulse, surface_impulse, wall_grid_cells)
from gasp_core.mpm.options import mpm_options


def test_plane_impulse_is_a_damped_penalty_that_never_pulls():
    coeffs = np.array([[100.0, 2.0, 0.01]] * 4)          # k N/m, c N s/m, skin m
    z = np.array([0.02, 0.005, 0.005, -0.01])            # above the skin, 5 mm in, 5 mm in leaving fast, 2 cm in
    vz = np.array([-1.0, 0.0, 10.0, -1.0])
    jn, budget = plane_impulse(z, vz, coeffs, 0.0, 0.5, 1e-3)
    assert np.allclose(jn, [0.0, 1e-3 * 100 * 0.005, 0.0, 1e-3 * (100 * 0.02 + 2.0)])
    assert np.allclose(budget, 0.5 * jn)


def test_a_collider_pushes_along_its_normal_relative_to_its_velocity():
    coeffs = np.array([[100.0, 2.0, 0.01]] * 4)
    z = np.array([0.02, 0.005, 0.005, -0.01])
    vz = np.array([-1.0, 0.0, 10.0, -1.0])
    up = np.tile([0.0, 0.0, 1.0], (4, 1))
    v = np.column_stack([np.full(4, 0.3), np.full(4, -0.2), vz])
    # a plane as a collider: the ground's impulses, whatever the tangential velocity
    jn, budget = surface_impulse(z, up, v, np.zeros((4, 3)), coeffs, 0.5, 1e-3)
    assert np.array_equal(jn, plane_impulse(z, vz, coeffs, 0.0, 0.5, 1e-3)[0])
    assert np.allclose(budget, 0.5 * jn)
    # a collider tilted and moving into the point at 1 m/s along its normal: the damping sees the relative speed
    n = np.array([[0.6, 0.0, 0.8]])
    j1, _ = surface_impulse(np.array([0.005]), n, np.zeros((1, 3)), n, coeffs[:1], 0.5, 1e-3)
    assert np.allclose(j1, 1e-3 * (100 * 0.005 + 2.0 * 1.0))


def test_collider_grid_rule_moves_inside_with_the_particle_contact():
    assert collider_grid_depth("grid", 0.01) == 0.0
    assert collider_grid_depth("particle", 0.01) == pytest.approx(0.02)


def test_node_friction_stops_a_node_but_never_turns_it_back():
    v = np.array([[0.3, 0.4, -1.0], [0.3, 0.4, 0.0], [0.3, 0.4, 0.0]])
    out = node_friction(v, np.array([2.0, 2.0, 2.0]), np.array([0.5, 10.0, 0.0]))
    assert np.allclose(out[0], [0.3 * 0.5, 0.4 * 0.5, -1.0])        # |v_t| 0.5 loses 0.5 / 2 = 0.25
    assert np.allclose(out[1], [0.0, 0.0, 0.0])                      # a large budget stops it, no more
    assert np.allclose(out[2], v[2])


def test_ground_nodes_are_out_of_reach_with_the_particle_contact():
    assert ground_node_layer("grid", 0.0, -0.03, 0.01) == 3
    assert ground_node_layer("particle", 0.0, -0.03, 0.01) == 1


def test_the_option_is_declared_with_its_values():
    assert CONTACT.default == "auto"
    opts = (*mpm_options(), CONTACT)
    assert check_options({"contact": "grid"}, opts, "e")["contact"] == "grid"
    with pytest.raises(SceneError, match="contact"):
        check_options({"contact": "nodes"}, opts, "e")


def test_auto_keeps_the_grid_contact_for_flowing_materials():
    from types import SimpleNamespace
    from gasp_core.seam.setup import Material
    from gasp_core.mpm.contact import contact_model, flowing_bodies
    jelly, sand = Material("jelly"), Material("sand")
    assert contact_model(SimpleNamespace(options={}, materials=[jelly])) == "particle"
    assert contact_model(SimpleNamespace(options={}, materials=[sand, Material("liquid")])) == "grid"
    mixed = SimpleNamespace(options={"contact": "auto"}, materials=[jelly, sand])   # chosen per body (issue 38 item 3)
    assert contact_model(mixed) == "mixed" and flowing_bodies(mixed).tolist() == [False, True]
    both = SimpleNamespace(options={"contact": "grid"}, materials=[jelly, sand])
    assert flowing_bodies(both).tolist() == [True, True]
    assert contact_model(SimpleNamespace(options={"contact": "grid"}, materials=[jelly, sand])) == "grid"
    assert contact_model(SimpleNamespace(options={"contact": "particle"}, materials=[sand])) == "particle"
    soft, stiff = Material("jelly", E=2e4), Material("jelly", E=1.4e6)   # stiff bodies too, since the balance
    assert contact_model(SimpleNamespace(options={}, materials=[soft])) == "particle"
    assert contact_model(SimpleNamespace(options={}, materials=[soft, stiff])) == "particle"
    assert contact_model(SimpleNamespace(options={"contact": "grid"}, materials=[stiff])) == "grid"



def test_walls_are_six_plane_supports_three_cells_inside_the_faces():
    """With the particle contact each face of the walls is a plane support ``n . x = offset`` 3 dx inside the face
    (after the ground, support 0, and the colliders' rows), its grid rule 1.5 cells deep; none with ``"grid"``, whose
    walls' rule stops the node layers on the planes and behind them, 3.5 cells decided half a cell clear of rounding
    (issue 38 item 2, round 32's walls; docs/contact.md)."""
    from gasp_core.seam.setup import Boundary, Material
    from gasp_core.testing.helpers import make_setup
    x = np.array([[0.7, 0.5, 0.5], [0.53, 0.5, 0.5]])   # the second point 0.03 m (< its skin) off the -x plane
    setup = make_setup(x, 1e-3, Material("jelly", E=1e4, nu=0.3, rho=300.0), lo=(0.2, 0, 0), hi=(1.2, 1, 1),
                       n_grid=10, boundaries=[Boundary("walls", friction=0.3), Boundary("ground", height=0.1, friction=0.5)])
    normals, rows = contact_planes(setup, "particle")
    # round 58: with a ground, the walls' floor face is no plane (the ground is the floor: wall_faces)
    assert normals.tolist() == [[0, 0, 1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, -1]]
    dx = setup.dx   # 0.1 m
    expected = [0.1, 0.2 + 3 * dx, -(1.2 - 3 * dx), 3 * dx, -(1 - 3 * dx), -(1 - 3 * dx)]
    assert np.allclose(rows[:, 0], expected, rtol=0, atol=1e-12)
    assert rows[:, 1].tolist() == [0.5] + [0.3] * 5 and rows[:, 2].tolist() == [0, 1, 2, 3, 4, 5]
    no_ground = make_setup(x, 1e-3, Material("jelly", E=1e4, nu=0.3, rho=300.0), lo=(0.2, 0, 0), hi=(1.2, 1, 1),
                           n_grid=10, boundaries=[Boundary("walls", friction=0.3)])
    n6, r6 = contact_planes(no_ground, "particle")   # without a ground the walls keep six faces, the floor's too
    assert n6.tolist() == [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]
    assert np.allclose(r6[:, 0], [0.2 + 3 * dx, -(1.2 - 3 * dx), 3 * dx, -(1 - 3 * dx), 3 * dx, -(1 - 3 * dx)])
    # on the wall's plane n . x = offset exactly: the depth is the skin
    assert np.allclose(normals[1] @ np.array([0.5, 0.7, 0.7]) - rows[1, 0], 0.0, atol=1e-12)
    skin = contact_coefficients(setup)[:, 2]
    assert skin[0] == pytest.approx(0.05, abs=1e-12) and skin[1] == pytest.approx(0.03, abs=1e-12)   # h/2 = 0.05
    assert contact_planes(setup, "grid")[0].shape == (0, 3)
    assert wall_grid_cells("grid") == 3.5 and wall_grid_cells("particle") == 1.5
