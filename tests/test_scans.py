"""Real captures simulate as the solids they show (issue 19): floaters, opacity limits, degenerate inputs,
resolution checks.

Scenes are built from real data or physics with a known answer: the free-fall drop of one frame
(semi-implicit Euler, ``g T^2 / 2 (1 + 1/N)``, as in ``test_freefall_e2e.py``), the real guitar's own
opacities.
"""
from __future__ import annotations

import dataclasses
from pathlib import Path
import json
import warnings

import numpy as np
import pytest
from gasp_testing import GUITAR, needs_package

from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.gs.gaussians import Gaussians
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene
from gasp_core.testing.helpers import GRAVITY as G
from test_freefall_e2e import sphere_of_flat_gaussians

T = 1.0 / 30.0


def scene(tmp_path, ply, n_grid=16, z=0.5, extra="", domain="", up="+z"):
    p = tmp_path / "scene.toml"
    p.write_text(f"""
frame_dt = {T!r}
n_frames = 1
[engine]
name = "taichi_mpm"
options = {{ threads = 1 }}
[domain]
n_grid = {n_grid}
{domain}
[[boundary]]
kind = "ground"
height = 0.0
friction = 0.5
[[object]]
file = "{ply}"
up_axis = "{up}"
position = [0.0, 0.0, {z}]
{extra}
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
""")
    return load_scene(p)


def with_floater(g: Gaussians, where=(0.0, 0.0, 1000.0)) -> Gaussians:
    """``g`` plus one copy of its first Gaussian moved to ``where`` (file units)."""
    one = g.subset([0])
    one.means[:] = where
    cat = {f: np.concatenate([getattr(g, f), getattr(one, f)]) for f in
           ("means", "scales", "rotations", "opacities", "sh_dc", "sh_rest")}
    return dataclasses.replace(g, **cat)


def test_one_floater_1000_m_away_neither_sizes_the_grid_nor_moves(tmp_path):
    """A 600-Gaussian ball of 5 cm and one Gaussian 1000 m above it: one warning naming 1 floater; the ball
    falls the integrator's exact drop in frame 1 (the floater used to make dx = 125 m and the drop 9.54 mm);
    the floater is written unchanged."""
    ply = tmp_path / "ball.ply"
    write_gaussians(ply, with_floater(sphere_of_flat_gaussians()))
    out = tmp_path / "out"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        simulate_scene(scene(tmp_path, ply, n_grid=32, z=0.06), out)
    floats = [str(w.message) for w in caught if "floater" in str(w.message)]
    assert len(floats) == 1 and "1 floater" in floats[0], [str(w.message) for w in caught]
    run = json.loads((out / "run.json").read_text())
    n = run["engine_stats"]["n_substeps"]
    f0, f1 = (read_gaussians(out / "ball" / f"frame_000{i}.ply") for i in (0, 1))
    drop = f0.means[:600, 2].mean() - f1.means[:600, 2].mean()
    exact = 0.5 * G * T ** 2 * (1.0 + 1.0 / n)
    assert drop == pytest.approx(exact, rel=0.005)
    print(f"N = {n}, drop {drop * 1e3:.4f} mm, exact {exact * 1e3:.4f} mm")
    assert n >= 20 and drop == pytest.approx(0.5 * G * T ** 2, rel=1.0 / n + 0.002)   # 5.45 mm + its 1 / N
    assert np.array_equal(f0.means[600], f1.means[600]) and f1.means[600, 2] > 999.0
    assert run["objects"][0]["n_floaters"] == 1


def test_keep_floaters_simulates_them(tmp_path):
    """A floater 0.2 m above the 5 cm ball is kept (one 2 m away would size the default domain, 20x the
    ball: refused, tests/test_hostile_34.py)."""
    from gasp_core.maps.floaters import find_floaters
    ply = tmp_path / "ball.ply"
    g = with_floater(sphere_of_flat_gaussians(), (0.0, 0.0, 0.2))
    assert find_floaters(g.means, g.scales.max(axis=1)).sum() == 1
    write_gaussians(ply, g)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from gasp_core.prepare.scene import prepare_scene
        prep = prepare_scene(scene(tmp_path, ply, extra="keep_floaters = true"))
    assert not [w for w in caught if "floater" in str(w.message)]
    assert prep.objects[0].moving is None and prep.objects[0].n_floaters == 0


