"""The gsplat renderer registers, and says why it cannot run where torch/gsplat/CUDA are missing."""
import pytest

gasp_render_gsplat = pytest.importorskip("gasp_render_gsplat")


def test_registers_with_reason():
    infos = gasp_render_gsplat.gasp_renderers()
    assert [i.name for i in infos] == ["gsplat"] and infos[0].devices == ("cuda",)
    reason = gasp_render_gsplat.available()
    if reason is not None:
        assert "torch" in reason or "gsplat" in reason or "CUDA" in reason
        from gasp_core.seam import GaspError
        from gasp_core.render.registry import get_renderer
        with pytest.raises(GaspError, match="cannot run"):
            get_renderer("gsplat")
