"""``gasp view`` in headless Chromium: the donut shows, and another frame changes the picture."""
import shutil
import time

import numpy as np
import pytest

pytest.importorskip("viser", reason="the view extra is not installed: pip install -e '.[view]'")
pytest.importorskip("imageio", reason='the render extra (imageio) is not installed: python -m pip install -e ".[render]"')
sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed: pip install playwright")
# Debian's full browser or its headless build, whichever is there
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-headless-shell")
if CHROMIUM is None:
    pytest.skip("no Chromium found: apt-get install -y chromium (or chromium-headless-shell)",
                allow_module_level=True)

ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-quic",
        "--no-first-run", "--disable-component-update", "--disable-sync", "--use-gl=swiftshader",
        "--enable-unsafe-swiftshader"]


def _sat(im):
    """Pixels of the donut: saturated pink/blue/tan, which the grey grid and the white page lack."""
    return (im.max(axis=2) - im.min(axis=2)) > 60


def _shot(page, path, timeout_s=90.0):
    """Screenshot once the splats are drawn and the picture stops changing (software WebGL is slow)."""
    import imageio.v3 as iio
    prev, t0 = None, time.time()
    while True:
        time.sleep(2.0)
        page.screenshot(path=str(path))
        img = iio.imread(path)[..., :3].astype(int)
        drawn = _sat(img).sum() > 2000
        if drawn and prev is not None and np.abs(img - prev).mean() < 0.05 or time.time() - t0 > timeout_s:
            return img
        prev = img


def test_view_shows_donut_and_slider_changes_picture(donut_run, tmp_path):
    from gasp_core.render.viewer import RunViewer
    v = RunViewer(donut_run, port=8311)
    try:
        with sync_api.sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
            page = browser.new_page(viewport={"width": 800, "height": 600})
            page.goto(f"http://127.0.0.1:{v.port}")
            a = _shot(page, tmp_path / "frame0.png")
            v.frame.value = v.run.n_frames - 1          # the slider's own handle: what a drag sets
            b = _shot(page, tmp_path / "last.png")
            browser.close()
    finally:
        v.stop()
    sat = _sat
    assert sat(a).sum() > 2000 and sat(b).sum() > 2000
    # it moved down the screen between frame 0 and the last frame
    assert np.nonzero(sat(b))[0].mean() > np.nonzero(sat(a))[0].mean() + 3
