"""Core Gaussians (BIRCH) and sub-Gaussian binding, on the real donut."""
import numpy as np
import pytest
from gasp_testing import scene_text

from gasp_core.games import flatten, gaussians_to_triangles, triangles_to_gaussians
from gasp_core.hierarchy import build_hierarchy, sub_triangles


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
    assert hier.n_cores == round(0.05 * len(means))
    assert np.bincount(hier.core_of, minlength=hier.n_cores).min() >= 1
    # at rest the binding reproduces every triangle
    assert np.abs(sub_triangles(hier, hier.core_tri) - tri).max() < 1e-12
    # cores are non-degenerate
    _, _, _, deg = triangles_to_gaussians(hier.core_tri)
    assert not deg.any()
    # BIRCH clusters are compact: members lie near their core centre (well within the object size)
    d = np.linalg.norm(means - hier.core_tri[hier.core_of, 0], axis=1)
    assert np.median(d) < 0.1 * np.ptp(means, axis=0).max()


def test_rigid_motion_of_cores_moves_subs_rigidly(hier, donut_tri):
    _, tri = donut_tri
    th = 0.9
    R = np.array([[np.cos(th), 0, np.sin(th)], [0, 1, 0], [-np.sin(th), 0, np.cos(th)]])
    t = np.array([0.3, -0.1, 0.2])
    moved = sub_triangles(hier, hier.core_tri @ R.T + t)
    assert np.abs(moved - (tri @ R.T + t)).max() < 1e-12


def test_stretch_of_cores_stretches_subs(hier, donut_tri):
    """In-plane offsets follow the cores' affine map; normal offsets ride the new normal scaled by sqrt(area)."""
    from gasp_core.hierarchy import affine_frames
    _, tri = donut_tri
    S = np.diag([2.0, 1.0, 0.5])
    core_t = hier.core_tri @ S.T
    moved = sub_triangles(hier, core_t)
    c = hier.core_of
    e2, e3 = core_t[c, 1] - core_t[c, 0], core_t[c, 2] - core_t[c, 0]
    nrm = np.cross(e2, e3)
    l_n = nrm / np.sqrt(np.linalg.norm(nrm, axis=1, keepdims=True))
    a = hier.local[:, 0]                                  # v1 of each sub in its core frame
    expect = core_t[c, 0] + a[:, :1] * l_n + a[:, 1:2] * e2 + a[:, 2:3] * e3
    assert np.abs(moved[:, 0] - expect).max() < 1e-12
    # an in-plane sub (zero normal coordinate) moves exactly by S
    rest = tri[:, 0]
    A0 = affine_frames(hier.core_tri)[c]
    in_plane = np.abs(a[:, 0] * np.linalg.norm(A0[:, :, 0], axis=1)) < 1e-6 * np.ptp(rest, axis=0).max()
    rel_rest = rest - hier.core_tri[c, 0]
    planar = rel_rest - np.einsum("ni,ni->n", rel_rest, A0[:, :, 0])[:, None] * A0[:, :, 0] / np.einsum("ni,ni->n", A0[:, :, 0], A0[:, :, 0])[:, None]
    assert in_plane.sum() > 0
    assert np.allclose((moved[:, 0] - core_t[c, 0])[in_plane], (planar @ S.T)[in_plane], atol=1e-5 * np.ptp(rest, axis=0).max())


def test_degenerate_core_gives_finite_subs(hier):
    collapsed = hier.core_tri.copy()
    collapsed[:, 1] = collapsed[:, 0]
    out = sub_triangles(hier, collapsed)
    assert np.all(np.isfinite(out))


def test_bad_fraction(donut_tri):
    with pytest.raises(ValueError, match="core_fraction"):
        build_hierarchy(*donut_tri, core_fraction=1.5)


def test_pipeline_with_cores_tracks_full_run(tmp_path, donut_small):
    """Simulating 25 % of the donut's Gaussians as cores stays close to simulating all of them."""
    pytest.importorskip("gasp_taichi_mpm")
    from gasp_core.io import read_gaussians
    from gasp_core.pipeline import simulate_scene
    from gasp_core.scene import load_scene
    runs = {}
    for frac in (1.0, 0.25):
        p = tmp_path / f"s{frac}.toml"
        p.write_text(scene_text(donut_small, n_frames=6, extra_object=f"core_fraction = {frac}"))
        res = simulate_scene(load_scene(p), tmp_path / f"o{frac}", progress=False)
        runs[frac] = (read_gaussians(tmp_path / f"o{frac}" / "donut_small" / "frame_0006.ply").means, res)
    full, part = runs[1.0][0], runs[0.25][0]
    size = np.ptp(full, axis=0).max()
    assert runs[0.25][1].summary["objects"][0]["n_simulated_gaussians"] < runs[1.0][1].summary["objects"][0]["n_simulated_gaussians"] / 3
    assert np.linalg.norm(part - full, axis=1).mean() < 0.05 * size
