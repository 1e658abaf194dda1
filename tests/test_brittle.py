"""The brittle material (issue 52, docs/fracture.md) on both MLS-MPM engines, against answers known in advance.

- One point, one substep (as ``test_metal_yield``): the damage the return mapping stores for a uniaxial Hencky
  stretch ``diag(exp(e), exp(-nu e), exp(-nu e))`` (uniaxial stress ``E e``) is the crack band's linear softening
  ``gasp_core.mpm.materials.brittle_damage`` (1e-6); compression at 10 times the tensile strength leaves
  ``d = 0``; a damaged point at rest keeps its ``d`` (never heals).
- A bar pulled at one end (``fixed_region`` at the other, ``Impulse`` ``mode = "set"``): the largest nominal
  stress any cross-section carries is ``tensile_strength`` within 5 %; the bar breaks; mass is conserved.
- A T-shaped rod of flat Gaussians hanging from its head (``fixed_region``) under gravity, through
  ``gasp simulate``'s pipeline: with ``tensile_strength = 0.6 rho g L`` it breaks in the upper half of its neck
  (two or more pieces in ``run.json`` by frame 12, its lower part then a grid cell off), with ``2.5 rho g L`` it
  stays one piece (a suddenly loaded rod reaches up to twice
  its static stress ``rho g L``).

- The work the damage dissipates per crack area is the same at n_grid 32 and 64 within 15 % (the crack band's
  regularisation). The absolute ``G_f`` of a crack in free material is the tension family's
  (``tests/test_tension_family.py``, band ``h = dx``); this bar breaks at its clamp's face, where the band is 1.5
  cells wide and dissipates 1.5 ``G_f`` (docs/fracture.md "The crack band").
- A notched bar breaks at its notch; a brittle ball breaks into at least 3 pieces landing from 2.5 m at a low
  strength and stays whole from 5 cm at a high one; a free bar broken by its own motion keeps its momentum and
  gains no energy.

Each check but the last two is shown to catch a broken model (the ``catches`` tests): the engines' material table
spoiled so that nothing ever damages, with a softening stress not regularised by ``dx``, or with the band ``dx``; the one-point checks
against a model that heals or damages in compression (a reference model here; also shown on warp_mpm's kernel
edited by hand, docs/fracture.md).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from gasp_core.mpm.points import held_codes
from gasp_core.colliders.model import Impulse
from gasp_core.errors import SceneError
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.scenes_fracture import CRACK_ZONE_CELLS, broken_runs, work_per_crack
from gasp_core.mpm.materials import P_FT, brittle_damage, material_table, snap_back_limit, softening_stress

E, NU, RHO, FT = 1e6, 0.25, 1000.0, 1e4
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
PLUGIN_MODULE = {"warp_mpm": "gasp_warp_mpm.engine", "taichi_mpm": "gasp_taichi_mpm.engine"}


def _names():
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in PLUGIN_MODULE]


def _opts(name: str, **kw) -> dict:
    return {"precision": "f64", **({"threads": 1} if name == "taichi_mpm" else {}), **kw}


def never_damages(monkeypatch, name: str) -> None:
    """Break the engine ``name``: its material table's tensile strength is made 1e30 Pa (nothing ever damages)."""
    def spoiled(materials, band=None, cells=None):
        kinds, params = material_table(materials, band, cells)
        params[:, P_FT] = 1e30
        return kinds, params
    monkeypatch.setattr(f"{PLUGIN_MODULE[name]}.material_table", spoiled)


# ----------------------------------------------------------------------------- one point, one substep
PROBE_BAND = 1 / 16    # the probe's crack band width dx, m (n_grid 16 on the unit cube)

#: The probe point, m: the middle of its cell along x (its crack's normal), where the crack band weight is 1 (round 33,
#: ``band_weight``); :data:`PROBE_NODE` on a node, weight 1/2. (On a node with the weight left out of the answer the
#: check failed from round 33 on, unseen in the slow tier: d 0.636 for 0.485 at 1.5 f_t.)
PROBE_X, PROBE_NODE = 0.5 + PROBE_BAND / 2, 0.5


def _probe(name: str, eps: float, d0: float = 0.0, gf: float = 10.0, x: float = PROBE_X) -> float:
    """The damage after one substep of one brittle point at ``(x, 0.5, 0.5)`` whose ``F`` is the uniaxial stretch of
    Hencky strain ``eps`` (lateral ``-nu eps``: uniaxial stress ``E eps``), starting from damage ``d0``."""
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=gf)
    s = SimSetup(x=np.array([[x, 0.5, 0.5]]), v=0.0, p_vol=np.array([1e-6]), body_id=0, materials=[m],
                 gravity=[0, 0, 0], domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=16, frame_dt=1e-6,
                 options=_opts(name, n_substeps=1))
    e = build_engine(engines()[name], s)
    try:
        st = e.get_state()
        st["F"] = np.diag([np.exp(eps), np.exp(-NU * eps), np.exp(-NU * eps)])[None].astype(st["F"].dtype)
        st["C"] = np.zeros_like(st["C"])
        st["Jp"] = np.full_like(st["Jp"], d0)
        e.set_state(st)
        e.step_frame()
        return float(e.damage()[0])
    finally:
        e.close()


