"""A rigid body under ``contact = "grid"`` takes the particle contact (round 51, issue 67; docs/contact.md "Round 51: a
rigid body on the grid contact"; ``gasp_core.mpm.contact.contact_model``).

The grid contact's node stops hold only the nodes at the plane; a rigid body has no stress to carry its weight down to
them, so on it a 7.5 cm rigid cube sank 36.9 mm in 1.1 s (its lowest points 30.6 mm under the plane, warp_mpm, n_grid
24) and no rigid stick on a 30 deg slope held (7-53 mm in 1 s at mu 0.7). Since round 51 the option's rigid bodies take
the particle contact (``"mixed"``, ``"particle"`` when every body is rigid), the others the grid contact.

Checked: the routing (default tier); a rigid cube on a flat ground under ``contact = "grid"`` (default tier on
warp_mpm, n_grid 24; slow: both engines, n_grid 24 and 32): over 1.1 s its centroid moves less than ``RIGID_SLOP`` (the
depth a resting rigid body may keep, 0.05 dx) down or up and its lowest point stays over the plane, within the particle
contact's skin; slides and sticks on a 30 deg slope (slow: slab, cube, disc, both engines, n_grid 24 and 32): a stick
(mu 0.7) moves < 1 mm in 1 s after a 0.1 s settle, a slide (mu 0.3) accelerates within 2.5 % of ``g (sin - mu cos)``.
The catch: the routing before (the rigid body on the grid rule) sinks the cube 36.9 mm (1.48 dx), its lowest point
30.6 mm under the plane; the slide shapes' sticks moved 7.4-53 mm (``benchmarks/results/rigid_grid_contact.txt``).
"""
from __future__ import annotations

import pytest
from slopes import ENGINES, closed_form

from gasp_core.mpm.contact import contact_model, flowing_bodies
from gasp_core.mpm.fields import field_bodies
from gasp_core.mpm.rigid import RIGID_SLOP
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.rigid_grid import SHAPES, WOOD, sink, slope_figure

JELLY = Material("jelly", model="elastic", E=1.0e5, nu=0.3, rho=1000.0)
SAND = Material("sand")
SLIDE_TOL = 0.025   # the slope tests' two-sided tolerance
STICK_MM = 1.0


def check_sink(drop: float, low: float, skin: float) -> None:
    """Two-sided: ``|drop| <= RIGID_SLOP`` (cells) and ``0 < low <= skin``."""
    assert abs(drop) <= RIGID_SLOP, f"the cube's centroid fell {drop:+.4f} dx in 1.1 s (|.| <= {RIGID_SLOP})"
    assert 0.0 < low <= skin, f"its lowest point {low:+.4f} dx over the plane (skin {skin:.4f} dx)"


def check_slope(fig: float, theta: float, mu: float) -> None:
    """Two-sided: a slide's acceleration within ``SLIDE_TOL`` of Coulomb's, a stick's travel under ``STICK_MM``."""
    a0 = closed_form(theta, mu)
    if a0 > 0.0:
        assert abs(fig / a0 - 1.0) <= SLIDE_TOL, f"a = {fig:.4f} m/s^2 against {a0:.4f} ({100 * (fig / a0 - 1):+.2f} %)"
    else:
        assert 0.0 <= fig < STICK_MM, f"moved {fig:.3f} mm in 1 s (sticks: < {STICK_MM} mm)"


def test_routing_puts_rigid_bodies_on_the_particle_contact():
    x, v = box_points((0.2, 0.2, 0.1), (0.3, 0.3, 0.2), 0.05)

    def scene(*mats, contact="grid"):
        s = make_setup(x, v, mats[0], options={"contact": contact})
        s.materials = list(mats)
        return s
    assert contact_model(scene(WOOD)) == "particle"
    assert contact_model(scene(WOOD, WOOD)) == "particle"
    for mats in ((JELLY, WOOD), (SAND, WOOD)):
        s = scene(*mats)
        assert contact_model(s) == "mixed" and list(flowing_bodies(s)) == [True, False]
        assert field_bodies(s) is None   # one field, as the grid contact by hand ran before
    assert contact_model(scene(JELLY)) == "grid" and contact_model(scene(JELLY, SAND)) == "grid"
    assert contact_model(scene(JELLY, WOOD, contact="auto")) == "particle"
    assert list(flowing_bodies(scene(SAND, WOOD, contact="auto"))) == [True, False]


def test_check_sink_catches_the_routing_before():
    with pytest.raises(AssertionError):   # the routing before, warp_mpm n_grid 24: 36.9 mm, lowest 30.6 mm under
        check_sink(36.9 / 25.0, -30.6 / 25.0, 0.25)
    with pytest.raises(AssertionError):   # a body floating a tenth of a cell
        check_sink(-0.1, 0.35, 0.25)
    check_sink(0.006, 0.244, 0.25)
    for bias in (0.95, 1.05):   # a 5 % biased slide
        with pytest.raises(AssertionError):
            check_slope(bias * closed_form(30.0, 0.3), 30.0, 0.3)
    with pytest.raises(AssertionError):   # the routing before: the slab (n_grid 32) crept 7.43 mm in 1 s
        check_slope(7.429, 30.0, 0.7)


@pytest.mark.parametrize("n_grid", [24, 32])
@pytest.mark.parametrize("engine", ENGINES)
def test_rigid_cube_rests_on_the_plane(engine, n_grid):
    check_sink(*sink(engine, n_grid))


@pytest.mark.parametrize("case", [(30.0, 0.7), (30.0, 0.3)], ids=["stick", "slide"])
@pytest.mark.parametrize("n_grid", [24, 32])
@pytest.mark.parametrize("shape", list(SHAPES))
@pytest.mark.parametrize("engine", ENGINES)
def test_rigid_shapes_meet_coulomb_under_grid_contact(engine, shape, n_grid, case):
    check_slope(slope_figure(engine, shape, n_grid, *case), *case)
