"""The two ``T^-1`` rebuild rules (``[[object]] rebuild``): GaMeS Gram-Schmidt (the paper) and the
triangle's covariance ``F Sigma F^T`` (PhysGaussian Eq. 6 with the triangle's own ``F``), issue 17 item 4.

Known answers: a homogeneous deformation ``F`` applied to the rest triangles of random flat Gaussians
must give exactly ``F Sigma F^T`` in the covariance rule (in the plane; the thin axis stays ``eps``);
both rules keep the mean, the normal and the in-plane area; they agree for rotations and uniform
stretch and differ under shear. The alpha rule on edges only ever shrinks the covariance.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.gs.io import read_gaussians
from gasp_core.maps.games import (EPS, gaussians_to_triangles, limit_edges, triangles_to_gaussians,
                                  triangles_to_gaussians_covariance)
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene

from gasp_testing import scene_text


def random_flat(n: int = 5000, seed: int = 0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    rot = quat_to_rotmat(q / np.linalg.norm(q, axis=1, keepdims=True))
    scales = np.column_stack([np.full(n, EPS), rng.uniform(0.005, 0.015, n), rng.uniform(0.005, 0.015, n)])
    means = rng.uniform(-0.5, 0.5, (n, 3))
    return means, rot, scales


def in_plane_cov(rot: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """``sum_k s_k^2 r_k r_k^T`` over the two in-plane axes, shape (n, 3, 3)."""
    r = rot[:, :, 1:]
    return np.einsum("nik,nk,njk->nij", r, scales[:, 1:] ** 2, r)


SHEAR = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
STRETCH_X = np.diag([1.5, 1.0, 1.0])
ROT = np.array([[np.cos(0.7), -np.sin(0.7), 0.0], [np.sin(0.7), np.cos(0.7), 0.0], [0.0, 0.0, 1.0]])


@pytest.mark.parametrize("F", [SHEAR, STRETCH_X, ROT, 1.3 * np.eye(3)], ids=["shear", "stretch", "rotation", "uniform"])
def test_covariance_rule_is_F_sigma_F_transpose(F):
    means, rot, scales = random_flat()
    tri = gaussians_to_triangles(means, rot, scales)
    moved = np.einsum("ij,nkj->nki", F, tri)
    m, r, s, degenerate = triangles_to_gaussians_covariance(moved)
    want = np.einsum("ij,njk,lk->nil", F, in_plane_cov(rot, scales), F)
    got = in_plane_cov(r, s)
    assert not degenerate.any()
    assert np.allclose(m, moved[:, 0])
    err = np.linalg.norm(got - want, axis=(1, 2)) / np.linalg.norm(want, axis=(1, 2))
    assert err.max() < 1e-9, f"max relative covariance error {err.max():.2e}"
    assert np.allclose(np.linalg.det(r), 1.0)


@pytest.mark.parametrize("F,differ", [(SHEAR, True), (STRETCH_X, True), (ROT, False), (1.3 * np.eye(3), False)],
                         ids=["shear", "stretch", "rotation", "uniform"])
def test_both_rules_share_normal_and_area_and_differ_only_where_edges_shear(F, differ):
    means, rot, scales = random_flat()
    moved = np.einsum("ij,nkj->nki", F, gaussians_to_triangles(means, rot, scales))
    _, r_g, s_g, _ = triangles_to_gaussians(moved)
    _, r_c, s_c, _ = triangles_to_gaussians_covariance(moved)
    assert np.allclose(np.abs(np.sum(r_g[:, :, 0] * r_c[:, :, 0], axis=1)), 1.0)        # same plane
    assert np.allclose(np.sum(r_g[:, :, 0] * r_c[:, :, 0], axis=1), 1.0)                 # same normal sign
    assert np.allclose(s_g[:, 1] * s_g[:, 2], s_c[:, 1] * s_c[:, 2], rtol=1e-9)         # same area
    diff = np.linalg.norm(in_plane_cov(r_g, s_g) - in_plane_cov(r_c, s_c), axis=(1, 2))
    rel = diff / np.linalg.norm(in_plane_cov(r_c, s_c), axis=(1, 2))
    if differ:
        assert np.median(rel) > 0.05, f"median covariance difference {np.median(rel):.3f}"
    else:
        assert rel.max() < 1e-9


def test_rest_triangles_give_back_the_input_covariance():
    means, rot, scales = random_flat()
    _, r, s, _ = triangles_to_gaussians_covariance(gaussians_to_triangles(means, rot, scales))
    want = in_plane_cov(rot, scales)
    assert np.allclose(in_plane_cov(r, s), want, rtol=1e-9, atol=1e-15)
    assert np.all(s[:, 1] >= s[:, 2])


def test_edge_limit_only_shrinks_the_covariance():
    means, rot, scales = random_flat()
    rest = gaussians_to_triangles(means, rot, scales)
    moved = np.einsum("ij,nkj->nki", 3.0 * SHEAR, rest)
    limited, clamped = limit_edges(rest, moved, 1.5)
    assert clamped.any()
    d_rest = np.linalg.norm(rest[:, 1:] - rest[:, :1], axis=2)
    d_lim = np.linalg.norm(limited[:, 1:] - limited[:, :1], axis=2)
    assert np.all(d_lim <= 1.5 * d_rest * (1 + 1e-12))
    before = in_plane_cov(*triangles_to_gaussians_covariance(moved)[1:3])
    after = in_plane_cov(*triangles_to_gaussians_covariance(limited)[1:3])
    # Sigma_after = Sigma_before - sum (1 - f_i^2) e_i e_i^T: no direction grows
    grow = np.linalg.eigvalsh(after - before).max(axis=1)
    assert grow.max() <= 1e-12 * np.linalg.eigvalsh(before).max()


def test_scene_key_rebuild_is_checked(write_scene, donut_small):
    bad = write_scene(scene_text(donut_small, n_frames=1, engine="warp_mpm", engine_options="{}",
                                 extra_object='rebuild = "fsigmaf"'))
    with pytest.raises(SceneError, match=r"rebuild.*'games', 'covariance'"):
        load_scene(bad)


@pytest.mark.skipif(__import__("importlib").util.find_spec("gasp_warp_mpm") is None, reason="warp_mpm not installed")
def test_covariance_rebuild_runs_end_to_end_with_the_same_means(tmp_path, write_scene, donut_small):
    """Same engine run, two rebuild rules: identical means (``m = v1`` either way), other shapes."""
    frames = {}
    for rule in ("games", "covariance"):
        scene = write_scene(scene_text(donut_small, n_frames=2, n_grid=16, engine="warp_mpm", engine_options="{}",
                                       extra_object=f'rebuild = "{rule}"'), name=f"{rule}.toml")
        simulate_scene(load_scene(scene), tmp_path / rule)
        frames[rule] = read_gaussians(tmp_path / rule / "donut_small" / "frame_0002.ply")
    g, c = frames["games"], frames["covariance"]
    assert np.array_equal(g.means, c.means)
    assert not np.allclose(g.rotations, c.rotations)
