"""The material key ``friction`` (issue 67 item 4: a pair's friction from its two bodies'; docs/scene_keys.md
"`friction`", docs/contact.md "Round 41: a body's friction from the scene").

A body's Coulomb coefficient against another body was a field of ``Material`` that only a setup built in code could
set; a scene had no key for it, and sand took its ``tan(phi)`` on every body. The key is read on the materials that do
not flow, range-checked, and a pair takes the geometric mean of its bodies' (``combine_friction``); sand's own is
``tan(phi)``.

The engine check (both grid engines; warp_mpm in the default tier): round 38's sand block thrown along the 4.5 cm jelly
slab (``sand_ball.slide_setup``, ``COULOMB_SLAB_H``), the slab's ``friction`` 0.3 and 1.0 (pair 0.416 and 0.760 against
the sand's own 0.577), Coulomb's ratio (momentum lost over normal impulse, throw to frame 3) within ``RATIO_TOL``
2.5 % of the pair's at 1.2 and 1.6 m/s. **Catch:** an engine that ignores the key (its pair the sand's own) fails.
"""
from __future__ import annotations

import dataclasses
import math

import pytest
from gasp_testing import scene_text, set_pair_friction

from gasp_core.errors import SceneError
from gasp_core.mpm import fields
from gasp_core.scene.spec import load_scene
from gasp_core.scene.tables import read_material
from gasp_core.seam.setup import Material
from gasp_core.testing import sand_ball as S
from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS, RATIO_TOL

TAN30 = math.tan(math.radians(30.0))


def test_the_key_reaches_the_body(donut_small, write_scene, tmp_path):
    scene = load_scene(write_scene(scene_text(donut_small, material='name = "jelly"\nfriction = 0.3')))
    assert scene.objects[0].material.friction == 0.3
    m = read_material({"name": "brittle", "substance": "porcelain", "friction": 0.7}, "object.material",
                      tmp_path / "s.toml")
    assert m.friction == 0.7 and m.E > 1e10          # the substance's figures and the key together
    assert read_material({"name": "metal"}, "object.material", tmp_path / "s.toml").friction is None


@pytest.mark.parametrize("value", [-0.1, 10.5, float("nan"), "high", True])
def test_a_bad_friction_is_one_line_naming_the_key(tmp_path, value):
    with pytest.raises(SceneError) as e:
        read_material({"name": "jelly", "friction": value}, "[[object]] #1.material", tmp_path / "s.toml")
    msg = str(e.value)
    assert "\n" not in msg and "[[object]] #1.material.friction = " in msg and "in [0, 10]" in msg, msg


@pytest.mark.parametrize("name", ["sand", "snow", "liquid"])
def test_a_flowing_body_refuses_the_key_and_says_what_it_takes(tmp_path, name):
    with pytest.raises(SceneError, match=r"does not use \['friction'\].*tan\(friction_angle\)"):
        read_material({"name": name, "friction": 0.3}, "object.material", tmp_path / "s.toml")


def test_a_pair_takes_the_geometric_mean_of_its_bodies():
    pair = S.slide_setup(0.5, solid=True)
    assert fields.field_friction(pair) == pytest.approx(fields.SOLID_FRICTION)   # neither names one
    pair.materials = [dataclasses.replace(pair.materials[0], friction=0.2), Material("jelly", friction=0.8)]
    assert fields.field_friction(pair) == pytest.approx(0.4, rel=1e-12)
    mixed = S.slide_setup(1.2, slab_h=S.COULOMB_SLAB_H)          # sand on a slab: the sand's own when unnamed
    assert fields.field_friction(mixed) == pytest.approx(TAN30, rel=1e-12)
    mixed.materials = [mixed.materials[0], dataclasses.replace(mixed.materials[1], friction=0.3)]
    assert fields.field_friction(mixed) == pytest.approx(math.sqrt(TAN30 * 0.3), rel=1e-12)
    mixed.materials[1] = dataclasses.replace(mixed.materials[1], friction=0.0)   # a frictionless body: no friction
    assert fields.field_friction(mixed) == 0.0


def _slab_run(engine: str, slab_mu: float) -> dict:
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    info = get_engine(engine)
    err = {}
    for v0 in RATIO_SPEEDS:
        setup = S.slide_setup(v0, {"threads": 1}, slab_h=S.COULOMB_SLAB_H)
        setup.materials = [setup.materials[0], dataclasses.replace(setup.materials[1], friction=slab_mu)]
        tr = run_trace(info, setup, RATIO_FRAMES)
        err[v0] = S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES) / math.sqrt(TAN30 * slab_mu) - 1.0
    return err


ENGINES = ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)]


@pytest.mark.parametrize("slab_mu", [0.3, pytest.param(1.0, marks=pytest.mark.slow)])
@pytest.mark.parametrize("engine", ENGINES)
def test_sand_slides_on_a_slab_with_the_pairs_friction(engine, slab_mu):
    err = _slab_run(engine, slab_mu)
    assert all(abs(e) <= RATIO_TOL for e in err.values()), err


def _ignore_the_key(monkeypatch, engine: str) -> None:
    """The engine's pair friction the sand's own ``tan(phi)``, whatever the slab names (the rule before the key)."""
    set_pair_friction(monkeypatch, engine, lambda setup: TAN30)


@pytest.mark.parametrize("engine", ENGINES)
def test_the_slab_check_catches_an_engine_that_ignores_the_key(engine, monkeypatch):
    _ignore_the_key(monkeypatch, engine)
    err = _slab_run(engine, 0.3)
    assert all(e > RATIO_TOL for e in err.values()), err
