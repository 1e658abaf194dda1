"""PhysGaussian's layout, ``surface_points = "centres"`` (issue 39 item 5): one simulated point per Gaussian and
its ``F`` estimated from its neighbours' motion (:mod:`gasp_core.maps.centres`).

Known answers: any affine motion of a rank-3 neighbourhood (a rigid rotation, a uniform stretch, a shear) gives
``F`` exactly; a planar neighbourhood (a shell without fill) gives the rotation exactly through the guard; a
collinear one gives the identity and is counted. Through the rebuild, the centre's triangle gives
``F Sigma F^T`` (the covariance rule). End to end, in free fall (every point moves alike, ``F = I``) the centres
layout rebuilds the same Gaussians as the vertex layout, from a third of the surface points.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.gs.io import read_gaussians
from gasp_core.maps.centres import build_centre_frame, centre_triangles, deformation_gradients
from gasp_core.maps.games import EPS, gaussians_to_triangles, triangles_to_gaussians_covariance
from gasp_core.scene.spec import load_scene

from gasp_testing import scene_text


def rotation(axis, angle):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def cloud(n=2000, seed=0, planar=False):
    x = np.random.default_rng(seed).uniform(-0.1, 0.1, (n, 3))
    if planar:
        x[:, 2] = 0.0
    return x


MOTIONS = {"rotation": rotation([1, 2, 3], 0.9), "uniform stretch": 1.3 * np.eye(3),
           "shear": np.array([[1.0, 0.6, 0.0], [0.0, 1.0, 0.0], [0.0, 0.2, 0.8]])}


@pytest.mark.parametrize("name", MOTIONS)
def test_affine_motion_gives_F_exactly(name):
    F_true = MOTIONS[name]
    x = cloud()
    frame = build_centre_frame(x, np.arange(0, 2000, 7), np.arange(2000))
    moved = x @ F_true.T + np.array([0.3, -0.2, 0.5])
    F = deformation_gradients(frame, moved)
    assert (frame.rank == 3).all()
    assert np.abs(F - F_true).max() < 1e-9
    assert np.abs(deformation_gradients(frame, x) - np.eye(3)).max() < 1e-9


def test_planar_neighbourhood_keeps_a_rotation_exact_and_a_line_gives_the_identity():
    x = cloud(planar=True)
    centres = np.arange(0, 2000, 11)
    frame = build_centre_frame(x, centres, np.arange(2000))
    R = rotation([0.3, -1.0, 0.4], 1.2)
    assert (frame.rank == 2).all() and frame.n_degenerate == 0
    assert np.abs(deformation_gradients(frame, x @ R.T) - R).max() < 1e-9
    S = np.diag([1.5, 0.7, 1.0])            # in-plane stretch: exact in the plane, the normal stays unit
    F = deformation_gradients(frame, x @ S.T)
    assert np.abs(F - S).max() < 1e-9
    line = np.zeros((50, 3))
    line[:, 0] = np.linspace(0, 1, 50)
    lf = build_centre_frame(line, np.arange(50), np.arange(50))
    assert lf.n_degenerate == 50
    assert np.array_equal(deformation_gradients(lf, line * 2.0), np.broadcast_to(np.eye(3), (50, 3, 3)))


def test_centre_triangle_rebuilds_F_sigma_F_transpose():
    rng = np.random.default_rng(3)
    n = 300
    q = rng.normal(size=(n, 4))
    rot = quat_to_rotmat(q / np.linalg.norm(q, axis=1, keepdims=True))
    scales = np.column_stack([np.full(n, EPS), rng.uniform(0.002, 0.01, n), rng.uniform(0.002, 0.01, n)])
    means = rng.uniform(-0.1, 0.1, (n, 3))
    tri = gaussians_to_triangles(means, rot, scales)
    fill = cloud(3000, seed=4)
    x = np.concatenate([means, fill])
    frame = build_centre_frame(x, np.arange(n), np.arange(len(x)))
    F_true = MOTIONS["shear"] @ rotation([0, 0, 1], 0.4)
    moved = x @ F_true.T
    m, r, s, _ = triangles_to_gaussians_covariance(centre_triangles(frame, moved, tri))
    cov = np.einsum("nij,nj,nkj->nik", r[:, :, 1:], s[:, 1:] ** 2, r[:, :, 1:])
    sigma = np.einsum("nij,nj,nkj->nik", rot[:, :, 1:], scales[:, 1:] ** 2, rot[:, :, 1:])
    want = F_true @ sigma @ F_true.T
    assert np.abs(m - means @ F_true.T).max() < 1e-12
    assert (np.linalg.norm(cov - want, axis=(1, 2)) / np.linalg.norm(want, axis=(1, 2))).max() < 1e-8


def test_scene_key_is_checked(write_scene, donut_small):
    with pytest.raises(SceneError, match=r"surface_points.*'vertices', 'centres', 'auto'"):
        load_scene(write_scene(scene_text(donut_small, extra_object='surface_points = "corners"')))
    with pytest.raises(SceneError, match=r"surface_points = \"centres\".*core_fraction"):
        load_scene(write_scene(scene_text(donut_small, extra_object='surface_points = "centres"\n'
                                                                    'core_fraction = 0.2')))
    assert load_scene(write_scene(scene_text(donut_small)), quality="reference").objects[0].surface_points \
        == "vertices"


def test_auto_takes_centres_only_where_the_trade_picked_them(write_scene, donut_small):
    """The levels' ``surface_points = "auto"``: centres on an elastic body with a material surface (the README
    donut's trade, docs/speed_accuracy.md) and on an elastic body's passive surface (draft, issue 55), vertices on
    the passive surface of another material, with Core Gaussians, or another material."""
    import dataclasses
    from gasp_core.prepare.surface import choose_surface_points
    spec = load_scene(write_scene(scene_text(donut_small)), quality="default").objects[0]
    assert spec.surface_points == "auto" and spec.material.name == "jelly"
    assert choose_surface_points(spec).surface_points == "centres"
    assert choose_surface_points(dataclasses.replace(spec, surface="material")).surface_points == "centres"
    assert choose_surface_points(dataclasses.replace(spec, surface="passive")).surface_points == "centres"
    for changed in ({"surface": "passive", "material": dataclasses.replace(spec.material, name="sand")},
                    {"core_fraction": 0.5}, {"material": dataclasses.replace(spec.material, name="sand")}):
        assert choose_surface_points(dataclasses.replace(spec, **changed)).surface_points == "vertices", changed
    draft = load_scene(write_scene(scene_text(donut_small)), quality="draft").objects[0]
    assert choose_surface_points(draft).surface_points == "centres"   # draft's passive surface, elastic (issue 55)
    assert choose_surface_points(dataclasses.replace(spec, surface_points="vertices")).surface_points == "vertices"


@pytest.mark.skipif(__import__("importlib").util.find_spec("gasp_warp_mpm") is None, reason="warp_mpm not installed")
@pytest.mark.parametrize("surface", ["material", "passive"])
def test_free_fall_rebuilds_the_vertex_layouts_gaussians_from_a_third_of_the_points(tmp_path, write_scene,
                                                                                    donut_small, surface):
    """2 frames of free fall (the donut starts 5 cm up and falls 2 cm): every point moves alike, so ``F = I``."""
    from gasp_core.run.pipeline import simulate_scene
    out = {}
    for pts in ("vertices", "centres"):
        # one step for both layouts (the contact's stable step depends on the points' spacing)
        scene = write_scene(scene_text(donut_small, n_frames=2, n_grid=16, engine="warp_mpm",
                                       engine_options="{ n_substeps = 40 }",
                                       extra_object=f'surface_points = "{pts}"\nsurface = "{surface}"\n'
                                                    'rebuild = "covariance"'), name=f"{pts}.toml")
        simulate_scene(load_scene(scene), tmp_path / pts)
        out[pts] = (read_gaussians(tmp_path / pts / "donut_small" / "frame_0002.ply"),
                    json.loads((tmp_path / pts / "run.json").read_text()))
    (gv, rv), (gc, rc) = out["vertices"], out["centres"]
    n = gv.n
    assert rv["n_render_points"] == 3 * n and rc["n_render_points"] == n
    assert rc["objects"][0]["surface_points"] == "centres" and rc["objects"][0]["centres_degenerate"] == 0
    if surface == "passive":    # massless surface points: the same fill (the same solid) as the vertex layout's
        assert rc["n_points"] - n == rv["n_points"] - 3 * n
        assert rc["engine_stats"]["mass"] == pytest.approx(rv["engine_stats"]["mass"], rel=1e-6)
    fall = np.abs(gc.means[:, 2] - read_gaussians(donut_small).means[:, 2]).mean()
    assert 0.015 < fall < 0.03                                  # it did fall: 1/2 g t^2 = 2.2 cm
    assert np.abs(gc.means - gv.means).max() < 1e-5 * 0.3      # same centres (float32 rounding)
    assert np.abs(gc.scales - gv.scales).max() < 1e-3 * np.abs(gv.scales).max()
