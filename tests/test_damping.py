"""Damping (issue 18): the ``viscosity`` material key end to end, its time-step limit, and the AFLIP option ``flip``.

The physics checks (Kelvin-Voigt log decrement of a bar against the analytic value, and broken engines it
catches) are the conformance scene ``bar_viscous_decay``; here: the key's plumbing, the capability refusal,
the step limit's formula, the option's exact APIC limit and both engines' agreement.
"""
from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.prepare.scene import scene_needs
from gasp_core.scene.spec import load_scene
from gasp_core.seam.build import build_engine, check_supported, needs
from gasp_core.seam.engine import Capabilities, EngineInfo
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.mpm.materials import material_table, P_ETA
from gasp_core.mpm.substeps import mpm_stable_dt, p_wave_speed, viscous_dt
from gasp_testing import DONUT, scene_text, needs_package

GRID_ENGINES = [e for e, mod in (("taichi_mpm", "gasp_taichi_mpm"), ("warp_mpm", "gasp_warp_mpm"))
                if importlib.util.find_spec(mod) is not None]


def test_scene_reads_viscosity_and_refuses_a_negative_one(write_scene):
    mat = 'name = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0\nviscosity = 12.5'
    scene = load_scene(write_scene(scene_text(DONUT, material=mat)))
    assert scene.objects[0].material.viscosity == 12.5
    assert "viscosity" in scene_needs(scene)["features"]
    with pytest.raises(SceneError, match=r"material\.viscosity = -1.*expected a finite number >= 0"):
        load_scene(write_scene(scene_text(DONUT, material=mat.replace("12.5", "-1.0")), "bad.toml"))
    assert "viscosity" not in scene_needs(load_scene(write_scene(scene_text(DONUT), "plain.toml")))["features"]


def test_an_engine_without_the_feature_refuses_viscosity_by_capability():
    info = EngineInfo(name="elastic_only", factory=lambda s: None,
                      capabilities=Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset()))
    check_supported(info, **needs([Material("jelly")]), others={})
    with pytest.raises(SceneError, match=r"does not support the feature 'viscosity'"):
        check_supported(info, **needs([Material("jelly", viscosity=1.0)]), others={})
    x, p_vol = box_points((0.4, 0.4, 0.4), (0.6, 0.6, 0.6), 0.05)
    with pytest.raises(SceneError, match=r"feature 'viscosity'"):
        build_engine(info, make_setup(x, p_vol, Material("jelly", viscosity=1.0)))


def test_viscosity_reaches_the_kernel_table():
    assert material_table([Material("neo_hookean", viscosity=3.0)])[1][0, P_ETA] == 3.0


def test_viscous_step_limit():
    """``dx / c`` without viscosity, the diffusion limit ``rho dx^2 / (4 eta)`` when it dominates, and the
    automatic step takes the smaller."""
    dx = 1.0 / 32
    m0 = Material("jelly", E=1e5, nu=0.0, rho=1000.0)
    c = p_wave_speed(m0)
    m = Material("jelly", E=1e5, nu=0.0, rho=1000.0, viscosity=1e-9)
    assert viscous_dt(m, dx) == pytest.approx(dx / c, rel=1e-6)
    big = Material("jelly", E=1e5, nu=0.0, rho=1000.0, viscosity=1e6)
    assert viscous_dt(big, dx) == pytest.approx(1000.0 * dx * dx / (4 * 1e6), rel=1e-4)
    g = (0.0, 0.0, 0.0)
    assert mpm_stable_dt([m0], dx, g, 0.0, cfl=0.4) == pytest.approx(0.4 * dx / c)
    assert mpm_stable_dt([m0, big], dx, g, 0.0, cfl=0.4) == pytest.approx(0.4 * viscous_dt(big, dx))
    # an engine that integrates the viscosity implicitly (taichi_mpm, warp_mpm) keeps the elastic step
    assert mpm_stable_dt([m0, big], dx, g, 0.0, cfl=0.4, implicit_viscosity=True) == pytest.approx(0.4 * dx / c)
    # between the two: the damped-oscillator bound (sqrt(1 + xi^2) - xi), xi = 2 eta / (rho c dx)
    mid = Material("jelly", E=1e5, nu=0.0, rho=1000.0, viscosity=318.0)
    xi = 2 * 318.0 / (1000.0 * c * dx)
    assert viscous_dt(mid, dx) == pytest.approx(dx / c * (math.sqrt(1 + xi * xi) - xi))


