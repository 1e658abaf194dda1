"""Round 101's hostile inputs, each read without a word or refused for the wrong cause:

1. a ``frames.json`` whose ``n_frames`` disagrees with its frame lists was read by the shorter of the two (render and
   export took the lists' count and said nothing); it is now refused naming the file and both numbers;
2. a closed ``[[collider]]`` box mesh 1 nm across was refused as "not closed (watertight)": trimesh merges vertices
   closer than 1e-8 (metres, absolute) when it loads and builds a mesh, which folds a 1 nm box into one point. The
   merge is now relative to the mesh's size, and a mesh smaller than one grid cell (``dx``) or that encloses no volume
   is refused naming that cause; an open mesh is still refused as not closed;
3. a ``--camera-path`` with two keyframes at the same frame rendered without a word (numpy's interpolation then
   picks one of the two by file order); it is now refused naming the file and the frame.

Each case takes a second or less.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.cli.main import main
from gasp_core.errors import SceneError
from gasp_core.fsutil import atomic_json
from gasp_core.gs.io import read_gaussians, write_gaussians

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"


def one_error(err: str, code: int, expected: int = 2) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("gasp: warning:")]
    assert code == expected and len(lines) == 1 and lines[0].startswith("gasp: error:"), (code, err)
    assert "Traceback" not in err
    return lines[0]


def mini_run(folder: Path, donut_small, n_frames: int, listed: int, static: bool = False) -> Path:
    """A run folder as gasp simulate writes it (PLY frames, run.json), its ``frames.json`` saying ``n_frames`` and
    listing ``listed`` frame files (both the same in a run gasp wrote); ``static``: a second object written once."""
    run = folder / "run"
    (run / "obj").mkdir(parents=True)
    g = read_gaussians(donut_small)
    for f in range(max(n_frames, listed)):
        write_gaussians(run / "obj" / f"frame_{f:04d}.ply", g)
    objects = [{"name": "obj", "n_gaussians": g.n, "frames": [f"obj/frame_{f:04d}.ply" for f in range(listed)]}]
    placed = [{"name": "obj", "placement": {"R": np.eye(3).tolist(), "scale": 1.0, "t": [0.0, 0.0, 0.0]}}]
    if static:
        (run / "still").mkdir()
        write_gaussians(run / "still" / "static.ply", g)
        objects.append({"name": "still", "n_gaussians": g.n, "static": "still/static.ply", "frames": []})
        placed.append({**placed[0], "name": "still"})
    layout = "split" if static else "frames"
    atomic_json(run / "frames.json", {"format": "ply", "layout": layout, "n_frames": n_frames, "objects": objects})
    atomic_json(run / "run.json", {"engine": "test", "frame_dt": 0.0333, "objects": placed})
    return run


# ------------------------------------------------------------------ 1. frames.json: n_frames against its lists


@pytest.mark.parametrize("n_frames, listed", [(3, 2), (2, 3)])
def test_a_frames_json_whose_n_frames_disagrees_with_its_list_is_refused(tmp_path, donut_small, n_frames, listed):
    from gasp_core.run.layout import open_frames
    run = mini_run(tmp_path, donut_small, n_frames, listed)
    with pytest.raises(SceneError) as e:
        open_frames(run)
    msg = str(e.value)
    assert str(run / "frames.json") in msg and f"n_frames = {n_frames}" in msg and f"{listed} frame" in msg, msg
    assert "objects[0].frames" in msg and "\n" not in msg


@pytest.mark.parametrize("command", ["render", "export"])
def test_render_and_export_refuse_it_in_one_line(tmp_path, donut_small, capsys, command):
    """Before, render drew 2 frames of a run whose frames.json says 3 (and export wrote 2) without a word."""
    run = mini_run(tmp_path, donut_small, 3, 2)
    out = tmp_path / ("r.gif" if command == "render" else "out")
    extra = ["--resolution", "32x24", "-q"] if command == "render" else ["--format", "ply"]
    code = main([command, str(run), "-o", str(out), *extra])
    line = one_error(capsys.readouterr().err, code)
    assert "frames.json" in line and "n_frames = 3" in line and "2 frame" in line, line
    assert not out.exists()


@pytest.mark.parametrize("n_frames", [0, -2])
def test_a_frames_json_of_no_frames_is_refused(tmp_path, donut_small, n_frames):
    """Round 101 (lead): a manifest whose objects all list their frames agrees with any n_frames when every moving
    object is gone; n_frames 0 or below was read as a run of no frames (an all-static run took its count from it)."""
    from gasp_core.run.layout import open_frames
    run = mini_run(tmp_path, donut_small, 1, 1, static=True)
    manifest = json.loads((run / "frames.json").read_text())
    manifest.update(n_frames=n_frames, objects=manifest["objects"][1:])
    atomic_json(run / "frames.json", manifest)
    with pytest.raises(SceneError, match=rf"frames.json: n_frames: expected a count of frames, 1 or more.*{n_frames}"):
        open_frames(run)


def test_a_consistent_frames_json_still_reads(tmp_path, donut_small):
    """What gasp simulate writes: every moving object lists n_frames files, a static one (split layout) none."""
    from gasp_core.run.layout import open_frames
    frames = open_frames(mini_run(tmp_path, donut_small, 3, 3, static=True))
    assert frames.n_frames == 3 and frames.gaussians(2, 1).n == frames.gaussians(2, 0).n


def test_frame_writer_output_still_reads(tmp_path, donut_small):
    """Writing is unchanged: FrameWriter's manifest after each frame is accepted as it stands."""
    from gasp_core.run.layout import FrameWriter, open_frames
    g = read_gaussians(donut_small)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    w = FrameWriter(tmp_path, ["a", "b"], [False, True], [None, None], layout="split")
    for f in range(3):
        w.write(f, [g, g])
        assert open_frames(tmp_path).n_frames == f + 1
        assert json.loads((tmp_path / "frames.json").read_text())["n_frames"] == f + 1


