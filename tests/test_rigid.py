"""The rigid limit of a stiff body (issue 40, ``docs/rigid.md``): the projection, the route choice and its keys."""
import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.prepare.route import RIGID_SHARE, choose, estimate, message, resolve_models
from gasp_core.mpm.substeps import CFL
from gasp_core.scene.tables import read_material
from gasp_core.seam import Boundary, Material, SimSetup
from gasp_core.mpm.rigid import affine_spin, rigid_contact, rigid_project, skew, step_view, zero_stress

DX = 0.02


def momenta(x, v, C, m):
    c = (m[:, None] * x).sum(0) / m.sum()
    P = (m[:, None] * v).sum(0)
    L = (m[:, None] * np.cross(x - c, v)).sum(0) + 0.25 * DX * DX * (m[:, None] * affine_spin(C)).sum(0)
    return P, L


@pytest.mark.parametrize("spin", [0.0, 1.0])
def test_projection_keeps_momentum_and_angular_momentum(spin):
    """Either share of the spin in the points' ``C`` (``APIC_SPIN``: 0 since round 67, 1 before) keeps both."""
    rng = np.random.default_rng(40)
    x = rng.uniform(-0.1, 0.1, (500, 3)) * [1.0, 0.5, 0.3]
    v = rng.normal(0.0, 1.0, (500, 3))
    C = rng.normal(0.0, 5.0, (500, 3, 3))
    m = rng.uniform(0.5, 2.0, 500)
    P0, L0 = momenta(x, v, C, m)
    v1, C1, w = rigid_project(x, v, C, m, DX, spin)
    P1, L1 = momenta(x, v1, C1, m)
    assert np.allclose(P1, P0, rtol=1e-12, atol=1e-12)
    assert np.allclose(L1, L0, rtol=1e-10, atol=1e-12)
    # the result is a rigid motion: its velocity gradient is the spin's skew matrix everywhere
    c = (m[:, None] * x).sum(0) / m.sum()
    assert np.allclose(v1 - P0 / m.sum(), np.cross(w, x - c), atol=1e-12)
    # a field that is not rigid changes (the projection is not the identity)
    assert np.abs(v1 - v).max() > 0.5


@pytest.mark.parametrize("spin", [0.0, 1.0])
def test_projection_keeps_a_rigid_motion(spin):
    """A rigid motion whose points carry ``spin [w]`` in ``C`` (as the projection leaves them) projects onto itself;
    with the other share of ``[w]`` in ``C`` the spin comes out off by the affine parts' ``M dx^2 / 2``."""
    rng = np.random.default_rng(1)
    x = rng.uniform(-0.1, 0.1, (300, 3))
    m = np.full(300, 0.3)
    w = np.array([0.5, -2.0, 3.0])
    V = np.array([0.1, 0.0, -1.0])
    c = x.mean(0)
    v = V + np.cross(w, x - c)
    v1, C1, w1 = rigid_project(x, v, np.broadcast_to(spin * skew(w), (300, 3, 3)), m, DX, spin)
    assert np.allclose(w1, w, rtol=1e-10) and np.allclose(v1, v, atol=1e-12)
    assert np.allclose(C1, spin * skew(w1), atol=1e-12)
    _, _, w0 = rigid_project(x, v, np.broadcast_to((1.0 - spin) * skew(w), (300, 3, 3)), m, DX, spin)
    assert np.linalg.norm(w0) > 1.01 * np.linalg.norm(w) if spin == 0.0 else np.linalg.norm(w0) < 0.99 * np.linalg.norm(w)



def test_projection_takes_the_booked_spin_back():
    """Round 76 (``SPIN_BOOKED``, the engines' default): the points carry the whole ``[w]`` in ``C`` and the body
    turns with its own inertia (inertia share 0); the booking ``M dx^2 / 2 w`` taken back, a rigid motion projects onto
    itself; left in (``booked`` None), the spin comes out ``1 + M dx^2 / (2 I)`` times high."""
    rng = np.random.default_rng(1)
    x = rng.uniform(-0.1, 0.1, (300, 3))
    m = np.full(300, 0.3)
    w = np.array([0.5, -2.0, 3.0])
    c = x.mean(0)
    v = np.array([0.1, 0.0, -1.0]) + np.cross(w, x - c)
    C = np.broadcast_to(skew(w), (300, 3, 3))
    _, _, w1 = rigid_project(x, v, C, m, DX, 0.0, booked=w)
    assert np.allclose(w1, w, rtol=1e-10)
    _, _, w0 = rigid_project(x, v, C, m, DX, 0.0)
    assert np.linalg.norm(w0) > 1.01 * np.linalg.norm(w)

