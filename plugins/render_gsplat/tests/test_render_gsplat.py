"""The gsplat renderer registers, and says why it cannot run where torch/gsplat/CUDA are missing."""
import pytest

gasp_render_gsplat = pytest.importorskip("gasp_render_gsplat")


def test_registers_with_reason():
    infos = gasp_render_gsplat.gasp_renderers()
    assert [i.name for i in infos] == ["gsplat"] and infos[0].devices == ("cuda",)
    reason = gasp_render_gsplat.available()
    if reason is not None:
        assert "torch" in reason or "gsplat" in reason or "CUDA" in reason
        from gasp_core.errors import GaspError
        from gasp_core.render.registry import get_renderer
        with pytest.raises(GaspError, match="cannot run"):
            get_renderer("gsplat")


def test_gsplat_matches_the_cpu_renderer_and_the_kept_reference():
    """Where gsplat runs (CUDA): the same camera and splats (real SH-3 data) give the CPU renderer's picture."""
    reason = gasp_render_gsplat.available()
    if reason is not None:
        pytest.skip(f"gsplat cannot run here: {reason}")
    from pathlib import Path

    import imageio.v3 as iio
    import numpy as np
    from gasp_core.gs.io import read_gaussians
    from gasp_core.gs.camera import Camera
    from gasp_core.render.registry import get_renderer
    from gasp_core.render.run import to_uint8
    from gasp_core.gs.splat_numpy import splats_from_gaussians
    data = Path(__file__).resolve().parents[3] / "tests" / "data"
    g = read_gaussians(data / "pc_short.ply")
    c = 0.5 * (g.means.min(0) + g.means.max(0))
    cam = Camera(c + np.array([0.3, -2.2, 0.4]), c, 40.0, 128, 96)     # as tests/test_render_sh.py
    s = splats_from_gaussians(g).seen_from(cam.position)
    bg = np.array([0.2, 0.2, 0.2])
    gpu = to_uint8(get_renderer("gsplat")(s, cam, bg)[0]).astype(int)
    cpu = to_uint8(get_renderer("numpy")(s, cam, bg)[0]).astype(int)
    ref = iio.imread(data / "render_reference_pc_short.png")[..., :3].astype(int)
    for other in (cpu, ref):
        assert np.abs(gpu - other).mean() < 0.5 and np.abs(gpu - other).max() <= 16
