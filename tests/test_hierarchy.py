"""Core Gaussians (BIRCH) and sub-Gaussian binding, on the real donut."""
import numpy as np
import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.maps.games import flatten, gaussians_to_triangles, triangles_to_gaussians
from gasp_core.maps.hierarchy import build_hierarchy, sub_triangles


@pytest.fixture(scope="module")
def donut_tri(donut):
    g = donut.subset(np.arange(0, donut.n, 4))
    s, R, _ = flatten(g.scales, g.rotmats())
    return g.means, gaussians_to_triangles(g.means, R, s)


@pytest.fixture(scope="module")
def hier(donut_tri):
    return build_hierarchy(*donut_tri, core_fraction=0.05)


def test_core_count_and_binding(hier, donut_tri):
    means, tri = donut_tri
    assert abs(hier.n_cores - round(0.05 * len(means))) <= 0.01 * round(0.05 * len(means))
    assert np.bincount(hier.core_of, minlength=hier.n_cores).min() >= 1
    # at rest the binding reproduces every triangle
    assert np.abs(sub_triangles(hier, hier.core_points) - tri).max() < 1e-12
    # core triangles are non-degenerate
    _, _, _, deg = triangles_to_gaussians(hier.core_tri)
    assert not deg.any()
    # clusters are compact: members lie near their core centre (well within the object size)
    d = np.linalg.norm(means - hier.core_points[hier.core_of, 0], axis=1)
    assert np.median(d) < 0.1 * np.ptp(means, axis=0).max()


def test_coefficients_bounded(hier):
    """Core frames enclose their members: every binding coefficient is at most 1 in size."""
    assert np.abs(hier.local).max() <= 1.0 + 1e-12


def test_affine_motion_of_cores_moves_subs_affinely(hier, donut_tri):
    """A random affine map of the core points moves every sub triangle by the same map."""
    _, tri = donut_tri
    rng = np.random.default_rng(3)
    M = np.eye(3) + 0.4 * rng.standard_normal((3, 3))
    t = rng.standard_normal(3)
    moved = sub_triangles(hier, hier.core_points @ M.T + t)
    assert np.abs(moved - (tri @ M.T + t)).max() < 1e-9


def test_rigid_motion_of_cores_moves_subs_rigidly(hier, donut_tri):
    _, tri = donut_tri
    th = 0.9
    R = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    t = np.array([0.3, -0.1, 0.2])
    moved = sub_triangles(hier, hier.core_points @ R.T + t)
    assert np.abs(moved - (tri @ R.T + t)).max() < 1e-12


def test_degenerate_core_gives_finite_subs(hier):
    collapsed = hier.core_points.copy()
    collapsed[:, 1] = collapsed[:, 0]
    out = sub_triangles(hier, collapsed)
    assert np.all(np.isfinite(out))


@pytest.mark.parametrize("frac, msg", [(1.5, "must be in"), (0.0, "must be in"), ("x", "must be a number"),
                                       (1e-6, "cores for")])
def test_bad_fraction_is_one_line_scene_error(donut_tri, frac, msg):
    from gasp_core.errors import SceneError
    with pytest.raises(SceneError, match=msg) as e:
        build_hierarchy(*donut_tri, core_fraction=frac)
    assert "\n" not in str(e.value)


def test_tiny_fraction_on_full_donut(donut):
    """core_fraction = 0.001 on the whole donut (45,624 Gaussians) gives 46 cores, bounded and exact at rest."""
    s, R, _ = flatten(donut.scales, donut.rotmats())
    tri = gaussians_to_triangles(donut.means, R, s)
    h = build_hierarchy(donut.means, tri, 0.001)
    assert h.n_cores == round(0.001 * donut.n)
    assert np.abs(h.local).max() <= 1.0 + 1e-12
    assert np.abs(sub_triangles(h, h.core_points) - tri).max() < 1e-12


def test_pipeline_with_cores_tracks_full_run(tmp_path, donut_small):
    """Simulating 25 % of the donut's Gaussians as cores stays close to simulating all of them."""
    needs_package("gasp_taichi_mpm")
    from gasp_core.gs.io import read_gaussians
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    runs = {}
    for frac in (1.0, 0.25):
        p = tmp_path / f"s{frac}.toml"
        p.write_text(scene_text(donut_small, n_frames=6, extra_object=f"core_fraction = {frac}"))
        res = simulate_scene(load_scene(p), tmp_path / f"o{frac}", quiet=True)
        runs[frac] = (read_gaussians(tmp_path / f"o{frac}" / "donut_small" / "frame_0006.ply").means, res)
    full, part = runs[1.0][0], runs[0.25][0]
    size = np.ptp(full, axis=0).max()
    assert runs[0.25][1].summary["objects"][0]["n_simulated_gaussians"] < runs[1.0][1].summary["objects"][0]["n_simulated_gaussians"] / 3
    assert np.linalg.norm(part - full, axis=1).mean() < 0.05 * size
