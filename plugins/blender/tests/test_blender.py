"""Tests of the ``blender`` engine plugin against physics with known answers.

Engine tests skip with the reason when bpy is not installed (the line ``gasp engines`` prints: a venv of its own).
"""
import json

import numpy as np
import pytest

from gasp_core.seam import Boundary, build_engine, Material, SceneError, SimSetup
from gasp_blender import CAPABILITIES, INSTALL_HINT, bpy_available
from gasp_blender import gasp_engines  # noqa: E402
from gasp_blender.cage import build_cage, embed, interpolate

def build(setup):
    """The engine as the core builds it: options checked and completed first (``build_engine``)."""
    return build_engine(gasp_engines()[0], setup)


G = 9.81
needs_bpy = pytest.mark.skipif(bpy_available() is not None, reason=bpy_available() or "")


def block(lo, hi, spacing):
    axes = [np.arange(a + spacing / 2, b, spacing) for a, b in zip(lo, hi)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return x, np.full(len(x), spacing ** 3)


def setup_for(x, p_vol, boundaries=(), options=None, material=None, frame_dt=1 / 30, v=0.0):
    return SimSetup(x=x, v=v, p_vol=p_vol, body_id=np.zeros(len(x), np.int32),
                    materials=[material or Material("jelly", E=1e5, nu=0.3, rho=1000.0)],
                    gravity=np.array([0.0, 0.0, -G]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    boundaries=list(boundaries), frame_dt=frame_dt, options=dict(options or {}))


def test_listed_with_capabilities():
    from gasp_core.seam.plugins import engines
    info = engines()["blender"]
    assert info.capabilities == CAPABILITIES
    assert info.unavailable_reason() in (None, INSTALL_HINT)
    assert CAPABILITIES.materials == {"jelly"} and CAPABILITIES.boundaries == {"ground", "fixed_region"}


def test_cage_embedding_reproduces_points():
    x, _ = block((0.1, 0.2, 0.3), (0.3, 0.35, 0.5), 0.01)
    cage = build_cage(x, 0.04)
    cell, w = embed(cage, x)
    assert np.allclose(w.sum(1), 1.0) and (w >= -1e-12).all()
    assert np.abs(interpolate(cage.vertices, cage, cell, w) - x).max() < 1e-12
    # a rigid motion of the cage moves the points rigidly
    c = np.cos(0.3), np.sin(0.3)
    Q = np.array([[c[0], -c[1], 0], [c[1], c[0], 0], [0, 0, 1]])
    assert np.abs(interpolate(cage.vertices @ Q.T, cage, cell, w) - x @ Q.T).max() < 1e-12


@needs_bpy
def test_bad_options_and_inputs_are_scene_errors():
    x, vol = block((0.4, 0.4, 0.5), (0.6, 0.6, 0.7), 0.02)
    with pytest.raises(SceneError, match="unknown option"):
        build(setup_for(x, vol, options={"substeps": 3}))
    with pytest.raises(SceneError, match="mode"):
        build(setup_for(x, vol, options={"mode": "fluid"}))
    # capabilities are checked by the core, before the factory (gasp_core.seam.build.build_engine)
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    info = get_engine("blender")
    with pytest.raises(SceneError, match="sand"):
        build_engine(info, setup_for(x, vol, material=Material("sand")))
    with pytest.raises(SceneError, match="walls"):
        build_engine(info, setup_for(x, vol, boundaries=[Boundary("walls")]))
    with pytest.raises(SceneError, match="initial velocities"):
        build(setup_for(x, vol, v=np.array([0.0, 0.0, 1.0])))


@needs_bpy
def test_free_fall_matches_g_t2_over_2():
    """No ground: after 0.3 s every point has fallen g t^2 / 2 (within 1 %)."""
    x, vol = block((0.4, 0.4, 0.6), (0.6, 0.6, 0.8), 0.025)
    eng = build(setup_for(x, vol))
    try:
        for _ in range(9):
            eng.step_frame()
        t = 9 / 30
        drop = x[:, 2] - eng.positions()[:, 2]
        assert np.mean(drop) == pytest.approx(0.5 * G * t * t, rel=0.01)
        assert np.abs(drop - 0.5 * G * t * t).max() < 0.01 * 0.5 * G * t * t
        assert np.abs(eng.positions()[:, :2] - x[:, :2]).max() < 1e-4
    finally:
        eng.close()


@needs_bpy
def test_rests_on_ground():
    """Dropped 2 cm onto the ground: comes to rest on it (no point 1 cm below, speed ~0)."""
    x, vol = block((0.4, 0.4, 0.12), (0.6, 0.6, 0.32), 0.025)
    eng = build(setup_for(x, vol, boundaries=[Boundary("ground", height=0.1)]))
    try:
        for _ in range(45):
            eng.step_frame()
        p, v = eng.positions(), eng.velocities()
        assert p[:, 2].min() > 0.1 - 0.01
        assert np.abs(p[:, 2].min() - 0.1) < 0.01
        assert np.linalg.norm(v, axis=1).max() < 0.05
    finally:
        eng.close()


@needs_bpy
def test_fixed_region_holds_points():
    """A bar clamped at one end: the clamped points stay exactly put, the free end sags."""
    x, vol = block((0.2, 0.45, 0.5), (0.7, 0.55, 0.6), 0.025)
    clamp = Boundary("fixed_region", lo=(0.0, 0.0, 0.0), hi=(0.26, 1.0, 1.0))
    eng = build(setup_for(x, vol, boundaries=[clamp], options={"cells_across": 10}))
    try:
        for _ in range(15):
            eng.step_frame()
        p = eng.positions()
        held = x[:, 0] <= 0.26
        assert np.abs(p[held] - x[held]).max() < 1e-5
        tip = x[:, 0] > 0.65
        assert (x[tip, 2] - p[tip, 2]).mean() > 1e-3
    finally:
        eng.close()


@needs_bpy
@pytest.mark.slow
def test_readme_donut_on_blender(tmp_path):
    """The README donut scene with only the engine changed: falls, lands on the ground, rests."""
    from pathlib import Path
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    from gasp_core.gs.io import read_gaussians
    root = Path(__file__).resolve().parents[3]
    scene = load_scene(root / "examples" / "donut_blender.toml")
    res = simulate_scene(scene, tmp_path / "out", quiet=True)
    obj = res.summary["objects"][0]
    tz = obj["placement"]["t"][2]          # file -> world: the file is z up, metres, shifted by t
    frames = [read_gaussians(tmp_path / "out" / obj["name"] / f"frame_{f:04d}.ply").means
              for f in range(scene.n_frames + 1)]
    z_min = np.array([m[:, 2].min() + tz for m in frames])
    vz = np.diff([m[:, 2].mean() for m in frames]) / scene.frame_dt
    assert z_min[0] == pytest.approx(0.05, abs=1e-6)
    assert z_min.min() > -0.005                    # never sinks through the ground
    assert abs(z_min[-1]) < 0.005                  # lands and stays on it (1 mm collision skin)
    assert vz.min() < -0.7                         # it fell (free fall from 5 cm reaches 0.99 m/s)
    assert np.abs(vz[-5:]).max() < 0.02 * np.abs(vz).max()   # at rest: end speed < 2 % of impact
    print(json.dumps({"z_min": z_min.round(4).tolist(), "vz": vz.round(3).tolist(), "engine_stats": res.summary["engine_stats"]}))


@needs_bpy
def test_repeat_is_bit_identical():
    """Same scene twice (drop onto the ground): bit-identical positions (declared deterministic on cpu)."""
    x, vol = block((0.4, 0.4, 0.12), (0.6, 0.6, 0.32), 0.025)
    runs = []
    for _ in range(2):
        eng = build(setup_for(x, vol, boundaries=[Boundary("ground", height=0.1)]))
        for _ in range(8):
            eng.step_frame()
        runs.append(eng.positions())
        eng.close()
    assert np.array_equal(runs[0], runs[1])


@needs_bpy
def test_cloth_free_fall_and_pinned_edge():
    """Cloth mode: a 1 cm sheet falls g t^2/2 (1 %); pinned along one edge it stays put there and drapes."""
    x, vol = block((0.3, 0.4, 0.7), (0.7, 0.6, 0.71), 0.01)
    eng = build(setup_for(x, vol, options={"mode": "cloth", "cells_across": 8}))
    try:
        assert np.abs(eng.positions() - x).max() < 1e-6      # the sheet carries the points exactly
        for _ in range(9):
            eng.step_frame()
        drop = np.mean(x[:, 2] - eng.positions()[:, 2])
        assert drop == pytest.approx(0.5 * G * 0.3 ** 2, rel=0.01)
    finally:
        eng.close()
    clamp = Boundary("fixed_region", lo=(0.0, 0.0, 0.0), hi=(0.31, 1.0, 1.0))
    eng = build(setup_for(x, vol, boundaries=[clamp], options={"mode": "cloth", "cells_across": 8}))
    try:
        for _ in range(30):
            eng.step_frame()
        p = eng.positions()
        held = x[:, 0] <= 0.31
        assert np.abs(p[held] - x[held]).max() < 1e-5
        assert (x[:, 2] - p[:, 2])[x[:, 0] > 0.68].mean() > 0.05   # the free edge hangs down
    finally:
        eng.close()


@needs_bpy
def test_second_engine_takes_the_scene_over():
    """bpy has one scene per process: the first engine refuses to step once a second one is built."""
    from gasp_core.errors import EngineError
    x, vol = block((0.4, 0.4, 0.5), (0.6, 0.6, 0.7), 0.05)
    first = build(setup_for(x, vol))
    second = build(setup_for(x, vol))
    try:
        with pytest.raises(EngineError, match="replaced by another"):
            first.step_frame()
        second.step_frame()
    finally:
        first.close()
        second.close()