def probe_failures(name: str, probe=_probe) -> list[str]:
    """What the one-point checks find wrong with ``probe`` (empty: it passes)."""
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=10.0)
    sf = softening_stress(m, PROBE_BAND)
    bad = []
    for s in (0.5 * FT, 1.5 * FT, 0.5 * (FT + sf), 2 * sf):   # elastic, softening (twice), fully broken
        d, want = probe(name, s / E), float(brittle_damage(s, FT, sf))
        if abs(d - want) > 1e-6:
            bad.append(f"stress {s:.0f} Pa: d = {d:.6f}, crack band softening gives {want:.6f}")
    d = probe(name, -10 * FT / E)   # uniaxial compression: axial stress -10 ft, lateral stresses 0
    if d != 0.0:
        bad.append(f"uniaxial compression at 10 tensile_strength: d = {d:.4f} (compression must not damage)")
    d = probe(name, 0.0, d0=0.4)
    if abs(d - 0.4) > 1e-9:
        bad.append(f"a point with d = 0.4 at rest has d = {d:.4f} after a substep (damage never heals)")
    return bad


def node_probe_failures(name: str) -> list[str]:
    """The softening of a point on a node, crack band weight 1/2 (``band_softening_stress``): its range half the band's
    (module ``band_weight``; round 33)."""
    from gasp_core.mpm.materials import band_softening_stress, band_weight
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=10.0)
    W = float(band_weight(np.array([PROBE_NODE / PROBE_BAND % 1.0 + 1.0, 1.0, 1.0]), np.array([1.0, 0.0, 0.0])))
    sf = float(band_softening_stress(FT, softening_stress(m, PROBE_BAND), W))
    bad = [] if W == 0.5 else [f"the node's band weight {W} (expected 0.5)"]
    for s in (1.5 * FT, 0.5 * (FT + sf)):
        d, want = _probe(name, s / E, x=PROBE_NODE), float(brittle_damage(s, FT, sf))
        if abs(d - want) > 1e-6:
            bad.append(f"on a node, stress {s:.0f} Pa: d = {d:.6f}, the weighted band gives {want:.6f}")
    return bad


@pytest.mark.parametrize("name", _names())
def test_damage_is_the_crack_band_softening_never_heals_and_not_in_compression(name):
    assert probe_failures(name) == []
    assert node_probe_failures(name) == []


def test_the_probe_checks_catch_a_model_that_heals_or_damages_in_compression():
    """Broken models as the engines would report them: one that forgets the damage between substeps, one whose
    criterion reads the largest |principal stress| (so compression damages); each fails a check."""
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=10.0)
    sf = softening_stress(m, PROBE_BAND)

    def stress(eps):
        e = np.array([eps, -NU * eps, -NU * eps])
        return 2 * MU * e + LAM * e.sum()

    heals = lambda name, eps, d0=0.0: float(brittle_damage(stress(eps).max(), FT, sf))            # noqa: E731
    absolute = lambda name, eps, d0=0.0: max(d0, float(brittle_damage(np.abs(stress(eps)).max(), FT, sf)))  # noqa: E731
    right = lambda name, eps, d0=0.0: max(d0, float(brittle_damage(stress(eps).max(), FT, sf)))   # noqa: E731
    assert probe_failures("reference", right) == []
    assert any("never heals" in b for b in probe_failures("heals", heals))
    assert any("compression" in b for b in probe_failures("abs", absolute))


def test_the_node_probe_catches_one_softening_range_for_every_point(monkeypatch):
    """An engine whose points all soften over the band's whole range (``weighted_band`` off, before round 33) fails
    the node probe (warp_mpm)."""
    pytest.importorskip("gasp_warp_mpm")
    from gasp_warp_mpm.held_rule import HeldRule
    monkeypatch.setattr(HeldRule, "weighted_band", False)
    assert any("on a node" in b for b in node_probe_failures("warp_mpm"))


