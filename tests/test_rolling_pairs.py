"""Round 65 (issue 67 items 2 and 4; ``docs/rigid.md`` "Round 65: rolling between rigid bodies"): the rigid pair's
law lets a round body roll on another rigid body, on the NumPy reference (``gasp_core.mpm.rigid_friction.
pair_contact`` with ``gasp_core.mpm.rigid_support``'s flatness).

A lattice ball (``sphere_points``, rho 1000) thrown sliding at ``v0`` without spin onto a slab (32 x 16 x 3 cm)
lying on a frictionless ground: friction at the contact point spins it up until it rolls; with the slab's recoil the
friction impulse is ``J = v0 / (1/m + 1/M + R^2 / I)`` (Coulomb, Newton; ``I`` the lattice ball's own, ``R`` the
contact's lever), then the ball moves at ``v0 - J / m`` and spins at ``w R = J R^2 / I``. The pair law is run alone
(gravity, the normal contact and the ground's frictionless normal each substep of 2e-4 s, 0.2 s), the contact taken
0.13 dx above the surfaces as the touching nodes' centre lies and moved onto them (``contact_plane``). Tolerance 5 %
either way; the catch: the flatness forced to 1 (a face on a face, the law before round 65) fails it.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.mpm.rigid_friction import pair_contact
from gasp_core.mpm.rigid_pairs import solve_pairs
from gasp_core.mpm.rigid_support import body_flatness, contact_plane, pair_flatness, support_table
from gasp_core.testing.helpers import box_points, sphere_points

TOL = 0.05


def _inertia(X: np.ndarray, m: float) -> np.ndarray:
    return m * (np.sum(X * X) * np.eye(3) - X.T @ X) / len(X)


def thrown_ball(R: float, dx: float, mu: float, flat=None, T: float = 0.2, dt: float = 2e-4, many: bool = False,
                apic: bool = False):
    """``(v, w R)`` after ``T`` s and their closed form ``(v, w R)`` (module notes), m/s; ``flat`` forces the pair's
    flatness (None: the tables'); ``many``: the pair through ``rigid_pairs.solve_pairs`` (8 sweeps); ``apic``: the
    law given the engines' inertia to round 66 (the lattice's plus APIC's ``M dx^2 / 2``), the closed form kept the
    body's own (round 67's catch)."""
    xb, pvb = sphere_points([0.0, 0.0, 0.0], R, dx / 2)
    xb = xb - xb.mean(0)
    xs, pvs = box_points([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03], dx / 2)
    cB = xs.mean(0)
    m, M = 1000.0 * pvb * len(xb), 1000.0 * pvs * len(xs)
    IA, IB = _inertia(xb, m), _inertia(xs - cB, M)
    IA_law, IB_law = (IA + 0.5 * dx * dx * m * np.eye(3), IB + 0.5 * dx * dx * M * np.eye(3)) if apic else (IA, IB)
    ta, tb = support_table(xb, pvb ** (1 / 3)), support_table(xs - cB, pvs ** (1 / 3))
    Rc = 0.5 * (np.ptp(xb[:, 2]) + dx / 2)
    n, cA, g = np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 0.03 + Rc]), np.array([0.0, 0.0, -9.81])
    if flat is None:
        flat = lambda t: pair_flatness(ta, np.eye(3), tb, np.eye(3), n, t)   # noqa: E731
    plane = contact_plane(ta, np.eye(3), cA, tb, np.eye(3), cB, n)
    x_c = cA + (Rc - 0.13 * dx) * n   # the touching nodes' centre, 0.13 dx above the surfaces (warp_mpm, n_grid 32)
    VA, wA, VB, wB = np.array([0.5, 0.0, 0.0]), np.zeros(3), np.zeros(3), np.zeros(3)
    for _ in range(round(T / dt)):
        VA, VB = VA + dt * g, VB + dt * g
        VB[2] = max(VB[2], 0.0)   # the frictionless ground
        if many:
            [(VA, wA), (VB, wB)], _ = solve_pairs([(VA, wA, IA_law, m, cA), (VB, wB, IB_law, M, cB)],
                                                  [(0, 1, x_c, n, mu, flat, plane)], g)
        else:
            (VA, wA), (VB, wB), _ = pair_contact((VA, wA, IA_law, m, cA), (VB, wB, IB_law, M, cB), x_c, n, mu, flat,
                                                 plane)
        VB[2] = max(VB[2], 0.0)
    J = 0.5 / (1.0 / m + 1.0 / M + Rc * Rc / IA[1, 1])
    return (VA[0], wA[1] * Rc), (0.5 - J / m, J * Rc * Rc / IA[1, 1])


@pytest.mark.parametrize("R,dx", [(0.03, 0.015), (0.03, 0.01), (0.045, 0.015), (0.045, 0.01)])
@pytest.mark.parametrize("mu", [0.5, 0.1])
def test_reference_ball_thrown_sliding_rolls(R, dx, mu):
    (v, wR), (v_c, wR_c) = thrown_ball(R, dx, mu)
    assert abs(v / v_c - 1.0) < TOL and abs(wR / wR_c - 1.0) < TOL, (v, wR, v_c, wR_c)


@pytest.mark.parametrize("R", [0.03, 0.045])
def test_reference_many_body_solve_rolls_the_ball(R):
    """The same through the many-body solve (``rigid_pairs.solve_pairs``): its faces' hold of the relative tipping
    spin is gated by the flatness, so the ball spins up and rolls on; forced to 1 it never spins."""
    (v, wR), (v_c, wR_c) = thrown_ball(R, 0.015, 0.5, T=0.1, dt=2e-4, many=True)
    assert abs(v / v_c - 1.0) < TOL and abs(wR / wR_c - 1.0) < TOL, (v, wR, v_c, wR_c)
    (v, wR), _ = thrown_ball(R, 0.015, 0.5, flat=1.0, T=0.1, dt=2e-4, many=True)
    assert wR == 0.0 and abs(v / v_c - 1.0) > TOL, (v, wR)


@pytest.mark.parametrize("many", [False, True])
def test_reference_catch_the_old_inertia(many):
    """Round 67: the law given the engines' inertia to round 66 (APIC's ``M dx^2 / 2`` added: 30 % more for a ball of
    2 cells' radius) misses the closed form with the body's own inertia (the ball 7 % fast, its spin 10 % slow), where
    the real law passes (:func:`test_reference_ball_thrown_sliding_rolls`)."""
    (v, wR), (v_c, wR_c) = thrown_ball(0.03, 0.015, 0.5, T=0.1, many=many, apic=True)
    assert abs(v / v_c - 1.0) > TOL and abs(wR / wR_c - 1.0) > TOL, (v, wR, v_c, wR_c)


def test_reference_catch_a_face_on_a_face_does_not_roll():
    """The catch: the flatness forced to 1 holds the ball's tipping moment: it never spins and stops."""
    (v, wR), (v_c, wR_c) = thrown_ball(0.03, 0.015, 0.5, flat=1.0)
    assert not (abs(v / v_c - 1.0) < TOL and abs(wR / wR_c - 1.0) < TOL), (v, wR)
    assert wR == 0.0