def _landing(options, viscosity=0.0):
    x, p_vol = box_points((0.4, 0.4, 0.2), (0.55, 0.55, 0.35), 1.0 / 64)
    return make_setup(x, p_vol, Material("jelly", E=5e4, nu=0.3, rho=1000.0, viscosity=viscosity), n_grid=32,
                      frame_dt=0.02, boundaries=[Boundary("ground", height=0.1, friction=0.5)],
                      options={"threads": 1, **options})


def _positions(engine, setup, n):
    from gasp_core.seam.plugins import engines
    eng = build_engine(engines()[engine], setup)
    for _ in range(n):
        eng.step_frame()
    x = eng.positions().astype(np.float64)
    eng.close()
    return x


@pytest.mark.parametrize("engine", GRID_ENGINES)
def test_flip_zero_is_apic_bit_for_bit(engine):
    assert np.array_equal(_positions(engine, _landing({}), 4), _positions(engine, _landing({"flip": 0.0}), 4))


@pytest.mark.parametrize("engine", GRID_ENGINES)
def test_a_very_viscous_bar_runs_stably_at_the_elastic_step(engine):
    """eta 5000 Pa s (damping ratio 3.1 on the first mode, xi = 32 at the grid scale): the explicit step needed 18x
    more substeps and the elastic step diverged in the second frame; the implicit step keeps the elastic substeps,
    stays finite, and the overdamped mode's velocity dies out as the analytic one (to under 10 % of its start in
    0.05 s; analytic: -1.6 %)."""
    from gasp_core.seam.plugins import engines
    from gasp_core.testing.scenes_damping import BAR_V0, bar_mode_setup
    s = bar_mode_setup(eta=5000.0)
    s.options["threads"] = 1
    eng = build_engine(engines()[engine], s)
    c = p_wave_speed(s.materials[0]) + float(np.max(np.linalg.norm(s.v, axis=1)))   # cfl_rule "sum" (round 54)
    assert eng.stats()["n_substeps"] == math.ceil(s.frame_dt / (0.4 * s.dx / c) - 1e-9)
    for _ in range(10):
        eng.step_frame()
    v = eng.velocities().astype(np.float64)
    eng.close()
    assert np.isfinite(v).all()
    assert np.abs(v[:, 0]).max() < 0.1 * BAR_V0


@pytest.mark.skipif(len(GRID_ENGINES) < 2, reason="needs both grid engines")
def test_warp_and_taichi_agree_with_flip_and_viscosity():
    """A jelly block landing with AFLIP (alpha 0.99) and viscosity 20 Pa s: both engines agree to 1e-3 of its size."""
    s = lambda: _landing({"flip": 0.99}, viscosity=20.0)  # noqa: E731
    a, b = _positions("taichi_mpm", s(), 12), _positions("warp_mpm", s(), 12)
    assert np.abs(a - s().x).max() > 0.03   # it fell onto the ground (4.6 cm)
    assert np.abs(a - b).max() < 1e-3 * 0.15


def test_bench_energy_figures():
    """``gasp bench``'s energy columns from the Gaussians' motion: a damped oscillation keeps less than an
    undamped one and less than its reference."""
    needs_package("distributed")
    from gasp_studies.measure import energy_figures
    from gasp_studies.run import RunOutput
    t = np.arange(41) * 0.05
    x0 = np.zeros((3, 3))

    def run(decay):
        z = 0.1 * np.exp(-decay * t) * np.sin(2 * np.pi * t)
        means = np.repeat(x0[None], len(t), axis=0)
        means[:, :, 2] = z[:, None]
        return RunOutput({"status": "ok"}, means.astype(np.float32), np.full(3, 2.0, np.float32))

    free, damped = run(0.0), run(1.0)
    f = energy_figures(free, free)
    assert f["ke_vs_ref"] == pytest.approx(1.0) and f["ke_left"] > 0.3
    d = energy_figures(free, damped)
    assert d["ke_left"] < 0.05 and d["ke_vs_ref"] < 0.5
    assert np.isnan(energy_figures(free, RunOutput({"status": "diverged"}))["ke_left"])