def guitar_with_inf_opacities(tmp_path, every=1):
    """The real guitar as PlayCanvas splat-transform re-encodes it: its fully opaque splats (alpha byte 255,
    logit +40 in PlayCanvas's own decoder; 667 of 90,854) stored as opacity logit +inf. Written through our
    3DGS writer (the re-encoded file itself is not shipped), keeping every ``every``-th splat and all +inf
    ones."""
    g = read_gaussians(GUITAR)
    full = g.opacities >= 40.0
    keep = np.flatnonzero(full | (np.arange(g.n) % every == 0))
    g = g.subset(keep)
    g.opacities[g.opacities >= 40.0] = np.inf
    ply = tmp_path / "guitar_inf.ply"
    write_gaussians(ply, g)
    return ply, int(full.sum())


def test_guitar_with_inf_opacities_reads_and_keeps_them(tmp_path):
    ply, n_inf = guitar_with_inf_opacities(tmp_path)
    g = read_gaussians(ply)
    assert n_inf == 667 and int(np.isposinf(g.opacities).sum()) == 667


@pytest.mark.slow
def test_guitar_with_inf_opacities_simulates_and_frames_keep_them(tmp_path):
    """Every 8th splat of the real guitar plus its 667 +inf ones, -y up, scaled to 1 m; frames keep +inf."""
    ply, _ = guitar_with_inf_opacities(tmp_path, every=8)
    out = tmp_path / "out"
    simulate_scene(scene(tmp_path, ply, extra="scale = 0.23", z=0.02, up="-y"), out)
    src = read_gaussians(ply)
    f1 = read_gaussians(out / "guitar_inf" / "frame_0001.ply")
    assert np.array_equal(np.isposinf(f1.opacities), np.isposinf(src.opacities))
    assert f1.opacities.tobytes() == src.opacities.tobytes()


def test_nan_opacity_is_still_an_error(tmp_path):
    g = sphere_of_flat_gaussians(50)
    g.opacities[3] = np.nan
    from gasp_core.errors import SceneError
    with pytest.raises(SceneError, match="opacit"):
        Gaussians(g.means, g.scales, g.rotations, g.opacities, g.sh_dc)


@pytest.mark.parametrize("kind", ["identical10", "identical600", "collinear", "coplanar"])
def test_degenerate_inputs_end(tmp_path, kind):
    """Identical, collinear or coplanar Gaussians give a thin body or a clear error, never a hang (the fill's
    closing ran 180 s and more on 10 identical Gaussians)."""
    from gasp_core.errors import SceneError
    base = sphere_of_flat_gaussians(600)
    n = 10 if kind == "identical10" else 600
    if kind.startswith("identical"):
        g = base.subset(np.zeros(n, int))
    else:
        g = base.subset(np.arange(n))
        t = np.linspace(-0.05, 0.05, n)
        g.means[:] = 0.0
        g.means[:, 0] = t
        if kind == "coplanar":
            g.means[:, 1] = np.random.default_rng(0).uniform(-0.05, 0.05, n)
    ply = tmp_path / "deg.ply"
    write_gaussians(ply, g)
    out = tmp_path / "out"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scene(scene(tmp_path, ply, z=0.1), out)
    except SceneError as e:
        print(kind, "error:", e)
        assert "deg.ply" in str(e) or "'deg'" in str(e)
        return
    assert (out / "deg" / "frame_0001.ply").exists()
    print(kind, {k: v for k, v in json.loads((out / "run.json").read_text())["objects"][0]["fill_report"].items() if k != "enclosed"})


SPOT = Path("/work/shared/data/mesh/spot_triangulated.obj")


