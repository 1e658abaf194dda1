"""The quality levels (gasp_core.scene.quality) and the surface rule (gasp_core.prepare.surface)."""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.maps.fill import fill_interior
from gasp_core.prepare.surface import MIN_SOLID_CELLS, surface_rule
from gasp_core.cli.main import main
from gasp_core.scene.quality import PRESETS, QUALITY_LEVELS, STUDIO_LEVEL, engine_options, studio_engine
from gasp_core.seam import Capabilities, EngineInfo, Preset
from gasp_core.seam.options import Option
from gasp_core.seam.plugins import engines
from gasp_core.mpm.options import MPM_PRESETS
from gasp_core.scene.spec import load_scene
from gasp_testing import scene_text, needs_package


def test_levels_fill_in_only_what_the_file_leaves_out(donut_small, write_scene):
    path = write_scene(scene_text(donut_small, n_grid=24))
    d, dr, r = (load_scene(path, quality=q) for q in QUALITY_LEVELS)
    assert (d.quality, d.domain.n_grid, d.domain.particles_per_cell, d.objects[0].surface) == ("draft", 24, 2, "passive")
    assert (dr.domain.n_grid, dr.domain.particles_per_cell, dr.objects[0].surface) == (24, 4, "auto")
    assert (r.domain.n_grid, r.domain.particles_per_cell, r.objects[0].surface, r.objects[0].core_fraction) == \
        (36, 8, "material", 1.0)
    assert load_scene(path).quality == "default"
    # a key the file sets wins over the level; the file's own `quality` is read, --quality replaces it
    text = scene_text(donut_small, n_grid=24, extra_top='quality = "reference"',
                      extra_object='surface = "passive"\ncore_fraction = 0.5')
    text = text.replace("n_grid = 24", "n_grid = 24\nparticles_per_cell = 1")
    s = load_scene(write_scene(text, "explicit.toml"))
    assert (s.quality, s.domain.particles_per_cell, s.objects[0].surface, s.objects[0].core_fraction) == \
        ("reference", 1, "passive", 0.5)
    assert load_scene(write_scene(text, "explicit.toml"), quality="draft").quality == "draft"


def test_a_bad_level_names_the_key_and_the_levels(donut_small, write_scene):
    path = write_scene(scene_text(donut_small, extra_top='quality = "best"'))
    with pytest.raises(SceneError, match=r"quality.*'best'.*draft"):
        load_scene(path)
    with pytest.raises(SceneError, match=r"--quality"):
        load_scene(write_scene(scene_text(donut_small), "ok.toml"), quality="fast")


def test_engine_options_of_a_level_are_what_the_engine_declares():
    mpm = {"draft": Preset({"passive_every": 16, "cfl": 0.8}), "default": Preset({"passive_every": 8, "cfl": 0.8}),
           "reference": Preset({"cfl": 0.2})}
    assert engine_options("default", {}, mpm) == {"passive_every": 8, "cfl": 0.8}
    assert engine_options("draft", {}, mpm) == {"passive_every": 16, "cfl": 0.8}
    assert engine_options("default", {}, {}) == {}                                # an engine declaring no preset
    assert engine_options("default", {"passive_every": 2}, mpm) == {"passive_every": 2, "cfl": 0.8}
    assert engine_options("reference", {"threads": 1}, mpm) == {"threads": 1, "cfl": 0.2}
    assert engine_options("default", {"cfl": 0.4}, mpm) == {"passive_every": 8, "cfl": 0.4}   # the scene's own wins
    assert set(PRESETS) == set(QUALITY_LEVELS)


def test_the_mpm_engines_declare_the_levels_measured_on_them():
    """The levels' engine options as measured (docs/speed_accuracy.md, "The time step" and "Quality levels"): the
    values the core applied before the engines declared them (issue 51), so runs are unchanged."""
    assert {lv: dict(p.options) for lv, p in MPM_PRESETS.items()} == {
        "draft": {"passive_every": 16, "cfl": 0.8}, "default": {"passive_every": 8, "cfl": 0.8},
        "reference": {"cfl": 0.2}}
    assert set(MPM_PRESETS) == set(QUALITY_LEVELS) and all(p.measured for p in MPM_PRESETS.values())
    for info in engines().values():
        assert set(info.presets) <= set(QUALITY_LEVELS), info.name
        declared = {o.name for o in info.options}
        assert all(set(p.options) <= declared for p in info.presets.values()), info.name


def test_a_preset_setting_an_undeclared_option_is_refused_at_registration():
    caps = Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset())
    with pytest.raises(ValueError, match=r"'x'.*'draft'.*\['cfl'\]"):
        EngineInfo("x", factory=lambda setup: None, capabilities=caps, presets={"draft": Preset({"cfl": 0.8})})


def test_the_studio_engine_takes_the_levels_options_then_repeats_without_an_option():
    def info(name, deterministic=(), options=None):
        caps = Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset(),
                            deterministic=frozenset(deterministic))
        return EngineInfo(name, factory=lambda setup: None, capabilities=caps, deterministic_options=options or {})
    threads, free, none = info("a_threads", {"cpu"}, {"threads": 1}), info("z_free", {"cpu"}), info("b_none")
    assert studio_engine([threads, none, free]) == "z_free"
    assert studio_engine([none, threads]) == "a_threads" and studio_engine([]) is None
    assert studio_engine([info("z_gpu", {"cuda"}), none]) == "b_none"      # repeats on CUDA only: no preference
    # an engine declaring a measured preset for the studio level comes first (the levels were measured on it)
    level = dataclasses.replace(info("c_level", {"cpu"}, {"threads": 1}), options=(Option("cfl", 0.4, ""),),
                                presets={STUDIO_LEVEL: Preset({"cfl": 0.8}, measured="docs/speed_accuracy.md")})
    unmeasured = dataclasses.replace(level, name="b_unmeasured", presets={STUDIO_LEVEL: Preset({"cfl": 0.8})})
    assert studio_engine([free, level]) == "c_level"
    assert studio_engine([free, unmeasured]) == "z_free"


