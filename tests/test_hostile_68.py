"""Issue 68: the hostile corpus's new cases that main got wrong, each as the user met it.

Engine options checked before the substep estimate uses them, brittle values beyond the working precision,
``gasp studio`` on the ``engine = "..."`` shorthand, a selection that holds every row, the studio's moving-piece
search on coincident Gaussians, corrupt or missing pieces sidecars, an unwritable Warp kernel cache, ``gasp info``
on a NaN camera, and the new user's ``--overwrite`` and dynamic-model findings. Every case takes seconds.
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package, scene_text

from gasp_core.cli.main import main
from gasp_core.errors import SceneError

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "examples" / "data"


def one_error(err: str, code: int, expected: int = 2) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert code == expected and len(lines) == 1 and lines[0].startswith("gasp: error:"), (code, err)
    assert "Traceback" not in err
    return lines[0]


# ------------------------------------------------ 1. engine options checked before the substep estimate


@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@pytest.mark.parametrize("option, expected", [
    ("cfl = 0", "option cfl=0"), ("dt = 0.0", "option dt=0.0"), ("n_substeps = 0", "option n_substeps=0"),
    ('max_substeps = "100"', "option max_substeps='100'"),
    ("dt = 1e-320", "exceeds max_substeps"), ("cfl = 1e-320", "exceeds max_substeps")])
def test_an_engine_option_out_of_range_is_one_line_naming_it(tmp_path, donut_small, capsys, engine, option,
                                                              expected):
    needs_package(f"gasp_{engine}")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=engine,
                                engine_options=f"{{ {option} }}"))
    code = main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert expected in line and f"engine '{engine}'" in line
    assert not (tmp_path / "out").exists()


# ------------------------------------------- 2. brittle values beyond the working precision, and a huge up


def brittle_scene(tmp_path, donut_small, engine, tensile_strength, precision=None) -> Path:
    opts = "{ threads = 1 }" if precision is None else f'{{ threads = 1, precision = "{precision}" }}'
    scene = tmp_path / "b.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine=engine, engine_options=opts,
                                material=f'name = "brittle"\nE = 2.0e5\nnu = 0.25\nrho = 300.0\n'
                                         f'tensile_strength = {tensile_strength}\nfracture_energy = 5.0'))
    return scene


@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@pytest.mark.parametrize("ts, precision, said", [
    ("1e-300", None, 'precision = "f64" does not hold it either'),
    ("1e-30", None, 'or precision = "f64"'),
    ("1e-300", "f64", "beyond precision 'f64'")])
def test_a_tensile_strength_whose_softening_stress_leaves_the_precision_is_refused(tmp_path, donut_small, capsys,
                                                                                   engine, ts, precision, said):
    """The corpus's ``tensile_strength = 1e-300``: ``s_f = 2 E G_f / (f_t h)`` was inf in the float32 table, the
    damage NaN, and the biscuit never broke, with one numpy warning."""
    needs_package(f"gasp_{engine}")
    code = main(["simulate", str(brittle_scene(tmp_path, donut_small, engine, ts, precision)), "-o",
                 str(tmp_path / "out"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert f"tensile_strength = {float(ts):g} Pa" in line and "softening stress" in line and said in line
    assert not (tmp_path / "out").exists()


def test_a_tensile_strength_whose_snap_back_limit_overflows_float64_is_one_line(tmp_path, donut_small, capsys):
    needs_package("gasp_taichi_mpm")
    code = main(["simulate", str(brittle_scene(tmp_path, donut_small, "taichi_mpm", "1e200")), "-o",
                 str(tmp_path / "out"), "-q"])
    line = one_error(capsys.readouterr().err, code)
    assert "tensile_strength = 1e+200 Pa" in line and "snap-back limit" in line and "overflows float64" in line


def test_an_up_of_1e308_has_the_direction_it_states():
    """``up = [1e308, 1e308, 0]``: its norm overflows, its direction is x + y."""
    from gasp_core.gs.support import rotation_to_z
    for big in ([1e308, 1e308, 0.0], [1e-320, 1e-320, 0.0]):
        R = rotation_to_z(big)
        assert np.allclose(R, rotation_to_z([1.0, 1.0, 0.0])) and np.allclose(R @ np.array([1, 1, 0]) / np.sqrt(2),
                                                                              [0, 0, 1])
    with pytest.raises(ValueError, match="no direction"):
        rotation_to_z([0.0, 0.0, 0.0])


def test_an_up_of_1e308_places_the_object(tmp_path, donut_small):
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    needs_package("gasp_taichi_mpm")
    scene = tmp_path / "u.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16).replace('up_axis = "+z"',
                                                                             "up = [1e308, 1e308, 0]"))
    prep = prepare_scene(load_scene(scene))
    assert np.all(np.isfinite(prep.setup.x))


# ---------------------------------------------------------- 3. gasp studio on the engine = "NAME" shorthand


@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_studio_opens_a_scene_that_names_its_engine_in_shorthand(tmp_path, donut_small, engine):
    """``engine = "warp_mpm"`` at the top level, which ``gasp simulate`` accepts: the studio raised AttributeError
    (``'str' object has no attribute 'get'``) in its form."""
    needs_package("viser")
    needs_package("tomli_w")
    needs_package(f"gasp_{engine}")
    from gasp_core.studio.app import Studio
    from gasp_core.studio.warm import choice_key
    scene = tmp_path / "s.toml"
    scene.write_text(f'engine = "{engine}"\n' + scene_text(donut_small, n_frames=2, n_grid=16).replace(
        '[engine]\nname = "taichi_mpm"\noptions = { threads = 1 }\n', ""))
    st = Studio(scene, tmp_path / "studio", port=0, warm=False)
    try:
        assert st.form.engine.value == engine
        doc = st.form.document()
        assert doc["engine"]["name"] == engine and choice_key(doc)[0] == engine
        st.scene.check(doc)
    finally:
        st.stop()


# ------------------------------------------------------- 4. a selection that holds every row: the whole object


@pytest.mark.parametrize("select", ["box", "indices"])
def test_a_selection_of_every_row_runs_as_the_whole_object(tmp_path, donut_small, select):
    """The studio's click on the donut, whose connected piece is the whole donut, then Run: ``gasp: error: the rest
    of [[object]] #1 ... a collider can only be made from a static object``, a collider the scene never states."""
    needs_package("gasp_taichi_mpm")
    from gasp_core.gs.io import read_gaussians
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    n = read_gaussians(donut_small).n
    sel = ("select = { box = { lo = [-1e3, -1e3, -1e3], hi = [1e3, 1e3, 1e3] } }" if select == "box"
           else f"select = {{ indices = {list(range(n))} }}")
    scene = tmp_path / "w.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, extra_object=sel))
    with pytest.warns(UserWarning, match=f"its selection holds all {n:,} Gaussians: it runs as the whole object"):
        prep = prepare_scene(load_scene(scene))
    assert not prep.scene.colliders and prep.objects[0].moving is None
    assert int((prep.setup.body_id[:prep.setup.n_render] == 0).sum()) >= n


def test_a_selection_of_all_but_one_row_keeps_its_rest_collider(tmp_path, donut_small):
    """The other side: a selection that leaves one row out still collides with its rest."""
    needs_package("gasp_taichi_mpm")
    from gasp_core.gs.io import read_gaussians
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    import warnings
    n = read_gaussians(donut_small).n
    scene = tmp_path / "w.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16,
                                extra_object=f"select = {{ indices = {list(range(1, n))} }}"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(load_scene(scene))
    assert [c.by_default for c in prep.scene.colliders] == [True] and len(prep.objects[0].moving) == n - 1