# ------------------------------------------------------------------ 2. a collider mesh too small for the grid


def _box(extents) -> np.ndarray:
    trimesh = needs_package("trimesh")
    needs_package("rtree")
    return trimesh.creation.box(extents=extents).triangles


def test_a_closed_1nm_box_is_refused_as_too_small_not_as_open():
    from gasp_core.colliders.sdf import SDF_SPACING, collider_from_triangles
    dx = 0.01
    with pytest.raises(SceneError) as e:
        collider_from_triangles(_box((1e-9,) * 3), SDF_SPACING * dx, name="[[collider]] #1 (nm.stl)")
    msg = str(e.value)
    assert "not closed" not in msg, msg
    assert "[[collider]] #1 (nm.stl)" in msg and "1e-09 m across" in msg and "dx = 0.01 m" in msg, msg


def test_a_mesh_smaller_than_a_grid_cell_is_refused_and_one_cell_across_is_taken():
    from gasp_core.colliders.sdf import SDF_SPACING, collider_from_triangles
    dx = 0.01
    with pytest.raises(SceneError, match=r"0\.005 m across.*dx = 0\.01 m"):
        collider_from_triangles(_box((0.005, 0.004, 0.003)), SDF_SPACING * dx)
    c = collider_from_triangles(_box((0.01, 0.004, 0.003)), SDF_SPACING * dx)
    assert c.triangles is not None and c.h == SDF_SPACING * dx


def test_a_closed_1nm_box_in_a_scene_names_its_size_and_the_file(tmp_path):
    """The scene's route: trimesh.load merged the box's eight corners into one point before any check."""
    trimesh = needs_package("trimesh")
    needs_package("rtree")
    from gasp_core.prepare.colliders import build_colliders
    from gasp_core.scene.spec import parse_scene
    mesh = tmp_path / "nm_box.stl"
    trimesh.creation.box(extents=(1e-9,) * 3).export(mesh)
    scene = parse_scene({"object": [{"file": str(DATA / "donut_v3dg.ply")}],
                         "collider": [{"mesh": str(mesh)}]}, tmp_path / "s.toml")
    with pytest.raises(SceneError) as e:
        build_colliders(scene, [], 0.02)
    msg = str(e.value)
    assert "not closed" not in msg and "nm_box.stl" in msg and "[[collider]]" in msg, msg
    assert "1e-09 m across" in msg and "dx = 0.02 m" in msg, msg


@pytest.mark.parametrize("size", [1e-9, 1e-6, 0.2])
def test_an_open_mesh_is_still_refused_as_not_closed_at_any_size(size):
    from gasp_core.colliders.sdf import collider_from_triangles
    with pytest.raises(SceneError, match="not closed"):
        collider_from_triangles(_box((size, 2 * size, 3 * size))[:-2], 0.005)


def test_a_flat_mesh_is_refused_as_degenerate():
    """A box flattened to no thickness (its faces collapse, top and bottom coincide), and four distinct points in
    one plane joined as a tetrahedron (closed: every edge shared by two faces): no inside either way."""
    from gasp_core.colliders.sdf import collider_from_triangles
    with pytest.raises(SceneError, match=r"degenerate: its vertices lie within 0 m of one plane \(0\.2 m across\)"):
        collider_from_triangles(_box((0.2, 0.2, 0.0)), 0.005)
    v = np.array([[0.0, 0, 0], [0.3, 0, 0], [0, 0.3, 0], [0.1, 0.1, 0]])
    with pytest.raises(SceneError, match="degenerate: its vertices lie within 0 m of one plane"):
        collider_from_triangles(v[np.array([(0, 2, 1), (0, 1, 3), (1, 2, 3), (2, 0, 3)])], 0.005)


