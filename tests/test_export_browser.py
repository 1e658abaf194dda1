"""A GASP GLB (KHR_gaussian_splatting) opened by a real reader, Babylon.js's glTF loader, in headless Chromium
(issue 42): it builds one GaussianSplattingMesh with every splat and draws a non-empty frame."""
import imageio.v3 as iio
import numpy as np
import pytest
from glb_browser import INSTALL, babylon_dir, chromium, open_in_babylon

pytest.importorskip("pygltflib", reason="the export extra is not installed: pip install -e '.[export]'")
pytest.importorskip("playwright.sync_api", reason="playwright is not installed: pip install playwright")
if chromium() is None:
    pytest.skip("no Chromium found: apt-get install -y chromium", allow_module_level=True)
MODULES = babylon_dir()
if MODULES is None:
    pytest.skip(f"Babylon.js not found: {INSTALL} (or GASP_NODE_MODULES=<a node_modules with both>)",
                allow_module_level=True)


def test_babylon_loads_a_gasp_glb_with_every_splat_and_draws_it(tmp_path, donut_small):
    from gasp_core.gs.gltf import write_glb
    from gasp_core.gs.io import read_gaussians
    g = read_gaussians(donut_small)
    write_glb(tmp_path / "d.glb", g, up_axis="+z")
    r = open_in_babylon(tmp_path / "d.glb", tmp_path / "shot.png", MODULES)
    assert "error" not in r, r
    assert r["classes"].count("GaussianSplattingMesh") == 1 and r["splats"] == [g.n], r
    img = iio.imread(tmp_path / "shot.png")[..., :3].astype(int)
    lit = img.max(axis=2) > 40                      # the background is black
    assert 2000 < lit.sum() < 0.9 * lit.size, lit.sum()
    rows, cols = np.nonzero(lit)                    # the donut is in the middle of the picture, not a stray pixel
    assert abs(rows.mean() - img.shape[0] / 2) < img.shape[0] / 4 and abs(cols.mean() - img.shape[1] / 2) < img.shape[1] / 4


def test_babylon_plays_a_glb_sequence_one_frame_at_a_time(tmp_path, donut_small):
    """gasp export --format glb_sequence: Babylon.js reads KHR_node_visibility and KHR_animation_pointer, so at each
    point of the animation exactly one frame's mesh is visible, beside the object's static rows (drawn throughout)."""
    import json
    from gasp_core.gs.io import read_gaussians
    from gasp_core.run.export import export_run
    from gasp_core.run.layout import FrameWriter
    g = read_gaussians(donut_small)
    moving = np.arange(0, g.n, 2)                       # half the rows move (as an object with select)
    run = tmp_path / "run"
    (run / "a").mkdir(parents=True)
    w = FrameWriter(run, ["a"], [False], [moving], "ply", "split")
    for f in range(5):                                  # the moving rows rise 2 cm a frame
        means = g.means.copy()
        means[moving, 2] += 0.02 * f
        w.write(f, [type(g)(means=means, scales=g.scales, rotations=g.rotations, opacities=g.opacities,
                            sh_dc=g.sh_dc, sh_rest=g.sh_rest, source=g.source, layout=g.layout)])
    (run / "run.json").write_text(json.dumps({"frame_dt": 0.1, "objects": [{"name": "a", "up_axis": "+z"}]}))
    export_run(run, "glb_sequence", tmp_path / "seq.glb")
    r = open_in_babylon(tmp_path / "seq.glb", tmp_path / "seq.png", MODULES, seek=(0.0, 0.5, 1.0))
    assert "error" not in r, r
    assert r["animation_groups"] == 1 and r["names"] == ["a_static"] + [f"a_frame_{f:04d}" for f in range(5)], r
    assert r["splats"] == [g.n - len(moving)] + [len(moving)] * 5, r
    assert r["visible"] == [["a_static", "a_frame_0000"], ["a_static", "a_frame_0002"], ["a_static", "a_frame_0004"]]


def test_babylon_opens_each_piece_of_a_split_glb_as_its_own_mesh(tmp_path, donut_small):
    """gasp export --split-pieces (issue 52): the GLB's piece nodes (gasp_core.gs.gltf.write_glb_nodes, the writer
    the export uses) open in Babylon.js as one GaussianSplattingMesh each, named by the node, with its splats."""
    from gasp_core.gs.gltf import write_glb_nodes
    from gasp_core.gs.io import read_gaussians
    g = read_gaussians(donut_small)
    parts = [(f"d_piece_{k:03d}", g.subset(np.arange(k, g.n, 3))) for k in range(3)]
    write_glb_nodes(tmp_path / "p.glb", parts, up_axis="+z")
    r = open_in_babylon(tmp_path / "p.glb", tmp_path / "p.png", MODULES)
    assert "error" not in r, r
    assert r["classes"].count("GaussianSplattingMesh") == 3, r
    assert sorted(zip(r["names"], r["splats"])) == [(n, p.n) for n, p in parts], r
