"""Tests of the taichi_mpm engine against physics with known answers and a NumPy transcription
of docs/mpm.md. Small grids (16-32) and a few thousand points keep the run short on 2 cores."""
import subprocess
import sys

import numpy as np
import pytest

from gasp_core.seam import (Boundary, build_engine, EngineDivergence, EngineError, Material, SceneError,
                           SimSetup)

pytest.importorskip("taichi")

from gasp_taichi_mpm import gasp_engines  # noqa: E402

G = 9.81


def build(setup):
    """The engine as the core builds it: options checked and completed first (``build_engine``)."""
    return build_engine(gasp_engines()[0], setup)


def block_setup(lo=(0.4, 0.4, 0.4), size=(0.2, 0.2, 0.2), n_grid=16, ppc_axis=2, material=None,
                boundaries=(), gravity=(0.0, 0.0, -G), v=(0.0, 0.0, 0.0), domain_hi=(1.0, 1.0, 1.0),
                **options):
    """A box of points on a regular lattice, ``ppc_axis**3`` points per grid cell."""
    dx = max(domain_hi) / n_grid
    h = dx / ppc_axis
    axes = [np.arange(int(round(s / h))) * h + h / 2 + o for s, o in zip(size, lo)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    return SimSetup(x=x, v=np.asarray(v, float), p_vol=h ** 3, body_id=0,
                    materials=[material or Material("jelly", E=1e4, nu=0.3, rho=1000.0)],
                    gravity=np.asarray(gravity, float), domain_lo=np.zeros(3),
                    domain_hi=np.asarray(domain_hi, float), n_grid=n_grid,
                    boundaries=list(boundaries), options=options)


def run(setup, n_frames):
    e = build(setup)
    for _ in range(n_frames):
        e.step_frame()
    return e


# ---------------------------------------------------------------- plugin registration
def test_plugin_is_registered_and_import_is_cheap():
    from gasp_core.seam.plugins import engines
    info = engines()["taichi_mpm"]
    assert {"grid", "initial_C", "viscosity"} <= info.capabilities.features
    assert info.unavailable_reason() is None
    assert info.deterministic_options == {"threads": 1}
    assert {o.name for o in info.options} == {"device", "precision", "dt", "n_substeps", "cfl", "cfl_rule", "max_substeps", "transfer_damping", "threads", "pin_threads", "contact_balance",
                                             "passive_every", "flip", "contact", "contact_fields", "schedule", "p2g",
                                             "tile_sort_every", "deterministic", "stress_at",
                                             "stress_passes", "roll_contact", "fracture_cells"}
    code = "import sys, gasp_taichi_mpm; assert 'taichi' not in sys.modules, 'taichi imported'"
    subprocess.run([sys.executable, "-c", code], check=True)


# ---------------------------------------------------------------- physics with known answers
def test_free_fall_matches_g_t2_over_2():
    s = block_setup(lo=(0.4, 0.4, 0.6), n_grid=32, material=Material("jelly", E=1e5))
    e = run(s, 6)  # 0.2 s in 6 x 31 substeps: symplectic Euler adds 1/186 = 0.5 %
    t = 6 * s.frame_dt
    drop = s.x[:, 2].mean() - e.positions()[:, 2].mean()
    assert drop == pytest.approx(0.5 * G * t ** 2, rel=0.01)
    # the block stays rigid in free fall: no relative motion
    rel = e.positions() - e.positions().mean(0) - (s.x - s.x.mean(0))
    assert np.abs(rel).max() < 1e-4


def test_block_dropped_on_ground_comes_to_rest_above_it():
    height = 0.2
    s = block_setup(lo=(0.4, 0.4, 0.3), size=(0.2, 0.2, 0.15), n_grid=16,
                    boundaries=[Boundary("ground", height=height, friction=0.5)])
    e = build(s)
    z_min, speeds, z_mean = [], [], []
    for _ in range(90):  # 3 s
        e.step_frame()
        x, v = e.positions(), e.velocities()
        assert np.isfinite(x).all() and np.isfinite(v).all()
        z_min.append(x[:, 2].min())
        speeds.append(np.linalg.norm(v, axis=1).max())
        z_mean.append(x[:, 2].mean())
    assert min(z_min) > height - s.dx  # never through the ground
    impact = np.sqrt(2 * G * (s.x[:, 2].min() - height))  # 1.4 m/s
    assert max(speeds[-10:]) < 0.2 * impact  # the bounces died down
    assert height < np.mean(z_mean[-10:]) < height + 0.15  # resting on the ground, not sunk


def test_momentum_is_conserved_without_gravity_and_boundaries():
    s = block_setup(n_grid=16, gravity=(0, 0, 0), material=Material("jelly", E=2e4))
    c = s.x.mean(0)
    omega = np.array([0.0, 0.0, 3.0])
    v = np.array([0.3, -0.2, 0.1]) + np.cross(omega, s.x - c)  # translation and spin
    W = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]], [-omega[1], omega[0], 0]])
    s = s.replace(v=v, C=W)
    m = s.p_mass[:, None]
    p0 = (m * s.v).sum(0)
    L0 = (m * np.cross(s.x - c, s.v)).sum(0)
    e = run(s, 5)
    x1, v1 = e.positions().astype(np.float64), e.velocities().astype(np.float64)
    p1 = (m * v1).sum(0)
    assert np.abs(p1 - p0).max() < 1e-5 * np.abs(p0).max()
    # APIC with the initial C = [omega]x keeps the spin (angular momentum about the moving centre)
    c1 = (m * x1).sum(0) / m.sum()
    L1 = (m * np.cross(x1 - c1, v1 - p1 / m.sum())).sum(0)
    assert np.abs(L1 - L0).max() < 1e-3 * np.abs(L0).max()


