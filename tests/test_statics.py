"""A static object that is also a collider (one placement), object ``rotation``, and run.json collider figures."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.colliders.model import Motion, rotvec_matrix
from gasp_core.colliders.sdf import box_collider
from gasp_core.prepare.colliders import build_colliders
from gasp_core.run.contact import CONTACT_DX, collider_records, contact_row
from gasp_core.errors import SceneError
from gasp_core.prepare.placed import UP_ROTATIONS, euler_matrix
from gasp_core.prepare.placement import place, prepare_object
from gasp_core.scene.spec import parse_scene
from gasp_core.seam.setup import Material, SimSetup

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
DONUT = DATA / "donut_v3dg.ply"


def test_euler_matrix_is_x_then_y_then_z():
    r = (-15.0, 12.0, 40.0)
    a = [math.radians(v) for v in r]
    expect = (rotvec_matrix(np.array([0.0, 0.0, a[2]])) @ rotvec_matrix(np.array([0.0, a[1], 0.0]))
              @ rotvec_matrix(np.array([a[0], 0.0, 0.0])))
    R = euler_matrix(r)
    np.testing.assert_allclose(R, expect, atol=1e-15)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_object_rotation_places_after_up_axis_then_recentres(tmp_path):
    scene = parse_scene({"object": [{"file": str(DONUT), "up_axis": "+y", "rotation": [30.0, 0.0, 90.0],
                                     "position": [0.1, 0.2, 0.3]}]}, tmp_path / "s.toml")
    o = prepare_object(scene.objects[0])
    R = euler_matrix((30.0, 0.0, 90.0)) @ UP_ROTATIONS["+y"]
    np.testing.assert_allclose(o.placement.R, R, atol=1e-15)
    w = o.placement.to_world(o.gaussians.means)
    lo, hi = w.min(axis=0), w.max(axis=0)  # recentre: bottom centre of the placed bounding box
    np.testing.assert_allclose([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]], [0.1, 0.2, 0.3], atol=1e-12)
    # without a rotation, the placement is what it always was
    plain = parse_scene({"object": [{"file": str(DONUT)}]}, tmp_path / "p.toml").objects[0]
    np.testing.assert_array_equal(place(o.gaussians, plain).R, np.eye(3))


def test_object_rotation_validated(tmp_path):
    with pytest.raises(SceneError, match=r"object\]\] #1.rotation"):
        parse_scene({"object": [{"file": str(DONUT), "rotation": [0.0, 400.0, 0.0]}]}, tmp_path / "s.toml")


def _two_objects(tmp_path, collider: dict, guitar: dict | None = None):
    """A static donut (the obstacle) and a moving one; the scene parsed and both objects prepared."""
    static = {"file": str(DONUT), "static": True, "recentre": False, "rotation": [-15.0, 12.0, 30.0],
              "position": [0.01, -0.02, 0.03], **(guitar or {})}
    data = {"object": [static, {"file": str(DONUT), "position": [0.0, 0.0, 0.5]}], "collider": [collider]}
    scene = parse_scene(data, tmp_path / "s.toml")
    return scene, [prepare_object(o) for o in scene.objects]


def test_collider_from_a_static_object_sits_where_the_object_is(tmp_path):
    """The collider named by ``object`` uses the object's placement: the same field as a ``gaussians``
    collider given that placement by hand (same occupancy; only rounding differs)."""
    needs_package("scipy")
    dx = 0.01
    scene, objects = _two_objects(tmp_path, {"object": 1, "friction": 0.3})
    (col,) = build_colliders(scene, objects, dx)
    assert col.source == "object:1" and col.friction == 0.3 and not col.moving
    by_hand = parse_scene({"object": [{"file": str(DONUT)}], "collider": [
        {"gaussians": str(DONUT), "recentre": False, "rotation": [-15.0, 12.0, 30.0],
         "position": [0.01, -0.02, 0.03]}]}, tmp_path / "h.toml")
    (ref,) = build_colliders(by_hand, [], dx)
    X = objects[0].placement.to_world(objects[0].gaussians.means[::50])
    X = X + np.random.default_rng(0).normal(scale=2 * dx, size=X.shape)
    a, b = col.distance(X), ref.distance(X)
    ok = np.isfinite(a) & np.isfinite(b)
    assert ok.mean() > 0.9
    # the two fields are sampled on grids offset by rounding, each exact to half a sample (dx / 4):
    # trilinear values agree far better than that (measured 4e-4 dx median on the guitar)
    assert np.median(np.abs(a[ok] - b[ok])) < 0.05 * dx
    assert (a[ok] < 0).any() and (a[ok] > 0).any()


def test_collider_refuses_a_simulated_object_and_its_own_placement(tmp_path):
    scene, objects = _two_objects(tmp_path, {"object": 2})
    with pytest.raises(SceneError, match="the object is simulated"):
        build_colliders(scene, objects, 0.01)
    scene, objects = _two_objects(tmp_path, {"object": 1, "rotation": [0.0, 0.0, 10.0]})
    with pytest.raises(SceneError, match="sits where the object is"):
        build_colliders(scene, objects, 0.01)


# ---------------------------------------------------------------- run.json figures
def _setup_with_box(x: np.ndarray, dx: float) -> SimSetup:
    setup = SimSetup(x=x, v=0.0, p_vol=np.full(len(x), 1e-6), body_id=0, materials=[Material()],
                     gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                     n_grid=round(1.0 / dx), boundaries=[], frame_dt=0.02)
    # the box's top face at z = 0.4; it moves up at 0.1 m/s
    setup.colliders = [box_collider((0.2, 0.2, 0.1), dx / 2, name="lid", friction=0.7,
                                    position=np.array([0.5, 0.5, 0.3]), motion=Motion(velocity=(0.0, 0.0, 0.1)))]
    return setup


def test_contact_row_depth_and_count_in_dx():
    dx = 1.0 / 32
    z = 0.4 + dx * np.array([-0.3, -0.1, 0.5, 0.99, 1.5, 3.0])  # depths 0.3 and 0.1 dx, then above the top
    x = np.column_stack([np.full(6, 0.5), np.full(6, 0.5), z])
    setup = _setup_with_box(x, dx)
    (row,) = contact_row(setup, x, 0.0)
    assert row["depth_dx"] == pytest.approx(0.3, abs=1e-4)
    assert row["n_contact"] == 4  # within CONTACT_DX = 1 dx of the surface, inside ones included
    assert CONTACT_DX == 1.0
    # at t = 0.1 s the box has risen 0.01 m (0.32 dx): the collider's pose at the frame's time
    (later,) = contact_row(setup, x, 0.1)
    assert later["depth_dx"] == pytest.approx(0.3 + 0.32, abs=1e-3)
    # nothing near: zero depth, no contact
    assert contact_row(setup, x + np.array([0.0, 0.0, 0.3]), 0.0) == [{"depth_dx": 0.0, "n_contact": 0}]


def test_collider_records_gather_the_frames():
    dx = 1.0 / 32
    setup = _setup_with_box(np.full((1, 3), 0.5), dx)
    per_frame = [{"frame": 0, "colliders": [{"depth_dx": 0.0, "n_contact": 0}]},
                 {"frame": 1, "colliders": [{"depth_dx": 0.4, "n_contact": 12}]},
                 {"frame": 2, "colliders": [{"depth_dx": 0.2, "n_contact": 9}]}]
    (rec,) = collider_records(setup, per_frame)
    c = setup.colliders[0]
    assert rec["name"] == "lid" and rec["source"] == "" and rec["friction"] == 0.7
    assert rec["sdf_shape"] == list(c.phi.shape) and rec["sdf_samples"] == c.phi.size
    assert rec["mesh_faces"] == 12  # the box's own triangles
    assert rec["motion"] == {"velocity": [0.0, 0.0, 0.1], "angular_velocity": [0.0, 0.0, 0.0], "path": None}
    assert (rec["max_depth_dx"], rec["max_depth_frame"], rec["n_contact_last"]) == (0.4, 1, 9)
    # a run without collider rows (none yet) says so instead of inventing figures
    (empty,) = collider_records(setup, [{"frame": 0}])
    assert empty["max_depth_dx"] is None and empty["n_contact_last"] is None
