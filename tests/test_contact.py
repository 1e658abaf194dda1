"""The particle contact's reference (gasp_core.toolkit.contact, docs/contact.md) and its engine option."""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.seam.options import check_options
from gasp_core.toolkit.contact import CONTACT, ground_node_layer, node_friction, plane_impulse
from gasp_core.toolkit.options import mpm_options


def test_plane_impulse_is_a_damped_penalty_that_never_pulls():
    coeffs = np.array([[100.0, 2.0, 0.01]] * 4)          # k N/m, c N s/m, skin m
    z = np.array([0.02, 0.005, 0.005, -0.01])            # above the skin, 5 mm in, 5 mm in leaving fast, 2 cm in
    vz = np.array([-1.0, 0.0, 10.0, -1.0])
    m, dt = 10.0, 1e-3                                   # dt^2 k << m: the explicit impulse within 3 %
    jn, budget = plane_impulse(z, vz, coeffs, 0.0, 0.5, dt, np.full(4, m))
    assert np.allclose(jn, [0.0, dt * 100 * 0.005, 0.0, dt * (100 * 0.02 + 2.0)], rtol=0.03)
    assert jn[0] == 0.0 and jn[2] == 0.0
    assert np.allclose(budget, 0.5 * jn)
    # backward Euler exactly: m v' = m v + dt (k (depth - dt v') - c v')
    v1 = vz[3] + jn[3] / m
    assert np.isclose(m * v1, m * vz[3] + dt * (100 * (0.02 - dt * v1) - 2.0 * v1), rtol=1e-12)


@pytest.mark.parametrize("omega_dt", [0.5, 1.6, 10.0])
def test_plane_impulse_never_makes_energy(omega_dt):
    """A point 1 mm into the ground, at rest (damping ratio 0.5), is pushed out no faster than its spring's
    stored energy allows, ``v <= omega d0``, at any ``omega dt``; the explicit penalty (the kernels' first
    version, which threw stiff bodies out of the domain) leaves at ``omega dt`` times that, and the check
    catches it."""
    m, k, d0 = 1e-3, 1e3, 1e-3
    omega = np.sqrt(k / m)
    c = 2 * 0.5 * np.sqrt(k * m)
    dt = omega_dt / omega
    coeffs = np.array([[k, c, 0.0]])

    def exit_speed(impulse):
        z, v = np.array([-d0]), np.array([0.0])
        for _ in range(400):
            v = v + impulse(z, v) / m
            z = z + dt * v
        return v[0] / (omega * d0)

    implicit = exit_speed(lambda z, v: plane_impulse(z, v, coeffs, 0.0, 0.0, dt, np.array([m]))[0])
    explicit = exit_speed(lambda z, v: np.where(-z > 0, np.maximum(0.0, dt * (k * -z - c * v)), 0.0))
    assert 0.0 < implicit < 1.0
    if omega_dt > 1.0:
        assert explicit > 1.05                           # energy out of nothing: what the check must catch


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
    from gasp_core.toolkit.contact import contact_model
    jelly, sand = Material("jelly"), Material("sand")
    assert contact_model(SimpleNamespace(options={}, materials=[jelly])) == "particle"
    assert contact_model(SimpleNamespace(options={"contact": "auto"}, materials=[jelly, sand])) == "grid"
    assert contact_model(SimpleNamespace(options={"contact": "particle"}, materials=[sand])) == "particle"