def test_fracture_energy_below_the_snap_back_limit_is_refused_naming_it():
    """``G_f <= f_t^2 h / (2 E)`` would make the band snap back: the material table refuses it, naming the limit;
    ``SimSetup`` refuses it at its own band width ``h = dx`` (1/16 m here: 3.125 J/m^2, whatever the points'
    spacing); just above it is taken, and ``s_f`` halves when ``h`` doubles (``G_f`` regularised by the band
    width)."""
    from gasp_core.seam.setup import crack_band
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=1.0)
    dx = 1 / 16
    limit = snap_back_limit(m, dx)
    assert limit == pytest.approx(FT ** 2 * dx / (2 * E))
    with pytest.raises(SceneError, match=r"snap-back limit tensile_strength\^2 h / \(2 E\) = 3\.125 J/m\^2"):
        material_table([m], dx)
    x, pv = box_points((0.4, 0.4, 0.4), (0.6, 0.6, 0.6), 0.05)
    assert crack_band(dx, np.full(len(x), pv), np.zeros(len(x), int), 1)[0] == pytest.approx(dx)
    m3 = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=3.0)   # under dx's limit
    with pytest.raises(SceneError, match=r"materials\[0\] \('brittle'\)\.fracture_energy = 3 J/m\^2 .* = 3\.125 "
                                         r"J/m\^2 at the crack band width h = dx = 0\.0625 m"):
        make_setup(x, pv, m3, n_grid=16)   # refused before any engine
    make_setup(x, pv, Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=3.2),
               n_grid=16)   # just over it: taken
    ok = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=1.01 * limit)
    assert material_table([ok], dx)[1][0, P_FT] == FT
    assert softening_stress(ok, dx / 2) == pytest.approx(2 * softening_stress(ok, dx))
    with pytest.raises(SceneError, match="needs its crack band width h"):
        material_table([ok])


# ----------------------------------------------------------------------------- a bar in tension
BAR_N_GRID, BAR_PULL = 32, 0.05       # cells on the unit cube; pulled end speed, m/s


def bar_setup(name: str, n_grid: int = BAR_N_GRID, per_dx: int = 2) -> tuple[SimSetup, np.ndarray]:
    """A 0.6 m bar of square section 0.125 m along x (lattice of spacing dx/2), held at x < 0.25, its end x > 0.75
    moved at ``BAR_PULL`` (``Impulse`` ``mode = "set"``), no gravity; and the gauge points (0.27 < x < 0.73)."""
    dx = 1 / n_grid
    x, pv = box_points((0.2, 0.4375, 0.4375), (0.8, 0.5625, 0.5625), dx / per_dx)
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=5.0)
    s = make_setup(x, pv, m, gravity=(0, 0, 0), n_grid=n_grid, frame_dt=0.0025,
                   boundaries=[Boundary("fixed_region", lo=(0, 0, 0), hi=(0.25, 1, 1))], options=_opts(name))
    s.impulses = [Impulse("box", (BAR_PULL, 0, 0), 0.0, 10.0, lo=(0.75, 0, 0), hi=(1, 1, 1), mode="set")]
    return s, (x[:, 0] > 0.27) & (x[:, 0] < 0.73)


def nominal_stress_xx(F: np.ndarray, d: np.ndarray) -> np.ndarray:
    """``P_xx`` (Pa) the brittle model carries at deformation gradients ``F`` (n, 3, 3) and damage ``d`` (n,):
    ``P = tau F^-T``, ``tau`` the Hencky stress with its tensile principal values scaled by ``1 - d``."""
    U, sig, _ = np.linalg.svd(F)
    eps = np.log(sig)
    s = 2 * MU * eps + LAM * eps.sum(axis=1, keepdims=True)
    s = np.where(s > 0, (1 - d[:, None]) * s, s)
    tau = np.einsum("nij,nj,nkj->nik", U, s, U)
    return np.einsum("nij,nkj->nik", tau, np.linalg.inv(F))[:, 0, 0]


def bar_run(name: str, n_frames: int = 60) -> dict:
    """The bar pulled for ``n_frames`` frames: the largest section-mean ``P_xx`` of any frame (Pa), the final
    largest damage, and the engine's mass before and after (kg)."""
    s, gauge = bar_setup(name)
    layer = np.round((s.x[:, 0] - 0.2) / (s.dx / 2)).astype(int)
    e = build_engine(engines()[name], s)
    try:
        out = {"mass0": e.stats()["mass"], "peak": 0.0}
        for _ in range(n_frames):
            e.step_frame()
            F, d = e.to_setup_order(e.get_state()["F"]), e.damage()
            P = nominal_stress_xx(np.asarray(F, np.float64), d)
            out["peak"] = max(out["peak"], max(P[gauge & (layer == k)].mean() for k in np.unique(layer[gauge])))
        out.update(d_max=float(d.max()), mass1=e.stats()["mass"])
        return out
    finally:
        e.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_a_bar_in_tension_carries_its_tensile_strength_then_breaks(name):
    """Peak section stress ``tensile_strength`` within 5 % (measured: see docs/fracture.md), the bar broken
    (``d = 1`` somewhere), mass kept to 1e-9."""
    r = bar_run(name)
    assert abs(r["peak"] / FT - 1) < 0.05, f"{name}: peak nominal stress {r['peak']:.0f} Pa, tensile_strength {FT:.0f}"
    assert r["d_max"] == 1.0
    assert abs(r["mass1"] / r["mass0"] - 1) < 1e-9


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_bar_check_catches_an_engine_that_never_damages(name, monkeypatch):
    never_damages(monkeypatch, name)
    r = bar_run(name)
    assert r["d_max"] == 0.0 and r["peak"] > 1.05 * FT, r


