"""Round 99's hostile inputs: a frame of 1e-300 s or 1e300 s reached the engines' step arithmetic and overflowed
(warp_mpm's ``(RIGID_OMEGA_DT / dt)^2`` at build, the core's sleep watch's ``frame_dt^2``), reported as a bug with a
traceback (exit 4 and 1). ``frame_dt`` is now read within ``gasp_core.seam.setup.FRAME_DT_RANGE`` (a nanosecond to
an hour), in the scene and in ``SimSetup``. Each case takes a second."""
from __future__ import annotations

import numpy as np
import pytest
from gasp_testing import needs_package, scene_text

import gasp_core.scene.spec as spec
from gasp_core.cli.main import main
from gasp_core.errors import SceneError
from gasp_core.seam.setup import FRAME_DT_RANGE, Material
from gasp_core.testing.helpers import box_points, make_setup


def frame_scene(tmp_path, donut_small, frame_dt: str):
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm")
                     .replace("frame_dt = 0.0333333", f"frame_dt = {frame_dt}"))
    return scene


@pytest.mark.parametrize("frame_dt", ["1e-300", "1e300", "0", "-0.03", "nan", "1e-10", "3601"])
def test_a_frame_dt_out_of_range_is_one_line_naming_it(tmp_path, donut_small, capsys, frame_dt):
    code = main(["simulate", str(frame_scene(tmp_path, donut_small, frame_dt)), "-o", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, (code, err)
    assert lines[0].startswith("gasp: error:") and "s.toml: frame_dt = " in lines[0] and "[1e-09, 3600]" in lines[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("frame_dt", [1e-300, 1e300, 0.0, float("nan"), float("inf")])
def test_a_setup_frame_dt_out_of_range_is_refused(frame_dt):
    x, pv = box_points([0.4, 0.4, 0.4], [0.5, 0.5, 0.5], 0.02)
    with pytest.raises(SceneError, match=r"SimSetup.frame_dt = .*\[1e-09, 3600\]"):
        make_setup(x, pv, Material("jelly", E=1e4, nu=0.3, rho=300.0), n_grid=16, frame_dt=frame_dt)


def test_the_range_holds_the_frames_a_scene_uses():
    """Both ends of the range are taken, and the bundled scenes' frames (1/30 s) lie inside it."""
    x, pv = box_points([0.4, 0.4, 0.4], [0.5, 0.5, 0.5], 0.02)
    for dt in (FRAME_DT_RANGE[0], 1.0 / 30.0, FRAME_DT_RANGE[1]):
        assert make_setup(x, pv, Material("jelly", E=1e4, nu=0.3, rho=300.0), n_grid=16, frame_dt=dt).frame_dt == dt


def test_the_check_catches_the_open_range_before(tmp_path, donut_small, capsys, monkeypatch):
    """With the scene's range as it was (any positive number) a frame of 1e-300 s reaches warp_mpm's build and ends
    as an engine bug (exit 4), the failure the check above exists for."""
    needs_package("gasp_warp_mpm")
    import gasp_core.seam.setup as setup
    monkeypatch.setattr(spec, "FRAME_DT_RANGE", (np.nextafter(0.0, 1.0), np.inf))
    monkeypatch.setattr(setup, "FRAME_DT_RANGE", (np.nextafter(0.0, 1.0), np.inf))
    code = main(["simulate", str(frame_scene(tmp_path, donut_small, "1e-300")), "-o", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    assert code == 4 and "OverflowError" in err
