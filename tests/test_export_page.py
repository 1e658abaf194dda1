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


N_ROWS = 2000


def _same_as_python_decode(run, rows):
    """The page's JavaScript decoder gives the numpy decoder's frames: centres exactly, the shape S to a
    float16 rounding."""
    from gasp_core.render.export import pack_run
    from gasp_core.render.page_codec import decode, sqrt_cov
    meta, data = pack_run(run)
    dec = decode(meta, data, meta["n_frames"])
    levels, lo, hi = 2 ** meta["bits"] - 1, np.array(meta["lo"]), np.array(meta["hi"])
    for k, got in rows.items():
        centre = lo + np.array(got["center"]).reshape(-1, 3) / levels * (hi - lo)
        np.testing.assert_allclose(centre, dec.means[k][:N_ROWS], rtol=0, atol=1e-9)
        S = np.array(got["sqrtcov"], np.uint16).view(np.float16).astype(float).reshape(-1, 6) * meta["size"]
        want = sqrt_cov(dec.quats[k][:N_ROWS], dec.scales[k][:N_ROWS])
        err = np.abs(S - want) / np.abs(want).max(axis=1, keepdims=True)     # float16 keeps 11 bits
        assert err.max() < 2e-3 and np.abs(want).max() > 0, err.max()


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


def test_sqrt_covariances_square_back():
    """The page's shape ``S = R diag(s) R^T`` squares to the renderer's covariance of the same real Gaussians."""
    from pathlib import Path

    from gasp_core.gs.io import read_gaussians
    from gasp_core.render.page_codec import sqrt_cov
    from gasp_core.gs.splat_numpy import splats_from_gaussians
    g = read_gaussians(Path(__file__).parent / "data" / "pc_short.ply")
    covs = splats_from_gaussians(g).covs
    s = sqrt_cov(g.rotations / np.linalg.norm(g.rotations, axis=1, keepdims=True), g.scales)
    S = s[:, [0, 1, 2, 1, 3, 4, 2, 4, 5]].reshape(-1, 3, 3)
    assert np.allclose(S @ S, covs, rtol=0, atol=1e-6 * np.abs(covs).max())
    assert not np.allclose(S, np.eye(3) * S[:, [0], [0]][:, :, None], atol=1e-3 * np.abs(S).max())   # turned


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
        rows = {k: page.evaluate(f"window.gasp.rows({k}, 0, {N_ROWS})") for k in (0, n - 1)}
        seen = _play_all(page, n)                            # the page's own Play button: every frame in turn
        browser.close()
    assert seen == set(range(n))
    _same_as_python_decode(donut_run, rows)
    a, b = _sat(shots[0]), _sat(shots[n - 1])
    assert a.sum() > 2000 and b.sum() > 2000                 # the donut is drawn in both
    assert np.abs(shots[0] - shots[n - 1]).mean() > 0.5      # the two frames differ
    # it fell: the donut's pixels are lower on the screen in the last frame
    assert np.nonzero(b)[0].mean() > np.nonzero(a)[0].mean() + 3


def _two_frame_run(tmp_path, move, n_frames=2):
    """A run folder of the real ``pc_short.ply`` (100 Gaussians): frame 0, then ``move(copy, k)`` for frame k."""
    import json
    from pathlib import Path

    from gasp_core.gs.io import read_gaussians, write_gaussians
    g = read_gaussians(Path(__file__).parent / "data" / "pc_short.ply")
    (tmp_path / "obj").mkdir()
    write_gaussians(tmp_path / "obj" / "frame_0000.ply", g)
    for k in range(1, n_frames):
        h = g.copy()
        move(h, k)
        write_gaussians(tmp_path / "obj" / f"frame_{k:04d}.ply", h)
    (tmp_path / "run.json").write_text(json.dumps({"frame_dt": 0.1, "objects": [
        {"name": "obj", "placement": {"R": np.eye(3).tolist(), "scale": 1.0, "t": [0.0, 0.0, 0.0]}}]}))
    return g, h


def _turn_squeeze_move(h, k):
    """Frame k: the scan turned 11.5 k degrees about y, squeezed and moved."""
    from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
    turn = quat_to_rotmat(np.array([np.cos(0.1 * k), 0.0, np.sin(0.1 * k), 0.0]))
    h.means = h.means @ turn.T + [0.005 * k, 0.0, -0.01 * k]
    h.rotations = rotmat_to_quat(turn @ h.rotmats())
    h.scales = h.scales * [1.0, 1.0 + 0.15 * k, 1.0 - 0.1 * k]