# ----------------------------------------------------------------------------- a rod hanging under its weight
NECK, NECK_L, HEAD, HEAD_H = 0.08, 0.3, 0.2, 0.1    # neck side and length, head side and height, m
ROD_Z0 = 0.45                                       # the rod's bottom, m (world)
RHO_G_L = RHO * 9.81 * NECK_L                       # the static stress at the top of the neck, Pa


def _box_faces(size, z0: float, spacing: float, skip_top: bool = False, hole: float = 0.0):
    """Centres and rotations (wxyz, thin axis along the face normal) of flat square Gaussians of side ``spacing``
    tiling the faces of the box ``|x|, |y| <= size / 2``, ``z0 <= z <= z0 + size[2]``; ``skip_top`` leaves out
    its top face, ``hole`` the central square of that side out of its bottom face."""
    size = np.asarray(size, float)
    lo = np.array([-size[0] / 2, -size[1] / 2, z0])
    hi = lo + size
    # rotation taking the local x axis (the thin one) to the world axis ``ax``
    q = {0: [1.0, 0.0, 0.0, 0.0], 1: [0.70710678, 0.0, 0.0, 0.70710678], 2: [0.70710678, 0.0, -0.70710678, 0.0]}
    means, rots = [], []
    for ax in range(3):
        u, w = [k for k in range(3) if k != ax]
        nu_, nw = round(size[u] / spacing), round(size[w] / spacing)
        U, W = np.meshgrid(lo[u] + (np.arange(nu_) + 0.5) * spacing, lo[w] + (np.arange(nw) + 0.5) * spacing,
                           indexing="ij")
        for side in (lo[ax], hi[ax]):
            if ax == 2 and side == hi[2] and skip_top:
                continue
            p = np.zeros((U.size, 3))
            p[:, u], p[:, w], p[:, ax] = U.ravel(), W.ravel(), side
            if ax == 2 and side == lo[2] and hole:
                p = p[(np.abs(p[:, 0]) > hole / 2) | (np.abs(p[:, 1]) > hole / 2)]
            means.append(p)
            rots.append(np.tile(q[ax], (len(p), 1)))
    return np.concatenate(means), np.concatenate(rots)


def t_rod(spacing: float = 0.02):
    """Flat Gaussians on the surface of a T: a neck ``NECK`` square, ``NECK_L`` long (z from 0), under a head
    ``HEAD`` square, ``HEAD_H`` high."""
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.maps.games import EPS
    m1, r1 = _box_faces((NECK, NECK, NECK_L), 0.0, spacing, skip_top=True)
    m2, r2 = _box_faces((HEAD, HEAD, HEAD_H), NECK_L, spacing, hole=NECK)
    means, rots = np.concatenate([m1, m2]), np.concatenate([r1, r2])
    n = len(means)
    return Gaussians(means=means, scales=np.column_stack([np.full(n, EPS), np.full(n, spacing / 2),
                                                          np.full(n, spacing / 2)]),
                     rotations=rots, opacities=np.full(n, 2.0, np.float32), sh_dc=np.full((n, 3), 0.5, np.float32))


def rod_scene_text(name: str, ply, tensile_strength: float, n_frames: int = 8) -> str:
    """The scene file of the T rod hanging from its head (``fixed_region`` over the head's top half, z > 0.8 m) on
    the engine ``name`` (taichi_mpm on one thread), its Gaussians in ``ply`` (:func:`t_rod`); also
    ``benchmarks/crack_faces.py --scene rod``."""
    opts = "{ threads = 1 }" if name == "taichi_mpm" else "{}"
    return f"""
frame_dt = 0.02
n_frames = {n_frames}
[engine]
name = "{name}"
options = {opts}
[domain]
lo = [-0.5, -0.5, -0.2]
hi = [0.5, 0.5, 1.0]
n_grid = 29
[[boundary]]
kind = "ground"
[[boundary]]
kind = "fixed_region"
lo = [-1.0, -1.0, 0.8]
hi = [1.0, 1.0, 1.0]
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, {ROD_Z0}]
[object.material]
name = "brittle"
E = {E}
nu = {NU}
rho = {RHO}
tensile_strength = {tensile_strength}
fracture_energy = 5.0
"""


