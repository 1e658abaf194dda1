"""Colliders, impulses and force fields: scene keys, distance fields, feature checks (gasp_core.colliders.model)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.colliders.model import ForceField, Impulse, Motion
from gasp_core.colliders.sdf import box_collider, collider_from_triangles
from gasp_core.mpm.grid_tables import frame_table, grid_tables
from gasp_core.errors import SceneError
from gasp_core.seam.build import check_supported, needs
from gasp_core.seam.engine import Capabilities, EngineInfo
from gasp_core.scene.spec import parse_scene

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"


def _scene(tmp_path, **extra):
    data = {"object": [{"file": str(DATA / "donut_v3dg.ply")}], **extra}
    return parse_scene(data, tmp_path / "s.toml")


def test_box_sdf_is_exact():
    c = box_collider((0.1, 0.2, 0.3), 0.01)
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.32], [0.12, 0.0, 0.0], [0.05, 0.1, 0.2]])
    np.testing.assert_allclose(c.distance(pts), [-0.1, 0.02, 0.02, -0.05], atol=1e-9)


def test_mesh_sdf_matches_box():
    trimesh = needs_package("trimesh")
    needs_package("rtree")
    m = trimesh.creation.box(extents=(0.2, 0.4, 0.6))
    c = collider_from_triangles(m.triangles, 0.01)
    pts = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.32], [0.12, 0.0, 0.0], [0.05, 0.1, 0.2]])
    np.testing.assert_allclose(c.distance(pts), [-0.1, 0.02, 0.02, -0.05], atol=1e-6)


def test_open_mesh_refused():
    trimesh = needs_package("trimesh")
    m = trimesh.creation.box(extents=(0.2, 0.4, 0.6))
    with pytest.raises(SceneError, match="not closed"):
        collider_from_triangles(m.triangles[:-2], 0.01)


def test_motion_pose_path_and_spin():
    c = box_collider((0.1, 0.1, 0.1), 0.02, motion=Motion(path=np.array([[0.0, 0, 0, 0], [1.0, 1.0, 0, 0]])))
    R, T, v, w = c.pose(0.25)
    np.testing.assert_allclose(T, [0.25, 0, 0])
    np.testing.assert_allclose(v, [1.0, 0, 0])
    c2 = box_collider((0.1, 0.1, 0.1), 0.02, motion=Motion(angular_velocity=(0.0, 0.0, math.pi)))
    R, T, v, w = c2.pose(0.5)
    np.testing.assert_allclose(R @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-12)


def test_impulse_weights_sum_to_one():
    i = Impulse("box", (1.0, 0, 0), t0=0.013, t1=0.051, lo=(0, 0, 0), hi=(1, 1, 1))
    dt = 0.004
    assert sum(i.weight(k * dt, dt) for k in range(100)) == pytest.approx(1.0)
    j = Impulse("sphere", (1.0, 0, 0), t0=0.013, t1=0.013, centre=(0, 0, 0), radius=1.0)
    assert sum(j.weight(k * dt, dt) for k in range(100)) == 1.0


def test_turbulence_divergence_free_and_seeded():
    f = ForceField("wind", speed=1.0, turbulence=2.0, turbulence_scale=0.2, seed=3)
    x = np.random.default_rng(0).uniform(-1, 1, (2000, 3))
    a = f.wind_velocity(x) - 1.0 * np.array(f.direction)
    assert np.sqrt((a ** 2).sum(axis=1).mean()) == pytest.approx(2.0, rel=0.15)
    eps = 1e-6
    div = sum((f.wind_velocity(x + eps * e) - f.wind_velocity(x - eps * e))[:, d] / (2 * eps)
              for d, e in enumerate(np.eye(3)))
    assert np.abs(div).max() < 1e-4
    np.testing.assert_array_equal(f.modes(), ForceField("wind", speed=1.0, turbulence=2.0,
                                                        turbulence_scale=0.2, seed=3).modes())


def test_wind_as_an_acceleration_is_refused_naming_the_new_keys(tmp_path):
    """The scene format before issue 17 gave wind an acceleration 'strength'; it now fails with the drag keys."""
    with pytest.raises(SceneError, match=r"'strength'.*no longer read.*'speed'.*'air_density'.*'drag_coefficient'"):
        _scene(tmp_path, force=[{"kind": "wind", "strength": 2.5, "direction": [1, 0, 0]}])
    with pytest.raises(SceneError, match="'speed'"):
        ForceField("wind", strength=1.0)
    f = _scene(tmp_path, force=[{"kind": "wind", "speed": 3.0, "air_density": 1.2, "drag_coefficient": 0.5}]).forces[0]
    assert (f.speed, f.drag_factor) == (3.0, pytest.approx(0.3))


def test_attractor_falloff():
    f = ForceField("attractor", strength=2.0, point=(0, 0, 0), radius=0.1, falloff="inverse_square")
    a = f.acceleration(np.array([[0.2, 0, 0], [0.05, 0, 0]]))
    np.testing.assert_allclose(a, [[-0.5, 0, 0], [-1.0, 0, 0]])


def test_scene_keys_parsed(tmp_path):
    s = _scene(tmp_path, force=[{"kind": "wind", "speed": 2.0, "direction": [0, 2, 0]}],
               impulse=[{"shape": "sphere", "centre": [0, 0, 0], "radius": 0.1, "velocity_change": [0, 0, 1],
                         "t0": 0.1}])
    assert s.forces[0].direction == (0.0, 1.0, 0.0)
    assert s.impulses[0].t1 == 0.1


@pytest.mark.parametrize("extra, match", [
    ({"collider": [{"friction": 0.5}]}, "exactly one of 'mesh', 'gaussians' or 'object'"),
    ({"collider": [{"mesh": "nope.obj"}]}, "does not exist"),
    ({"collider": [{"gaussians": str(DATA / "donut_v3dg.ply"), "velocity": [1, 0, 0]}]}, "only a 'mesh' collider can move"),
    ({"collider": [{"object": 3}]}, r"object = 3"),
    ({"collider": [{"object": 1, "frction": 0.1}]}, "unknown key"),
    ({"force": [{"kind": "wind"}]}, "needs 'speed'"),
    ({"force": [{"kind": "wind", "speed": 1, "direction": [0, 0, 0]}]}, "non-zero vector"),
    ({"force": [{"kind": "vortex", "strength": 1}]}, "kind"),
    ({"force": [{"kind": "attractor", "strength": 1}]}, "needs 'point'"),
    ({"force": [{"kind": "attractor", "strength": 1, "point": [0, 0, 0], "falloff": "cubic"}]}, "falloff"),
    ({"impulse": [{"shape": "box", "lo": [0, 0, 0], "hi": [1, 1, 1]}]}, "needs 'velocity_change'"),
    ({"impulse": [{"shape": "box", "lo": [0, 0, 0], "hi": [1, 1, 1], "velocity_change": [1, 0, 0], "t0": 1.0,
                   "t1": 0.5}]}, "before t0"),
    ({"impulse": [{"shape": "box", "lo": [0, 0, 0], "hi": [1, 1, 1], "velocity_change": [1, 0, 0],
                   "mode": "set"}]}, "needs t1 > t0"),
])
def test_bad_keys_are_one_line_scene_errors(tmp_path, extra, match):
    with pytest.raises(SceneError, match=match) as e:
        _scene(tmp_path, **extra)
    assert "\n" not in str(e.value)


def test_missing_feature_names_engines_that_have_it():
    def info(name, feats):
        return EngineInfo(name, lambda s: None, Capabilities(frozenset({"jelly"}), frozenset(), features=frozenset(feats)))
    a, b = info("plain", ()), info("able", {"static_colliders"})
    features = needs(colliders=[box_collider((0.1, 0.1, 0.1), 0.02)])["features"]
    assert features == ["static_colliders"]
    with pytest.raises(SceneError, match=r"static_colliders.*engines that do: \['able'\]"):
        check_supported(a, features=features, others={"plain": a, "able": b})


def test_grid_tables_layout():
    class S:
        colliders = [box_collider((0.1, 0.1, 0.1), 0.05, motion=Motion(velocity=(1.0, 0, 0)))]
        forces = [ForceField("wind", speed=1.0)]
        impulses = [Impulse("box", (1.0, 0, 0), lo=(0, 0, 0), hi=(1, 1, 1))]
    t = grid_tables(S)
    assert (t.n_colliders, t.n_forces, t.n_impulses) == (1, 1, 1)
    assert len(t.sdf) == S.colliders[0].phi.size and len(t.sdf_grad) == 3 * len(t.sdf)
    tab = frame_table(S, 0.1, 4, 0.01).reshape(4, -1)
    assert tab.shape == (4, t.width)
    np.testing.assert_allclose(tab[:, 10], 0.1 + np.arange(4) * 0.01)   # T_x moves with the collider
    assert tab[0, -1] == 0.0     # the impulse (t0 = 0) is before this frame


def _face(c, u, v, L1, L2, a):
    i, j = np.meshgrid(np.arange(round(L1 / a)), np.arange(round(L2 / a)), indexing="ij")
    m = c + ((i.ravel() + 0.5) * a - L1 / 2)[:, None] * u + ((j.ravel() + 0.5) * a - L2 / 2)[:, None] * v
    return np.stack([m, m + 0.5 * a * u, m + 0.5 * a * v], axis=1)


def test_a_collider_from_splats_has_its_surface_where_the_footprints_are():
    """A 0.9 x 0.9 x 0.12 m slab whose faces are tiled with flat Gaussians (GaMeS triangles in the face planes): the
    collider's zero level on the top face lies within half an SDF sample of the plane z = 0.12 m. The fill's voxel
    is bounded by its grid (0.9 m / 160 = 5.6 mm here, 9 mm on the README guitar), so its surface alone sat 1.63
    samples (5.7 mm) inside this slab and about a dx above the guitar's strings; measured now: +0.37 samples."""
    from gasp_core.colliders.sdf import collider_from_splats
    X, Y, Z = np.eye(3)
    L, H, a = 0.9, 0.12, 0.01
    splats = np.concatenate([_face(np.array([0, 0, H]), X, Y, L, L, a), _face(np.zeros(3), X, Y, L, L, a),
                             *[_face(np.array([s * L / 2, 0, H / 2]), Y, Z, L, H, a) for s in (1, -1)],
                             *[_face(np.array([0, s * L / 2, H / 2]), X, Z, L, H, a) for s in (1, -1)]])
    h = 0.5 * L / 128
    col = collider_from_splats(splats, h)
    top = np.array([[0.0, 0.0, H], [0.2, -0.1, H], [-0.3, 0.3, H]])
    phi = col.distance(top, 0.0) / h
    assert np.all(np.abs(phi) <= 0.5), phi
    above = col.distance(top + np.array([0, 0, 2 * h]), 0.0) / h     # and it is a distance: 2 samples above, 2 +- 0.5
    assert np.all(np.abs(above - 2.0 - phi) <= 0.5), above
