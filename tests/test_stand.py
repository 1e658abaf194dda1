"""Can a body carry itself (issues 28 and 38, item 6): gasp_core.prepare.stand's E_crit and the warning `gasp simulate`
gives, the same value `gasp info --rho` reports.

Known answers: a uniform column of height L (above its base) and section second moment I under its weight W
buckles at Greenhill's ``E = W L^2 / (7.837 I)``; the estimate names twice that (gravity switched on at once), and
more for a column few points across (MPM's thin-part softness, ``THIN_SOFTNESS``). A body whose centre of mass lies
beyond its footprint tips whatever its E. The slender figure is a box on two legs made of flat Gaussians on its
faces (what a scan gives), filled by the pipeline.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from gasp_core.prepare.stand import DYNAMIC_FACTOR, stand_estimate, stand_warning
from gasp_core.testing.helpers import box_points

#: Torso (x, y, z sizes) and legs (side, height), metres: a 0.25 m figure on two 4 cm legs (2.5 cells at n_grid 32).
TORSO = (0.10, 0.06, 0.12)
LEG, LEG_H, LEG_GAP = 0.04, 0.13, 0.02
GREENHILL = 7.837


def _greenhill(a: float, L: float, rho: float, base: float) -> float:
    """Greenhill's E (Pa) of a square column of side ``a`` standing ``L - base`` above its base."""
    Lc = L - base
    return rho * 9.81 * a * a * Lc * Lc * Lc / (GREENHILL * a ** 4 / 12)


def test_uniform_column_is_greenhill_times_the_dynamic_factor():
    a, L, rho = 0.02, 0.2, 300.0
    x, pv = box_points((0, 0, 0), (a, a, L), 0.002)            # 10 points across: thick
    est = stand_estimate(x, np.full(len(x), pv), rho)
    g = _greenhill(a, L, rho, est.base_height)
    assert abs(est.E_static / g - 1) < 0.03, (est, g)          # measured -1.6 %
    assert abs(est.E_crit / (DYNAMIC_FACTOR * g) - 1) < 0.03, (est, g)
    assert est.com_over_footprint


def test_a_column_three_points_across_is_softer_by_the_measured_factor():
    """3 points across: 1.28x softer (benchmarks/results/thin_softness_warp_mpm.md), so 1.28x the E."""
    a, L, rho = 0.03, 0.3, 300.0
    x, pv = box_points((0, 0, 0), (a, a, L), 0.01)
    est = stand_estimate(x, np.full(len(x), pv), rho, dx=0.01)
    g = _greenhill(a, L, rho, est.base_height)
    assert abs(est.softness - 1.28) < 0.05, est
    assert abs(est.E_static / (1.28 * g) - 1) < 0.05, (est, g)


def test_a_leaning_column_tips_over():
    x, pv = box_points((0, 0, 0), (0.02, 0.02, 0.2), 0.002)
    x[:, 0] += 0.2 * x[:, 2]                       # sheared: the top is 2 widths over
    est = stand_estimate(x, np.full(len(x), pv), 300.0)
    assert not est.com_over_footprint
    assert "tips over" in stand_warning("col", est, 1e9)


def figure(path, shear: float = 0.0):
    """Flat Gaussians (5 mm apart, thin axis along the face normal) on the faces of a box on two legs, sheared by
    ``y += shear z`` (an imperfection: a lean of ``atan(shear)`` along the legs' weak axis, the base kept flat)."""
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    boxes = [((-LEG_GAP / 2 - LEG, -LEG / 2, 0.0), (-LEG_GAP / 2, LEG / 2, LEG_H)),
             ((LEG_GAP / 2, -LEG / 2, 0.0), (LEG_GAP / 2 + LEG, LEG / 2, LEG_H)),
             ((-TORSO[0] / 2, -TORSO[1] / 2, LEG_H), (TORSO[0] / 2, TORSO[1] / 2, LEG_H + TORSO[2]))]
    means, normals = [], []
    step = 0.005
    for lo, hi in boxes:
        lo, hi = np.array(lo), np.array(hi)
        for d in range(3):
            e1, e2 = [k for k in range(3) if k != d]
            u = np.arange(lo[e1] + step / 2, hi[e1], step)
            w = np.arange(lo[e2] + step / 2, hi[e2], step)
            U, Wg = np.meshgrid(u, w, indexing="ij")
            for side, sign in ((lo[d], -1.0), (hi[d], 1.0)):
                p = np.zeros((U.size, 3))
                p[:, e1], p[:, e2], p[:, d] = U.ravel(), Wg.ravel(), side
                n = np.zeros(3)
                n[d] = sign
                means.append(p)
                normals.append(np.tile(n, (len(p), 1)))
    means, normals = np.concatenate(means), np.concatenate(normals)
    means[:, 1] += shear * means[:, 2]
    quats = np.array([Rotation.align_vectors([n], [[1.0, 0.0, 0.0]])[0].as_quat() for n in normals])
    g = Gaussians(means=means, scales=np.tile([1e-8, step / 2, step / 2], (len(means), 1)),
                  rotations=quats[:, [3, 0, 1, 2]], opacities=np.full(len(means), 3.0, np.float32),
                  sh_dc=np.full((len(means), 3), 0.5, np.float32))
    return write_gaussians(path, g)


