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
    from gasp_core.mpm.substeps import passive_schedule
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
    in time interpolation of :func:`gasp_core.mpm.substeps.passive_schedule`) keeps the passive points to
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
    """A passive point with no material within its stencil (stranded) falls freely (issue 55: such points stayed in the
    air as specks over the guitar's sand heap): after 0.1 s it is 0.5 g t^2 lower, within 2 %, and
    ``stats()["passive_stranded"]`` counts it (the skin on the block is not counted)."""
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
    drop = far[0, 2] - x[0, 2]
    assert drop == pytest.approx(0.5 * G * 0.1 ** 2, rel=0.02), drop               # free fall, not left in the air
    np.testing.assert_allclose(x[0, :2], far[0, :2], atol=1e-6)                   # straight down
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
    from gasp_warp_mpm.engine import WarpMPMEngine
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


#: Cells the marker skin of :func:`block_with_markers` lies outside the block's outer points: the draft README
#: donut's lowest surface vertex is 1.21 dx below its lowest fill point (its fill stops short of the surface).
MARKER_OFFSET = 1.2
#: Tolerance of a held marker on its face, in cells: far above the float32 rounding of the face's height
#: (2e-7 dx here), far below the 0.95 dx a marker of :func:`block_with_markers` would lie below the plane with the block
#: resting on its skin (measured without the rule: 1.1 dx below the ground, 0.12 dx beyond the wall).
HOLD_TOL = 1e-3


def block_with_markers(n_grid: int = 16) -> SimSetup:
    """A jelly block (material points at dx/2) thrown towards the +x wall above a ground (z = 0.2 m, frictionless),
    with passive markers ``MARKER_OFFSET`` dx outside its bottom and +x faces; walls on the domain's faces.
    ``passive_every`` 16, the largest allowed (two gathers in a frame of 22 substeps)."""
    from gasp_core.seam.setup import Boundary
    dx = 1.0 / n_grid
    x, p_vol = box_points([0.45, 0.4, 0.3], [0.65, 0.6, 0.45], dx / 2)
    g = np.linspace(0.42, 0.58, 5)
    off = MARKER_OFFSET * dx
    bottom = np.stack(np.meshgrid(np.linspace(0.47, 0.63, 5), g, [x[:, 2].min() - off], indexing="ij"), -1)
    side = np.stack(np.meshgrid([x[:, 0].max() + off], g, np.linspace(0.32, 0.43, 4), indexing="ij"), -1)
    mk = np.concatenate([bottom.reshape(-1, 3), side.reshape(-1, 3)])
    xs = np.concatenate([mk, x])
    return SimSetup(x=xs, v=np.tile([1.5, 0.0, 0.0], (len(xs), 1)), p_vol=np.r_[np.zeros(len(mk)), np.full(len(x), p_vol)],
                    body_id=0, materials=[JELLY], gravity=[0, 0, -G], domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=n_grid, frame_dt=1 / 30, n_render=len(mk), passive=np.r_[np.ones(len(mk), bool), np.zeros(len(x), bool)],
                    boundaries=[Boundary("ground", height=0.2, friction=0.0), Boundary("walls", friction=0.0)],
                    options={"threads": 1, "passive_every": 16})


def _markers_run(name: str, n_frames: int = 8, s: SimSetup | None = None) -> tuple[np.ndarray, str]:
    """The markers' positions per frame (frames, m, 3) and the divergence message ('' when the run finished) of
    ``s`` (default :func:`block_with_markers`)."""
    from gasp_core.errors import EngineDivergence
    s = block_with_markers() if s is None else s
    e = build_engine(engines()[name], s)
    traj, err = [], ""
    try:
        for _ in range(n_frames):
            e.step_frame()
            traj.append(e.positions()[s.passive].astype(np.float64))
    except EngineDivergence as ex:
        err = str(ex)
    finally:
        e.close()
    return np.array(traj), err


def _markers_held(traj: np.ndarray, err: str, dx: float) -> list[str]:
    """What is wrong with a run of :func:`block_with_markers` (empty: nothing): the run must finish, and over the
    frames the lowest marker must be on the ground (0.2 m) and the farthest on the +x wall's face (13 dx: the
    particle contact's plane, 3 dx inside the domain's face; 14 dx with the grid rule,
    ``gasp_core.mpm.points.passive_bounds``), each within ``HOLD_TOL`` dx: none past the face, and held on it,
    not short of it (a rule holding them at the material's skin or at a wrong height fails too)."""
    if err:
        return [f"diverged: {err[:120]}"]
    z_lo, x_hi = float(traj[:, :, 2].min()), float(traj[:, :, 0].max())
    bad = []
    if abs(z_lo - 0.2) > HOLD_TOL * dx:
        bad.append(f"lowest marker {(z_lo - 0.2) / dx:+.4f} dx from the ground")
    if abs(x_hi - 13 * dx) > HOLD_TOL * dx:
        bad.append(f"farthest marker {(x_hi - 13 * dx) / dx:+.4f} dx from the wall's face")
    return bad


