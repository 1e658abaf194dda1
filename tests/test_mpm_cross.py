"""The two MLS-MPM backends against each other, concern by concern (issue 27, docs/mpm.md): for each of the eight
materials, the same ``F``, ``Jp`` and parameters give the same return mapping (new ``F``, ``Jp``) and Kirchhoff
stress ``tau`` in taichi_mpm and warp_mpm, and the same ``F``, ``C``, ``v`` give the same grid momentum and mass
from one P2G, to float32 tolerance. The check is shown to catch a constitutive model whose stiffnesses (``mu``,
``lam``, ``K``) are 5 % off.

Both engines run in f32 on the CPU; one setup holds the eight materials as eight bodies, so each backend compiles
its kernels once (Taichi about a minute on two loaded cores the first time, then from its offline cache).

This module must not use ``from __future__ import annotations``: Warp reads the annotations of the probe kernel.
"""
import numpy as np
import pytest
from gasp_testing import needs_package

needs_package("taichi")
wp = needs_package("warp")

from gasp_core.seam import build_engine, Material, SimSetup  # noqa: E402
from gasp_core.seam.plugins import engines  # noqa: E402
from gasp_core.mpm.materials import MATERIAL_CODES, P_K, P_LAM, P_MU  # noqa: E402

MATERIALS = list(MATERIAL_CODES)   # the eight, in code order
PER_BODY = 12                       # points per material
DT = 2e-4                           # s, one substep
#: Relative tolerance of a comparison (to the largest magnitude of that quantity for that material): a few f32
#: roundings after the iterative polar / Jacobi / SVD; a 5 % error in a stiffness is 50 times larger.
RTOL = 1e-3


def cross_setup() -> SimSetup:
    """Seven bodies (one per material) of :data:`PER_BODY` scattered points, f32, one substep of :data:`DT`."""
    rng = np.random.default_rng(27)
    n = PER_BODY * len(MATERIALS)
    mu_i = {"grain_diameter": 1e-3, "friction_angle_2": 45.0}   # sand with its mu(I) rheology (docs/contact.md)
    mats = [Material(name, E=2e4, nu=0.3, rho=1000.0, yield_stress=300.0, softening=0.5, tensile_strength=300.0,
                     **(mu_i if name == "sand" else {})) for name in MATERIALS]
    return SimSetup(x=rng.uniform(0.3, 0.7, (n, 3)), v=rng.normal(0, 0.2, (n, 3)), p_vol=rng.uniform(0.5, 1.5, n) * 1e-5,
                    body_id=np.repeat(np.arange(len(MATERIALS)), PER_BODY), materials=mats,
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16,
                    frame_dt=DT, options={"n_substeps": 1, "precision": "f32"})


def cross_state(n: int):
    """``F`` (small and large stretches, some compressed: every return mapping is active on some points),
    ``C`` (1/s) and ``Jp`` (1 for snow, plastic strain for plasticine, damage for brittle, else 1) per point,
    float64."""
    rng = np.random.default_rng(28)
    scale = np.where(np.arange(n) % 3 == 0, 0.01, 0.12)[:, None, None]   # a third stay elastic
    F = np.eye(3) + scale * rng.normal(size=(n, 3, 3))
    C = rng.normal(0, 2.0, (n, 3, 3))
    body = np.repeat(np.arange(len(MATERIALS)), PER_BODY)
    Jp = np.where(body == MATERIAL_CODES["plasticine"], rng.uniform(0, 0.5, n),
                  np.where(body == MATERIAL_CODES["snow"], rng.uniform(0.95, 1.05, n), 1.0))
    brittle = body == MATERIAL_CODES["brittle"]   # damage: a quarter broken through (their sand branch)
    Jp[brittle] = np.where(np.arange(n)[brittle] % 4 == 0, 1.0, rng.uniform(0, 0.5, brittle.sum()))
    return F, C, Jp


# ----------------------------------------------------------------------------- the two backends
def taichi_run(setup, F, C, Jp, stiffness=1.0):
    """taichi_mpm: (new F, new Jp, tau) of the return mapping at ``F``, and (grid momentum, mass) of one P2G.

    ``stiffness`` scales the ``mu``, ``lam`` and ``K`` columns of the material table (a deliberately broken model)."""
    import taichi as ti
    e = build_engine(engines()["taichi_mpm"], setup)
    s, o, inv = e.solver, e._order, e._inverse
    if stiffness != 1.0:
        par = s.mat.to_numpy()
        par[:, [P_MU, P_LAM, P_K]] *= stiffness
        s.mat.from_numpy(par)
    tau = ti.Matrix.field(3, 3, s.real, shape=s.F.shape)

    @ti.kernel
    def probe(solver: ti.template(), out: ti.template()):
        for p in range(solver.n_points[None]):
            out[p] = solver.return_mapping(p, solver.F[p])

    s.set(s.F, F[o])
    s.set(s.Jp, Jp[o])
    probe(s, tau)
    mapped = s.get(s.F)[inv], s.get(s.Jp)[inv], tau.to_numpy()[:len(F)][inv]
    s.set(s.F, F[o])
    s.set(s.Jp, Jp[o])
    s.set(s.C, C[o])
    s.g2p_p2g(0)   # P2G alone (no G2P before it)
    acc = s.grid_mv.to_numpy().sum(axis=0)
    return mapped, (acc[..., :3], acc[..., 3])


