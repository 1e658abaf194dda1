"""Tests of the ``mujoco_flex`` engine plugin: lattice, embedding, physics with known answers, real data."""
from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from gasp_core.seam import Boundary, build_engine, EngineDivergence, Material, SceneError, SimSetup

mujoco = pytest.importorskip("mujoco")

from gasp_mujoco_flex import CAPABILITIES  # noqa: E402
from gasp_mujoco_flex import gasp_engines  # noqa: E402
from gasp_mujoco_flex.lattice import build_lattice, embed_points, interpolate  # noqa: E402

def build(setup):
    """The engine as the core builds it: options checked and completed first (``build_engine``)."""
    return build_engine(gasp_engines()[0], setup)


G = 9.81
DONUT = Path(__file__).resolve().parents[3] / "examples" / "data" / "donut_v3dg.ply"


def block_points(n=6, size=0.1, z0=0.3, x0=0.0):
    """Points on a regular n^3 grid filling a cube of side ``size`` whose bottom is at ``z0``."""
    g = (np.arange(n) + 0.5) / n * size
    x = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    x[:, :2] -= size / 2
    x[:, 0] += x0
    x[:, 2] += z0
    return x


def make_setup(x, material, boundaries=(), v=0.0, p_vol=1e-6, **options):
    return SimSetup(x=x, v=v, p_vol=p_vol, body_id=0, materials=[material],
                    gravity=[0.0, 0.0, -G], domain_lo=[-1, -1, -1], domain_hi=[1, 1, 1],
                    frame_dt=1 / 30, boundaries=list(boundaries), options={"cells_across": 4, **options})


JELLY = Material("jelly", E=1e5, nu=0.3, rho=1000.0)


# ----------------------------------------------------------------------------- plugin
def test_plugin_is_registered_and_import_is_lazy():
    from gasp_core.seam.plugins import engines
    info = engines()["mujoco_flex"]
    assert info.capabilities == CAPABILITIES
    assert info.capabilities.materials == {"jelly", "metal", "rigid"}
    assert "grid" not in info.capabilities.features
    settings, reference = info.sweep(False)
    assert reference == {"cells_across": 16, "cfl": 0.25, "core_fraction": 1.0} and reference not in settings
    assert info.unavailable_reason() is None
    code = "import sys, gasp_mujoco_flex; print('mujoco' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# ----------------------------------------------------------------------------- lattice
def test_lattice_is_conforming_and_covers_a_hollow_shell():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(4000, 3))
    x *= 0.1 / np.linalg.norm(x, axis=1, keepdims=True)            # points on a sphere shell only
    lat = build_lattice(x, 0.025)
    # the interior was filled: the centre cell is occupied
    c = np.floor((np.zeros(3) - lat.origin) / lat.h).astype(int)
    assert lat.occupied[tuple(c)]
    # every tet has volume h^3/6 (no degenerate or duplicated corner)
    V = lat.vertices[lat.tets]
    vol = np.abs(np.einsum("ij,ij->i", np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]), V[:, 3] - V[:, 0])) / 6
    np.testing.assert_allclose(vol, lat.h ** 3 / 6, rtol=1e-9)
    # conforming: each triangular face is shared by at most two tets, and the boundary faces form a
    # closed surface (each boundary edge is shared by an even number of boundary faces)
    faces = np.sort(np.concatenate([lat.tets[:, [0, 1, 2]], lat.tets[:, [0, 1, 3]],
                                    lat.tets[:, [0, 2, 3]], lat.tets[:, [1, 2, 3]]]), axis=1)
    _, counts = np.unique(faces, axis=0, return_counts=True)
    assert counts.max() == 2
    uniq, counts = np.unique(faces, axis=0, return_counts=True)
    boundary = uniq[counts == 1]
    edges = np.sort(np.concatenate([boundary[:, [0, 1]], boundary[:, [1, 2]], boundary[:, [0, 2]]]), axis=1)
    _, ecount = np.unique(edges, axis=0, return_counts=True)
    assert np.all(ecount % 2 == 0)
    # embedding: inside points have weights in [0, 1] and are reproduced exactly
    tet, w = embed_points(lat, x)
    assert w.min() >= -1e-12 and w.max() <= 1 + 1e-12
    np.testing.assert_allclose(interpolate(lat.vertices, lat.tets, tet, w), x, atol=1e-12)
    # points outside any occupied cell: extrapolated weights, still exact
    y = x * 1.5
    tet, w = embed_points(lat, y)
    assert w.min() < 0
    np.testing.assert_allclose(interpolate(lat.vertices, lat.tets, tet, w), y, atol=1e-12)