@pytest.mark.parametrize("name", [n for n in _engine_names() if n != "mujoco_flex"])
def test_passive_points_are_held_by_the_ground_and_walls(name):
    """Passive markers 1.2 dx outside a block's fill (as on the draft README donut, whose markers sank through the
    ground and left the grid at frame 8): the block, thrown at 1.5 m/s, hits the +x wall and lands on the ground;
    one gather a frame. No marker goes below the ground or beyond the wall's face (``passive_bounds``), the
    markers that reach them lie on them, and the run finishes."""
    traj, err = _markers_run(name)
    assert _markers_held(traj, err, 1 / 16) == []


@pytest.mark.parametrize("name", [n for n in _engine_names() if n != "mujoco_flex"])
def test_a_ground_below_the_walls_floor_plane_is_the_markers_floor(name):
    """Round 97: the ground 1.6 dx above the domain's bottom, under the walls' floor plane (3 dx up), with the
    particle contact, whose planes have no floor face where there is a ground (``contact.wall_faces``, round 58). The
    markers under the block land on the ground with it, not on the floor's plane 1.4 dx above it (measured before:
    the lowest marker +1.4000 dx from the ground on both engines, held on the floor's plane while the block rested on
    the ground)."""
    from gasp_core.seam.setup import Boundary
    s = block_with_markers()
    s = dataclasses.replace(s, boundaries=[Boundary("ground", height=0.1, friction=0.0), Boundary("walls", friction=0.0)])
    traj, err = _markers_run(name, s=s)
    assert not err, err
    assert abs(float(traj[:, :, 2].min()) - 0.1) <= HOLD_TOL / 16, (float(traj[:, :, 2].min()) - 0.1) * 16


@pytest.mark.parametrize("name", [n for n in _engine_names() if n != "mujoco_flex"])
def test_the_hold_check_catches_an_engine_without_the_rule(name, monkeypatch):
    """The same run with the rule taken out of the engine (its box made unbounded): the markers sink 1.1 dx into the
    ground and cross the wall's face by 0.12 dx (measured on both engines), and the check says so."""
    unbounded = lambda setup, contact="grid": (np.full(3, -np.inf), np.full(3, np.inf))      # noqa: E731
    module = {"warp_mpm": "gasp_warp_mpm.engine", "taichi_mpm": "gasp_taichi_mpm.engine"}[name]
    monkeypatch.setattr(f"{module}.passive_bounds", unbounded)
    traj, err = _markers_run(name)
    bad = _markers_held(traj, err, 1 / 16)
    assert any("from the ground" in b for b in bad) and any("wall's face" in b for b in bad), bad


def test_passive_bounds_and_hold_passive():
    """The box of ``passive_bounds`` (ground: its height; walls: their planes, 3 dx in from each face, with either
    contact model since round 32) and ``hold_passive``'s projection (velocity into a face removed)."""
    from gasp_core.seam.setup import Boundary
    from gasp_core.mpm.points import hold_passive, passive_bounds
    s = block_with_skin()                                          # n_grid 24 on [0, 1]^3, no boundary
    lo, hi = passive_bounds(s)
    assert np.all(np.isinf(lo)) and np.all(np.isinf(hi)) and np.all(lo < 0) and np.all(hi > 0)
    s = dataclasses.replace(s, boundaries=[Boundary("ground", height=0.3), Boundary("ground", height=0.25),
                                           Boundary("walls"), Boundary("fixed_region", lo=(0, 0, 0), hi=(0.1, 0.1, 0.1))])
    lo, hi = passive_bounds(s, "grid")
    np.testing.assert_allclose(lo, [3 / 24, 3 / 24, 0.3], rtol=1e-12)
    np.testing.assert_allclose(hi, [21 / 24] * 3, rtol=1e-12)
    lo3, hi3 = passive_bounds(s, "particle")   # the particle contact: the same planes
    np.testing.assert_allclose(lo3, lo, rtol=1e-12)
    np.testing.assert_allclose(hi3, hi, rtol=1e-12)
    low = dataclasses.replace(s, boundaries=[Boundary("ground", height=0.05), Boundary("walls")])
    for contact in ("grid", "particle"):   # round 97: a ground under the floor's plane (3/24) is the floor for both
        assert passive_bounds(low, contact)[0][2] == 0.05
    x = np.array([[0.5, 0.5, 0.2], [0.95, 0.5, 0.5], [0.5, 0.5, 0.5]])
    v = np.array([[1.0, 0.0, -2.0], [3.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
    xh, vh = hold_passive(x, v, lo, hi)
    np.testing.assert_array_equal(xh, [[0.5, 0.5, 0.3], [21 / 24, 0.5, 0.5], [0.5, 0.5, 0.5]])
    np.testing.assert_array_equal(vh, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0]])
    xh, vh = hold_passive(x[:1], [[0.0, 0.0, 2.0]], lo, hi)         # leaving the ground: kept
    np.testing.assert_array_equal(vh, [[0.0, 0.0, 2.0]])