def test_the_studio_level_runs_the_studios_donut_on_its_engine(tmp_path, donut_small, write_scene, capsys):
    """What ``gasp studio`` launches: ``gasp simulate SCENE --json --quality STUDIO_LEVEL`` on the studio's engine
    among those that run viscous jelly, the donut over a ground (a 16th of its Gaussians, n_grid 16, one frame)."""
    assert STUDIO_LEVEL in QUALITY_LEVELS
    can = [i for i in engines().values() if i.unavailable_reason() is None
           and not i.capabilities.missing(["jelly"], ["ground"], ["viscosity"])]
    engine = studio_engine(can)
    if engine is None:
        pytest.skip("no installed engine runs viscous jelly")
    jelly = 'name = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0\nviscosity = 4.0'
    scene = write_scene(scene_text(donut_small, n_frames=1, n_grid=16, engine=engine, engine_options="{ }",
                                   material=jelly))
    out = tmp_path / "run"
    assert main(["simulate", str(scene), "-o", str(out), "--json", "--quality", STUDIO_LEVEL]) == 0
    events = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert [e["frame"] for e in events if e["event"] == "frame"] == [0, 1]
    assert (out / "donut_small" / "frame_0001.ply").is_file()
    run = json.loads((out / "run.json").read_text())
    preset = PRESETS[STUDIO_LEVEL]
    assert (run["quality"], run["engine"]) == (STUDIO_LEVEL, engine)
    assert run["objects"][0]["surface"] == preset.objects["surface"]
    level = engines()[engine].presets[STUDIO_LEVEL].options
    assert level and all(run["engine_options"][k] == v for k, v in level.items())


def _ball(radius: float, n: int = 2000) -> np.ndarray:
    """Points on a sphere (Fibonacci lattice), metres."""
    i = np.arange(n) + 0.5
    phi, theta = np.arccos(1 - 2 * i / n), np.pi * (1 + 5 ** 0.5) * i
    return radius * np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=1)


def test_surface_rule_passive_on_a_resolved_solid_material_otherwise():
    dx = 0.01
    pts = _ball(0.05)              # volume 5.2e-4 m^3 = 524 cells: passive
    fr = fill_interior(pts, dx / 2, fill=True, surface_mass=False)
    passive, rec = surface_rule(True, len(pts), fr, dx, "sand")
    assert passive and rec["surface"] == "passive" and rec["fill_method"] == "six-ray"
    assert surface_rule(True, len(pts), fr, dx, "jelly")[0] is False        # an elastic body keeps the full model
    assert rec["solid_cells"] == pytest.approx(4 / 3 * np.pi * 0.05 ** 3 / dx ** 3, rel=0.3)
    assert rec["n_surface_points"] == 2000 and rec["n_fill_points"] == len(fr.fill_x)
    # the same ball with fill = false (a footprint shell, like the kitchen's leaves): material
    shell = fill_interior(pts, dx / 2, fill=False, surface_mass=False)
    assert surface_rule(False, len(pts), shell, dx, "sand")[0] is False
    # a ball a few cells across (about 34 cells of solid): too little for the vertices to ride on
    small = _ball(0.02, 800)
    fr = fill_interior(small, dx / 2, fill=True, surface_mass=False)
    passive, rec = surface_rule(True, len(small), fr, dx, "sand")
    assert rec["solid_cells"] < MIN_SOLID_CELLS and passive is False and rec["surface"] == "material"
    # a brittle body takes the passive surface over any interior (its shell would break into a cloud, issue 66)
    assert len(fr.fill_x) > 0 and surface_rule(True, len(small), fr, dx, "brittle")[0] is True
    assert surface_rule(False, len(pts), shell, dx, "brittle")[0] is False       # no closed fill: material


def test_the_pipeline_resolves_auto_and_records_the_rule(donut_small, write_scene):
    needs_package("gasp_taichi_mpm")
    from gasp_core.prepare.scene import prepare_scene
    jelly = prepare_scene(load_scene(write_scene(scene_text(donut_small, n_grid=24), "jelly.toml")))
    assert jelly.objects[0].surface_rule["surface"] == "material" and jelly.setup.passive is None
    sand = 'name = "sand"\nE = 3.0e5\nnu = 0.3\nrho = 1600.0\nfriction_angle = 35.0'
    # n_grid 32: the sand donut's default domain holds its runout on the ground (gasp_core.prepare.runout), 0.96 m a
    # side; at 24 its 45 mm cells give the full model, at 32 (30 mm) the passive surface this test follows
    path = write_scene(scene_text(donut_small, n_grid=32, material=sand))
    prep = prepare_scene(load_scene(path))
    rule = prep.objects[0].surface_rule
    assert rule["surface"] == "passive" and prep.setup.passive is not None
    assert int(prep.setup.passive.sum()) == rule["n_surface_points"]
    assert prep.setup.options["passive_every"] == 8                     # the level's option, declared by the engine
    ref = prepare_scene(load_scene(path, quality="reference"))
    assert ref.objects[0].surface_rule is None and ref.setup.passive is None and ref.setup.options["cfl"] == 0.2