def test_embedding_exact_at_rest_flex_and_rigid():
    x = np.concatenate([block_points(z0=0.3), block_points(n=5, z0=0.3, x0=0.3)])
    body = np.r_[np.zeros(216, np.int32), np.ones(125, np.int32)]
    s = SimSetup(x=x, v=0.0, p_vol=1e-6, body_id=body, materials=[JELLY, Material("rigid", rho=500)],
                 gravity=[0, 0, -G], domain_lo=[-1, -1, -1], domain_hi=[1, 1, 1],
                 options={"cells_across": 4})
    e = build(s)
    np.testing.assert_allclose(e.positions(), x, atol=1e-9, rtol=0)
    np.testing.assert_allclose(e.velocities(), 0.0, atol=1e-12)
    st = e.stats()
    assert st["n_points"] == len(x) and st["n_tets"] > 0 and st["n_rigid_boxes"] > 0
    assert st["device"] == "cpu" and st["precision"] == "f64"
    e.close()


# ----------------------------------------------------------------------------- physics
def test_free_fall_of_elastic_block():
    x = block_points(z0=0.5)
    e = build(make_setup(x, JELLY))
    c0 = e.positions().mean(axis=0)
    n_frames = 6                                  # 0.2 s
    for _ in range(n_frames):
        e.step_frame()
    t = n_frames / 30
    c = e.positions().mean(axis=0)
    expected = 0.5 * G * t * t
    assert abs((c0[2] - c[2]) / expected - 1.0) < 0.01
    assert np.abs(c[:2] - c0[:2]).max() < 1e-9
    # no deformation in free fall: the shape is translated rigidly
    np.testing.assert_allclose(e.positions() - (c - c0), x, atol=1e-6)
    np.testing.assert_allclose(e.velocities()[:, 2].mean(), -G * t, rtol=0.01)


@pytest.mark.parametrize("material", [JELLY, Material("rigid", rho=500)], ids=["flex", "rigid"])
def test_positions_are_current_after_every_frame(material):
    """After ``step_frame`` positions belong to the same state as the velocities: frame k's drop is
    exactly what MuJoCo's semi-implicit Euler gives, g (kT)^2/2 (1 + 1/(kN)) (the sum of n g dt^2 over
    the kN substeps). Before the fix they were one substep late (xpos / flexvert_xpos are computed
    before mj_step integrates): -1/N against g T^2/2, -2/N against this (issue 17, item 3)."""
    x = block_points(z0=0.5)
    e = build(make_setup(x, material))
    n, dt = e.stats()["n_substeps"], e.stats()["dt"]
    for k in (1, 2):
        e.step_frame()
        drop = x[:, 2].mean() - e.positions()[:, 2].mean()
        assert drop == pytest.approx(G * dt ** 2 * (k * n) * (k * n + 1) / 2, rel=1e-9), (k, n)
        np.testing.assert_allclose(e.velocities()[:, 2], -G * k * n * dt, rtol=1e-9)


def test_elastic_block_settles_on_ground():
    x = block_points(z0=0.15)
    e = build(make_setup(x, JELLY, [Boundary("ground", height=0.0, friction=0.5)]))
    h = e.stats()["cell_size"][0]
    for _ in range(24):                            # 0.8 s (lands at about 0.17 s)
        e.step_frame()
    p, v = e.positions(), e.velocities()
    assert np.all(np.isfinite(p)) and np.all(np.isfinite(v))
    assert p[:, 2].min() > -h
    assert p[:, 2].min() < h                               # it fell onto the ground (lattice margin < h)
    assert np.abs(v).max() < 1e-3                          # at rest
    # elastic: it rests near its rest shape (height within 20 %)
    assert abs(np.ptp(p[:, 2]) / np.ptp(x[:, 2]) - 1) < 0.2