def standing_spot(tmp_path, n_grid=40, n_frames=10, extra=""):
    """Spot the cow (Keenan Crane, public domain) as 3000 GaMeS mesh-mode splats standing on its hooves,
    0.30 m tall, dropped 1 cm onto a ground with friction 0.5 as jelly: E = 1 MPa, rho = 1000 kg/m^3, so
    rho g h / E = 0.29 %. Returns the z extent (0.5 to 99.5 % quantiles of the means) per frame."""
    trimesh = needs_package("trimesh")
    if not SPOT.exists():
        pytest.skip(f"{SPOT} not found")
    mesh = trimesh.load(SPOT, process=False)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    from gasp_core.testing.meshes import mesh_splats
    ply = tmp_path / "spot.ply"
    write_gaussians(ply, mesh_splats(mesh.vertices, mesh.faces, 3000))
    scale = 0.30 / float(np.ptp(mesh.vertices[:, 1]))
    p = tmp_path / "spot.toml"
    p.write_text(f"""
frame_dt = {T!r}
n_frames = {n_frames}
[engine]
name = "taichi_mpm"
options = {{ threads = 1 }}
[domain]
n_grid = {n_grid}
[[boundary]]
kind = "ground"
height = 0.0
friction = 0.5
[[object]]
file = "{ply}"
up_axis = "+y"
scale = {scale!r}
position = [0.0, 0.0, 0.01]
{extra}
[object.material]
name = "jelly"
E = 1.0e6
nu = 0.3
rho = 1000.0
""")
    out = tmp_path / "out"
    simulate_scene(load_scene(p), out)
    heights = []
    for i in range(n_frames + 1):
        z = read_gaussians(out / "spot" / f"frame_{i:04d}.ply").means[:, 2]
        heights.append(float(np.quantile(z, 0.995) - np.quantile(z, 0.005)))
    return np.array(heights)


@pytest.mark.slow
def test_statue_standing_on_its_feet_keeps_its_height(tmp_path):
    h = standing_spot(tmp_path)
    print("height / frame-0 height:", np.round(h / h[0], 4).tolist())
    assert h.min() >= 0.95 * h[0]


def test_zero_scale_reads_as_flat_and_frames_keep_it(tmp_path):
    """A log-scale of -inf is a zero extent (flat): read as scale 0, simulated, written back as -inf."""
    g = sphere_of_flat_gaussians()
    g.scales[:50, 0] = 0.0                    # the thin axis of 50 splats exactly flat
    ply = tmp_path / "ball.ply"
    write_gaussians(ply, g)
    from plyfile import PlyData
    assert np.isneginf(PlyData.read(str(ply))["vertex"]["scale_0"]).sum() == 50
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        simulate_scene(scene(tmp_path, ply, n_grid=16, z=0.06), out)
    s1 = PlyData.read(str(out / "ball" / "frame_0001.ply"))["vertex"]
    assert np.array_equal(np.isneginf(s1["scale_0"]), np.arange(600) < 50)


def test_cells_larger_than_the_object_are_an_error(tmp_path):
    """The issue's case: padding = 10, n_grid 16 gives dx = 0.197 m for a 0.1 m ball (it hovered 5 cm up)."""
    from gasp_core.errors import SceneError
    ply = tmp_path / "ball.ply"
    write_gaussians(ply, sphere_of_flat_gaussians())
    # refused by the first size check that sees it (prepare/assembly: fewer than 2 cells across)
    with pytest.raises(SceneError, match=r"object 'ball' is 0\.1 m across, less than 1 grid cell\(s\) \(dx = 0\.\d+ m.*n_grid"):
        simulate_scene(scene(tmp_path, ply, domain="padding = 10.0", z=0.06), tmp_path / "out")


