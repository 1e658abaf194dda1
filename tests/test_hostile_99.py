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


# ---------------------------------------- a second ground, and a snow whose stiffening leaves exp's range


def test_a_second_ground_or_walls_is_one_line_naming_both(tmp_path, donut_small, capsys):
    """Two grounds at 0 and 0.5 m ran: the start check read the lower, the engines held every point above the higher
    (the donut, 5 cm up, started 0.45 m inside it) and said nothing."""
    for extra, kind in (('[[boundary]]\nkind = "ground"\nheight = 0.5\n', "ground"),
                        ('[[boundary]]\nkind = "walls"\n[[boundary]]\nkind = "walls"\nfriction = 0.1\n', "walls")):
        scene = tmp_path / f"{kind}.toml"
        scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm").replace(
            "[[object]]", extra + "[[object]]", 1))
        code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
        err = capsys.readouterr().err
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert code == 2 and len(lines) == 1, (code, err)
        assert f'#1 and #2 are both kind = "{kind}"' in lines[0] or f'#2 and #3 are both kind = "{kind}"' in lines[0]
        assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("material, said", [
    ('name = "snow"\ntheta_c = 2.0', "theta_c = 2.0 (float); expected a finite number in (0, 1)"),
    ('name = "snow"\nhardening = 1e5', "exp(2.5e+03) overflows; expected hardening x theta_c <= 40")])
def test_a_snow_outside_its_model_is_one_line_naming_the_file(tmp_path, donut_small, capsys, material, said):
    """``theta_c`` 2 clamped the singular values at -1 and was reported as 2.4e5 substeps a frame ("lower E"); a
    hardening of 1e5 overflowed ``exp(hardening theta_c)`` in the step's wave speed (an engine bug, exit 4)."""
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, material=material))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == 2 and len(lines) == 1 and str(scene) in lines[0] and said in lines[0], (code, err)


def test_the_snow_check_catches_the_unbounded_stiffening_before(monkeypatch):
    """With the bound taken off, the same snow reaches the wave speed's ``exp`` and overflows there."""
    import gasp_core.seam.setup as setup
    monkeypatch.setattr(setup, "MAX_STIFFENING", float("inf"))
    m = Material("snow", hardening=1e5)
    m.check()
    with pytest.raises(OverflowError):
        m.p_wave_speed


def test_the_ground_check_catches_the_reader_before(tmp_path, donut_small, capsys, monkeypatch):
    """With every [[boundary]] read as before (no count of grounds), the two-ground scene runs to its end (exit 0)
    with the donut inside the upper ground: the silent wrong answer the check above refuses."""
    from gasp_core.scene.tables import read_boundary
    from gasp_core.scene.values import as_tables
    monkeypatch.setattr(spec, "read_boundaries", lambda data, src: [
        read_boundary(b, f"[[boundary]] #{i + 1}", src) for i, b in enumerate(as_tables(data.get("boundary", []),
                                                                                       "boundary", src))])
    scene = tmp_path / "g.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm").replace(
        "[[object]]", '[[boundary]]\nkind = "ground"\nheight = 0.5\n[[object]]', 1))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 0


def test_a_brittle_substance_below_its_snap_back_names_the_file_and_object(tmp_path, donut_small, capsys):
    """The table's porcelain with the user's own E of 1e5 Pa takes the crack band, whose snap-back limit its G_f of
    20.6 J/m^2 is far below: the one line names the scene and the object (it named ``SimSetup.materials[0]``)."""
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm",
                                material='name = "brittle"\nsubstance = "porcelain"\nE = 1e5'))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("gasp: warning:")]
    assert code == 2 and len(lines) == 1, (code, err)
    assert f"{scene}: object 'donut_small': material.fracture_energy = 20.6" in lines[0] and "snap-back" in lines[0]