def rod_run(tmp_path, name: str, tensile_strength: float, n_frames: int = 8) -> tuple[list, float | None, list]:
    """``gasp simulate``'s pipeline on the T rod hanging from its head (``fixed_region`` over the head's top half,
    z > 0.8 m): ``run.json``'s frames, the rest height (rod frame, m) of the highest Gaussian that fell more
    than 2 cm (None: none fell), and the run's ``pieces`` events."""
    from gasp_core.run.report import Reporter
    from gasp_core.gs.io import read_gaussians, write_gaussians
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    write_gaussians(tmp_path / "rod.ply", t_rod())
    (tmp_path / "rod.toml").write_text(rod_scene_text(name, tmp_path / "rod.ply", tensile_strength, n_frames))
    out = tmp_path / "run"
    rep = Reporter()
    simulate_scene(load_scene(tmp_path / "rod.toml"), out, reporter=rep)
    frames = json.loads((out / "run.json").read_text())["frames"]
    g0 = read_gaussians(out / "rod" / "frame_0000.ply").means
    g1 = read_gaussians(out / "rod" / f"frame_{n_frames:04d}.ply").means
    fell = g0[:, 2] - g1[:, 2] > 0.02
    crack = float(g0[fell, 2].max()) if fell.any() else None   # frames are written in the file's frame
    return frames, crack, [e for e in rep.events if e["event"] == "pieces"]


#: The rod's frames: its lower part, broken off at about frame 4, has fallen a grid cell (4.1 cm) from the head by
#: frame 9-10 (issue 66: pieces are what has come apart; 2 at frame 9, 3 at frame 10 on warp_mpm).
ROD_FRAMES = 12


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_a_rod_under_its_weight_breaks_in_its_upper_half_below_rho_g_L(tmp_path, name):
    frames, crack, events = rod_run(tmp_path, name, 0.6 * RHO_G_L, ROD_FRAMES)
    assert frames[0]["pieces"] == 1 and frames[-1]["pieces"] >= 2, [f["pieces"] for f in frames]
    counts = [(f["pieces"], f["debris"]) for f in frames]      # an event when the pieces or the crumbs change
    changes = [f["frame"] for k, f in enumerate(frames) if k == 0 or counts[k] != counts[k - 1]]
    assert [e["frame"] for e in events] == changes and events[-1]["pieces"] == frames[-1]["pieces"]
    assert crack is not None and NECK_L / 2 < crack <= NECK_L, f"{name}: broke at {crack} m of the {NECK_L} m neck"
    total = sum(frames[0]["piece_mass"])
    assert all(abs((sum(f["piece_mass"]) + f["debris_mass"]) / total - 1) < 1e-9 for f in frames)


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_a_rod_stays_whole_above_twice_rho_g_L(tmp_path, name):
    frames, crack, events = rod_run(tmp_path, name, 2.5 * RHO_G_L, ROD_FRAMES)
    assert [f["pieces"] for f in frames] == [1] * len(frames) and crack is None and len(events) == 1


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_rod_check_catches_an_engine_that_never_damages(tmp_path, name, monkeypatch):
    never_damages(monkeypatch, name)
    frames, crack, _ = rod_run(tmp_path, name, 0.6 * RHO_G_L, ROD_FRAMES)
    assert frames[-1]["pieces"] == 1 and crack is None


