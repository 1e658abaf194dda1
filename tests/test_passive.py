"""Passive surface points (``SimSetup.passive``, ``surface = "passive"``): the core's MLS embedding,
the setup's checks, and engines carrying passive points in free fall (a known answer: a body in free
fall moves rigidly, so a massless point on it falls with it, ``1/2 g t^2``)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.errors import SceneError
from gasp_core.seam.build import build_engine
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.seam.passive import EmbeddedEngine, mls_embedding
from gasp_core.seam.plugins import engines
from gasp_core.testing.helpers import box_points

G = 9.81
JELLY = Material("jelly", E=1e5, nu=0.3, rho=500.0)


def test_mls_embedding_reproduces_affine_motion():
    """A linear MLS basis reproduces affine fields: any affine map of the anchors moves the embedded
    points by the same map, to rounding."""
    rng = np.random.default_rng(0)
    anchors = rng.uniform(-1, 1, size=(400, 3))
    points = rng.uniform(-0.9, 0.9, size=(50, 3))
    idx, phi = mls_embedding(points, anchors)
    np.testing.assert_allclose(phi.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.einsum("mk,mkj->mj", phi, anchors[idx]), points, atol=1e-9)
    A = np.array([[1.1, 0.2, -0.1], [0.0, 0.9, 0.3], [0.05, -0.2, 1.2]])
    b = np.array([0.3, -0.1, 2.0])
    moved = anchors @ A.T + b
    np.testing.assert_allclose(np.einsum("mk,mkj->mj", phi, moved[idx]), points @ A.T + b, atol=1e-9)


def block_with_skin(n_grid=24):
    """A jelly block of material points at dx/2 spacing and passive points on its top face."""
    dx = 1.0 / n_grid
    x, p_vol = box_points([0.4, 0.4, 0.5], [0.6, 0.6, 0.7], dx / 2)
    g = np.linspace(0.41, 0.59, 7)
    top = np.stack(np.meshgrid(g, g, [0.7], indexing="ij"), -1).reshape(-1, 3)
    xs = np.concatenate([top, x])
    vol = np.concatenate([np.zeros(len(top)), np.full(len(x), p_vol)])
    passive = np.r_[np.ones(len(top), bool), np.zeros(len(x), bool)]
    return SimSetup(x=xs, v=0.0, p_vol=vol, body_id=0, materials=[JELLY], gravity=[0, 0, -G],
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid, frame_dt=1 / 30,
                    n_render=len(top), passive=passive)


def test_setup_checks_passive_rows():
    s = block_with_skin()
    assert s.n_passive == 49 and s.material_mask.sum() == len(s.x) - 49
    with pytest.raises(SceneError, match="passive rows .* must have volume 0"):
        dataclasses.replace(s, p_vol=np.where(s.passive, 1e-6, s.p_vol))
    with pytest.raises(SceneError, match="only rendered rows"):
        dataclasses.replace(s, n_render=10)
    with pytest.raises(SceneError, match="every point is passive"):
        dataclasses.replace(s, p_vol=np.zeros(len(s.x)), passive=np.ones(len(s.x), bool), n_render=len(s.x))


def _engine_names():
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in
            ("taichi_mpm", "warp_mpm", "mujoco_flex")]


@pytest.mark.parametrize("name", _engine_names())
@pytest.mark.parametrize("own", [True, False], ids=["feature", "core_embedding"])
def test_passive_points_fall_with_the_body(name, own):
    """Free fall for 0.2 s: the passive points move like the material points (rigid translation,
    ``1/2 g t^2``), to 1e-4 of the drop (f32 rounding of the positions); with ``own=False`` the
    engine is registered without ``passive_points`` and the core embeds them."""
    info = engines()[name]
    if not own:
        caps = dataclasses.replace(info.capabilities, features=info.capabilities.features - {"passive_points"})
        info = dataclasses.replace(info, capabilities=caps)
    s = block_with_skin()
    if name != "mujoco_flex":
        s.options = {"threads": 1}
    e = build_engine(info, s)
    try:
        assert isinstance(e, EmbeddedEngine) is (not own)
        st = e.stats()
        np.testing.assert_allclose(st["mass"], JELLY.rho * s.p_vol.sum(), rtol=1e-6)
        x0 = e.positions().astype(np.float64)
        for _ in range(6):
            e.step_frame()
        d = e.positions().astype(np.float64) - x0
    finally:
        e.close()
    drop = 0.5 * G * 0.2 ** 2
    mat = d[~s.passive].mean(axis=0)
    assert abs(-mat[2] / drop - 1.0) < 0.02                       # the body fell (grid time stepping)
    np.testing.assert_allclose(d[s.passive], np.broadcast_to(mat, (s.n_passive, 3)), atol=1e-4 * drop)


@pytest.mark.parametrize("n,every", [(1, 1), (10, 1), (10, 3), (122, 8), (122, 122), (5, 9)])
def test_passive_schedule_is_exact_for_velocity_linear_in_time(n, every):
    """``passive_schedule`` moves a point by ``a v_prev + b v_now`` at its updates; for a grid
    velocity linear in the substep (free fall, any uniform acceleration) the sum equals the plain
    per-substep update ``dt * sum_s v_s`` exactly, whatever ``every``, and the frame's last substep
    always updates."""
    from gasp_core.toolkit.substeps import passive_schedule
    dt = 1e-3
    c0, c1 = np.array([0.3, -1.0, 2.0]), np.array([0.01, 0.5, -0.2])

    def v(s):   # velocity after the grid update of substep s; s = -1: the stored start velocity
        return c0 + c1 * s
    plan = passive_schedule(n, every, dt)
    assert plan[-1][0] == n - 1 and len({(a, b) for _s, a, b in plan}) <= 2
    assert len(plan) == -(-n // min(every, n))
    x, prev = np.zeros(3), v(-1)
    for s, a, b in plan:
        x += a * prev + b * v(s)
        prev = v(s)
    np.testing.assert_allclose(x, dt * sum(v(s) for s in range(n)), rtol=1e-12)


@pytest.mark.parametrize("name", [n for n in _engine_names() if n != "mujoco_flex"])
def test_passive_every_follows_an_impact(name):
    """The engine option ``passive_every``: a jelly block thrown sideways lands on the ground at
    frame 5 of 10. Gathering the grid velocity every 4th substep instead of every one (the linear
    in time interpolation of :func:`gasp_core.toolkit.substeps.passive_schedule`) keeps the passive points to
    1e-3 dx of the per-substep run during the fall (velocity linear in time: exact but for f32
    rounding; measured 4.9e-5 dx) and within 0.05 dx through the impact and the sliding (measured
    0.0037 dx on both engines with the affine advance; 0.021 dx with straight lines between gathers)."""
    from gasp_core.seam.setup import Boundary
    runs = {}
    for every in (1, 4):
        s = block_with_skin()
        s = dataclasses.replace(s, boundaries=[Boundary("ground", height=0.4, friction=0.5)],
                                v=np.tile([0.5, 0.0, 0.0], (len(s.x), 1)), options={"threads": 1, "passive_every": every})
        e = build_engine(engines()[name], s)
        try:
            traj = []
            for _ in range(10):
                e.step_frame()
                traj.append(e.positions()[s.passive].astype(np.float64))
        finally:
            e.close()
        runs[every] = np.array(traj)
    d = np.linalg.norm(runs[4] - runs[1], axis=2).max(axis=1) / s.dx
    top = runs[1][:, :, 2].mean(axis=1)
    assert top.min() < 0.6 + 0.01 and runs[1][-1, :, 0].mean() > 0.55   # it reached the ground and moved on
    assert d[:4].max() < 1e-3, d
    assert 1e-3 < d.max() < 0.05, d


@pytest.mark.parametrize("name", [n for n in _engine_names() if n != "mujoco_flex"])
def test_stranded_passive_points_are_counted(name):
    """A passive point with no material within its stencil gathers no velocity: it stays put while
    the body falls away, and ``stats()["passive_stranded"]`` counts it (the skin on the block is
    not counted)."""
    s = block_with_skin()
    far = np.array([[0.2, 0.2, 0.8]])                              # 5 dx from the block's corner
    n = len(s.x) + 1
    s = dataclasses.replace(s, x=np.concatenate([far, s.x]), v=np.zeros((n, 3)), body_id=np.zeros(n, np.int64),
                            p_vol=np.r_[0.0, s.p_vol], passive=np.r_[True, s.passive], n_render=s.n_render + 1,
                            options={"threads": 1})
    e = build_engine(engines()[name], s)
    try:
        assert "passive_stranded" not in e.stats()                # before any frame
        for _ in range(3):
            e.step_frame()
        x = e.positions().astype(np.float64)
        st = e.stats()
    finally:
        e.close()
    assert st["passive_stranded"] == 1
    np.testing.assert_array_equal(x[0], far[0].astype(np.float32).astype(np.float64))   # not moved (f32)
    assert x[1:, 2][s.passive[1:]].mean() < 0.7 - 0.5 * G * 0.1 ** 2 * 0.9   # the skin fell with the block


def test_simulate_warns_about_stranded_passive_points(donut, write_scene, tmp_path, monkeypatch):
    """``gasp simulate`` passes the engine's ``passive_stranded`` on as a warning naming the count
    (the count itself is tested on the engines above; here the engine is made to report 5)."""
    needs_package("warp")
    from gasp_testing import scene_text
    from gasp_core.gs.io import write_gaussians
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.run.report import Reporter
    from gasp_core.scene.spec import load_scene
    from gasp_warp_mpm.solver import WarpMPMEngine
    ply = tmp_path / "donut_tiny.ply"
    write_gaussians(ply, donut.subset(np.arange(0, donut.n, 64)))
    scene = load_scene(write_scene(scene_text(ply, n_frames=2, n_grid=16, engine="warp_mpm", engine_options="{}",
                                              extra_object='surface = "passive"')))
    real = WarpMPMEngine.stats
    monkeypatch.setattr(WarpMPMEngine, "stats", lambda self: {**real(self), "passive_stranded": 5})
    reporter = Reporter()                     # keeps the run's events
    res = simulate_scene(scene, tmp_path / "out", reporter=reporter)
    said = [e["message"] for e in reporter.events if e["event"] == "warning"]
    assert res.summary["engine_stats"]["passive_stranded"] == 5
    n_passive = res.summary["n_render_points"]
    assert [m for m in said if m.startswith(f"5 of {n_passive} passive surface points")], said
