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