def test_rows_that_never_move_are_stored_once(tmp_path):
    """Frame 1 moves 10 of 100 real Gaussians: the page stores frame 0 whole and 10 rows of frame 1 (18 bytes
    each before gzip), and those 10 rows decode to frame 1's centres within half a quantum."""
    from gasp_core.render.export import pack_run
    from gasp_core.render.page_codec import decode, morton_order

    def move(h, k):
        h.means[20:30] += [0.0, 0.0, 0.05]
    g, h = _two_frame_run(tmp_path, move)
    meta, data = pack_run(tmp_path)
    assert meta["n_moving"] == 10
    assert len(data) == meta["deltas_offset"] + 18 * 10 == 4 * 100 + 4 * 10 + 20 * 100 + 18 * 10
    order = morton_order(g.means)
    rows = np.frombuffer(data, "<u4", 10, meta["moving_offset"])
    assert sorted(order[rows].tolist()) == list(range(20, 30))
    dec = decode(meta, data, 2)
    half_quantum = 0.5 * (np.array(meta["hi"]) - np.array(meta["lo"])) / (2 ** meta["bits"] - 1)
    err = np.abs(dec.means[1] - h.means[order])
    assert (err <= half_quantum + 1e-12).all() and err.max() > 0.01 * half_quantum.min()


def test_compression_error_is_within_its_stated_bounds(tmp_path):
    """A real scan turned, squeezed and moved between two frames: what the page shows differs from the
    frames by at most the codec's stated steps, and by more than nothing (it is lossy, as documented)."""
    from gasp_core.render.export import pack_run
    from gasp_core.render.page_codec import decode
    _two_frame_run(tmp_path, lambda h, k: _turn_squeeze_move(h, 2))
    meta, data = pack_run(tmp_path, errors=True)
    e, bits = meta["errors"], meta["bits"]
    assert 0.05 / 2 ** bits < e["centre"] <= 0.5 / (2 ** bits - 1) + 1e-9
    assert 0.01 < e["rotation_deg"] <= np.degrees(meta["rot_step"]) * 3 ** 0.5 / 2 + 0.06
    assert 1e-4 < e["scale_rel"] <= np.expm1(meta["log_step"] / 2) + 2e-3
    assert 0 < e["shape"] < 0.01
    assert decode(meta, data, 2).means.shape == (2, 100, 3)


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium found (apt-get install -y chromium)")
def test_small_page_plays_every_frame_as_numpy_decodes_it(tmp_path):
    """Five frames of a real scan turning and squeezing: the page, opened from disk in Chromium, plays every
    frame, and its JavaScript decoder gives what :func:`page_codec.decode` gives (centres exactly, shapes
    to a float16 rounding), in the first and the last frame."""
    from gasp_core.render.export import export_page
    run = tmp_path / "run"
    run.mkdir()
    _two_frame_run(run, _turn_squeeze_move, n_frames=5)
    page_path = export_page(run, tmp_path / "small.html")
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page(viewport={"width": 400, "height": 300})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(page_path.as_uri())
        page.wait_for_function("window.gasp && window.gasp.ready || window.gaspError", timeout=60_000)
        assert page.evaluate("window.gaspError || ''") == "" and not errors
        rows = {k: page.evaluate(f"window.gasp.rows({k}, 0, 100)") for k in (0, 4)}
        seen = _play_all(page, 5)
        browser.close()
    assert seen == set(range(5))
    _same_as_python_decode(run, rows)


def _play_all(page, n):
    """From frame 0, paused, press the page's Play button; the frames it shows within a few minutes."""
    page.evaluate("window.gasp.show(0)")
    page.click("#play")
    seen = set()
    for _ in range(10000):
        seen.add(page.evaluate("window.gasp.frame()"))
        if len(seen) == n:
            break
        time.sleep(0.02)
    return seen


def test_donut_page_is_small(donut_run, tmp_path):
    """The 15-frame donut run (45,624 Gaussians, a coarse grid: it keeps bouncing) fits in under 3.5 MB
    (the frames stored whole took 16 MB), and the codec's errors stay small in scene units."""
    from gasp_core.render.export import export_page, pack_run
    page = export_page(donut_run, tmp_path / "donut.html")
    assert 1.0e6 < page.stat().st_size < 3.5e6, page.stat().st_size
    meta, _ = pack_run(donut_run, errors=True)
    assert meta["n_frames"] == 15 and meta["n"] == 45624
    e = meta["errors"]
    assert e["centre"] < 5e-4 and e["shape"] < 3e-3 and e["rotation_deg"] < 0.8 and e["scale_rel"] < 0.012
