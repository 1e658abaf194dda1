"""Tests of the warp_mpm engine against physics with known answers (docs/mpm.md).

Small scenes (n_grid 16-32, about 1-4 thousand points) so that the file runs in well under a
minute on two cores once the kernels are compiled (first compile: about 10 s per precision).
"""
import importlib.util
import subprocess
import sys

import numpy as np
import pytest

from gasp_core.seam import (Boundary, build_engine, EngineDivergence, EngineError, Material, SceneError,
                           SimSetup)

pytest.importorskip("warp")
from gasp_warp_mpm import gasp_engines  # noqa: E402

G = 9.81
FRAME_DT = 1.0 / 30.0


def build(setup):
    """The engine as the core builds it: options checked and completed first (``build_engine``)."""
    return build_engine(gasp_engines()[0], setup)


def block(n_side, lo, size):
    """Points on a regular n_side^3 lattice filling the cube [lo, lo + size], and their volume."""
    g = (np.arange(n_side) + 0.5) / n_side * size
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3) + np.asarray(lo, float)
    return x, (size / n_side) ** 3


def make_setup(material="jelly", n_side=12, lo=(0.35, 0.35, 0.3), size=0.3, n_grid=16,
               boundaries=(), gravity=(0.0, 0.0, -G), v=(0.0, 0.0, 0.0), options=None, **mat):
    x, p_vol = block(n_side, lo, size)
    mat.setdefault("E", 5e4)
    return SimSetup(x=x, v=np.broadcast_to(v, x.shape), p_vol=p_vol, body_id=0,
                    materials=[Material(material, **mat)], gravity=np.array(gravity),
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid,
                    boundaries=list(boundaries), frame_dt=FRAME_DT, options=dict(options or {}))


def run(setup, n_frames):
    e = build(setup)
    for _ in range(n_frames):
        e.step_frame()
    return e


def test_registered_and_lazy():
    from gasp_core.seam.plugins import engines
    info = engines()["warp_mpm"]
    assert info.distribution == "gasp-warp-mpm"
    assert info.unavailable_reason() is None
    assert {"grid", "initial_C"} <= info.capabilities.features and "sand" in info.capabilities.materials
    assert info.deterministic_options == {}  # Warp's CPU kernels run on one thread
    settings, reference = info.sweep(True)
    assert reference not in settings and all(s["precision"] == "f32" for s in settings)
    code = "import sys, gasp_warp_mpm; assert 'warp' not in sys.modules, 'warp imported eagerly'"
    subprocess.run([sys.executable, "-c", code], check=True)


def test_svd3_convention():
    """wp.svd3 gives proper rotations U, V and puts a reflection's sign on sig[2] (docs/mpm.md)."""
    import warp as wp
    from gasp_warp_mpm.kernels import build_kernels
    k = build_kernels(wp.float64)
    rng = np.random.default_rng(1)
    A = np.eye(3) + 0.3 * rng.standard_normal((64, 3, 3))
    A[::2] = A[::2] @ np.diag([1.0, 1.0, -1.0])  # half of them reflections
    U, sig, V = k.svd(A)
    assert np.allclose(np.linalg.det(U), 1.0, atol=1e-9) and np.allclose(np.linalg.det(V), 1.0, atol=1e-9)
    assert np.allclose(U @ (sig[:, :, None] * np.swapaxes(V, 1, 2)), A, atol=1e-9)
    assert np.all(np.sign(sig[:, 2]) == np.sign(np.linalg.det(A)))
    assert np.all(sig[:, 0] >= sig[:, 1]) and np.all(sig[:, 1] >= np.abs(sig[:, 2]))


