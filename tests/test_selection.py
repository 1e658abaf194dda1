"""Select what moves (issue 9 A): a region of a file simulated, the rest static, whole frames written.

Real data: the V3DG donut (half of it selected by a box) and the splaTV kitchen (the spinach in
the pan, at one model time). The static rows of every frame are compared byte for byte.
"""
import json
import tomllib
from pathlib import Path

import numpy as np
from scipy.special import expit
import pytest
from gasp_testing import DONUT, ROOT, needs_package
from plyfile import PlyData

from gasp_core.errors import SceneError
from gasp_core.gs.io import read_gaussians
from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.prepare.scene import prepare_scene
from gasp_core.run.pipeline import simulate_scene
from gasp_core.prepare.dynamic import still_rows
from gasp_core.prepare.placement import prepare_object
from gasp_core.scene.spec import load_scene, parse_scene
from gasp_core.prepare.selection import grow_selection, static_splats

KITCHEN = ROOT / "examples" / "kitchen_spinach.toml"
SPLATV = ROOT / "examples" / "data" / "spinach_4.splatv"
N_DONUT = 45624
G = 9.81
FRAME_DT = 1.0 / 30.0

JELLY = '[object.material]\nname = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0\n'


def donut_scene(select: str = "", extra: str = "", n_frames: int = 2, static_object: str = "") -> str:
    """The donut 5 cm above a ground plane, half of it (file x <= 0) selected unless ``select`` says."""
    select = select or "select = { box = { lo = [-1.0, -1.0, -1.0], hi = [0.0, 1.0, 1.0] } }"
    return f"""
frame_dt = {FRAME_DT}
n_frames = {n_frames}
[engine]
name = "taichi_mpm"
options = {{ threads = 1 }}
[domain]
n_grid = 24
[[boundary]]
kind = "ground"
height = 0.0
[[object]]
file = "{DONUT}"
position = [0.0, 0.0, 0.05]
{select}
{extra}
{JELLY}
{static_object}
"""


def parse(text: str, src: Path = ROOT / "tests" / "scene.toml"):
    return parse_scene(tomllib.loads(text), src)


def vertex(path) -> np.ndarray:
    return PlyData.read(str(path))["vertex"].data


# ---------------------------------------------------------------- the donut, half of it moving

STATIC_DONUT = f"""
[[object]]
file = "{DONUT}"
position = [0.5, 0.0, 0.0]
static = true
"""


@pytest.fixture(scope="module")
def half_donut(tmp_path_factory):
    needs_package("gasp_taichi_mpm")
    tmp = tmp_path_factory.mktemp("half")
    scene = tmp / "half.toml"
    # the half falls freely: its unselected rest, a collider by default (gasp_core.prepare.around), left out
    scene.write_text(donut_scene(extra="rest_collider = false", static_object=STATIC_DONUT))
    res = simulate_scene(load_scene(scene), tmp / "out", quiet=True)
    return tmp / "out", res


def test_every_frame_is_the_whole_file_static_rows_bit_for_bit(half_donut):
    out, _ = half_donut
    src = vertex(DONUT)
    static = src["x"] > 0  # the box takes x <= 0 (file frame)
    frames = [vertex(p) for p in sorted((out / "0_donut_v3dg").glob("frame_*.ply"))]
    assert len(frames) == 3
    for f in frames:
        assert len(f) == N_DONUT
        assert f[static].tobytes() == frames[0][static].tobytes()
    # the input order, and the input's values: every field but the quaternion (the input stores it
    # unnormalised; gasp writes it normalised) bit for bit
    for k in src.dtype.names:
        if not k.startswith("rot"):
            assert np.array_equal(src[k][static].view(np.uint32), frames[0][k][static].view(np.uint32)), k
    q_in = np.stack([src[f"rot_{i}"][static] for i in range(4)], 1).astype(np.float64)
    q_out = np.stack([frames[0][f"rot_{i}"][static] for i in range(4)], 1)
    assert np.allclose(q_in / np.linalg.norm(q_in, axis=1, keepdims=True), q_out, atol=1e-6)