@pytest.mark.parametrize("name", ["jelly", "neo_hookean", "metal", "sand", "snow", "plasticine", "liquid", "brittle"])
def test_each_material_runs_finite(name):
    mat = Material(name, E=2e4, nu=0.3, yield_stress=500.0, tensile_strength=500.0)
    s = block_setup(lo=(0.4, 0.4, 0.1), size=(0.2, 0.2, 0.2), material=mat,
                    boundaries=[Boundary("ground", height=0.1)])
    e = run(s, 3)
    assert np.isfinite(e.positions()).all() and np.isfinite(e.velocities()).all()
    assert e.positions()[:, 2].min() > 0.1 - s.dx


def test_two_bodies_of_different_materials_move_as_each_alone():
    """Per-point material dispatch: a jelly and a sand block far apart (no shared grid nodes)."""
    ground = [Boundary("ground", height=0.15)]
    jelly = Material("jelly", E=2e4)
    sand = Material("sand", E=2e4)
    a = block_setup(lo=(0.15, 0.4, 0.15), material=jelly, boundaries=ground)
    b = block_setup(lo=(0.6, 0.4, 0.15), material=sand, boundaries=ground)
    both = SimSetup(x=np.vstack([a.x, b.x]), v=np.zeros(3), p_vol=a.p_vol[0],
                    body_id=np.r_[np.zeros(len(a.x)), np.ones(len(b.x))].astype(np.int32),
                    materials=[jelly, sand], gravity=a.gravity, domain_lo=a.domain_lo,
                    domain_hi=a.domain_hi, n_grid=a.n_grid, boundaries=ground,
                    options={"n_substeps": 20, "contact": "grid"})
    x = run(both, 4).positions()
    # one contact model for all three runs: contact = "auto" picks it per scene (the sand makes the pair's "grid",
    # the jelly alone would get "particle"), docs/contact.md
    xa = run(a.replace(options={"n_substeps": 20, "contact": "grid"}), 4).positions()
    xb = run(b.replace(options={"n_substeps": 20, "contact": "grid"}), 4).positions()
    assert np.abs(x[:len(a.x)] - xa).max() < 1e-5
    assert np.abs(x[len(a.x):] - xb).max() < 1e-5
    assert np.abs(xa - xb - (a.x - b.x)).max() > 1e-3  # and the two materials do differ


