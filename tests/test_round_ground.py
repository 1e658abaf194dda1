"""Round 88 (``gasp_core.mpm.round_ground``): which rigid bodies meet the planes on their exact sphere, with what radius,
and the per-point contact rows that give that sphere's force: their sum the body's stiffness, their moment about the
mass centre zero, no skin; a body placed in the ground lifted by its sphere's depth."""
from __future__ import annotations

import math

import numpy as np
import pytest

import gasp_core.mpm.round_ground as rg
from gasp_core.mpm.contact import contact_coefficients
from gasp_core.mpm.rigid import face_counts, lift_setup, rigid_contact, step_view
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.scenes_passive import fibonacci_sphere

R, H, GROUND = 0.05, 0.00625, 0.05
C = np.array([0.3, 0.3, GROUND + R])


def _setup(x, p_vol, n_render=0, model="rigid", options=None):
    s = make_setup(x, p_vol, Material("jelly", model=model, E=1.0e10, nu=0.3, rho=700.0), gravity=(0.0, 0.0, -9.81),
                   lo=np.zeros(3), hi=np.full(3, 0.6), n_grid=48, frame_dt=1.0 / 60,
                   boundaries=[Boundary("ground", height=GROUND, friction=0.5)])
    s.n_render = n_render
    if options:
        s.options = {**(s.options or {}), **options}
    return s


def _fill(c=C, radius=R, axes=(1.0, 1.0, 1.0)):
    x, _ = box_points(c - radius * np.asarray(axes), c + radius * np.asarray(axes), H)
    x = x[np.linalg.norm((x - c) / np.asarray(axes), axis=1) <= radius - H / 2]
    return x, np.full(len(x), 4.0 / 3.0 * math.pi * radius ** 3 * np.prod(axes) / len(x))


def _shell_ball(n=804):
    x, _ = _fill()
    shell = C + R * fibonacci_sphere(n)
    volume = 4.0 / 3.0 * math.pi * R ** 3   # the shell carries 0.4 of it, each row its share
    return np.concatenate([shell, x]), np.r_[np.full(n, 0.4 * volume / n), np.full(len(x), 0.6 * volume / len(x))], n


def test_the_radius_is_the_gaussians_sphere_or_the_volumes():
    x, p_vol, n = _shell_ball()
    assert rg.ground_radius(_setup(x, p_vol, n))[0] == pytest.approx(R, rel=1e-3)   # on its Gaussians
    x, p_vol = _fill()
    volume_radius = (3.0 * p_vol.sum() / (4.0 * math.pi)) ** (1.0 / 3.0)
    assert rg.ground_radius(_setup(x, p_vol))[0] == pytest.approx(volume_radius)   # a fill alone: its volume's
    # a lattice of Gaussians: a sphere within the layer its outer Gaussians span (here its bottom facet 0.0406 m from
    # the centre, its farthest 0.0469: 0.0436), not half a spacing out as a fill alone
    d = np.linalg.norm(x - (p_vol[:, None] * x).sum(0) / p_vol.sum(), axis=1)
    radius = rg.ground_radius(_setup(x, p_vol, len(x)))[0]
    assert C[2] - x[:, 2].min() < radius < d.max() < volume_radius


@pytest.mark.parametrize("what", ["cube", "ellipsoid", "soft", "option off", "switch off"])
def test_other_bodies_keep_their_points(what, monkeypatch):
    x, p_vol, n = _shell_ball()
    kw = {}
    if what == "cube":
        x, _ = box_points(C - R, C + R, H)
        p_vol, n = np.full(len(x), H ** 3), 0
    elif what == "ellipsoid":
        x, p_vol = _fill(axes=(1.0, 1.0, 0.7))
        n = 0
    elif what == "soft":
        kw["model"] = "elastic"
    elif what == "option off":
        kw["options"] = {"roll_contact": False}
    else:
        monkeypatch.setattr(rg, "ROUND_GROUND", 0)
    assert rg.ground_radius(_setup(x, p_vol, n, **kw))[0] == 0.0