def test_fixed_region_holds_pinned_points():
    g = (np.arange(12) + 0.5) / 12 * 0.3
    gy = (np.arange(4) + 0.5) / 4 * 0.1
    x = np.stack(np.meshgrid(g, gy, gy, indexing="ij"), -1).reshape(-1, 3)
    x[:, 2] += 0.3
    fixed = Boundary("fixed_region", lo=(0.0, 0.0, 0.3), hi=(0.05, 0.1, 0.4))
    e = build(make_setup(x, JELLY, [fixed], cells_across=10))
    inside = np.all((x >= fixed.lo) & (x <= fixed.hi), axis=1)
    assert 0 < inside.sum() < len(x)
    for _ in range(10):
        e.step_frame()
    p = e.positions()
    np.testing.assert_allclose(p[inside], x[inside], atol=1e-9, rtol=0)
    assert (p[:, 2] - x[:, 2]).min() < -0.005        # the free end sags under gravity
    assert np.all(np.isfinite(p))


def test_rigid_body_falls_and_rests():
    x = block_points(z0=0.2)
    e = build(make_setup(x, Material("rigid", rho=500), [Boundary("ground")]))
    h = max(np.ptp(x, axis=0)) / 4
    d0 = np.linalg.norm(x[:, None] - x[None, ::17], axis=-1)
    for _ in range(3):                             # 0.1 s of free fall
        e.step_frame()
    np.testing.assert_allclose(x[:, 2].mean() - e.positions()[:, 2].mean(), 0.5 * G * 0.1 ** 2, rtol=0.02)
    for _ in range(27):
        e.step_frame()
    p, v = e.positions(), e.velocities()
    assert p[:, 2].min() > -0.01 * h and p[:, 2].min() < h   # resting on the ground, not above it
    assert np.abs(v).max() < 1e-3
    np.testing.assert_allclose(np.linalg.norm(p[:, None] - p[None, ::17], axis=-1), d0, atol=1e-9)


def test_metal_compiles_with_von_mises_plasticity():
    m = Material("metal", E=1e6, nu=0.3, rho=1000.0, yield_stress=1e3)
    e = build(make_setup(block_points(z0=0.3), m))
    assert e.model.flex_plasticmode[0] & 2                       # stretching is plastic
    np.testing.assert_allclose(e.model.flex_yield[0, 0], m.yield_stress / m.E)


# ----------------------------------------------------------------------------- errors
def test_unknown_option_is_a_scene_error_naming_it():
    with pytest.raises(SceneError, match="n_grid_typo"):
        build(make_setup(block_points(), JELLY, n_grid_typo=3))


@pytest.mark.parametrize("key,value", [("dt", -1.0), ("cell_size", 0.0), ("device", "cuda"),
                                       ("integrator", "implicitfast"), ("dt", 1.0)])
def test_bad_option_values_are_scene_errors(key, value):
    with pytest.raises(SceneError, match=key):
        build(make_setup(block_points(), JELLY, **{key: value}))


def test_unsupported_material_is_refused_by_the_core():
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    with pytest.raises(SceneError, match="material 'sand'"):
        build_engine(engines()["mujoco_flex"], make_setup(block_points(), Material("sand")))


def test_initial_velocity_gradient_is_not_asked_of_a_non_grid_engine():
    """SimSetup.C is for grid engines; mujoco_flex carries a rotation in the point velocities."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    x = block_points()
    w = np.array([0.0, 0.0, np.pi])
    C = np.broadcast_to(np.array([[0, -w[2], 0], [w[2], 0, 0], [0, 0, 0]]), (len(x), 3, 3))
    s = make_setup(x, JELLY, v=np.cross(w, x - x.mean(0))).replace(C=C)
    e = build_engine(engines()["mujoco_flex"], s)
    r = x - x.mean(0)
    lz = np.cross(r, e.velocities())[:, 2].sum() / np.cross(r, s.v)[:, 2].sum()
    assert 0.8 < lz < 1.2, lz  # the spin reaches the lattice through the point velocities


def test_negative_poisson_ratio_is_a_scene_error():
    """MuJoCo's flex elasticity takes 0 <= nu < 0.5 ("Poisson ratio must be in [0, 0.5)"): declared as a
    limit (gasp_mujoco_flex.LIMITS), refused by the core before the factory, a rigid body's nu unread."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    info = engines()["mujoco_flex"]
    with pytest.raises(SceneError, match=r"engine 'mujoco_flex': material 'jelly': nu=-0.3; this engine takes "
                                         r"nu >= 0 \(MuJoCo's flex elasticity\)"):
        build_engine(info, make_setup(block_points(), Material("jelly", E=1e5, nu=-0.3, rho=1000.0)))
    with pytest.raises(SceneError, match=r"yield_stress = 0.0; expected a finite number > 0"):   # the core's own rule
        build_engine(info, make_setup(block_points(), Material("metal", E=1e5, yield_stress=0.0)))
    build_engine(info, make_setup(block_points(), Material("rigid", nu=-0.3))).close()