@pytest.mark.parametrize("dx", [0.02, 0.015, 0.01])
def test_support_tables_tell_a_ball_from_a_face(dx):
    """A lattice ball (radius 3 and 4.5 cm, 1.5-4.5 cells) reads round (0) along its table's directions and two slips
    each, on average below 0.01 and nowhere above 0.25, and 0 straight down; boxes (a 6 x 6
    x 3 cm block, the slab) read flat (1) on every face along either slip, narrow sides too, and round across an
    edge."""
    for R in (0.03, 0.045):
        xb, pvb = sphere_points([0.0, 0.0, 0.0], R, dx / 2)
        tab = support_table(xb - xb.mean(0), pvb ** (1 / 3))
        fs = []
        for d in tab[0]:
            for v in ([0.3, 0.5, 0.8], [0.9, -0.2, 0.1]):
                t = np.cross(d, v)
                fs.append(body_flatness(tab, np.eye(3), d, t / np.linalg.norm(t)))
        # measured: 0-3 of the 536 read above 0, at most 0.14 (the lattice's facets)
        assert np.mean(fs) < 0.01 and max(fs) < 0.25, (R, np.mean(fs), max(fs))
        assert body_flatness(tab, np.eye(3), [0, 0, -1], [1, 0, 0]) == 0.0
    for hi in ([0.06, 0.06, 0.03], [0.32, 0.16, 0.03]):
        xs, pvs = box_points([0.0, 0.0, 0.0], hi, dx / 2)
        tab = support_table(xs - xs.mean(0), pvs ** (1 / 3))
        for ax in range(3):
            for sign in (1.0, -1.0):
                d = sign * np.eye(3)[ax]
                for t in np.eye(3)[[a for a in range(3) if a != ax]]:
                    assert body_flatness(tab, np.eye(3), d, t) == 1.0, (hi, d, t)
        edge = np.array([1.0, 0.0, 1.0]) / 2 ** 0.5
        assert body_flatness(tab, np.eye(3), edge, [edge[2], 0.0, -edge[0]]) == 0.0


def test_support_table_follows_the_pose():
    """A block turned 90 degrees about x: its broad face now looks along -y in the world and reads flat there; its
    edge between that face and its +x side reads round."""
    xs, pvs = box_points([0.0, 0.0, 0.0], [0.09, 0.09, 0.03], 0.0075)
    tab = support_table(xs - xs.mean(0), pvs ** (1 / 3))
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    assert body_flatness(tab, Rx, [0, -1, 0], [1, 0, 0]) == 1.0
    edge = np.array([1.0, -1.0, 0.0]) / 2 ** 0.5
    assert body_flatness(tab, Rx, edge, [edge[1], -edge[0], 0.0]) == 0.0
    assert pair_flatness(tab, Rx, None, np.eye(3), [0, 0, 1], [1, 0, 0]) == 1.0