# ----------------------------------------------------------------------------- the fracture energy
def dissipated_per_area(name: str, n_grid: int, per_dx: int = 2, n_frames: int = 60) -> float:
    """The work the bar's damage dissipated once broken, per unit of its cross-section (J/m^2), the bar of
    :func:`bar_setup` at ``per_dx ** 3`` points per cell.

    Per point of volume ``V`` and damage ``d``: linear softening dissipates ``f_t s d / (2 E)`` per unit volume,
    ``s = f_t s_f / ((1 - d)(s_f - f_t) + f_t)`` the largest undamaged stress it has seen (the inverse of
    ``brittle_damage``); a point broken through (``d = 1``) has dissipated ``f_t s_f / (2 E)``, ``G_f / h`` for
    the right ``s_f``. ``s_f`` is read from the engine's own material table (what it runs with). This measures
    the band's volume times its energy density; the work done by the pull cannot isolate it here (the bar stores
    ``f_t^2 / (2 E) L = 30 J/m^2`` before it breaks, six times ``G_f``, and sheds it as waves). Summed over the
    zone of the first crack to part (``gasp_core.testing.scenes_fracture.work_per_crack``): the waves may damage
    or part the bar at its other grip afterwards (nu 0.25: both grips concentrate the stress alike). The held points
    are left out: they never soften, and one whose mirror image is broken through reads ``d`` 1 without having
    dissipated anything (docs/fracture.md "The held region"; counted, they read 8.42 and 9.96 J/m^2 here)."""
    from gasp_core.mpm.materials import P_SF
    s, _ = bar_setup(name, n_grid, per_dx)
    e = build_engine(engines()[name], s)
    table = e.solver.mat.to_numpy() if name == "taichi_mpm" else e.mat_par.numpy()
    sf = float(table[0, P_SF])
    layer, cracks = np.round((s.x[:, 0] - s.x[:, 0].min()) * per_dx / s.dx).astype(int), []
    try:
        for _ in range(n_frames):
            e.step_frame()
            d = e.damage()
            cracks = cracks or broken_runs(layer, d)
        sf = point_sf(name, s, np.asarray(e.positions(), np.float64), sf)
    finally:
        e.close()
    D = FT ** 2 * sf * d / (2 * E * ((1 - d) * (sf - FT) + FT))
    D[held_codes(s.x, s.boundaries, s.dx) > 0] = 0.0   # a held point never softens: its d is its image's crack
    return work_per_crack(layer, s.p_vol * D, cracks, per_dx * CRACK_ZONE_CELLS) / 0.125 ** 2


def point_sf(name: str, s, xs: np.ndarray, sf: float) -> np.ndarray:
    """Each point's own end of softening (Pa, (n,)) at positions ``xs`` (n, 3), its crack normal along x: ``sf``
    scaled by its crack band weight (``gasp_core.mpm.materials.band_weight``, round 33) where the engine's
    ``weighted_band`` is on."""
    from gasp_core.mpm.materials import band_softening_stress, band_weight
    if name == "taichi_mpm":
        from gasp_taichi_mpm.constitutive import Constitutive as Rule
    else:
        from gasp_warp_mpm.held_rule import HeldRule as Rule
    if not Rule.weighted_band:
        return np.full(len(xs), sf)
    X = (xs - np.asarray(s.domain_lo, np.float64)) / s.dx
    return band_softening_stress(FT, sf, band_weight(X - np.floor(X - 0.5), np.array([1.0, 0.0, 0.0])))


def fixed_band(monkeypatch, name: str, h) -> None:
    """Break the engine ``name``: its softening stress is the one of a band ``h(materials, band)`` wide (m)."""
    def spoiled(materials, band=None, cells=None):
        from gasp_core.mpm.materials import P_SF
        kinds, params = material_table(materials, band, cells)
        params[:, P_SF] = [softening_stress(mm, h(band)) if mm.name == "brittle" else 0.0 for mm in materials]
        return kinds, params
    monkeypatch.setattr(f"{PLUGIN_MODULE[name]}.material_table", spoiled)


def not_regularised(monkeypatch, name: str) -> None:
    """Break the engine ``name``: its softening stress is the one of a band 1/32 m wide whatever ``n_grid``."""
    fixed_band(monkeypatch, name, lambda band: 1 / 32)


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_fracture_energy_does_not_depend_on_n_grid(name):
    """Dissipated work per crack area at n_grid 32 and 64 within 15 % of each other (measured 5.06 and 5.04 J/m^2
    on warp_mpm, docs/fracture.md)."""
    w32, w64 = dissipated_per_area(name, 32), dissipated_per_area(name, 64)
    assert abs(w64 / w32 - 1) < 0.15, f"{name}: {w32:.3f} J/m^2 at n_grid 32, {w64:.3f} at 64"


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_n_grid_check_catches_a_fracture_energy_not_regularised(name, monkeypatch):
    not_regularised(monkeypatch, name)
    w32, w64 = dissipated_per_area(name, 32), dissipated_per_area(name, 64)
    assert abs(w64 / w32 - 1) > 0.15, (w32, w64)