#: Round 54: under cfl_rule "sum" (13 substeps a frame, was 7) the sand block's top drops 3.59 cm in 0.5 s, not the 4
#: the check asks (4.25 under "max"); its slump is not converged in the step at n_grid 16: 4.25 / 3.59 / 2.90 / 2.16 cm
#: at 7 / 13 / 26 / 52 substeps a frame (spread 8.4 / 6.2 / 4.2 / 2.7 cm), so the check's 4 cm was met by a coarse step.
#: Round 55 (docs/contact.md "Round 55: the sand's slump against the step"; tests/test_sand_slump_step.py): the cause
#: is the grid contact's touched layer, not the sand; both engines the same figures. Off (touch_contact False) the drop
#: is 10.55 / 9.25 / 8.45 cm at 7 / 26 / 104 substeps; with contact "particle" 11.07 / 11.11 / 11.12 cm.
SAND_SLUMP_STEP = ("round 55: the sand's slump at n_grid 16 shrinks with the step (top drop 4.25 / 3.59 / 2.90 / 2.16 "
                   "/ 1.50 / 1.06 cm at 7 / 13 / 26 / 52 / 104 / 208 substeps a frame, both engines): the grid "
                   "contact's touched layer, a node layer above the ground's plane inside the sand, takes the ground's "
                   "stop and Coulomb bound on the node's whole velocity every substep (docs/contact.md 'Round 55'); "
                   "3.59 cm < 4 cm at the default 13")


@pytest.mark.parametrize("name", [pytest.param("sand", marks=pytest.mark.xfail(strict=True, reason=SAND_SLUMP_STEP)),
                                  "liquid"])
def test_sand_and_liquid_spread(name):
    s = block_setup(lo=(0.4, 0.4, 0.15), size=(0.2, 0.2, 0.2), n_grid=16,
                    material=Material(name, E=2e4, nu=0.3, friction_angle=30.0),
                    boundaries=[Boundary("ground", height=0.15, friction=0.0 if name == "liquid" else 0.5),
                                Boundary("walls", friction=0.0)])
    e = run(s, 15)  # 0.5 s
    x = e.positions()
    assert (x > -s.dx).all() and (x < 1 + s.dx).all()  # held by the walls
    top0 = np.percentile(s.x[:, 2], 95)
    assert np.percentile(x[:, 2], 95) < top0 - 0.04  # the top dropped
    width0 = np.ptp(s.x[:, 0])
    assert np.ptp(x[:, 0]) > width0 + 0.04  # and it spread sideways


def test_elastic_block_keeps_its_shape_on_the_ground():
    """Contrast for the spreading test: jelly does not spread."""
    s = block_setup(lo=(0.4, 0.4, 0.15), size=(0.2, 0.2, 0.2), n_grid=16,
                    material=Material("jelly", E=5e4), boundaries=[Boundary("ground", height=0.15)])
    x = run(s, 15).positions()
    assert np.ptp(x[:, 0]) < np.ptp(s.x[:, 0]) + 0.02


def test_fixed_region_holds_points_while_the_rest_sags():
    # a cantilever along x: x <= 0.3 is clamped, 0.2 m stick out
    fixed = Boundary("fixed_region", lo=(0.0, 0.0, 0.0), hi=(0.3, 1.0, 1.0))
    s = block_setup(lo=(0.2, 0.45, 0.5), size=(0.3, 0.1, 0.1), n_grid=32,
                    material=Material("jelly", E=1e6), boundaries=[fixed])
    e = build(s)
    inside = s.x[:, 0] <= 0.3
    tip = s.x[:, 0] > 0.45
    sags = []
    for _ in range(6):
        e.step_frame()
        x = e.positions()
        assert np.array_equal(x[inside], s.x[inside].astype(x.dtype))
        sags.append(s.x[tip, 2].mean() - x[tip, 2].mean())
    # Euler-Bernoulli static tip deflection rho g L^4 12 / (8 E a^2) = 2.4 mm; it swings about it
    assert max(sags) > 0.003
    assert max(sags) < 0.03  # held back, unlike free fall (0.196 m after 0.2 s)


# ---------------------------------------------------------------- blow-ups
def test_a_point_leaving_the_grid_drops_out_and_a_fast_one_diverges():
    """A point flying at 1 m/s reaches the grid limit x = (n_grid - 1.5) dx = 0.906 at t = 0.056 s: it stays where it
    left, out of the transfers, and the run goes on (feature left_domain; the count: tests/test_left_domain.py). One
    at 200 m/s with one substep a frame moves more than a cell a substep: a blow-up naming its frame."""
    s = block_setup(gravity=(0, 0, 0))
    x = np.vstack([s.x, [[0.85, 0.5, 0.5]]])
    v = np.zeros_like(x)
    v[-1] = [1.0, 0.0, 0.0]
    s = s.replace(x=x, v=v, p_vol=np.full(len(x), s.p_vol[0]), body_id=np.zeros(len(x), np.int32))
    e = build(s)
    for _ in range(3):
        e.step_frame()
    out = e.positions()[-1]
    assert 0.906 <= out[0] < 0.906 + e.dt + 1e-6
    e.step_frame()
    np.testing.assert_array_equal(e.positions()[-1], out)
    v[-1] = [200.0, 0.0, 0.0]
    fast = build(s.replace(v=v, options={**s.options, "n_substeps": 1}))   # the automatic step follows the speed
    with pytest.raises(EngineDivergence, match="frame 1") as info:
        fast.step_frame()
    assert info.value.frame == 1 and "time step" in info.value.cause