@pytest.mark.parametrize("nu", [0.3, -0.3])
def test_free_fall_com(nu):
    """No floor: the centre of mass falls g t^2 / 2 (within 1 %) in t = 0.2 s; x, y stay.

    An auxetic material (nu < 0, within SimSetup's -1 < nu < 0.5) is accepted and falls alike."""
    s = make_setup(lo=(0.35, 0.35, 0.6), options={"n_substeps": 40}, nu=nu)
    e = build(s)
    c0 = e.positions().mean(axis=0)
    for _ in range(6):
        e.step_frame()
    c = e.positions().mean(axis=0)
    t = 6 * FRAME_DT
    drop = c0[2] - c[2]
    assert abs(drop - 0.5 * G * t * t) < 0.01 * 0.5 * G * t * t, drop
    assert np.allclose(c[:2], c0[:2], atol=1e-5)
    assert abs(e.velocities()[:, 2].mean() + G * t) < 0.01 * G * t


def test_block_rests_on_ground():
    """A block dropped 0.1 m onto the ground stays above it (no point lower than height - dx) and
    after 3 s rests there: centre of mass within dx of height + size / 2, mean speed below 10 %
    of the impact speed sqrt(2 g 0.1)."""
    h, size = 0.1, 0.3
    s = make_setup(lo=(0.35, 0.35, 0.2), size=size, E=2e5,
                   boundaries=[Boundary("ground", height=h, friction=0.5)])
    e = build(s)
    lowest = np.inf
    for _ in range(90):
        e.step_frame()
        lowest = min(lowest, float(e.positions()[:, 2].min()))
    assert lowest > h - s.dx
    assert abs(e.positions()[:, 2].mean() - (h + size / 2)) < s.dx
    assert np.linalg.norm(e.velocities(), axis=1).mean() < 0.1 * np.sqrt(2 * G * 0.1)


def test_momentum_conserved_in_free_flight():
    """No gravity, no boundary: total linear momentum of a spinning, moving block is conserved."""
    x, p_vol = block(12, (0.35, 0.35, 0.35), 0.3)
    r = x - x.mean(axis=0)
    v = np.array([0.3, -0.2, 0.1]) + np.cross([0.0, 0.0, 2.0], r)
    s = SimSetup(x=x, v=v, p_vol=p_vol, body_id=0, materials=[Material("jelly", E=5e4)],
                 gravity=np.zeros(3), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16,
                 frame_dt=FRAME_DT, options={"precision": "f64"})
    p0 = (s.p_mass[:, None] * v).sum(axis=0)
    e = run(s, 5)
    p1 = (s.p_mass[:, None] * e.velocities()).sum(axis=0)
    assert np.allclose(p1, p0, rtol=0, atol=1e-9 * np.abs(p0).max())


@pytest.mark.parametrize("material", ["jelly", "neo_hookean", "metal", "sand", "snow",
                                      "plasticine", "liquid", "brittle"])
def test_every_material_runs_finite(material):
    s = make_setup(material, n_side=8, boundaries=[Boundary("ground", height=0.1), Boundary("walls")],
                   lo=(0.35, 0.35, 0.15), E=2e4, tensile_strength=500.0)
    e = run(s, 10)
    x, v = e.positions(), e.velocities()
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(v))
    assert x[:, 2].min() > 0.1 - s.dx
    st = e.stats()
    assert st["n_points"] == len(s.x) and st["n_grid"] == 16 and st["precision"] == "f32"
    assert st["n_substeps"] * st["dt"] == pytest.approx(FRAME_DT)


def test_sand_spreads_jelly_does_not():
    """A sand column collapses and spreads on the ground; the same jelly column keeps its width."""
    def spread(material):
        s = make_setup(material, n_side=10, lo=(0.4, 0.4, 0.1), size=0.2, n_grid=32,
                       boundaries=[Boundary("ground", height=0.1, friction=0.5)], E=2e5)
        x0 = s.x.copy()
        x = run(s, 20).positions()
        return np.ptp(x[:, 0]) / np.ptp(x0[:, 0]), x[:, 2].max() / x0[:, 2].max()

    sand_w, sand_h = spread("sand")
    jelly_w, _ = spread("jelly")
    assert sand_w > 1.3 and sand_h < 0.9, (sand_w, sand_h)
    assert jelly_w < 1.1, jelly_w