def ball(E=2e11, rho=7850.0, model="auto", name="jelly", lift=0.05, r=0.05, n=2000, **kw):
    rng = np.random.default_rng(3)
    d = rng.normal(size=(n, 3))
    x = r * d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(0, 1, (n, 1)) ** (1 / 3) + [0.5, 0.5, r + lift]
    return SimSetup(x=x, v=np.zeros(3), p_vol=(4 / 3 * np.pi * r ** 3) / n, body_id=0,
                    materials=[Material(name, E=E, nu=0.3, rho=rho, model=model, **kw)],
                    gravity=np.array([0, 0, -9.81]), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=32,
                    boundaries=[Boundary("ground", height=0.0)])


def routes(setup, features=frozenset({"rigid_limit"})):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        out = resolve_models(setup, ["ball"], features, CFL)     # a grid engine's declared default cfl
    return out[0], [str(x.message) for x in w]


def test_route_steel_ball_is_rigid_and_said():
    s = ball()
    r, lines = routes(s)
    assert r["model"] == "rigid" and s.materials[0].model == "rigid"
    # impact at sqrt(2 g 0.05) = 0.99 m/s, bar speed sqrt(2e11 / 7850) = 5048 m/s
    assert r["impact_speed"] == pytest.approx(0.990, rel=0.01)
    assert r["strain_impact"] == pytest.approx(0.990 / 5048, rel=0.01)
    assert len(lines) == 1 and "rigid limit" in lines[0] and "material.model = \"elastic\"" in lines[0]


def test_route_soft_body_stays_elastic():
    s = ball(E=2e4, rho=300.0)
    r, lines = routes(s)
    assert r["model"] == "elastic" and r["deformation_cells"] > RIGID_SHARE
    assert s.materials[0].model == "elastic"


def test_route_boundary_of_the_rule():
    """The choice flips where the deformation crosses RIGID_SHARE of a cell."""
    s = ball()
    est = estimate(s.materials[0], s.x, s.p_vol, s.v, s.gravity, 0.0, s.dx, s.frame_dt, 3.0)
    # E for which the impact deformation is exactly the share: eps = v / sqrt(E / rho) = RIGID_SHARE dx / L
    size = float(np.ptp(s.x, axis=0).max())
    E_edge = 7850.0 * (est["impact_speed"] * size / (RIGID_SHARE * s.dx)) ** 2
    for E, want in ((1.2 * E_edge, "rigid"), (0.8 * E_edge, "elastic")):
        m = Material("jelly", E=E, nu=0.3, rho=7850.0)
        assert choose(m, estimate(m, s.x, s.p_vol, s.v, s.gravity, 0.0, s.dx, s.frame_dt, 3.0), True)[0] == want


def test_route_keys_and_engines():
    # an explicit key wins; an engine without the rigid limit keeps auto's choice elastic and says what it would save
    assert routes(ball(model="elastic"))[0]["model"] == "elastic"
    assert routes(ball(E=2e4, rho=300.0, model="rigid"))[0]["model"] == "rigid"
    r, lines = routes(ball(), frozenset())
    assert r["model"] == "elastic" and "no rigid limit" in r["why"]
    assert len(lines) == 1 and "rigid_limit" in lines[0]
    # metal whose impact stress passes its yield stress stays elastic
    m = Material("metal", E=2e11, nu=0.3, rho=7850.0, yield_stress=1e5)
    s = ball()
    assert choose(m, estimate(m, s.x, s.p_vol, s.v, s.gravity, 0.0, s.dx, s.frame_dt, 3.0), True)[0] == "elastic"
    # sand has no rigid limit: its model stays the material's own
    assert routes(ball(E=1e6, rho=1500.0, name="sand"))[0]["model"] == "auto"


def test_model_key_in_scene_files():
    src = Path("scene.toml")
    assert read_material({"name": "jelly", "model": "rigid"}, "object[0].material", src).model == "rigid"
    assert read_material({"name": "jelly"}, "object[0].material", src).model == "auto"
    with pytest.raises(SceneError, match=r"object\[0\].material.model"):
        read_material({"name": "jelly", "model": "stiff"}, "object[0].material", src)
    with pytest.raises(SceneError, match="does not use \\['model'\\]"):
        read_material({"name": "sand", "model": "rigid"}, "object[0].material", src)
    with pytest.raises(SceneError, match="needs an elastic material"):
        Material("sand", model="rigid").check()