def test_coarse_grid_warns_with_the_n_grid_that_gives_8_cells():
    from gasp_core.maps.fill import FillReport
    from gasp_core.prepare.checks import check_resolution
    solid = FillReport("ball", 1e-3, 10, 0.01, 0.001, "six-ray", True, 1)
    # a filled solid is judged by its thinnest part (tests/test_thin_parts.py), not by its box (issue 54)
    assert check_resolution("ball", np.array([0.1, 0.1, 0.1]), 0.025, 16, solid) == []
    sheet = FillReport("flag", 1e-5, 0, 0.01, 0.001, "shell-open", False, 0)
    assert check_resolution("flag", np.array([0.3, 0.2, 1e-4]), 0.01, 64, sheet) == []   # a sheet: its width
    msgs = check_resolution("flag", np.array([0.1, 0.1, 1e-4]), 0.025, 16, sheet)
    assert len(msgs) == 1 and "4.0 grid cells across its width" in msgs[0] and "n_grid = 32 gives 8" in msgs[0]
    unfilled = dataclasses.replace(solid, n_fill=0)    # closed, but too small to hold a fill point: by its box
    assert len(check_resolution("ball", np.array([0.1, 0.1, 0.1]), 0.025, 16, unfilled)) == 1
    thin = dataclasses.replace(solid, thin_share=0.2, thin_h=0.002, h=0.005, thin_box=[[0.0, 0.0, 0.0], [0.1, 0.0, 0.01]])
    msgs = check_resolution("cow", np.array([0.3, 0.3, 0.3]), 0.01, 64, thin)
    assert len(msgs) == 1 and "thin parts (20% of its solid" in msgs[0] and "n_grid = 160 fills them" in msgs[0]
    assert "within [0.0, 0.0, 0.0] to [0.1, 0.0, 0.01] m" in msgs[0]


def orbit_cameras(up, n=24):
    """graphdeco cameras.json entries for ``n`` cameras on a circle about ``up``, looking at the origin
    (OpenCV: camera z forward, y down; ``rotation`` camera-to-world)."""
    up = np.asarray(up, float)
    a = np.cross(up, [0.3, 0.5, 0.7])
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    cams = []
    for i, t in enumerate(np.linspace(0, 2 * np.pi, n, endpoint=False)):
        pos = 2 * (np.cos(t) * a + np.sin(t) * b) + 0.5 * up
        z = -pos / np.linalg.norm(pos)
        x = np.cross(-up, z)
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        cams.append({"id": i, "img_name": f"{i:04d}", "width": 800, "height": 800, "position": pos.tolist(),
                     "rotation": np.column_stack([x, y, z]).tolist(), "fx": 1000.0, "fy": 1000.0})
    return cams


def test_info_up_axis_from_cameras_json(tmp_path, capsys):
    """The donut turned so that +z goes to -x, with orbit cameras upright about -x beside it: the cameras
    decide, whatever the geometry says."""
    from gasp_testing import DONUT
    from gasp_core.cli.main import main
    g = read_gaussians(DONUT).subset(np.arange(0, 45624, 8))
    R = np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]])       # +z -> -x
    from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
    g = dataclasses.replace(g, means=g.means @ R.T, rotations=rotmat_to_quat(R @ quat_to_rotmat(g.rotations)))
    write_gaussians(tmp_path / "donut.ply", g)
    (tmp_path / "cameras.json").write_text(json.dumps(orbit_cameras([-1.0, 0, 0])))
    assert main(["info", str(tmp_path / "donut.ply"), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["up_axis_guess"] == "-x" and d["up_axis_confidence"] > 0.9 and "cameras" in d["up_axis_method"]


def test_info_scale_volume_and_mass_of_the_real_donut(capsys):
    """--size gives the scale that makes the height along the guessed up axis that size; the filled volume
    lies between 60 % and 100 % of the convex hull (test_fill's bound for a donut); mass = rho x volume."""
    from gasp_testing import DONUT
    from gasp_core.cli.main import main
    trimesh = needs_package("trimesh")
    assert main(["info", str(DONUT), "--json", "--size", "19.05cm", "--rho", "300", "--n-grid", "32"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["up_axis_guess"] == "+z" and d["suggested_scale"] == pytest.approx(2.0, rel=2e-3)
    g = read_gaussians(DONUT)
    hull = trimesh.convex.convex_hull(2.0 * g.means[1 / (1 + np.exp(-g.opacities)) >= 0.1]).volume
    assert d["volume_unit"] == "m^3" and 0.6 * hull < d["filled_volume"] < hull
    assert d["mass_kg"] == pytest.approx(300 * d["filled_volume"])
    assert d["fill_method"] == "six-ray" and 0 < d["fill_confidence"] <= 1