def scene_file(ply, E: float, tmp_path, name: str, surface: str = "auto", obj: str | None = None,
               rho: float = 1000.0, sleep: bool = True, n_frames: int = 30, model: str = "auto") -> Path:
    """A scene: ``ply`` (or the ``obj`` lines) standing on a ground, warp_mpm, n_grid 32, jelly of ``E`` Pa;
    ``model``: its ``material.model`` (``auto`` takes the rigid limit where its weight deforms it under a quarter cell,
    gasp_core.prepare.route: the scan-like figure from about 1.52e5 Pa)."""
    obj = obj or f'file = "{ply}"'
    text = f"""sleep = {str(sleep).lower()}
frame_dt = 0.0333333
n_frames = {n_frames}
[engine]
name = "warp_mpm"
[domain]
n_grid = 32
[[boundary]]
kind = "ground"
height = 0.0
friction = 0.8
[[object]]
{obj}
up_axis = "+z"
position = [0.0, 0.0, 0.0]
surface = "{surface}"
[object.material]
name = "jelly"
model = "{model}"
E = {E}
nu = 0.3
rho = {rho}
"""
    p = Path(tmp_path) / f"{name}.toml"
    p.write_text(text)
    return p


def prepared(ply, E: float, tmp_path, surface: str = "auto", obj: str | None = None, rho: float = 1000.0):
    """``prepare_scene`` of :func:`scene_file` (warnings as they come)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    return prepare_scene(load_scene(scene_file(ply, E, tmp_path, f"E{E:.0f}_{surface}", surface, obj, rho)))


def _warnings(ply, E: float, tmp_path, surface: str = "auto", obj: str | None = None, rho: float = 1000.0):
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        prepared(ply, E, tmp_path, surface, obj, rho)
    return [str(w.message) for w in got if "own weight" in str(w.message) or "tips over" in str(w.message)]


def _named(line: str) -> float:
    return float(line.split("needs E of about ")[1].split(" Pa")[0])


@pytest.fixture(scope="module")
def figure_ply(tmp_path_factory):
    return figure(tmp_path_factory.mktemp("figure") / "figure.ply")


def test_slender_figure_is_warned_below_its_E_crit_and_info_names_the_same_E(figure_ply, tmp_path):
    """The warning names the E it needs; just above it there is none; with a passive surface (the fill alone
    carries the mass) it names the same E within 15 %; `gasp info --rho` (up axis unsure: judged standing along +z,
    the default) names the same E: the same points and dx (before: 2.3e5 from info's own fill against 2.8e5 from the
    scene's). Where ``auto`` runs it rigid (round 39) the line says so, not that it will fall."""
    from gasp_core.cli.info import info
    lines = _warnings(figure_ply, 1e3, tmp_path)
    assert len(lines) == 1 and "needs E of about" in lines[0] and lines[0].endswith("will sag or fall over"), lines
    E_crit = _named(lines[0])
    assert 2e5 < E_crit < 1e6, lines
    assert "runs as a rigid body" in _warnings(figure_ply, 0.95 * E_crit, tmp_path)[0]   # auto's rigid limit
    assert not _warnings(figure_ply, 1.05 * E_crit, tmp_path)
    passive = _warnings(figure_ply, 1e3, tmp_path, surface="passive")    # the fill alone carries the mass
    # measured 12 % apart here, 0.4 % on the sheared figure (53 % and 70 % before): what is left is the fill's own
    # sampling (a 1 cm lattice on 4 cm legs covers 4.5 cm, the full model's skin 4.4 cm)
    assert abs(_named(passive[0]) / E_crit - 1) < 0.15, (passive, lines)
    d = info(figure_ply, rho=1000.0, n_grid=32)
    assert abs(d["stand_E_crit_Pa"] / E_crit - 1) < 0.005, (d["stand_E_crit_Pa"], E_crit)   # 3 digits in the line
    assert d["stand_com_inside"] is True and d["stand_E_static_Pa"] == d["stand_E_crit_Pa"] / DYNAMIC_FACTOR
    assert d["up_axis_guess"] == "unknown" and "+z" in d["stand_note"]


#: Greenhill's uniform columns: (second moment of area / area^2) of the section, for E = 2 * W L^2 / (7.837 I).
PRISMS = {"box": 1 / 12, "cylinder": 1 / (4 * np.pi)}


@pytest.mark.parametrize("shape", ["sphere", "box", "cylinder", "torus"])
def test_ordinary_shapes_given_as_meshes_get_sane_estimates(shape, tmp_path):
    """A 10 cm jelly sphere, a 10 cm box, a cylinder (6 x 15 cm) and a torus lying flat (20 cm across), as meshes
    standing on the ground at E 2e4 Pa, rho 300: no warning. The box and the cylinder are uniform columns: twice
    Greenhill's E within 10 % (section and weight from the mesh's area and volume, length above the base); the
    sphere and the torus are no columns: below 100 rho g H, the E at which their weight strains them 1 % (the sphere
    got 1.2e26 Pa before, the torus 3.9e5)."""
    import trimesh
    m = {"sphere": lambda: trimesh.creation.icosphere(3, 0.05),
         "box": lambda: trimesh.creation.box((0.1, 0.1, 0.1)).subdivide().subdivide().subdivide(),
         "cylinder": lambda: trimesh.creation.cylinder(0.03, 0.15),
         "torus": lambda: trimesh.creation.torus(0.07, 0.03)}[shape]()
    m.apply_translation([0.0, 0.0, -m.bounds[0][2]])
    path = tmp_path / f"{shape}.obj"
    m.export(path)
    obj = f'mesh = "{path}"'
    assert not _warnings(None, 2e4, tmp_path, obj=obj, rho=300.0)
    s = prepared(None, 2e4, tmp_path, obj=obj, rho=300.0).setup
    keep = s.p_vol > 0
    est = stand_estimate(s.x[keep], s.p_vol[keep], 300.0, dx=s.dx)
    assert est.com_over_footprint
    assert abs(s.x[keep, 2].min()) < 2 * s.dx                      # judged: it stands on the ground
    if shape in PRISMS:
        A = m.volume / float(m.extents[2])                          # the section, m^2; its I from the shape
        Lc = est.height - est.base_height                           # the points' height and weight above the base
        W = 300.0 * 9.81 * float(s.p_vol[keep].sum()) * Lc / est.height
        expected = DYNAMIC_FACTOR * W * Lc ** 2 / (GREENHILL * PRISMS[shape] * A * A)
        assert abs(est.E_crit / expected - 1) < 0.1, (est, expected)
    else:
        assert 0 < est.E_crit < 100 * 300.0 * 9.81 * est.height, est


def test_a_dropped_donut_gets_no_stand_warning():
    """The README's donut (examples/donut_jelly.toml) falls onto the ground from 5 cm: not standing, no warning."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        prepare_scene(load_scene(Path(__file__).parents[1] / "examples" / "donut_jelly.toml"))
    assert not [str(w.message) for w in got if "own weight" in str(w.message) or "tips over" in str(w.message)]


def test_a_donut_lying_on_the_ground_stands():
    """examples/donut_wind.toml: the donut rests on its rounded underside; its footprint is the convex hull of its
    points within a cell of the ground (all round the ring), over its centre of mass in the hole. No warning of either
    kind (a lying donut on the ground got "needs E of about 3.9e5 Pa" before)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        ps = prepare_scene(load_scene(Path(__file__).parents[1] / "examples" / "donut_wind.toml"))
    assert not [str(w.message) for w in got if "tips over" in str(w.message) or "own weight" in str(w.message)]
    s = ps.setup
    keep = s.p_vol > 0
    est = stand_estimate(s.x[keep], s.p_vol[keep], 300.0, dx=s.dx)
    assert est.com_over_footprint and est.E_crit < 0.1 * 2e4, est


def lean_and_height(m: np.ndarray, x0: np.ndarray) -> tuple[float, float]:
    """Lean (degrees: the top tenth's centroid against the bottom tenth's, from the vertical) and height (the top
    tenth's centroid over its start) of the points ``m`` (n, 3) that started at ``x0``."""
    top = x0[:, 2] > np.percentile(x0[:, 2], 90)
    bot = x0[:, 2] < np.percentile(x0[:, 2], 10)
    d = m[top].mean(0) - m[bot].mean(0)
    return float(np.degrees(np.arctan2(np.hypot(d[0], d[1]), d[2]))), float(m[top, 2].mean() / x0[top, 2].mean())


def _run_figure(ply, E: float, tmp_path, n_frames: int = 30, model: str = "auto") -> list[tuple[float, float]]:
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    rows, x0 = [], []

    def on_frame(k, gs):
        m = gs[0].means.astype(np.float64)
        x0.append(m.copy()) if not x0 else None
        rows.append(lean_and_height(m, x0[0]))
    toml = scene_file(ply, E, tmp_path, f"run{E:.0f}_{model}", sleep=False, n_frames=n_frames, model=model)
    try:
        simulate_scene(load_scene(toml), tmp_path / f"out{E:.0f}_{model}", quiet=True, on_frame=on_frame)
    except Exception:      # fell out of the domain: the frames so far
        pass
    return rows


@pytest.mark.slow
def test_the_figure_stands_at_the_E_named_and_falls_at_a_fifth(tmp_path):
    """The must-show (issue 38, item 6), warp_mpm, 30 frames, sleep off, the figure leaning 0.57 deg (shear 0.01)
    along its legs' weak axis: at the E the warning names its lean grows by under 0.1 deg and its height stays within
    3 %; at a fifth of it the lean passes 5 deg (measured: +0.0000 deg and 0.9993 at E_crit 3.25e5 Pa; 9.1 deg by
    frame 10 at a fifth). Round 39: 3.07e5 named, run rigid by ``auto``; forced elastic +1.34 deg (docs/contact.md)."""
    ply = figure(tmp_path / "figure.ply", shear=0.01)
    lines = _warnings(ply, 1.0, tmp_path)
    E_crit = _named(lines[0])
    at = _run_figure(ply, E_crit, tmp_path)
    assert len(at) >= 30, len(at)
    leans, heights = np.array(at).T
    assert leans.max() - leans[0] < 0.1 and abs(heights - 1).max() < 0.03, at
    low = _run_figure(ply, E_crit / 5, tmp_path)
    assert max(lean for lean, _ in low) > leans[0] + 5.0, low


# ----------------------------------------------------------------------------- the figure as a scan sees it (issue 54)
def scan_figure(path, seed=54, shear=0.01, jitter=0.0015, tilt_deg=15.0, dropout=0.2, step=0.005):
    """The figure of test_stand, as a scan sees it: each face's Gaussians jittered (position +-jitter m along every
    axis, normal tilted by up to tilt_deg, sizes 0.6-1.4 x), a share dropped, and no Gaussian on the legs' soles."""
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    rng = np.random.default_rng(seed)
    boxes = [((-LEG_GAP / 2 - LEG, -LEG / 2, 0.0), (-LEG_GAP / 2, LEG / 2, LEG_H)),
             ((LEG_GAP / 2, -LEG / 2, 0.0), (LEG_GAP / 2 + LEG, LEG / 2, LEG_H)),
             ((-TORSO[0] / 2, -TORSO[1] / 2, LEG_H), (TORSO[0] / 2, TORSO[1] / 2, LEG_H + TORSO[2]))]
    means, normals = [], []
    for bi, (lo, hi) in enumerate(boxes):
        lo, hi = np.array(lo), np.array(hi)
        for d in range(3):
            e1, e2 = [k for k in range(3) if k != d]
            u = np.arange(lo[e1] + step / 2, hi[e1], step); w = np.arange(lo[e2] + step / 2, hi[e2], step)
            U, Wg = np.meshgrid(u, w, indexing="ij")
            for side, sign in ((lo[d], -1.0), (hi[d], 1.0)):
                if bi < 2 and d == 2 and sign < 0:
                    continue                       # open soles
                p = np.zeros((U.size, 3)); p[:, e1], p[:, e2], p[:, d] = U.ravel(), Wg.ravel(), side
                n = np.zeros(3); n[d] = sign
                means.append(p); normals.append(np.tile(n, (len(p), 1)))
    means, normals = np.concatenate(means), np.concatenate(normals)
    keep = rng.random(len(means)) >= dropout
    means, normals = means[keep], normals[keep]
    means = means + rng.uniform(-jitter, jitter, means.shape)
    means[:, 2] = np.maximum(means[:, 2], 0.0)
    means[:, 1] += shear * means[:, 2]
    base = np.array([Rotation.align_vectors([n], [[1.0, 0.0, 0.0]])[0].as_quat() for n in normals])
    axis = rng.normal(size=(len(means), 3)); axis /= np.linalg.norm(axis, axis=1)[:, None]
    tilt = Rotation.from_rotvec(axis * np.radians(rng.uniform(0, tilt_deg, (len(means), 1))))
    quats = (tilt * Rotation.from_quat(base)).as_quat()
    sizes = step / 2 * rng.uniform(0.6, 1.4, (len(means), 2))
    g = Gaussians(means=means, scales=np.column_stack([np.full(len(means), 1e-8), sizes]),
                  rotations=quats[:, [3, 0, 1, 2]], opacities=np.full(len(means), 3.0, np.float32),
                  sh_dc=np.full((len(means), 3), 0.5, np.float32))
    return write_gaussians(path, g)


def test_no_fill_point_of_the_scan_like_figure_starts_in_the_ground(tmp_path):
    """Issue 54 item 6: the open soles' enclosure ends at the side splats' footprints, 2 sigma of their sizes under the
    lowest Gaussians (on the ground); the fill's floor (the ground) keeps every fill point out of it, and cuts no
    more than that: the lowest fill point lies within one fill cell over the ground (measured: -2.2 mm before, 13
    fill points in the ground, which held the figure up at a fifth of the E named; 8.1 mm of h = 10.3 mm since)."""
    ply = scan_figure(tmp_path / "scan_figure.ply")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepared(ply, 1e6, tmp_path)
    fill_z = prep.setup.x[prep.setup.n_render:, 2]
    h = prep.objects[0].fill_report.h
    assert 0.0 <= fill_z.min() < h, (fill_z.min(), h)


@pytest.mark.parametrize("seed", [54, 7])
def test_the_scan_like_figures_legs_are_filled_on_the_ground(seed, tmp_path):
    """Issue 54 item 6: the figure's open-soled legs under its closed torso sat on the open-base share (sealed
    0.727-0.762 over seeds 54, 11, 7, 3): over 0.75 the six rays decided and the legs stayed hollow (seed 7: 1 fill
    point in them, their volume 0.38 of the legs'; seed 3: 0.48). The ground closes the soles whose outline it
    touches (``gasp_core.maps.occupancy._soles``): the legs' volume (points with volume under the torso, beside
    the gap) is 1.04-1.07 of the two 4 x 4 x 13 cm legs on seeds 54, 7, 11, 3 and 5 (1.05-1.10 by whole cells,
    before the faces' shares), both legs hold fill points, and the estimate names 2.89e5-3.03e5 Pa (2.57e5-2.77e5 by
    whole cells; seed 7: 6.27e5 with hollow legs)."""
    ply = scan_figure(tmp_path / "scan_figure.ply", seed=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepared(ply, 1e6, tmp_path)
    x, p_vol, n = prep.setup.x, prep.setup.p_vol, prep.setup.n_render
    legs = (np.abs(x[:, 0]) > LEG_GAP / 2) & (x[:, 2] < LEG_H)
    assert 1.03 < p_vol[legs].sum() / (2 * LEG * LEG * LEG_H) < 1.13
    for side in (-1, 1):
        assert (legs[n:] & (side * x[n:, 0] > 0)).sum() > 40, side


def _must_show(seed: int, tmp_path, model: str = "auto") -> None:
    """The scan-like figure of ``seed`` at the E its warning names: its lean grows by at most 1 deg over 30 frames;
    at a third of it by more than 1 deg over 30 frames and more than 5 over 45 (``model``: ``material.model``)."""
    ply = scan_figure(tmp_path / "scan_figure.ply", seed=seed)
    E_crit = _named(_warnings(ply, 1.0, tmp_path)[0])
    at = _run_figure(ply, E_crit, tmp_path, model=model)
    assert len(at) >= 30 and max(lean for lean, _ in at[:31]) - at[0][0] <= 1.0, at
    low = _run_figure(ply, E_crit / 3, tmp_path, n_frames=45, model=model)
    assert max(lean for lean, _ in low[:31]) > low[0][0] + 1.0, low
    assert max(lean for lean, _ in low) > low[0][0] + 5.0, low


# Found in round 38 (2026-11-28) by a slow-tier run and bisected to 395a1a7 (the fill's face shares made the default,
# issue 66 item 3): seed 54 named 2.89e5 Pa and at a third (9.63e4) stood (lean +0.13 deg by frame 30, +0.26 by 45), a
# strict xfail until round 87. Round 87 found it passing: +1.34 deg by frame 30 and +12.7 by 45 at a third (+0.34 at the
# E named). Round 86's balance no longer takes back the torque of a flat patch (``gasp_core.mpm.take_back``); with
# ``PLANE_BOUND`` off the figure stands at a third again (+0.10 / +0.20, warp_mpm, a probe).


@pytest.mark.slow
@pytest.mark.parametrize("seed", [54, 7])
def test_the_scan_like_figure_stands_at_the_E_named_and_falls_at_a_third(seed, tmp_path):
    """Issue 54 item 6's must-show: the figure above as a scan gives it (positions jittered 1.5 mm, normals tilted up
    to 15 deg, sizes 0.6-1.4x, a fifth of the Gaussians dropped, the soles open), warp_mpm, sleep off. At the E the
    warning names its lean grows by at most 1 deg over 30 frames; at a third of it by more than 1 deg over 30 frames
    and more than 5 over 45 (it falls). Under ``auto`` the E named (2.9e5-3.0e5) takes the rigid limit (from about
    1.52e5 Pa): +0.00 there in round 39, +0.34 in round 87 (seed 54); the elastic body: the test below. Measured
    (round 39): seed 7 2.94e5 named, at a third +5.4 by frame 30; seed 54 (round 87) 2.89e5 named, at a third +1.34
    by 30 and +12.7 by 45. Before the fill's floor and soles on the ground seed 54 named 2.69e5 and stood at a third
    and a fifth (+0.03 deg), seed 7 named 6.27e5 (docs/contact.md)."""
    _must_show(seed, tmp_path)


#: Round 39: the figure forced elastic at the E named (``auto`` is rigid there): its lean's plateau over the bound.
ELASTIC_LEANS = {54: "lean +1.10 deg by frame 30 (plateau +1.15 by 45; +0.35 at 1.5x, +0.45 at 0.7x)",
                 7: "lean +1.15 deg by frame 30 (+1.33 by 45; +0.50 at 1.5x, +2.1 at 0.7x)"}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [pytest.param(s, marks=pytest.mark.xfail(strict=True, reason=r))
                                  for s, r in ELASTIC_LEANS.items()] + [11])
def test_the_scan_like_figure_as_an_elastic_body_stands_at_the_E_named(seed, tmp_path):
    """:func:`_must_show` on the body the estimate is about, forced elastic (``auto`` takes the rigid limit from
    about 1.52e5 Pa, gasp_core.prepare.route, so the E named judges a rigid body). Measured (round 39, warp_mpm CPU):
    seed 11 3.03e5 named, +0.46; at a third +2.01 by 30, +18.3 by 45; seeds 54 and 7 fail at the E named
    (:data:`ELASTIC_LEANS`); seed 3 (not run) stands there (+0.03) and at a third. docs/contact.md."""
    _must_show(seed, tmp_path, "elastic")