def test_absurd_dt_raises_engine_divergence_not_nan(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    e = build(make_setup(block_points(), JELLY, [Boundary("ground")], dt=1 / 30))
    with pytest.raises(EngineDivergence) as info:
        for _ in range(30):
            e.step_frame()
            assert np.all(np.isfinite(e.positions()))
    assert info.value.frame >= 1 and info.value.cause
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()       # MuJoCo's warning went into the exception


def test_euler_blow_up_raises_engine_divergence():
    e = build(make_setup(block_points(), JELLY, [Boundary("ground")], integrator="Euler", dt=1e-2))
    with pytest.raises(EngineDivergence):
        for _ in range(30):
            e.step_frame()


# ----------------------------------------------------------------------------- real data
@pytest.mark.skipif(not DONUT.exists(), reason=f"real data missing: {DONUT}")
def test_donut_drops_lands_and_rests():
    from plyfile import PlyData
    v = PlyData.read(str(DONUT))["vertex"]
    x = np.stack([v["x"], v["y"], v["z"]], axis=1).astype(np.float64)
    assert len(x) == 45624
    x[:, 2] += 0.05                                          # lifted 5 cm
    s = SimSetup(x=x, v=0.0, p_vol=1e-7, body_id=0, materials=[JELLY], gravity=[0, 0, -G],
                 domain_lo=[-0.5, -0.5, -0.1], domain_hi=[0.5, 0.5, 0.5], frame_dt=1 / 30,
                 boundaries=[Boundary("ground", height=0.0, friction=0.5)])
    e = build(s)
    np.testing.assert_allclose(e.positions(), x, atol=1e-9, rtol=0)
    h = e.stats()["cell_size"][0]
    t0 = time.perf_counter()
    n_frames = 20
    for _ in range(n_frames):
        e.step_frame()
    fps = n_frames / (time.perf_counter() - t0)
    p, vel = e.positions(), e.velocities()
    assert np.all(np.isfinite(p))
    assert p[:, 2].min() > -h                                # nothing sank through the ground
    drop = x[:, 2].mean() - p[:, 2].mean()
    assert 0.5 * (x[:, 2].min() - 0.0) < drop < x[:, 2].min() + h   # it landed, not hovering, not sunk
    assert np.abs(vel).max() < 1e-2                          # at rest
    print(f"donut: {e.stats()['n_lattice_vertices']} lattice vertices, {e.stats()['n_tets']} tets, "
          f"h = {h:.4f} m, dt = {e.stats()['dt']:.3g} s, {fps:.2f} frames/s")


def test_metal_keeps_a_permanent_dent_where_jelly_springs_back():
    """Same E and impact (3 m/s onto the ground): von Mises yield leaves the block squashed."""
    x = block_points(z0=0.02)
    shape = {}
    for m in (Material("jelly", E=1e6, nu=0.3, rho=1000.0),
              Material("metal", E=1e6, nu=0.3, rho=1000.0, yield_stress=1e3)):
        # p_vol: each point stands for its (0.1 m / 6)^3 cube, so the block weighs rho (0.1 m)^3 = 1 kg
        # (the engine simulates sum rho p_vol: with 1e-6 m^3 per point it would be 0.216 kg)
        e = build(make_setup(x, m, [Boundary("ground")], v=[0.0, 0.0, -3.0], p_vol=(0.1 / 6) ** 3,
                                   cells_across=3))
        for _ in range(10):
            e.step_frame()
        p = e.positions()
        assert np.abs(e.velocities()).max() < 1e-3                      # at rest again
        shape[m.name] = (np.ptp(p[:, 2]) / np.ptp(x[:, 2]), np.ptp(p[:, 0]) / np.ptp(x[:, 0]))
    print(shape)
    assert abs(shape["jelly"][0] - 1) < 0.01 and abs(shape["jelly"][1] - 1) < 0.01
    assert shape["metal"][0] < 0.985 and shape["metal"][1] > 1.015
