"""Rendered strips of frames in the ``gasp compare`` and ``gasp bench`` reports, on a tiny cut of the real donut."""
import importlib.util

import numpy as np
import pytest

pytest.importorskip("distributed", reason="the studies extra is not installed (pip install -e '.[studies]')")

from gasp_testing import DONUT, scene_text  # noqa: E402
from gasp_core.errors import SceneError  # noqa: E402
from gasp_core.gs.io import read_gaussians, write_gaussians  # noqa: E402
from gasp_core.seam.plugins import engines  # noqa: E402
from gasp_core.gs.splat_numpy import splats_from_gaussians  # noqa: E402
from gasp_studies import strips  # noqa: E402
from gasp_studies.bench import bench_scene  # noqa: E402
from gasp_studies.compare import compare_scene  # noqa: E402

INSTALLED = engines()
needs_warp = pytest.mark.skipif("warp_mpm" not in INSTALLED, reason="warp_mpm not installed")
needs_flex = pytest.mark.skipif("mujoco_flex" not in INSTALLED, reason="mujoco_flex not installed")
needs_numba = pytest.mark.skipif(importlib.util.find_spec("numba") is None or importlib.util.find_spec("imageio") is None,
                                 reason="the render extra (numba, imageio) is not installed")
W, H = strips.STRIP_CELL
LABEL_ROWS = 40   # the label boxes (up to three 12 px lines) lie above this row of each frame


@pytest.fixture(scope="module")
def donut_tiny(tmp_path_factory):
    """Every 32nd Gaussian of the real donut (1,426 Gaussians)."""
    g = read_gaussians(DONUT)
    path = tmp_path_factory.mktemp("tiny") / "donut_tiny.ply"
    write_gaussians(path, g.subset(np.arange(0, g.n, 32)))
    return path


def _object_mask(tile):
    """Pixels of the donut (pink, blue and tan): the background is grey by construction (sky, floor and
    grid colours in :func:`gasp_core.gs.camera.ground_background` spread at most 0.03 = 8/255 between
    channels), so a channel spread above 40/255 is the object."""
    return (tile.max(axis=2).astype(int) - tile.min(axis=2).astype(int)) > 40


def test_strip_frames_are_evenly_spaced_with_first_and_last():
    assert strips.strip_frames(10) == (0, 2, 4, 6, 8, 10)
    assert strips.strip_frames(15) == (0, 3, 6, 9, 12, 15)
    assert strips.strip_frames(3) == (0, 1, 2, 3)          # fewer frames than asked: every frame once
    assert strips.strip_frames(36, 2) == (0, 36)
    assert strips.strip_frames(36, 0) == ()
    with pytest.raises(SceneError, match="--strip-frames"):
        strips.strip_frames(10, -1)


@needs_warp
@needs_flex
@needs_numba
def test_compare_report_embeds_a_comparable_strip_per_engine(donut_tiny, write_scene, tmp_path):
    import imageio.v3 as iio
    # the donut's bottom starts 5 cm above the ground: it lands after sqrt(2 h / g) = 0.10 s = frame 3
    scene = write_scene(scene_text(donut_tiny, n_frames=3, n_grid=16, engine="warp_mpm", engine_options="{}"))
    out = tmp_path / "cmp"
    compare_scene(scene, ["warp_mpm", "mujoco_flex"], out, progress=False)
    text = (out / "report.md").read_text()
    frames = strips.strip_frames(3)
    assert frames == (0, 1, 2, 3)
    imgs = {}
    for name in ("warp_mpm", "mujoco_flex"):
        assert f"![{name}](strip_{name}.png)" in text
        img = iio.imread(out / f"strip_{name}.png")
        assert img.shape == (H, W * len(frames), 3) and img.dtype == np.uint8
        tiles = [img[LABEL_ROWS:, j * W:(j + 1) * W] for j in range(len(frames))]
        masks = [_object_mask(t) for t in tiles]
        # the camera frames the object's bounding sphere (margin 1.1): the donut (0.31 m across, a third as
        # tall) covers roughly 40 % x 30 % of a frame, ~8 % of its pixels once its oval outline is counted;
        # at least a quarter of that must be strongly coloured (the white icing is not counted)
        assert all(m.mean() > 0.02 for m in masks), [m.mean() for m in masks]
        rows = [np.nonzero(m)[0].mean() for m in masks]
        # it falls: 4.9 cm by frame 3, about a sixth of its 0.31 m width, i.e. ~15 px on a ~100 px wide donut
        # seen 25 degrees from above; a quarter of that must show
        assert rows[-1] - rows[0] > 4.0, rows
        imgs[name] = tiles
    # one camera for every engine: frame 0 is the input for both, so the pictures are the same pixels
    assert np.array_equal(imgs["warp_mpm"][0], imgs["mujoco_flex"][0])
    assert "frames 0 (0 s), 1 (0.0333 s), 2 (0.0667 s), 3 (0.1 s)" in text
    assert "skipped" not in text
    assert sorted(p.name for p in out.glob("*.png")) == ["divergence.png", "strip_mujoco_flex.png",
                                                          "strip_warp_mpm.png", "timing.png"]