def test_fixed_region_holds():
    """A cantilever: points starting in the fixed box do not move; the free end sags."""
    x, p_vol = block(10, (0.0, 0.0, 0.0), 1.0)
    x = x * np.array([0.5, 0.1, 0.1]) + np.array([0.2, 0.45, 0.6])
    fixed = Boundary("fixed_region", lo=(0.0, 0.0, 0.0), hi=(0.3, 1.0, 1.0))
    s = SimSetup(x=x, v=np.zeros(3), p_vol=p_vol * 0.005, body_id=0, materials=[Material("jelly", E=1e5)],
                 gravity=np.array([0.0, 0.0, -G]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                 n_grid=32, boundaries=[fixed], frame_dt=FRAME_DT)
    held = np.all((x >= 0.0) & (x <= [0.3, 1.0, 1.0]), axis=1)
    assert 0 < held.sum() < len(x)
    y = run(s, 10).positions()
    assert np.array_equal(y[held], x[held].astype(y.dtype))
    tip = x[:, 0] > 0.65
    assert (y[tip, 2] - x[tip, 2]).mean() < -0.01


def test_a_point_leaving_the_grid_drops_out_and_a_fast_one_diverges():
    """A block flying sideways at 3 m/s with no walls leaves the grid (x > lo + (n_grid - 1.5) dx = 0.906 m): its
    points stay where they left, out of the transfers, and the run goes on (feature left_domain; the count:
    tests/test_left_domain.py). The same block at 100 m/s with one substep a frame moves more than a cell a substep: a blow-up."""
    s = make_setup(lo=(0.6, 0.35, 0.35), v=(3.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0))
    e = build(s)
    for _ in range(8):
        e.step_frame()
    x = e.positions()
    line = (16 - 1.5) / 16
    assert (x[:, 0] >= line).all() and (x[:, 0] < line + 3.0 * e.dt + 1e-6).all()
    e.step_frame()
    np.testing.assert_array_equal(e.positions(), x)
    fast = build(make_setup(lo=(0.6, 0.35, 0.35), v=(100.0, 0.0, 0.0), gravity=(0.0, 0.0, 0.0),
                            options={"n_substeps": 1}))
    with pytest.raises(EngineDivergence) as info:
        for _ in range(2):       # counted by the next frame's P2G
            fast.step_frame()
    assert "time step" in info.value.cause


def test_huge_dt_diverges():
    # the grid contact: the particle contact would shorten the hand-set step to its own stable one (issue 38)
    s = make_setup(E=1e7, boundaries=[Boundary("ground", height=0.1)], options={"dt": FRAME_DT, "contact": "grid"})
    e = build(s)
    with pytest.raises(EngineDivergence) as info:
        for _ in range(30):
            e.step_frame()
    assert 1 <= info.value.frame == e.frame
    assert info.value.cause


def test_bit_identical_runs_on_cpu():
    def once():
        s = make_setup("sand", n_side=10, lo=(0.4, 0.4, 0.1), size=0.2,
                       boundaries=[Boundary("ground", height=0.1), Boundary("walls")])
        return run(s, 8).positions()

    assert np.array_equal(once(), once())


def test_bad_options():
    with pytest.raises(SceneError, match="bogus"):
        build(make_setup(options={"bogus": 1}))
    with pytest.raises(SceneError, match="precision"):
        build(make_setup(options={"precision": "f16"}))
    with pytest.raises(SceneError, match="option dt=-1.0"):
        build(make_setup(options={"dt": -1.0}))
    with pytest.raises(SceneError, match="device='gpu'"):
        build(make_setup(options={"device": "gpu"}))
    with pytest.raises(SceneError, match="not both"):
        build(make_setup(options={"dt": 1e-4, "n_substeps": 10}))
    build(make_setup(options={"threads": 2, "cfl": 0.3}))  # accepted


def test_material_it_lacks_is_refused_by_the_core():
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    with pytest.raises(SceneError, match="material 'rigid'"):
        build_engine(engines()["warp_mpm"], make_setup("rigid"))


def test_cuda_without_device():
    import warp as wp
    wp.init()
    if wp.is_cuda_available():
        pytest.skip("a CUDA device is present")
    with pytest.raises(EngineError, match="cuda"):
        build(make_setup(options={"device": "cuda"}))
    with pytest.raises(EngineError, match="cuda:1"):
        build(make_setup(options={"device": "cuda:1"}))


def test_f64_matches_f32():
    s32 = make_setup(boundaries=[Boundary("ground", height=0.1)])
    s64 = make_setup(boundaries=[Boundary("ground", height=0.1)], options={"precision": "f64"})
    x32, x64 = run(s32, 10).positions(), run(s64, 10).positions()
    assert x64.dtype == np.float64 and x32.dtype == np.float32
    assert np.abs(x32 - x64).max() < 1e-4 * 0.3


@pytest.mark.skipif(importlib.util.find_spec("gasp_taichi_mpm") is None,
                    reason="gasp-taichi-mpm is not installed")
def test_agrees_with_taichi_mpm():
    """Same jelly scene on both MPM plugins (ground, n_grid 32, 1 s): positions agree to 1e-3 of
    the block size (docs/mpm.md, conformance requirement)."""
    pytest.importorskip("taichi")
    from gasp_taichi_mpm import gasp_engines as taichi_engines
    size = 0.3
    s = make_setup(n_side=10, lo=(0.35, 0.35, 0.25), size=size, n_grid=32,
                   boundaries=[Boundary("ground", height=0.1, friction=0.5)],
                   options={"threads": 1})
    ew, et = build(s.replace(options=dict(s.options))), build_engine(taichi_engines()[0], s)
    for _ in range(30):
        ew.step_frame()
        et.step_frame()
    diff = np.abs(ew.positions().astype(np.float64) - et.positions().astype(np.float64)).max()
    print(f"warp_mpm vs taichi_mpm after 1 s: max |dx| = {diff:.3g} m = {diff / size:.3g} x size")
    assert diff < 1e-3 * size


def test_contact_coefficients_follow_the_points_when_they_are_resorted():
    """Each point keeps its own particle-contact coefficients (stiffness, damping, skin) after the CPU re-sort by
    cell and after a state restore (they differ between points of different volumes; before this, the re-sort
    permuted x, v, F, ... but not them)."""
    from gasp_core.testing.helpers import make_setup, sphere_points
    from gasp_core.mpm.contact import contact_coefficients
    rng = np.random.default_rng(3)
    x, p_vol = sphere_points((0.5, 0.5, 0.2), 0.08, 0.02)
    p_vol = p_vol * rng.uniform(0.3, 1.0, len(x))          # coefficients differ point to point
    setup = make_setup(x, p_vol, Material("jelly", E=2e4, nu=0.3, rho=300.0), n_grid=16,
                       boundaries=[Boundary("ground", height=0.1, friction=0.5)], v=(0.3, 0.1, -1.0),
                       options={"contact": "particle"})
    eng = build_engine(gasp_engines()[0], setup)
    try:
        for _ in range(4):
            eng.step_frame()
        assert not np.array_equal(eng._order, np.arange(len(x)))   # the points were re-sorted
        want = contact_coefficients(setup)[eng._order]
        assert np.allclose(eng.p_contact.numpy(), want, rtol=1e-6)
        state = eng.get_state()
        eng._order = eng._order[::-1].copy()
        eng.set_state(state)
        assert np.allclose(eng.p_contact.numpy(), contact_coefficients(setup)[eng._order], rtol=1e-6)
    finally:
        eng.close()