def work_to_break_failures(name: str, per_dxs=(3,)) -> list[str]:
    """What the absolute check finds wrong: the bar at n_grid 32 must dissipate ``G_f = 5 J/m^2`` per crack area
    within 20 % at ``per_dx ** 3`` points per cell. It breaks at its clamp's face (``nu`` 0.25: the grip holds the
    section's lateral contraction), where the band is the free layers within 1.5 cells of the face: 1.0 ``dx`` at 27
    points per cell (the band ``h = dx``; 5.34 J/m^2 with round 33's band weight), 1.5 ``dx`` at 8 (a strict xfail: 6.85
    J/m^2 with the band weight, 7.61 before, both engines)."""
    bad = []
    for per_dx in per_dxs:
        w = dissipated_per_area(name, BAR_N_GRID, per_dx)
        if abs(w / 5.0 - 1) >= 0.20:
            bad.append(f"{per_dx ** 3} points per cell: {w:.3f} J/m^2 against G_f = 5")
    return bad


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_work_to_break_the_bar_is_its_fracture_energy(name):
    assert work_to_break_failures(name) == []


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 66: a crack at a clamp's face at 8 points per cell breaks 3 layers "
                                       "(1.5 dx) in the band dx: 6.85 J/m^2 for G_f 5 (+37 %; 7.61 before round 33's "
                                       "crack band weight), warp_mpm")
@pytest.mark.parametrize("name", _names())
def test_the_work_to_break_the_bar_at_its_clamp_at_8_points_a_cell(name):
    assert work_to_break_failures(name, (2,)) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_work_check_catches_the_band_of_the_kernels_support(name, monkeypatch):
    """The band ``2 dx`` (every layer a jump's B-spline hat reaches, the quadratic kernel's support across a node
    pair; 27 points per cell): the check fails it (measured 5.91 J/m^2 with ``dx``, +18 %, on warp_mpm)."""
    fixed_band(monkeypatch, name, lambda band: 2 * float(band[0]))
    assert any(b.startswith("27 points per cell") for b in work_to_break_failures(name))


# ----------------------------------------------------------------------------- the crack starts at the notch
def notched_bar_cracks(name: str) -> np.ndarray:
    """The rest x (m) of the layers of points broken through (``d > 0.99``) after the bar of :func:`bar_setup`,
    with its points in the layer at x = 0.5 m taken out over the upper half of its section (a notch), is pulled
    for 60 frames. The plain bar breaks next to its clamp (x 0.255-0.287 m at n_grid 32)."""
    s, _ = bar_setup(name)
    keep = ~((np.abs(s.x[:, 0] - 0.5) < s.dx / 2) & (s.x[:, 1] > 0.5))
    s = s.replace(x=s.x[keep], v=s.v[keep], p_vol=s.p_vol[keep], body_id=s.body_id[keep])
    e = build_engine(engines()[name], s)
    try:
        for _ in range(60):
            e.step_frame()
        d = e.damage()
    finally:
        e.close()
    return np.unique(np.round(s.x[d > 0.99, 0], 4))


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_a_notched_bar_breaks_at_its_notch(name):
    """Measured: layers at x = 0.492, 0.508, 0.524 m (the notch at 0.5, spacing 1/64 m) on warp_mpm."""
    broken = notched_bar_cracks(name)
    assert len(broken) and np.all(np.abs(broken - 0.5) < 1.5 / BAR_N_GRID), f"{name}: broken layers at {broken}"


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_notch_check_catches_an_engine_that_never_damages(name, monkeypatch):
    never_damages(monkeypatch, name)
    assert len(notched_bar_cracks(name)) == 0


# ----------------------------------------------------------------------------- momentum and energy over a break
def free_bar_break(name: str, n_frames: int = 30) -> dict:
    """The bar of :func:`bar_setup` with no boundary and no impulse, its half x > 0.5 m thrown at +1 m/s along x
    (the jump sends ``rho c / 2 = 15.8 kPa`` through it, over its strength): per frame the total momentum (kg m/s)
    and the kinetic plus elastic energy (J, the elastic energy from ``F`` and ``d``: the Hencky energy density
    ``1/2 sum_i s'_i eps_i``), and the pieces at the end."""
    from gasp_core.run.pieces import tracker_for
    s, _ = bar_setup(name)
    v = np.where(s.x[:, :1] > 0.5, [[1.0, 0.0, 0.0]], 0.0)
    s = s.replace(v=v, boundaries=[], impulses=[])
    e = build_engine(engines()[name], s)
    out = {"p": [float((s.p_mass[:, None] * v).sum(0)[0])], "E": [0.5 * float((s.p_mass * (v ** 2).sum(1)).sum())]}
    try:
        for _ in range(n_frames):
            e.step_frame()
            F, d, vel = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64), e.damage(), e.velocities()
            _, sig, _ = np.linalg.svd(F)
            eps = np.log(sig)
            sp = 2 * MU * eps + LAM * eps.sum(axis=1, keepdims=True)
            sp = np.where(sp > 0, (1 - d[:, None]) * sp, sp)
            out["p"].append(float((s.p_mass[:, None] * vel).sum(0)[0]))
            out["E"].append(0.5 * float((s.p_mass * (vel ** 2).sum(1)).sum() + (s.p_vol * (sp * eps).sum(1)).sum()))
        out["pieces"] = tracker_for(s).row(e.positions(), d)[0]["pieces"]
    finally:
        e.close()
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_a_free_bar_that_breaks_keeps_its_momentum_and_gains_no_energy(name):
    # 90 frames: the pieces are the parts that have come apart by a cell (issue 66 item 4); the bar is broken through
    # by frame 30 but its halves part by a cell only later (in the crack band dx, round 31: 1 piece at 60 frames, 3
    # at 90 on warp_mpm; 3 at 60 in the band 1.5 dx of before)
    r = free_bar_break(name, n_frames=90)
    assert r["pieces"] >= 2, r["pieces"]
    p, E0 = np.array(r["p"]), r["E"][0]
    assert np.all(np.abs(p / p[0] - 1) < 0.01), p
    assert max(r["E"][1:]) <= 1.01 * E0, (E0, max(r["E"][1:]))


