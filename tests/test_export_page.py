"""``gasp view RUN --export``: the written page opens from ``file://`` in headless Chromium (no server)
and shows the donut falling: the last frame's donut sits lower on screen than frame 0's, and playing
changes the frame."""
import shutil
import time

import numpy as np
import pytest

from gasp_core.errors import SceneError

sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed (pip install playwright)")
CHROMIUM = next((p for p in (shutil.which(n) for n in ("chromium", "chromium-headless-shell", "chromium-browser",
                                                       "google-chrome")) if p), None)
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--no-first-run",
        "--disable-component-update", "--disable-sync", "--use-gl=swiftshader", "--enable-unsafe-swiftshader"]


def _sat(im):
    """Pixels of the donut: saturated pink/blue/tan, which the grey grid and the pale page lack."""
    return (im.max(axis=2) - im.min(axis=2)) > 60


def test_export_refuses_existing_page_and_names_it(donut_run, tmp_path):
    from gasp_core.render.export import export_page
    page = export_page(donut_run, tmp_path / "site", frames=[0])
    assert page == tmp_path / "site" / "index.html" and page.stat().st_size > 1000
    with pytest.raises(SceneError, match="exists; pass --overwrite"):
        export_page(donut_run, tmp_path / "site", frames=[0])
    export_page(donut_run, tmp_path / "site", frames=[0], overwrite=True)


def test_sqrt_covariances_square_back(donut_run):
    from gasp_core.render.export import sqrt_covariances
    from gasp_core.render.run import load_run
    covs = load_run(donut_run).splats(0).covs[:500]
    s = sqrt_covariances(covs)
    S = s[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3)
    assert np.allclose(S @ S, covs, rtol=0, atol=1e-6 * np.abs(covs).max())


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium found (apt-get install -y chromium)")
def test_exported_page_shows_donut_moving_from_file(donut_run, tmp_path):
    iio = pytest.importorskip("imageio.v3", reason='the render extra (imageio) is not installed: '
                              'python -m pip install -e ".[render]"')
    from gasp_core.cli.main import main
    page_path = tmp_path / "donut.html"
    assert main(["view", str(donut_run), "--export", str(page_path)]) == 0
    shots = {}
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page(viewport={"width": 800, "height": 600})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(page_path.as_uri())
        page.wait_for_function("window.gasp && window.gasp.ready || window.gaspError", timeout=120_000)
        assert page.evaluate("window.gaspError || ''") == "" and not errors
        n = page.evaluate("window.gasp.n_frames")
        for k in (0, n - 1):
            page.evaluate(f"window.gasp.show({k})")
            time.sleep(1.0)
            page.screenshot(path=str(tmp_path / f"f{k}.png"))
            shots[k] = iio.imread(tmp_path / f"f{k}.png")[..., :3].astype(int)
        page.click("#play")                                  # the page's own Play button
        page.wait_for_function(f"window.gasp.frame() !== {n - 1}", timeout=60_000)
        browser.close()
    a, b = _sat(shots[0]), _sat(shots[n - 1])
    assert a.sum() > 2000 and b.sum() > 2000                 # the donut is drawn in both
    assert np.abs(shots[0] - shots[n - 1]).mean() > 0.5      # the two frames differ
    # it fell: the donut's pixels are lower on the screen in the last frame
    assert np.nonzero(b)[0].mean() > np.nonzero(a)[0].mean() + 3


def test_rows_that_never_move_are_stored_once(tmp_path):
    """Frame 1 moves 10 of 100 real Gaussians: the page stores frame 0 whole and 10 rows of frame 1."""
    import gzip
    import json
    from pathlib import Path

    from gasp_core.gs.io import read_gaussians, write_gaussians
    from gasp_core.render.export import pack_run
    g = read_gaussians(Path(__file__).parent / "data" / "pc_short.ply")
    h = g.copy()
    h.means[20:30] += [0.0, 0.0, 0.05]
    (tmp_path / "obj").mkdir()
    write_gaussians(tmp_path / "obj" / "frame_0000.ply", g)
    write_gaussians(tmp_path / "obj" / "frame_0001.ply", h)
    (tmp_path / "run.json").write_text(json.dumps({"frame_dt": 0.1, "objects": [
        {"name": "obj", "placement": {"R": np.eye(3).tolist(), "scale": 1.0, "t": [0.0, 0.0, 0.0]}}]}))
    meta, data = pack_run(tmp_path)
    assert meta["n_moving"] == 10
    assert len(data) == 4 * 100 + 4 * 10 + 18 * 100 + 18 * 10
    rows = np.frombuffer(data, "<u4", 10, meta["moving_offset"])
    assert rows.tolist() == list(range(20, 30))
    c1 = np.frombuffer(data, "<u2", 30, meta["frames_offset"] + 18 * 100).reshape(10, 3)
    lo, hi = np.array(meta["lo"]), np.array(meta["hi"])
    np.testing.assert_allclose(lo + (hi - lo) * c1 / 65535.0, h.means[20:30], atol=1e-4 * meta["size"])
    assert gzip.decompress(gzip.compress(data)) == data