def test_huge_time_step_raises_divergence_not_nan_positions():
    # the grid contact: the particle contact would shorten the hand-set step to its own stable one (issue 38)
    s = block_setup(lo=(0.4, 0.4, 0.1), material=Material("jelly", E=1e7),
                    boundaries=[Boundary("ground", height=0.1)], n_substeps=1, contact="grid")
    e = build(s)
    with pytest.raises(EngineDivergence) as info:
        for _ in range(30):
            e.step_frame()
            assert np.isfinite(e.positions()).all()
    assert "time step" in info.value.cause
    assert np.isfinite(e.positions()).all()  # the last good frame, never NaN


# ---------------------------------------------------------------- options, precision, determinism
def test_threads_1_is_bit_for_bit_deterministic():
    s = block_setup(lo=(0.4, 0.4, 0.1), boundaries=[Boundary("ground", height=0.1)], threads=1)
    a = run(s, 4).positions()
    b = run(s, 4).positions()
    assert np.array_equal(a, b)


def test_any_thread_count_gives_the_same_numbers_as_one_thread():
    """The coloured block P2G sums every node in a fixed order (colour, block, sorted point), and the implicit
    viscous step sums its dot products in fixed chunks, whatever the threads. 32,768 points: each colour pass has
    about 4,000, so Taichi (at least 512 iterations per thread) splits it over all 3 threads."""
    mat = Material("jelly", E=1e4, nu=0.3, rho=1000.0, viscosity=5.0)
    kw = dict(lo=(0.25, 0.25, 0.2), size=(0.5, 0.5, 0.5), ppc_axis=4, material=mat, contact_balance=False,
              boundaries=[Boundary("ground", height=0.1)])   # the balance's impulse sums are atomic (engine.py)
    e1 = run(block_setup(threads=1, **kw), 3)
    assert e1.stats()["p2g"] == "coloured blocks" and e1.stats()["viscous_cg_iterations"] > 0
    a, v = e1.positions(), e1.velocities()
    e3 = run(block_setup(threads=3, **kw), 3)
    assert np.array_equal(e3.positions(), a) and np.array_equal(e3.velocities(), v)
    assert np.abs(a - block_setup(**kw).x).max() > 0.01   # it moved


def test_unknown_option_is_a_scene_error_naming_it():
    with pytest.raises(SceneError, match="substep"):
        build(block_setup(substep=10))
    with pytest.raises(SceneError, match="precision"):
        build(block_setup(precision="f16"))


def test_options_are_checked_as_declared():
    with pytest.raises(SceneError, match="not both"):
        build(block_setup(dt=1e-4, n_substeps=10))
    with pytest.raises(SceneError, match="threads=0"):
        build(block_setup(threads=0))
    # Taichi runs on the default CUDA device only: an indexed device is refused by name
    with pytest.raises(SceneError, match="device='cuda:1'"):
        build(block_setup(device="cuda:1"))


def test_material_it_lacks_is_refused_by_the_core_before_taichi_starts():
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    s = block_setup(material=Material("rigid"))
    with pytest.raises(SceneError, match="material 'rigid'"):
        build_engine(engines()["taichi_mpm"], s)


def test_cuda_without_gpu_is_an_engine_error():
    import taichi as ti
    if ti.lang.misc.is_arch_supported(ti.cuda):
        pytest.skip("this machine has CUDA")
    with pytest.raises(EngineError, match="cuda"):
        build(block_setup(device="cuda"))