# ----------------------------------------------------------------------------- a ball dropped on the ground
def ball_setup(name: str, speed: float, tensile_strength: float, fracture_energy: float) -> SimSetup:
    """A brittle ball (radius 0.1 m, E 200 kPa, nu 0.25, rho 300 kg/m^3, lattice of spacing dx/2 at n_grid 32, frames
    of 0.01 s) that reaches the ground (friction 0.5, walls) at ``speed`` m/s: it starts 5 mm above it with that speed."""
    from gasp_core.testing.helpers import sphere_points
    dx, ground = 1 / 32, 0.1 + 3 / 32
    x, pv = sphere_points((0.5, 0.5, ground + 0.105), 0.1, dx / 2)
    m = Material("brittle", E=2e5, nu=0.25, rho=300.0, tensile_strength=tensile_strength,
                 fracture_energy=fracture_energy)
    return make_setup(x, pv, m, v=np.array([0.0, 0.0, -speed]), n_grid=32, frame_dt=0.01,
                      boundaries=[Boundary("ground", height=ground, friction=0.5), Boundary("walls")],
                      options={"precision": "f32", **({"threads": 1} if name == "taichi_mpm" else {})})


def ball_pieces(name: str, drop: float, tensile_strength: float, fracture_energy: float) -> int:
    """Pieces after 15 frames of :func:`ball_setup`'s ball landing at ``sqrt(2 g drop)`` (the same impact as a drop
    from ``drop`` m, a smaller domain)."""
    from gasp_core.run.pieces import tracker_for
    s = ball_setup(name, np.sqrt(2 * 9.81 * drop), tensile_strength, fracture_energy)
    e = build_engine(engines()[name], s)
    try:
        for _ in range(15):
            e.step_frame()
        return tracker_for(s).row(e.positions(), e.damage())[0]["pieces"]
    finally:
        e.close()


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_a_ball_breaks_from_2_5_m_at_a_low_strength_and_stays_whole_from_5_cm_at_a_high_one(name):
    """Measured: see docs/fracture.md; f_t = 10 kPa from 2.5 m (7 m/s, impact stress about rho c v = 54 kPa); 1 piece
    at 25 kPa from 5 cm (about 7.7 kPa). From 1 m (34 kPa) the ball breaks (83 % of its points at d >= 0.9) but does
    not come apart by a grid cell within the 15 frames: 1 piece (issue 66; 4 by the damage alone before). ``G_f`` 10 and 80
    J/m^2 in the band ``h = dx`` (softening stresses ``s_f`` 12.8 and 41 kPa; round 30's band ``1.5 dx`` took 15 and
    120 J/m^2 for the same ``s_f``)."""
    assert ball_pieces(name, 2.5, 1e4, 10.0) >= 3
    assert ball_pieces(name, 0.05, 2.5e4, 80.0) == 1


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_ball_check_catches_an_engine_that_never_damages(name, monkeypatch):
    never_damages(monkeypatch, name)
    assert ball_pieces(name, 2.5, 1e4, 15.0) == 1


def test_the_studio_offers_brittle_with_its_two_keys():
    """The studio's material menu comes from the installed engines' materials (issue 52: both MLS-MPM engines);
    its starting values are the ball's that breaks from 1 m, above the snap-back limit at any crack band width
    ``h = dx`` under 0.04 m."""
    from gasp_core.studio.form import installed_engines, typical
    assert set(installed_engines("brittle")) == set(_names())
    start = typical("brittle")
    assert start["tensile_strength"] == 1e4 and start["fracture_energy"] == 10.0
    m = Material("brittle", **{k: v for k, v in start.items()})
    assert m.snap_back_limit(0.039) < m.fracture_energy <= m.snap_back_limit(0.04)
