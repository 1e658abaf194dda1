"""The sand cone's friction as the engines read it (docs/mpm.md "The angle a sand flows at"; issue 67 item 5).

The engines' ``sand`` row yields at ``|dev tau| = alpha (3 lam + 2 mu) |tr eps|`` with ``alpha`` from
``Material.friction_angle`` (``material_table``'s ``P_ALPHA``), that is ``sqrt(J2) = eta p`` with
``eta = 3 alpha / sqrt(2)``. ``gasp_core.testing.scenes_granular.flow_dp_angle(phi)`` must give the cone whose layers
flow at ``phi`` (``eta = tan(phi)``, the Lube column's sand since round 33) and ``plane_strain_dp_angle(phi)`` the one
through Mohr-Coulomb's plane-strain failure (``eta = sin(phi)``); the docs' table of ``friction_angle`` against the
flow angle is checked against the same table. The catch: the column's cone before round 33 is not the flow cone.
"""
from __future__ import annotations

import math

import pytest

from gasp_core.mpm.materials import P_ALPHA, material_table
from gasp_core.seam.setup import Material
from gasp_core.testing import scenes_granular as sg


def eta_of(friction_angle: float) -> float:
    """``sqrt(J2) / p`` at yield of the engines' cone at ``friction_angle`` (deg), from the kernels' table."""
    alpha = material_table([Material("sand", friction_angle=friction_angle)])[1][0, P_ALPHA]
    return 3.0 * alpha / math.sqrt(2.0)


@pytest.mark.parametrize("phi", [20.0, 28.0, 32.0, 36.0, 40.0])
def test_the_flow_cone_flows_at_its_angle_and_the_plane_strain_cone_at_sin(phi):
    t = math.radians(phi)
    assert eta_of(sg.flow_dp_angle(phi)) == pytest.approx(math.tan(t), rel=1e-12)
    assert eta_of(sg.plane_strain_dp_angle(phi)) == pytest.approx(math.sin(t), rel=1e-12)


@pytest.mark.parametrize("friction_angle,flows_at", [(20.0, 24.0), (25.0, 29.6), (27.29, 32.0), (30.0, 34.7),
                                                     (35.0, 39.3), (40.0, 43.4)])
def test_the_docs_table_of_flow_angles(friction_angle, flows_at):
    assert math.degrees(math.atan(eta_of(friction_angle))) == pytest.approx(flows_at, abs=0.05)


def test_catch_the_columns_cone_before_round_33_is_not_the_flow_cone():
    before = sg.plane_strain_dp_angle(sg.COLUMN_PHI)
    assert abs(eta_of(before) / math.tan(math.radians(sg.COLUMN_PHI)) - 1) > 0.05   # 0.530 against 0.625: -15 %