def test_step_view_and_zero_stress():
    s = ball(model="rigid")
    v = step_view(s)
    assert v.materials[0].E == 1.0 and s.materials[0].E == 2e11
    assert step_view(ball(model="elastic")) is not None and step_view(ball(model="elastic")).materials[0].E == 2e11
    from gasp_core.mpm.materials import JELLY, METAL, P_LAM, P_MU, material_table
    kinds, params = zero_stress(*material_table([Material("metal", E=1e9), Material("jelly", E=1e5)]),
                                [Material("metal", E=1e9, model="rigid"), Material("jelly", E=1e5)], JELLY)
    assert list(kinds) == [JELLY, JELLY] and params[0, P_MU] == 0 and params[0, P_LAM] == 0
    assert params[1, P_MU] == pytest.approx(1e5 / 2.6)
    assert METAL != JELLY


def test_rigid_contact_follows_the_step_not_E():
    s = ball(model="rigid")
    coeffs = np.zeros((len(s.x), 3))
    a, b = rigid_contact(s, 1e-3, coeffs), rigid_contact(s, 2e-3, coeffs)
    assert np.allclose(a[:, 0], 4.0 * b[:, 0])       # k ~ 1 / dt^2
    s2 = ball(model="rigid", E=2e9)
    assert np.allclose(rigid_contact(s2, 1e-3, coeffs)[:, 0], a[:, 0])   # E does not enter


def test_route_without_a_ground_assumes_a_fall_to_the_domain_floor():
    """No ground: a soft body is not taken rigid for want of an impact (a collider or the floor may stop it)."""
    s = ball(E=2e4, rho=300.0)
    s.boundaries = []
    r, _ = routes(s)
    assert r["model"] == "elastic" and r["impact_speed"] == pytest.approx(np.sqrt(2 * 9.81 * s.x[:, 2].min()), rel=1e-6)


def test_spin_shares_book_a_body_alone_or_one_whose_booking_ratio_is_at_most_one(monkeypatch):
    """Round 76 (``gasp_core.mpm.spin_booking.spin_shares``): the hardwood box on its own field of the two-field contact and
    the two halves of it that share a field (booking ratio 0.29) book; a small rigid cube two spacings across that
    shares its field with another (ratio above 1: a fragment's) keeps the transfer before, while one alone in its field
    books; a sand body's row is 0. Round 77: where the scene is coloured again at every frame (three cubes) its fields
    change during the run, so being alone at the build does not count there: none of the three books (the middle one
    did before round 77; with ``RECOLOUR`` off the fields hold and it books again)."""
    from gasp_core.mpm import colouring
    import sys as _sys
    from pathlib import Path as _Path
    from gasp_core.mpm.spin_booking import booking_ratio, spin_shares
    _sys.path.insert(0, str(_Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
    import finestep_paths
    st, _ = finestep_paths.scene("sand_rigid")
    carry, book = spin_shares(st)
    assert carry.tolist() == [1.0, 0.0] and book.tolist() == [1.0, 0.0]
    st2, _ = finestep_paths.scene("sand_rigid2")
    r = booking_ratio(st2)
    assert 0.2 < r[0] < 0.4 and 0.2 < r[1] < 0.4 and r[2] == 0.0, r
    assert spin_shares(st2)[1].tolist() == [1.0, 1.0, 0.0]
    s = st.dx / 2   # three rigid cubes of 2 x 2 x 2 points in a row: coloured A, B, A (the first and last share A)
    cube = np.mgrid[0:2, 0:2, 0:2].reshape(3, -1).T * s
    x = np.vstack([cube + [0.0, 0.0, 0.01], cube + [3 * s, 0.0, 0.01], cube + [6 * s, 0.0, 0.01]])
    mats = [Material("jelly", E=1e10, rho=700.0, model="rigid")] * 3
    tiny = dataclasses.replace(st, x=x, v=np.zeros_like(x), p_vol=np.full(len(x), s ** 3),
                               body_id=np.repeat([0, 1, 2], 8), materials=mats)
    assert (booking_ratio(tiny) > 1.0).all(), booking_ratio(tiny)
    assert colouring.coloured(tiny)
    assert spin_shares(tiny)[1].tolist() == [0.0, 0.0, 0.0]   # recoloured per frame: the ratio alone decides
    monkeypatch.setattr(colouring, "RECOLOUR", False)
    assert spin_shares(tiny)[1].tolist() == [0.0, 1.0, 0.0]   # the build's fields hold: the middle one, alone, books
