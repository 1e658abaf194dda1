"""Each value of a scene is checked by one rule, in one place (issue 16, "One place per value")."""
import re

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.scene.spec import load_scene
from gasp_core.seam.schema import MATERIAL_KINDS, MATERIAL_PARAMS
from gasp_core.seam.setup import Material, SimSetup, grid_spacing
from gasp_testing import scene_text


def _setup(material: Material) -> SimSetup:
    x = np.random.default_rng(0).uniform(0.4, 0.6, (20, 3))
    return SimSetup(x=x, v=0.0, p_vol=1e-6, body_id=0, materials=[material], gravity=(0, 0, -9.81),
                    domain_lo=(0, 0, 0), domain_hi=(1, 1, 1), n_grid=16)


def _expected(message: str) -> str:
    return re.search(r"expected .*", message).group(0)


@pytest.mark.parametrize("key, value", [("nu", -1.0), ("nu", 0.5), ("E", 0.0), ("rho", -3.0),
                                        ("yield_stress", 0.0), ("friction_angle", 90.0), ("theta_c", 0.0)])
def test_a_material_value_is_refused_with_the_same_words_by_the_scene_and_by_simsetup(
        donut_small, write_scene, key, value):
    name = next(m for m, kind in MATERIAL_KINDS.items() if key in kind.keys)   # a material that uses the key
    table = {"name": f'"{name}"', "E": 2.0e4, "nu": 0.3, "rho": 300.0, key: value}
    material = "\n".join(f"{k} = {v}" for k, v in table.items())
    with pytest.raises(SceneError) as from_scene:
        load_scene(write_scene(scene_text(donut_small, material=material)))
    with pytest.raises(SceneError) as from_setup:
        _setup(Material(name, **{key: value}))
    assert f".{key} = " in str(from_scene.value) and f".{key} = " in str(from_setup.value)
    assert _expected(str(from_scene.value)) == _expected(str(from_setup.value))


def test_an_auxetic_material_is_accepted_by_the_scene_and_by_simsetup(donut_small, write_scene):
    """-1 < nu < 0.5 everywhere (an engine with a narrower range declares its own limit)."""
    material = 'name = "jelly"\nE = 2.0e4\nnu = -0.5\nrho = 300.0'
    scene = load_scene(write_scene(scene_text(donut_small, material=material)))
    assert scene.objects[0].material.nu == -0.5
    _setup(Material("jelly", nu=-0.5))
    assert set(MATERIAL_PARAMS) == {"E", "nu", "rho", "yield_stress", "friction_angle", "grain_diameter",
                                    "friction_angle_2", "softening", "hardening", "theta_c", "theta_s", "viscosity",
                                    "tensile_strength", "fracture_energy"}


def test_the_moduli_and_dx_have_one_formula():
    m = Material("liquid", E=1e4, nu=0.45)
    assert m.K == pytest.approx(1e4 / (3 * 0.1))
    assert m.mu == pytest.approx(1e4 / 2.9) and m.lam == pytest.approx(1e4 * 0.45 / (1.45 * 0.1))
    s = _setup(Material())
    assert s.dx == grid_spacing(s.domain_lo, s.domain_hi, s.n_grid) == 1 / 16


def test_what_a_scene_needs_is_one_rule_on_the_scene_and_on_its_setup(tmp_path, donut_small):
    """A static object turned into a collider, a moving mesh-free scene: the early check and build_engine agree."""
    from gasp_core.prepare.assembly import build_setup
    from gasp_core.prepare.placement import prepare_object
    from gasp_core.prepare.scene import scene_needs
    from gasp_core.scene.spec import parse_scene
    from gasp_core.seam.build import setup_needs
    static = {"file": str(donut_small), "static": True, "recentre": False}
    moving = {"file": str(donut_small), "position": [0.0, 0.0, 0.5], "fill": False, "material": {"viscosity": 2.0}}
    data = {"object": [static, moving], "collider": [{"object": 1}], "domain": {"n_grid": 16},
            "boundary": [{"kind": "ground", "height": -0.2}],
            "force": [{"kind": "wind", "direction": [1.0, 0.0, 0.0], "speed": 1.0}],
            "impulse": [{"shape": "sphere", "centre": [0.0, 0.0, 0.5], "radius": 0.1,
                         "velocity_change": [0.0, 0.0, 1.0], "t0": 0.0, "t1": 0.1}]}
    scene = parse_scene(data, tmp_path / "s.toml")
    setup, _ = build_setup(scene, [prepare_object(o) for o in scene.objects])
    assert scene_needs(scene) == setup_needs(setup) == {
        "materials": ["jelly"], "boundaries": ["ground"], "features": ["viscosity", "static_colliders", "wind", "impulse"]}


def test_options_are_checked_by_the_core_alone_and_the_engine_reads_them_completed():
    """build_engine checks the declared Options (excludes included) and hands the factory every option."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.engine import Capabilities, EngineInfo
    from gasp_core.mpm.options import mpm_options
    seen = {}

    def factory(setup):
        seen.update(setup.options)
        return object()
    info = EngineInfo("e", factory, Capabilities(frozenset({"jelly"}), frozenset()), options=mpm_options())
    s = _setup(Material())
    s.options = {"dt": 1e-4, "n_substeps": 3}
    with pytest.raises(SceneError, match="engine 'e': give option dt or option n_substeps, not both"):
        build_engine(info, s)
    assert not seen  # refused before the factory
    s.options = {"n_substeps": 3}
    build_engine(info, s)
    assert seen == {"device": "cpu", "precision": "f32", "dt": None, "n_substeps": 3, "cfl": 0.4,
                    "cfl_rule": "sum", "max_substeps": 20000}


def test_a_selected_object_is_flattened_once(tmp_path, donut_small, monkeypatch):
    """prepare_object flattens the whole file once; the selection takes its rows, bit for bit those of
    flattening the selected rows alone."""
    from gasp_core.maps import games
    from gasp_core.prepare import selection
    from gasp_core.prepare.placement import prepare_object
    from gasp_core.scene.spec import parse_scene
    spec = parse_scene({"object": [{"file": str(donut_small), "rotation": [13.0, -7.0, 31.0],
                                    "select": {"box": {"lo": [-1.0, -1.0, -1.0], "hi": [0.0, 1.0, 1.0]}}}]},
                       tmp_path / "s.toml").objects[0]
    calls = []
    real = games.flatten
    monkeypatch.setattr(selection, "flatten", lambda *a, **k: calls.append(len(a[0])) or real(*a, **k))
    o = prepare_object(spec)
    assert calls == [o.gaussians.n]  # one flatten, of the whole file
    alone = selection.flat_world(o.gaussians.subset(o.moving), o.placement)
    np.testing.assert_array_equal(o.tri_rest, alone[3])
    np.testing.assert_array_equal(o.rot_rest, alone[1])
    assert o.flatten_report == alone[4] and o.flatten_report.n == len(o.moving) < o.gaussians.n