def test_the_selected_half_falls_freely(half_donut):
    """Two frames of free fall (the donut starts 5 cm up): the moving half drops g t^2 / 2 = 2.18 cm."""
    out, _ = half_donut
    moving = vertex(DONUT)["x"] <= 0
    f0, f2 = (vertex(out / "0_donut_v3dg" / f"frame_{i:04d}.ply") for i in (0, 2))
    dz = f2["z"][moving].astype(np.float64) - f0["z"][moving]
    expect = -0.5 * G * (2 * FRAME_DT) ** 2
    assert np.median(dz) == pytest.approx(expect, rel=0.1)
    assert np.all(np.abs(f2["x"][moving] - f0["x"][moving]) < 5e-3)


def test_static_object_written_unchanged(half_donut):
    out, res = half_donut
    frames = sorted((out / "1_donut_v3dg").glob("frame_*.ply"))
    first = vertex(frames[0])
    assert len(first) == N_DONUT
    for p in frames[1:]:
        assert vertex(p).tobytes() == first.tobytes()


def test_run_json_counts(half_donut):
    out, res = half_donut
    run = json.loads((out / "run.json").read_text())
    n_sel = int(np.sum(vertex(DONUT)["x"] <= 0))
    assert 0.3 * N_DONUT < n_sel < 0.7 * N_DONUT
    assert run["n_gaussians"] == 2 * N_DONUT
    assert run["n_selected"] == n_sel and run["n_static"] == 2 * N_DONUT - n_sel
    half, still = run["objects"]
    assert (half["n_gaussians"], half["n_selected"], half["n_static"]) == (N_DONUT, n_sel, N_DONUT - n_sel)
    assert half["select"]["kind"] == "box" and half["select"]["frame"] == "file"
    assert (still["static"], still["n_selected"], still["n_static"], still["n_fill_points"]) == \
        (True, 0, N_DONUT, 0)
    # only the selected half reaches the engine: its triangle vertices (or centres, the level's layout on jelly)
    per = {"vertices": 3, "centres": 1}[half["surface_points"]]
    assert run["n_render_points"] == per * n_sel
    assert run["n_points"] == per * n_sel + half["n_fill_points"]
    assert run["engine_stats"]["n_points"] == run["n_points"]


# ---------------------------------------------------------------- selection kinds, prepare only


@pytest.fixture(scope="module")
def donut_box_rows():
    o = prepare_object(parse(donut_scene()).objects[0])
    rows = np.flatnonzero(read_gaussians(DONUT).means[:, 0] <= 0)
    assert np.array_equal(o.moving, rows)
    return o, rows


def test_indices_and_masks_select_the_same_rows(tmp_path, donut_box_rows):
    o, rows = donut_box_rows
    mask = np.zeros(N_DONUT, bool)
    mask[rows] = True
    np.save(tmp_path / "mask.npy", mask)
    np.save(tmp_path / "rows.npy", rows[::-1].astype(np.int32))  # any order, any integer type
    src = tmp_path / "s.toml"
    for sel in ('select = { mask = "mask.npy" }', 'select = { mask = "rows.npy" }',
                f"select = {{ indices = {rows.tolist()} }}"):
        got = prepare_object(parse(donut_scene(sel), src).objects[0])
        assert np.array_equal(got.moving, rows), sel
        assert len(got.tri_rest) == len(rows)


def test_world_frame_box_and_sphere(donut_box_rows):
    o, rows = donut_box_rows
    world = o.placement.to_world(o.gaussians.means)
    x0 = float(o.placement.to_world(np.zeros((1, 3)))[0, 0])  # file x = 0 in the world frame
    got = prepare_object(parse(donut_scene(
        f'select = {{ box = {{ lo = [-1.0, -1.0, -1.0], hi = [{x0!r}, 1.0, 1.0] }}, frame = "world" }}')).objects[0])
    assert np.array_equal(got.moving, np.flatnonzero(world[:, 0] <= x0))
    assert abs(len(got.moving) - len(rows)) <= 2  # the same plane, up to rounding at the boundary
    c = world.mean(axis=0)
    got = prepare_object(parse(donut_scene(
        f'select = {{ sphere = {{ centre = {c.tolist()}, radius = 0.05 }}, frame = "world" }}')).objects[0])
    assert np.array_equal(got.moving, np.flatnonzero(np.linalg.norm(world - c, axis=1) <= 0.05))


