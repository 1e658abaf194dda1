"""Issue 68: a scene that leaves out ``up_axis`` laid the guitar on its side without a word, though ``gasp info``
guesses -y at 0.966. Now an object whose scene states neither ``up_axis`` nor ``up`` takes the guess where it is
sure (what ``gasp info`` calls a guess, not unsure: confidence >= UP_SURE), said in one line naming the object,
the axis and the key that pins it; where the guess is unsure it keeps ``+z`` as before and says so."""
import warnings

import numpy as np
import pytest

from gasp_core.gs.io import read_gaussians
from gasp_core.gs.up_axis import UP_SURE, guess_up
from gasp_core.prepare.placed import UP_ROTATIONS
from gasp_core.prepare.placement import prepare_object
from gasp_core.prepare.up import resolve_up_axis
from gasp_core.scene.spec import load_scene
from gasp_testing import DONUT, GUITAR, ROOT

SLAB = ROOT / "examples" / "data" / "guitar_slab.ply"    # a slab of the guitar: gasp info is unsure on it


def _spec(tmp_path, ply, up_line=""):
    (tmp_path / "s.toml").write_text(f"""
frame_dt = 0.0333333
n_frames = 2
engine = "taichi_mpm"
[[boundary]]
kind = "ground"
[[object]]
file = "{ply}"
{up_line}
position = [0.0, 0.0, 0.05]
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
""")
    return load_scene(tmp_path / "s.toml").objects[0]


def _up_lines(caught):
    return [str(w.message) for w in caught if "up_axis" in str(w.message)]


def test_the_guitar_without_up_axis_stands_as_gasp_info_guesses(tmp_path):
    spec = _spec(tmp_path, GUITAR)
    assert not spec.up_axis_stated
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        o = prepare_object(spec)
    assert o.spec.up_axis == "-y" and np.array_equal(o.placement.R, UP_ROTATIONS["-y"])   # standing, not on its side
    lines = _up_lines(caught)
    assert len(lines) == 1 and "\n" not in lines[0], lines
    assert "'guitar.compressed'" in lines[0] and "-y" in lines[0] and 'up_axis = "-y"' in lines[0], lines
    assert "0.97" in lines[0]          # the confidence gasp info gives (0.966)


def test_the_donut_without_up_axis_takes_its_sure_guess(tmp_path):
    g = read_gaussians(DONUT)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        spec = resolve_up_axis(_spec(tmp_path, DONUT), g)
    assert spec.up_axis == "+z" and spec.up_axis_stated
    lines = _up_lines(caught)
    assert len(lines) == 1 and "'donut_v3dg'" in lines[0] and "guessed up axis +z" in lines[0], lines


def test_an_unsure_guess_keeps_plus_z_and_says_so(tmp_path):
    g = read_gaussians(SLAB)
    u = guess_up(g)
    assert u.up == "unknown" and u.confidence < UP_SURE            # the premise: gasp info is unsure here
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        spec = resolve_up_axis(_spec(tmp_path, SLAB), g)
    assert spec.up_axis == "+z"                                    # today's behaviour
    lines = _up_lines(caught)
    assert len(lines) == 1 and "'guitar_slab'" in lines[0] and "unsure" in lines[0] and "+z" in lines[0], lines


@pytest.mark.parametrize("up_line", ['up_axis = "+z"', 'up = [0.0, 0.0, 1.0]'])
def test_a_stated_up_is_kept_without_a_word(tmp_path, up_line):
    spec = _spec(tmp_path, GUITAR, up_line)
    assert spec.up_axis_stated
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert resolve_up_axis(spec, read_gaussians(GUITAR)) is spec
    assert not _up_lines(caught)


def test_up_axis_stated_is_not_a_scene_key(tmp_path):
    from gasp_core.errors import SceneError
    with pytest.raises(SceneError, match="up_axis_stated"):
        _spec(tmp_path, DONUT, "up_axis_stated = true")