@needs_flex
def test_compare_without_numba_keeps_the_report_and_says_why(donut_tiny, write_scene, tmp_path, monkeypatch):
    real = importlib.util.find_spec
    # as if the render extra were not installed (in this process, which renders; the runs' workers are not asked)
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "numba" else real(name, *a))
    scene = write_scene(scene_text(donut_tiny, n_frames=2, n_grid=16, engine="mujoco_flex", engine_options="{}"))
    out = tmp_path / "cmp"
    res = compare_scene(scene, ["mujoco_flex"], out, progress=False)
    assert [o.record["status"] for o in res.outputs] == ["ok"]
    text = (out / "report.md").read_text()
    assert "Strips of rendered frames skipped" in text and "numba is not installed" in text
    assert "python -m pip install -e" in text and '[render]"' in text
    assert not list(out.glob("strip_*.png"))
    assert (out / "table.csv").stat().st_size > 0


@needs_numba
def test_a_renderer_failing_midway_leaves_no_strip_and_a_reason(tmp_path, monkeypatch):
    import gasp_core.render.registry as render
    g = read_gaussians(DONUT)
    s = splats_from_gaussians(g.subset(np.arange(0, g.n, 64)))
    calls = []

    def broken(splats, camera, background):
        calls.append(1)
        if len(calls) > 2:
            raise RuntimeError("out of tiles")
        return np.zeros((camera.height, camera.width, 3), np.float32), np.zeros((camera.height, camera.width))

    monkeypatch.setattr(render, "get_renderer", lambda name=None, **kw: broken)
    groups = {"a": [strips.StripRow("a", {0: s, 1: s})], "b": [strips.StripRow("b", {0: s, 1: s})]}
    res = strips.render_strips(tmp_path, groups, (0, 1), 0.1, 0.0)
    assert res.files == {} and res.skipped == "RuntimeError: out of tiles"
    assert not list(tmp_path.iterdir())
    md = "\n".join(strips.strips_markdown(res, 0.1))
    assert "skipped: RuntimeError: out of tiles" in md and "![" not in md


@needs_numba
def test_a_frame_a_run_did_not_reach_is_bare_background(tmp_path):
    import imageio.v3 as iio
    g = read_gaussians(DONUT)
    s = splats_from_gaussians(g.subset(np.arange(0, g.n, 16)))
    res = strips.render_strips(tmp_path, {"x": [strips.StripRow("x", {0: s})]}, (0, 5), 0.1, float(s.means[:, 2].min()),
                               size=(128, 96))
    assert res.skipped is None and res.files == {"x": "strip_x.png"}
    img = iio.imread(tmp_path / "strip_x.png")
    assert img.shape == (96, 256, 3)
    assert _object_mask(img[LABEL_ROWS:, :128]).mean() > 0.02
    assert not _object_mask(img[LABEL_ROWS:, 128:]).any()          # frame 5: never reached, no object


@needs_flex
@needs_numba
def test_bench_summary_embeds_reference_and_cheapest_settings(donut_tiny, write_scene, tmp_path):
    import imageio.v3 as iio
    scene = write_scene(scene_text(donut_tiny, n_frames=2, n_grid=16, engine="mujoco_flex", engine_options="{}"))
    out = tmp_path / "bench"
    sweep = [{"cells_across": 8, "cfl": 0.25}, {"cells_across": 4, "cfl": 0.5}]
    res = bench_scene(scene, out, engines=["mujoco_flex"], n_frames=2, progress=False,
                      settings={"mujoco_flex": sweep})
    summ = res.summary["mujoco_flex"]
    shown = 1 + len({id(c) for c in (summ["within_1pct"], summ["within_5pct"]) if c is not None})
    img = iio.imread(out / "strip_mujoco_flex.png")
    assert img.shape == (H * shown, W * 3, 3)                       # frames 0, 1, 2
    text = (out / "summary.md").read_text()
    assert "![mujoco_flex](strip_mujoco_flex.png)" in text
    assert "reference `cells_across8 cfl0.25`" in text
    assert all(_object_mask(img[r * H + LABEL_ROWS:(r + 1) * H, :W]).mean() > 0.02 for r in range(shown))