def test_grow_takes_the_whole_donut_from_a_small_piece():
    """A 2 cm slab of the ring grows to the connected donut (its splats overlap all round)."""
    g = read_gaussians(DONUT)
    lo, hi = g.means.min(axis=0), g.means.max(axis=0)
    a = [float(lo[0]), float(lo[1] + hi[1]) / 2 - 0.01, float(lo[2])]
    b = [float(lo[0]) + 0.02, float(lo[1] + hi[1]) / 2 + 0.01, float(hi[2])]
    seed = prepare_object(parse(donut_scene(f"select = {{ box = {{ lo = {a}, hi = {b} }} }}")).objects[0])
    grown = prepare_object(parse(donut_scene(
        f"select = {{ box = {{ lo = {a}, hi = {b} }}, grow = true }}")).objects[0])
    assert len(seed.moving) < 0.05 * N_DONUT
    # every opaque Gaussian (39,963 of 45,624 reach min_opacity = 0.1) is one connected piece; the
    # transparent ones link nothing, so only those in the seed box come along
    opaque = 1.0 / (1.0 + np.exp(-g.opacities.astype(np.float64))) >= 0.1
    assert opaque.sum() == 39963
    assert np.array_equal(grown.moving, np.union1d(seed.moving, np.flatnonzero(opaque)))


def test_grow_selection_links_overlapping_splats_only():
    """Two chains of splats 0.1 apart, the chains 1 apart: growing never crosses between them."""
    chain = np.arange(10) * 0.1
    means = np.concatenate([np.stack([chain, 0 * chain, 0 * chain], 1),
                            np.stack([chain, 0 * chain + 1.0, 0 * chain], 1)])
    radii = np.full(20, 0.15)  # each splat reaches its neighbours' centres (0.1), not the next ones (0.2)
    assert np.array_equal(grow_selection(np.array([3]), means, radii), np.arange(10))
    assert np.array_equal(grow_selection(np.array([3, 15]), means, radii), np.arange(20))
    gap = radii.copy()
    gap[4:6] = 0.05  # rows 4 and 5 reach neither each other nor, 0.2 away, rows 3 and 6's neighbours
    assert np.array_equal(grow_selection(np.array([3]), means, gap), np.arange(5))
    linking = np.ones(20, bool)
    linking[2] = False  # a transparent splat links nothing
    assert np.array_equal(grow_selection(np.array([3]), means, radii, linking), np.arange(3, 10))
    assert np.array_equal(grow_selection(np.array([2]), means, radii, linking), np.array([2]))


def test_static_object_reaches_no_engine_and_gives_its_splats(donut_box_rows):
    text = donut_scene("select = { indices = [0, 1, 2, 3] }", static_object=STATIC_DONUT)
    prep = prepare_scene(parse(text))
    per = {"vertices": 3, "centres": 1}[prep.objects[0].spec.surface_points]   # the level's layout
    assert prep.setup.n_render == per * 4 and len(prep.setup.materials) == 1
    assert set(np.unique(prep.setup.body_id)) == {0}
    splats = static_splats(prep)
    assert [s[0] for s in splats] == ["0_donut_v3dg", "1_donut_v3dg"]
    (_, tri0, op0), (_, tri1, op1) = splats
    assert tri0.shape == (N_DONUT - 4, 3, 3) and tri1.shape == (N_DONUT, 3, 3)
    g = read_gaussians(DONUT)
    assert np.array_equal(op1, g.opacities) and np.array_equal(op0, g.opacities[4:])
    still = prep.objects[1]
    assert np.allclose(tri1[:, 0], still.placement.to_world(g.means))
    # placed from the whole file: the static donut's bottom at z = 0, centred on x = 0.5
    assert tri1[:, 0, 2].min() == pytest.approx(0.0, abs=1e-12)


# ---------------------------------------------------------------- one-line errors naming the key