def warp_run(setup, F, C, Jp):
    """warp_mpm: as :func:`taichi_run` (``build_return_mapping`` in a probe kernel; the engine's P2G launch)."""
    from gasp_warp_mpm.constitutive import build_return_mapping
    e = build_engine(engines()["warp_mpm"], setup)
    Ft, o = wp.float32, e._order
    vec3, mat33 = e.k.vec3, e.k.mat33
    return_mapping = build_return_mapping(Ft)

    @wp.kernel
    def probe(F: wp.array(dtype=mat33), body: wp.array(dtype=wp.int32), mat_kind: wp.array(dtype=wp.int32),
              mat_par: wp.array2d(dtype=Ft), Jp: wp.array(dtype=Ft), F_out: wp.array(dtype=mat33),
              tau_out: wp.array(dtype=mat33), dt: Ft, x: wp.array(dtype=vec3), lo: vec3, inv_dx: Ft):
        p = wp.tid()
        X = (x[p] - lo) * inv_dx   # the stencil's offset, as the P2G gives it (the brittle band weight reads it)
        fx = X - vec3(wp.floor(X[0] - Ft(0.5)), wp.floor(X[1] - Ft(0.5)), wp.floor(X[2] - Ft(0.5)))
        Fn, tau = return_mapping(F[p], p, body, mat_kind, mat_par, Jp, dt, fx, 1)   # a free point: band weight on
        F_out[p] = Fn
        tau_out[p] = tau

    n = len(F)
    Fa = wp.array(F[o].astype(np.float32), dtype=mat33, device="cpu")
    Jpa = wp.array(Jp[o].astype(np.float32), dtype=Ft, device="cpu")
    F_out = wp.zeros(n, dtype=mat33, device="cpu")
    tau = wp.zeros(n, dtype=mat33, device="cpu")
    lo = vec3(*[float(c) for c in setup.domain_lo])
    wp.launch(probe, dim=n, inputs=[Fa, e.body, e.mat_kind, e.mat_par, Jpa, F_out, tau, Ft(e.dt), e.x, lo,
                                    Ft(1.0 / setup.dx)], device="cpu")
    inv = np.empty(n, np.int64)
    inv[o] = np.arange(n)
    mapped = F_out.numpy()[inv], Jpa.numpy()[inv], tau.numpy()[inv]
    e.F.assign(F[o].astype(np.float32))
    e.Jp.assign(Jp[o].astype(np.float32))
    e.C.assign(C[o].astype(np.float32))
    e._launches[0].launch()   # the recorded P2G launch (launches: P2G, grid update, G2P)
    g = e.grid_mv.numpy().reshape((setup.n_grid,) * 3 + (4,))
    return mapped, (g[..., :3], g[..., 3])


def mismatches(a, b) -> list[str]:
    """Per material, the quantities on which two runs differ by more than :data:`RTOL` of that material's
    largest magnitude (F, Jp, tau); and the grid momentum and mass."""
    (Fa, Jpa, taua), (mva, ma) = a
    (Fb, Jpb, taub), (mvb, mb) = b
    out = []
    for code, name in enumerate(MATERIALS):
        rows = slice(code * PER_BODY, (code + 1) * PER_BODY)
        for what, x, y in (("F", Fa, Fb), ("Jp", Jpa, Jpb), ("tau", taua, taub)):
            err = np.abs(x[rows] - y[rows]).max()
            if err > RTOL * max(np.abs(x[rows]).max(), 1e-30):
                out.append(f"{name} {what}: {err:.3g} of {np.abs(x[rows]).max():.3g}")
    for what, x, y in (("grid momentum", mva, mvb), ("grid mass", ma, mb)):
        err = np.abs(x - y).max()
        if err > RTOL * np.abs(x).max():
            out.append(f"{what}: {err:.3g} of {np.abs(x).max():.3g}")
    return out


@pytest.fixture(scope="module")
def runs():
    setup = cross_setup()
    F, C, Jp = cross_state(len(setup.x))
    return (taichi_run(setup, F, C, Jp), warp_run(cross_setup(), F, C, Jp),
            taichi_run(cross_setup(), F, C, Jp, stiffness=1.05), Jp)


def test_every_return_mapping_is_exercised(runs):
    """The state drives each plastic model past its yield surface on some points (else the test shows little)."""
    (F_new, Jp_new, _), _ = runs[0]
    F, _, Jp = cross_state(len(F_new))
    for name in ("metal", "sand", "plasticine", "snow", "liquid"):
        rows = slice(MATERIAL_CODES[name] * PER_BODY, (MATERIAL_CODES[name] + 1) * PER_BODY)
        assert np.abs(F_new[rows] - F[rows]).max() > 1e-3, name
    for name in ("plasticine", "snow"):
        rows = slice(MATERIAL_CODES[name] * PER_BODY, (MATERIAL_CODES[name] + 1) * PER_BODY)
        assert np.abs(Jp_new[rows] - Jp[rows]).max() > 1e-4, name


def test_both_backends_give_the_same_stress_and_grid_momentum(runs):
    bad = mismatches(runs[0], runs[1])
    assert not bad, "taichi_mpm and warp_mpm differ: " + "; ".join(bad)


def test_the_cross_check_catches_stiffnesses_5_percent_off(runs):
    """mu, lam and K scaled by 1.05 in taichi_mpm: every material's stress, and the grid momentum, differ."""
    bad = mismatches(runs[2], runs[1])
    for name in MATERIALS:
        assert any(b.startswith(f"{name} tau") for b in bad), (name, bad)
    assert any(b.startswith("grid momentum") for b in bad), bad