def test_f64_works_and_agrees_with_f32():
    s = block_setup(lo=(0.4, 0.4, 0.1), boundaries=[Boundary("ground", height=0.1)])
    x64 = run(s.replace(options={"precision": "f64"}), 6).positions()
    assert x64.dtype == np.float64
    x32 = run(s, 6).positions()
    assert x32.dtype == np.float32
    assert np.abs(x64 - x32).max() < 1e-3 * 0.2


def test_old_engine_is_invalidated_by_a_new_one():
    s = block_setup()
    a = build(s)
    build(s)
    with pytest.raises(EngineError, match="invalidated"):
        a.step_frame()


def test_the_kernel_cache_is_not_cut_to_taichis_100_mib(monkeypatch):
    """Over Taichi's default cap (100 MiB, less than GASP's test run compiles) a quarter of the cached kernels is
    dropped at each exit and compiled again; the engine raises the cap, and a cap set in the environment wins."""
    import taichi as ti
    from gasp_taichi_mpm.engine import CACHE_MAX_BYTES
    monkeypatch.delenv("TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES", raising=False)
    build(block_setup())
    assert ti.lang.impl.current_cfg().offline_cache_max_size_of_files == CACHE_MAX_BYTES >= 1 << 30
    monkeypatch.setenv("TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES", "123456789")
    build(block_setup())
    assert ti.lang.impl.current_cfg().offline_cache_max_size_of_files == 123456789


def test_cpu_kernels_compile_without_the_advanced_passes_unless_the_environment_asks(monkeypatch):
    """The advanced passes doubled a cold first frame and bought no speed (``CPU_ADVANCED_OPTIMIZATION``); a value
    in the environment wins, in both directions."""
    import taichi as ti
    monkeypatch.delenv("TI_ADVANCED_OPTIMIZATION", raising=False)
    build(block_setup())
    assert ti.lang.impl.current_cfg().advanced_optimization is False
    monkeypatch.setenv("TI_ADVANCED_OPTIMIZATION", "1")
    build(block_setup())
    assert ti.lang.impl.current_cfg().advanced_optimization is True
    monkeypatch.setenv("TI_ADVANCED_OPTIMIZATION", "0")
    build(block_setup())
    assert ti.lang.impl.current_cfg().advanced_optimization is False


def test_stats_report_the_time_step_from_gasp_core_mpm():
    from gasp_core.mpm.substeps import mpm_stable_dt, substeps_for
    s = block_setup()
    st = build(s).stats()
    n, dt = substeps_for(s.frame_dt, mpm_stable_dt(s.materials, s.dx, s.gravity, 1.0, 0.0, 0.4))
    assert (st["n_substeps"], st["dt"]) == (n, pytest.approx(dt))
    assert st["n_points"] == len(s.x) and st["n_grid"] == 16 and st["device"] == "cpu"


# ---------------------------------------------------------------- one substep against docs/mpm.md in NumPy
def _svd_proper(F):
    U, sig, Vt = np.linalg.svd(F)
    V = Vt.T
    if np.linalg.det(U) < 0:
        U[:, 2] *= -1
        sig[2] *= -1
    if np.linalg.det(V) < 0:
        V[:, 2] *= -1
        sig[2] *= -1
    return U, sig, V