BAD = [
    ('select = { box = { lo = [5.0, 5.0, 5.0], hi = [6.0, 6.0, 6.0] } }',
     r"select box holds 0 of 45624 Gaussians; their centres span"),
    ('select = { sphere = { centre = [1.0, 1.0, 1.0], radius = 0.01 } }', r"select sphere holds 0 of 45624"),
    ("select = { indices = [0, 45624] }", r"select indices: index 45624 out of range for a file of 45624"),
    ("select = { indices = [-1] }", r"select.indices = \[-1\].*expected a non-empty list of row indices"),
    ("select = { indices = [] }", r"expected a non-empty list"),
    ('select = { cube = { lo = [0, 0, 0] } }', r"unknown key\(s\) \['cube'\] in \[\[object\]\] #1.select"),
    ('select = { indices = [1], box = { lo = [0.0, 0.0, 0.0], hi = [1.0, 1.0, 1.0] } }',
     r"select needs exactly one of \['box', 'sphere', 'indices', 'mask', 'file'\], got \['box', 'indices'\]"),
    ("select = { grow = true }", r"needs exactly one of .* got none"),
    ('select = { indices = [1], frame = "world" }', r"select.frame applies to a box or sphere, not to indices"),
    ('select = { box = { lo = [0.0, 0.0, 0.0], hi = [0.0, 1.0, 1.0] } }', r"select.box 'hi' must exceed 'lo'"),
    ('select = { box = { lo = [0.0, 0.0, 0.0] } }', r"select.box needs 'lo' and 'hi'"),
    ('select = { sphere = { centre = [0.0, 0.0, 0.0], radius = 0 } }', r"select.sphere.radius = 0"),
    ('select = { mask = "nowhere.npy" }', r"select.mask 'nowhere.npy' is not a file"),
    ('select = "all"', r"select = 'all' \(string\); expected a table"),
]


@pytest.mark.parametrize("select, match", BAD, ids=range(len(BAD)))
def test_bad_selection_is_one_line_scene_error(select, match):
    with pytest.raises(SceneError, match=match) as e:
        scene = parse(donut_scene(select))
        prepare_object(scene.objects[0])
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("content, match", [
    (np.zeros(10, bool), r"boolean mask '.*m.npy' has shape \(10,\); expected \(45624,\)"),
    (np.zeros(N_DONUT, np.float32), r"has dtype float32; expected bool"),
    (np.zeros((2, 3), np.int64), r"index array '.*' has shape \(2, 3\); expected a 1-D array"),
    (np.array([0, 99999]), r"select mask: index 99999 out of range"),
    (np.zeros(N_DONUT, bool), r"select mask holds 0 of 45624 Gaussians"),
], ids=["length", "dtype", "2d", "range", "empty"])
def test_bad_mask(tmp_path, content, match):
    np.save(tmp_path / "m.npy", content)
    with pytest.raises(SceneError, match=match):
        prepare_object(parse(donut_scene('select = { mask = "m.npy" }'), tmp_path / "s.toml").objects[0])


def test_bad_static_objects():
    text = donut_scene().replace("position = [0.0, 0.0, 0.05]", "position = [0.0, 0.0, 0.05]\nstatic = true")
    with pytest.raises(SceneError, match=r"#1 is static = true \(never simulated\) but also sets "
                                         r"\['material', 'select'\]"):
        parse(text)
    only = f'[[object]]\nfile = "{DONUT}"\nstatic = true\n'
    with pytest.raises(SceneError, match="every \\[\\[object\\]\\] is static = true; nothing to simulate"):
        parse(only)
    with pytest.raises(SceneError, match=r"static = 1 \(integer\); expected true or false"):
        parse(f'[[object]]\nfile = "{DONUT}"\nstatic = 1\n')


# ---------------------------------------------------------------- the kitchen: a dynamic model