def test_a_closed_mesh_whose_volume_cancels_is_refused_as_degenerate():
    """Two closed boxes apart, the second turned inside out: watertight, 0.3 m across, a net volume of 0."""
    from gasp_core.colliders.sdf import collider_from_triangles
    a = _box((0.1, 0.1, 0.1))
    b = (a + [0.2, 0.0, 0.0])[:, ::-1]          # moved 0.1 m beyond the first, each face's order reversed
    with pytest.raises(SceneError, match=r"degenerate: closed, 0\.3 m across, but it encloses a volume of \S+ m\^3"):
        collider_from_triangles(np.concatenate([a, b]), 0.005)


def test_a_mesh_with_a_vertex_that_is_not_finite_is_refused_naming_it():
    from gasp_core.colliders.sdf import collider_from_triangles
    tris = _box((0.2, 0.2, 0.2)).copy()
    tris[3, 1, 2] = np.nan
    with pytest.raises(SceneError, match="'ramp': 1 vertices are not finite numbers"):
        collider_from_triangles(tris, 0.005, name="ramp")


# ------------------------------------------------------------------ 3. two keyframes at one frame


def _path(tmp_path, frames) -> Path:
    f = tmp_path / "path.json"
    f.write_text(json.dumps({"keyframes": [{"frame": fr, "position": [2, k, 1], "look_at": [0, 0, 0]}
                                           for k, fr in enumerate(frames)]}))
    return f


@pytest.mark.parametrize("frames, said", [([0, 4, 4, 8], "keyframes 1 and 2"), ([4, 0, 4.0], "keyframes 0 and 2")])
def test_two_keyframes_at_one_frame_are_refused(tmp_path, frames, said):
    from gasp_core.render.paths import keyframe_path
    f = _path(tmp_path, frames)
    with pytest.raises(SceneError) as e:
        keyframe_path(f)
    msg = str(e.value)
    assert str(f) in msg and said in msg and "frame 4" in msg and "\n" not in msg, msg


def test_render_refuses_two_keyframes_at_one_frame(tmp_path, donut_small, capsys):
    run = mini_run(tmp_path, donut_small, 2, 2)
    f = _path(tmp_path, [0, 1, 1])
    code = main(["render", str(run), "-o", str(tmp_path / "r.gif"), "-q", "--resolution", "32x24",
                 "--camera-path", str(f)])
    line = one_error(capsys.readouterr().err, code)
    assert "path.json" in line and "keyframes 1 and 2" in line and "frame 1" in line, line
    assert not (tmp_path / "r.gif").exists()


def test_a_cut_on_the_next_frame_still_renders(tmp_path):
    """A jump cut needs no shared frame: keyframes at 3 and 4 hold one camera to frame 3 and the other from 4."""
    from gasp_core.render.paths import keyframe_path
    cams = keyframe_path(_path(tmp_path, [0, 3, 4, 8]))(np.zeros(3), np.ones(3), 9, 64, 48, 40.0)
    np.testing.assert_allclose(cams[3].position, [2, 1, 1])
    np.testing.assert_allclose(cams[4].position, [2, 2, 1])


# ------------------------------------------------------------------ round 101 (lead): gasp info --n-grid's range


@pytest.mark.parametrize("value", ["100000", "7", "abc"])
def test_info_n_grid_outside_the_scenes_range_is_refused_naming_the_option(capsys, value):
    """Before, ``--n-grid 100000`` went on to a fill grid of 159589 x 159006 x 105276 and was refused for that, naming
    neither the option nor its range."""
    with pytest.raises(SystemExit) as done:   # argparse's type error: one line, exit 2 (GaspArgumentParser)
        main(["info", str(DATA / "donut_v3dg.ply"), "--n-grid", value])
    line = one_error(capsys.readouterr().err, done.value.code)
    assert "--n-grid" in line and "[8, 1024]" in line and repr(value) in line, line


# ------------------------------------------------------------------ round 101 (lead): --strip-frames bounded by the run


def test_strip_frames_past_the_run_take_every_frame_without_the_numbers_memory():
    """Before, ``--strip-frames 100000000`` laid 1e8 evenly spaced frame numbers (0.8 GB, then 1e8 Python ints,
    about 3 GB) to keep the run's 11; now more than the run's frames reads as every frame, as documented."""
    import tracemalloc
    from gasp_studies.strips import strip_frames
    tracemalloc.start()
    try:
        assert strip_frames(10, 100_000_000) == tuple(range(11))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 10_000_000, peak
    assert strip_frames(10, 3) == (0, 5, 10) and strip_frames(10, 0) == () and strip_frames(10, 1) == (10,)