def _spec_stress(m, F, Jp):
    """The constitutive table of docs/mpm.md, literally. Returns tau, F, Jp."""
    mu, lam, eye = m.mu, m.lam, np.eye(3)
    if m.name == "jelly":
        U, sig, V = _svd_proper(F)
        J = np.linalg.det(F)
        return 2 * mu * (F - U @ V.T) @ F.T + lam * J * (J - 1) * eye, F, Jp
    if m.name == "neo_hookean":
        J = np.linalg.det(F)
        return mu * (F @ F.T - eye) + lam * np.log(max(J, 1e-6)) * eye, F, Jp
    if m.name == "snow":
        h = np.exp(m.hardening * (1 - Jp))
        U, sig, V = _svd_proper(F)
        sc = np.clip(sig, 1 - m.theta_c, 1 + m.theta_s)
        Jp = Jp * np.prod(sig) / np.prod(sc)
        F = U @ np.diag(sc) @ V.T
        J = np.linalg.det(F)
        return 2 * mu * h * (F - U @ V.T) @ F.T + lam * h * J * (J - 1) * eye, F, Jp
    if m.name == "liquid":
        J = np.linalg.det(F)
        K = m.E / (3 * (1 - 2 * m.nu))
        return K * J * (J - 1) * eye, np.cbrt(J) * eye, Jp
    U, sig, V = _svd_proper(F)
    eps = np.log(np.maximum(sig, 1e-4))
    tr = eps.sum()
    e = eps - tr / 3
    ne = np.linalg.norm(e)
    if m.name == "sand":
        s = np.sin(np.radians(m.friction_angle))
        a = np.sqrt(2 / 3) * 2 * s / (3 - s)
        if tr >= 0:
            eps = np.zeros(3)
        else:
            dg = ne + (3 * lam + 2 * mu) / (2 * mu) * tr * a
            if dg > 0:
                eps = eps - dg * e / ne
        F = U @ np.diag(np.exp(eps)) @ V.T
    else:
        ys = m.yield_stress * (max(0.0, 1 - m.softening * Jp) if m.name == "plasticine" else 1.0)
        dg = ne - np.sqrt(2.0 / 3.0) * ys / (2 * mu)   # docs/mpm.md: yield at the uniaxial Y
        if dg > 0:
            eps = eps - dg * e / ne
            F = U @ np.diag(np.exp(eps)) @ V.T
        if m.name == "plasticine":
            Jp = Jp + max(dg, 0.0)
    tau = U @ np.diag(2 * mu * eps + lam * eps.sum()) @ U.T
    return tau, F, Jp


def _spec_substep(s, x, v, C, F, Jp, dt):
    """One substep of docs/mpm.md (no boundaries), float64."""
    ng, dx, lo = s.n_grid, s.dx, s.domain_lo
    inv_dx = 1 / dx
    gm = np.zeros((ng,) * 3)
    gv = np.zeros((ng,) * 3 + (3,))
    m = s.materials[0]
    F, Jp = F.copy(), Jp.copy()
    offsets = [np.array(o) for o in np.ndindex(3, 3, 3)]
    for p in range(len(x)):
        X = (x[p] - lo) * inv_dx
        base = np.floor(X - 0.5).astype(int)
        fx = X - base
        w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
        Fp = (np.eye(3) + dt * C[p]) @ F[p]
        tau, F[p], Jp[p] = _spec_stress(m, Fp, Jp[p])
        pm = s.p_mass[p]
        affine = -dt * s.p_vol[p] * 4 * inv_dx ** 2 * tau + pm * C[p]
        for o in offsets:
            dpos = (o - fx) * dx
            wt = w[o[0]][0] * w[o[1]][1] * w[o[2]][2]
            gv[tuple(base + o)] += wt * (pm * v[p] + affine @ dpos)
            gm[tuple(base + o)] += wt * pm
    act = gm > 0
    gv[act] = gv[act] / gm[act][:, None] + dt * s.gravity
    xn, vn, Cn = x.copy(), np.zeros_like(v), np.zeros_like(C)
    for p in range(len(x)):
        X = (x[p] - lo) * inv_dx
        base = np.floor(X - 0.5).astype(int)
        fx = X - base
        w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2]
        for o in offsets:
            dpos = (o - fx) * dx
            wt = w[o[0]][0] * w[o[1]][1] * w[o[2]][2]
            g = gv[tuple(base + o)]
            vn[p] += wt * g
            Cn[p] += 4 * inv_dx ** 2 * wt * np.outer(g, dpos)
        xn[p] += dt * vn[p]
    return xn, vn, Cn, F, Jp