def test_select_after_psi():
    """select with dynamic_time: psi(V, s) first, then the box on the positions at s."""
    scene = load_scene(KITCHEN)
    spec = scene.objects[0]
    o = prepare_object(spec)
    g = splatv_at(*read_splatv(SPLATV), spec.dynamic_time)
    sel = spec.select
    inside = np.all((g.means >= sel.lo) & (g.means <= sel.hi), axis=1)
    assert np.array_equal(o.moving, np.flatnonzero(inside)) and len(o.moving) == 351
    assert np.array_equal(o.gaussians.means, g.means)
    # at another model time the box holds other Gaussians: the selection follows psi
    g0 = splatv_at(*read_splatv(SPLATV), 0.0)
    assert not np.array_equal(np.flatnonzero(np.all((g0.means >= sel.lo) & (g0.means <= sel.hi), axis=1)),
                              o.moving)


def test_kitchen_two_frames(tmp_path):
    needs_package("gasp_taichi_mpm")
    data = tomllib.loads(KITCHEN.read_text())
    data["domain"]["n_grid"] = 16
    data["engine"]["options"] = {"threads": 1}
    scene = parse_scene(data, KITCHEN)
    res = simulate_scene(scene, tmp_path / "out", n_frames=2, quiet=True)
    run = res.summary
    assert (run["n_gaussians"], run["n_selected"], run["n_static"]) == (62442, 351, 62091)
    assert run["n_render_points"] == 3 * 351 and run["n_points"] < 0.1 * 3 * 62442
    o = prepare_object(scene.objects[0])
    rows, still = o.moving, still_rows(o)       # the still rows keep their opacity at s (issue 68)
    static = np.ones(62442, bool)
    static[rows] = False
    frames = [vertex(tmp_path / "out" / "spinach_4" / f"frame_{i:04d}.ply") for i in range(3)]
    model = read_splatv(SPLATV)
    for k, f in enumerate(frames):   # the kitchen keeps playing around the spinach: psi(V, s + k frame_dt) (issue 31)
        assert len(f) == 62442
        psi = splatv_at(*model, 0.5 + k * scene.frame_dt)
        for j, axis in enumerate("xyz"):
            assert np.array_equal(f[axis][static], psi.means[static, j].astype(np.float32)), (k, axis)
        # opacity as alpha: a logit of -738 (alpha 1e-321, subnormal) reads -40 where the CPU flushes subnormals;
        # the still rows keep psi(V, s)'s (issue 68)
        alpha = np.where(still, expit(splatv_at(*model, 0.5).opacities), expit(psi.opacities))
        assert np.allclose(expit(f["opacity"][static].astype(np.float64)), alpha[static], rtol=1e-6, atol=1e-12)
        assert 0.75 * static.sum() < (still & static).sum() < static.sum()
        if k:
            assert not np.array_equal(f["x"][static], frames[0]["x"][static])
    dz = frames[2]["z"][rows].astype(np.float64) - frames[0]["z"][rows]
    # the spinach is simulated: it settles into the pan (the rest of the capture, a collider by default since the
    # example took it) by a fraction of a millimetre (median 0.2 mm in file units at n_grid 16, largest 1.6); file y
    # points down (scale 0.08 m per unit)
    dy = frames[2]["y"][rows].astype(np.float64) - frames[0]["y"][rows]
    assert np.abs(dy).max() > 1e-4 and np.all(np.abs(dy) < 0.1) and np.all(np.isfinite(dz))


def test_selection_with_core_gaussians_rebuilds_the_whole_file():
    """select and core_fraction together: the hierarchy is built on the selected rows only."""
    from gasp_core.run.frames import rebuild
    prep = prepare_scene(parse(donut_scene(extra="core_fraction = 0.25")))
    o = prep.objects[0]
    n_sel = len(o.moving)
    assert o.surface.form == "cores" and len(o.tri_rest) == n_sel
    assert prep.setup.n_render == 4 * len(o.surface.hierarchy.core_points)  # 4-point frames of the cores
    g, rot, _ = rebuild(o, prep.setup.x, o.rot_rest)
    assert g.n == N_DONUT and rot.shape == (n_sel, 3, 3)
    static = np.ones(N_DONUT, bool)
    static[o.moving] = False
    src = read_gaussians(DONUT)
    for k in ("means", "scales", "rotations", "opacities", "sh_dc"):
        assert np.array_equal(getattr(g, k)[static], getattr(src, k)[static]), k
    assert np.allclose(g.means[o.moving], src.means[o.moving], atol=1e-9)
