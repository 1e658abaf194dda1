"""Tests of the ``genesis`` engine plugin against physics with known answers.

Genesis compiles its kernels when the first scene is built (about a minute on 2 cores, ~10 s with a
warm ``~/.cache/quadrants``), so the scenes here are tiny: a few hundred points, ``n_grid`` 16.
"""
import numpy as np
import pytest

pytest.importorskip("genesis", reason="genesis-world is not installed (gasp engines prints the line)")

from gasp_core.seam import (Boundary, build_engine, EngineDivergence, EngineError, Material, SceneError,
                           SimSetup)
from gasp_genesis import CAPABILITIES, genesis_available  # noqa: E402
from gasp_genesis import gasp_engines  # noqa: E402
from gasp_genesis.engine import init_genesis  # noqa: E402

def build(setup):
    """The engine as the core builds it: options checked and completed first (``build_engine``)."""
    return build_engine(gasp_engines()[0], setup)


G = 9.81


def block(lo, hi, spacing):
    """Points on a regular lattice filling the box [lo, hi], spacing in metres, and their volume."""
    axes = [np.arange(a + spacing / 2, b, spacing) for a, b in zip(lo, hi)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return x, np.full(len(x), spacing ** 3)


def setup_for(x, p_vol, boundaries=(), options=None, material=None, n_grid=16, frame_dt=1 / 30):
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=p_vol, body_id=np.zeros(len(x), np.int32),
                    materials=[material or Material("jelly", E=1e4, nu=0.3, rho=1000.0)],
                    gravity=np.array([0.0, 0.0, -G]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=n_grid, boundaries=list(boundaries), frame_dt=frame_dt,
                    options=dict(options or {}))


def test_available_and_capabilities():
    assert genesis_available() is None
    assert {"jelly", "sand", "liquid"} <= CAPABILITIES.materials
    assert "plasticine" not in CAPABILITIES.materials and "fixed_region" not in CAPABILITIES.boundaries
    assert CAPABILITIES.features == {"grid"}  # Genesis starts C at zero: no "initial_C"


def test_unknown_option_is_scene_error():
    x, vol = block((0.4, 0.4, 0.6), (0.6, 0.6, 0.8), 1 / 32)
    with pytest.raises(SceneError, match="unknown option.*'substeps'"):
        build(setup_for(x, vol, options={"substeps": 10}))
    with pytest.raises(SceneError, match="precision"):
        build(setup_for(x, vol, options={"precision": "f16"}))


def test_unsupported_material_and_boundary_are_scene_errors():
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    info = engines()["genesis"]
    x, vol = block((0.4, 0.4, 0.6), (0.6, 0.6, 0.8), 1 / 32)
    with pytest.raises(SceneError, match="plasticine"):
        build_engine(info, setup_for(x, vol, material=Material("plasticine")))
    with pytest.raises(SceneError, match="fixed_region"):
        build_engine(info, setup_for(x, vol, boundaries=[Boundary("fixed_region")]))
    with pytest.raises(SceneError, match="outside Genesis's MPM box"):  # within 3 dx of the floor
        build(setup_for(x - [0, 0, 0.55], vol))


def test_second_precision_in_process_is_engine_error():
    init_genesis("cpu", "f32")  # no-op if an earlier test initialised Genesis the same way
    x, vol = block((0.4, 0.4, 0.6), (0.6, 0.6, 0.8), 1 / 32)
    with pytest.raises(EngineError, match="already initialised"):
        build(setup_for(x, vol, options={"precision": "f64"}))


def test_free_fall_matches_g_t2_over_2():
    """No ground: after 0.2 s a block has fallen g t^2 / 2 and moves at g t (within 1%)."""
    x, vol = block((0.42, 0.42, 0.70), (0.58, 0.58, 0.80), 1 / 32)
    n_frames, frame_dt, n_substeps = 6, 1 / 30, 40  # 240 substeps: integrator bias 1/240
    eng = build(setup_for(x, vol, options={"n_substeps": n_substeps}, frame_dt=frame_dt))
    try:
        st = eng.stats()
        assert st["n_substeps"] == n_substeps and st["n_points"] == len(x)
        assert st["dt"] == pytest.approx(frame_dt / n_substeps)
        for _ in range(n_frames):
            eng.step_frame()
        t = n_frames * frame_dt
        p, v = eng.positions(), eng.velocities()
        assert p.shape == x.shape and np.isfinite(p).all()
        drop = float(np.mean(x[:, 2] - p[:, 2]))
        assert drop == pytest.approx(0.5 * G * t * t, rel=0.01)
        assert float(np.mean(v[:, 2])) == pytest.approx(-G * t, rel=0.01)
        # a free block keeps its shape and does not drift sideways
        np.testing.assert_allclose(p[:, :2], x[:, :2], atol=1e-3)
        np.testing.assert_allclose(p[:, 2] - p[:, 2].mean(), x[:, 2] - x[:, 2].mean(), atol=1e-3)
    finally:
        eng.close()


def test_block_comes_to_rest_on_ground():
    """A block dropped 0.1 m onto a ground plane stays above it and stops (falls 0.5 s)."""
    height = 0.3
    x, vol = block((0.42, 0.42, 0.40), (0.58, 0.58, 0.50), 1 / 32)
    eng = build(setup_for(x, vol, boundaries=[Boundary("ground", height=height, friction=0.5)],
                                options={"n_substeps": 20}))
    try:
        assert eng.stats()["n_planes"] == 1
        for _ in range(15):
            eng.step_frame()
        p, v = eng.positions(), eng.velocities()
        dx = eng.stats()["dx"]
        assert np.isfinite(p).all() and np.isfinite(v).all()
        assert p[:, 2].min() >= height - 0.25 * dx, "points went through the ground"
        assert float(np.mean(x[:, 2] - p[:, 2])) > 0.05, "the block did not fall"
        # free fall for 0.5 s would be at 4.9 m/s; on the ground it is (nearly) still
        assert abs(float(np.mean(v[:, 2]))) < 0.3
    finally:
        eng.close()



def test_blow_up_is_engine_divergence():
    """A stiff block with one substep per frame (dt 30x the elastic limit) blows up."""
    x, vol = block((0.42, 0.42, 0.40), (0.58, 0.58, 0.50), 1 / 32)
    eng = build(setup_for(x, vol, material=Material("jelly", E=1e9), options={"n_substeps": 1}))
    try:
        with pytest.raises(EngineDivergence, match="time step") as info:
            for _ in range(30):
                eng.step_frame()
        assert 1 <= info.value.frame <= 30
    finally:
        eng.close()


@pytest.mark.slow
def test_wall_friction_slows_a_sliding_block():
    """On the box floor, walls with friction 0 keep the speed; friction 0.5 brakes ~ mu g t."""
    x, vol = block((0.2, 0.42, 0.19), (0.36, 0.58, 0.29), 1 / 32)
    v = np.zeros_like(x)
    v[:, 0] = 2.0
    speeds = {}
    for friction in (0.0, 0.5):
        s = setup_for(x, vol, boundaries=[Boundary("walls", friction=friction)], options={"n_substeps": 20})
        eng = build(s.replace(v=v))
        try:
            for _ in range(3):
                eng.step_frame()
            speeds[friction] = float(np.mean(eng.velocities()[:, 0]))
        finally:
            eng.close()
    assert speeds[0.0] == pytest.approx(2.0, rel=0.01)
    assert 2.0 - speeds[0.5] == pytest.approx(0.5 * G * 0.1, rel=0.3)