@pytest.mark.parametrize("name", ["jelly", "neo_hookean", "metal", "sand", "snow", "plasticine", "liquid"])
def test_one_substep_matches_numpy_transcription_of_the_spec(name):
    rng = np.random.default_rng(7)
    n = 40
    mat = Material(name, E=2e4, nu=0.3, yield_stress=300.0, softening=0.5)
    x = rng.uniform(0.3, 0.7, (n, 3))
    v = rng.normal(0, 0.2, (n, 3))
    C = rng.normal(0, 2.0, (n, 3, 3))
    F = np.eye(3) + rng.normal(0, 0.08, (n, 3, 3))
    Jp = np.where(name == "plasticine", rng.uniform(0, 0.5, n), rng.uniform(0.98, 1.02, n))
    s = SimSetup(x=x, v=v, p_vol=rng.uniform(0.5, 1.5, n) * 1e-5, body_id=0, materials=[mat],
                 gravity=np.array([0.0, 0.0, -G]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                 n_grid=16, frame_dt=2e-4, options={"n_substeps": 1, "stress_at": "start"},
                 boundaries=[Boundary("ground", height=0.0)])  # no node reached; same kernels as above
    # docs/mpm.md's substep takes the stress at the step's start; the default trapezoid (round 70, its own checks in
    # tests/test_stress_trapezoid.py) also reads the last substep's gradient, which this one-substep state lacks
    e = build(s)
    o = e._order
    e.solver.set(e.solver.C, C[o])
    e.solver.set(e.solver.F, F[o])
    e.solver.set(e.solver.Jp, Jp[o])
    e.step_frame()
    xr, vr, Cr, Fr, Jpr = _spec_substep(s, x, v, C, F, Jp, 2e-4)
    inv = e._inverse
    # f32 engine against the float64 transcription: tolerances are a few f32 roundings
    np.testing.assert_allclose(e.velocities(), vr, rtol=0, atol=2e-6 * (1 + np.abs(vr).max()))
    np.testing.assert_allclose(e.positions(), xr, rtol=0, atol=2e-7)
    np.testing.assert_allclose(e.solver.get(e.solver.C)[inv], Cr, rtol=0, atol=1e-5 * np.abs(Cr).max())
    np.testing.assert_allclose(e.solver.get(e.solver.F)[inv], Fr, rtol=0, atol=2e-6)
    np.testing.assert_allclose(e.solver.get(e.solver.Jp)[inv], Jpr, rtol=0, atol=2e-6)
    if name in ("metal", "sand", "plasticine", "snow"):
        assert not np.allclose(Fr, (np.eye(3) + 2e-4 * C) @ F)  # the return mapping was active


def test_atomic_scatter_path_agrees_with_coloured_blocks(monkeypatch):
    """The atomic P2G (used on CUDA, or for huge grids) forced on CPU gives the same motion."""
    import gasp_taichi_mpm.engine as engine_mod
    s = block_setup(lo=(0.4, 0.4, 0.1), boundaries=[Boundary("ground", height=0.1)])
    x_private = run(s, 4).positions()
    monkeypatch.setattr(engine_mod, "MAX_PRIVATE_GRID_BYTES", 0)
    e = run(s, 4)
    assert e.stats()["p2g"] == "atomic"
    assert np.abs(e.positions() - x_private).max() < 1e-5


def test_contact_coefficients_follow_the_points_through_the_block_sort():
    """Each point keeps its own particle-contact coefficients (stiffness, damping, skin) while the coloured P2G
    re-sorts the points by block (every 10 substeps and each frame's start). The block sort is an index
    (``solver.order``) over fields that stay in the engine's cell order, so ``p_contact`` must stay aligned with
    ``x``: row i is setup point ``_order[i]``'s (the same check as warp_mpm's, whose CPU re-sort moves the points)."""
    from gasp_core.testing.helpers import make_setup, sphere_points
    from gasp_core.mpm.contact import contact_coefficients
    rng = np.random.default_rng(3)
    x, p_vol = sphere_points((0.5, 0.5, 0.2), 0.08, 0.02)
    p_vol = p_vol * rng.uniform(0.3, 1.0, len(x))          # coefficients differ point to point
    setup = make_setup(x, p_vol, Material("jelly", E=2e4, nu=0.3, rho=300.0), n_grid=16,
                       boundaries=[Boundary("ground", height=0.1, friction=0.5)], v=(0.3, 0.1, -1.0),
                       options={"contact": "particle", "device": "cpu"})
    eng = build_engine(gasp_engines()[0], setup)
    try:
        s = eng.solver
        assert s.coloured and s.n_planes == 1
        for _ in range(4):
            eng.step_frame()
        assert not np.array_equal(eng._order, np.arange(len(x)))   # the engine's order is not the setup's
        assert not np.array_equal(s.order.to_numpy()[:len(x)], np.arange(len(x)))   # the block sort ran
        want = contact_coefficients(setup)[eng._order]
        assert np.allclose(s.get(s.p_contact), want, rtol=1e-6)
        assert np.allclose(eng.positions(), s.get(s.x)[eng._inverse], atol=0)   # x in the same order
        state = eng.get_state()
        eng.set_state(state)
        assert np.allclose(s.get(s.p_contact), contact_coefficients(setup)[eng._order], rtol=1e-6)
    finally:
        eng.close()