def test_a_spheres_rows_stay_its_points_for_the_colliders(monkeypatch):
    """The per-point rows (``rigid_contact``, ``face_counts``) are the same with the sphere's plane contact on or off:
    the engines give a sphere's points their shares on the planes alone (``plane_point``), and the colliders keep
    the points' rows."""
    x, p_vol, n = _shell_ball()
    s = _setup(x, p_vol, n)
    rows = rigid_contact(s, 1.0e-4, contact_coefficients(step_view(s)))
    counts = face_counts(s)
    monkeypatch.setattr(rg, "ROUND_GROUND", 0)
    assert rg.ground_radius(s)[0] == 0.0
    np.testing.assert_array_equal(rows, rigid_contact(s, 1.0e-4, contact_coefficients(step_view(s))))
    np.testing.assert_array_equal(counts, face_counts(s))
    m = np.asarray(s.p_mass, np.float64)   # shares in proportion to the masses: no moment about the mass centre
    c = (m[:, None] * x).sum(0) / m.sum()
    assert np.abs((m[:, None] * (x - c)).sum(0)).max() < 1e-12 * m.sum()


def test_a_sphere_in_the_ground_is_lifted_by_its_spheres_depth():
    x, p_vol, n = _shell_ball()
    s = _setup(x - [0.0, 0.0, 0.01], p_vol, n)   # 1 cm into the ground
    lifted = lift_setup(s)
    assert np.asarray(lifted.x)[:, 2].mean() - np.asarray(s.x)[:, 2].mean() == pytest.approx(0.01, abs=1e-6)
    assert rg.shape_depth(C - [0.0, 0.0, 0.01], np.eye(3), [R, 0, 0, 0, 0], [0.0, 0.0, 1.0], GROUND) == \
        pytest.approx(0.01)


def _cylinder(tilt_deg=0.0, gaussians=True, seed=0):
    """A solid cylinder of radius R, 15 cm long, its axis along y turned by ``tilt_deg`` about x: a lattice fill and
    (``gaussians``) a seeded random shell on its side."""
    L, rng = 0.15, np.random.default_rng(seed)
    x, _ = box_points(-np.array([R, L / 2, R]), np.array([R, L / 2, R]), H)
    x = x[np.linalg.norm(x[:, [0, 2]], axis=1) <= R - H / 2]
    vol = math.pi * R * R * L
    n = 2000 if gaussians else 0
    phi, y = rng.uniform(0, 2 * math.pi, n), rng.uniform(-L / 2, L / 2, n)
    shell = np.stack([R * np.cos(phi), y, R * np.sin(phi)], axis=1)
    t = math.radians(tilt_deg)
    rot = np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])
    pts = np.concatenate([shell, x]) @ rot.T + C
    if not n:
        return pts, np.full(len(x), vol / len(x)), 0, rot
    r_fill = (x[:, [0, 2]] ** 2).sum(1)   # the volumes that give a solid cylinder's I = 0.5 M R^2 about its axis
    vf, vs = np.linalg.solve([[len(x), n], [r_fill.sum(), n * R * R]], [vol, 0.5 * vol * R * R])
    return pts, np.r_[np.full(n, vs), np.full(len(x), vf)], n, rot


@pytest.mark.parametrize("tilt", [0.0, 30.0])
@pytest.mark.parametrize("gaussians", [True, False])
def test_a_cylinders_shape_is_found_and_its_axis_fitted(tilt, gaussians):
    x, p_vol, n, rot = _cylinder(tilt, gaussians)
    shape = rg.ground_shapes(_setup(x, p_vol, n))[0]
    assert shape[1] == pytest.approx(0.075, rel=0.05) and shape[0] == pytest.approx(R, rel=0.02)
    axis = rot @ [0.0, 1.0, 0.0]
    assert abs(abs(shape[2:] @ axis) - 1.0) < 1e-6   # within 0.08 degrees of the true axis
    band = rg.level_band(rg.ground_shapes(_setup(x, p_vol, n)), 0.05 * 0.0125)[0]
    assert band == pytest.approx(0.05 * 0.0125 / (2 * shape[1]))


def test_a_lying_cylinders_depth_is_its_lowest_line():
    shape = np.array([R, 0.075, 0.0, 1.0, 0.0])
    assert rg.shape_depth(C, np.eye(3), shape, [0, 0, 1.0], GROUND) == pytest.approx(0.0, abs=1e-12)
    t = math.radians(10.0)   # tilted 10 degrees about x: its lowest rim R cos + h sin below the centre
    rot = np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])
    want = R * math.cos(t) + 0.075 * math.sin(t) - R
    assert rg.shape_depth(C, rot, shape, [0, 0, 1.0], GROUND) == pytest.approx(want)
