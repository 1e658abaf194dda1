"""Round 100's hostile inputs, on ``gasp import-motion`` (an animated triangle soup read back into Gaussians):

- a motion frame whose vertices are at 1e30 m was refused by the Gaussians' own check, naming the scene's input PLY,
  not the motion file that held the coordinate;
- a motion frame whose triangles are all degenerate (every vertex at one point, as a tool that collapses a mesh
  writes it) was imported with exit 0, and its frame was a file that ``gasp`` itself refuses to read ("all 2,852
  Gaussians lie at one point").

Both are now refused by ``gasp_core.run.soup`` naming the motion file. And on ``gasp render --camera-index`` (a
capture's graphdeco ``cameras.json``): a camera with ``fy`` or ``height`` 0 ended as an exit-1 ZeroDivisionError
("a bug in gasp"); a zero rotation was reported as "position and look_at are the same point"; and no camera error
named the file or the camera. ``gasp_core.render.paths.graphdeco_camera`` now checks them, naming both. And on
``settle = true``: a scene with gravity and nothing to rest on settled out of the domain and its record said
``settled: true`` (the points out of the grid had stopped moving); it is refused, and a body that leaves the domain
while settling is counted (``settle.left_domain``, ``settled`` false). And on ``gasp compare`` and ``gasp bench``:
``--timeout 0`` was read as "not given" (the default hour), and ``--frames 10000000000`` ran on until each run's hour
was up; the first is refused and the second stops after its first frame at ``gasp simulate``'s work bound; a
``--reference-n-grid`` outside ``n_grid``'s range is refused before any run; and ``gasp bench`` itself ended in an
exit-1 ``NameError`` after every sweep (its strips' line); ``--engines ""`` ran every engine. And an
``[[object]] alpha`` under 1 shrank every Gaussian at rest from frame 0; it is refused (``ALPHA_MIN``). Each case takes
about a second."""
from __future__ import annotations

import json

import numpy as np
import pytest
from gasp_testing import needs_package, scene_text

trimesh = needs_package("trimesh")

import gasp_core.run.soup as soup  # noqa: E402
from gasp_core.cli.main import main  # noqa: E402
from gasp_core.errors import SceneError  # noqa: E402
from gasp_core.gs.io import read_gaussians  # noqa: E402


@pytest.fixture(scope="module")
def soup_scene(tmp_path_factory, donut_small):
    """The small donut's scene and its exported rest soup's triangles, (n, 3, 3) m."""
    d = tmp_path_factory.mktemp("hostile_100")
    scene = d / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    assert main(["export-soup", str(scene), "-o", str(d / "soup")]) == 0
    mesh = trimesh.load(d / "soup" / "donut_small.obj", process=False, force="mesh", maintain_order=True)
    return scene, np.asarray(mesh.vertices)[np.asarray(mesh.faces)]


def motion(tmp_path, tri: np.ndarray):
    """A motion folder of one frame holding the triangles ``tri`` (n, 3, 3), as an OBJ."""
    folder = tmp_path / "motion"
    folder.mkdir(parents=True)
    lines = [f"v {float(a)!r} {float(b)!r} {float(c)!r}" for a, b, c in tri.reshape(-1, 3)]
    lines += [f"f {3 * i + 1} {3 * i + 2} {3 * i + 3}" for i in range(len(tri))]
    (folder / "frame_0000.obj").write_text("\n".join(lines) + "\n")
    return folder


def run(capsys, scene, folder, out):
    code = main(["import-motion", str(scene), str(folder), "-o", str(out)])
    return code, capsys.readouterr().err


def test_the_rest_soup_itself_imports(tmp_path, soup_scene, capsys):
    """The cases below differ from this one by their tampering alone."""
    scene, tri = soup_scene
    code, err = run(capsys, scene, motion(tmp_path, tri), tmp_path / "out")
    assert code == 0, err
    assert read_gaussians(tmp_path / "out" / "donut_small" / "frame_0000.ply").n == len(tri)


@pytest.mark.parametrize("value", [1e30, -1e19])
def test_a_coordinate_past_float32_headroom_names_the_motion_file(tmp_path, soup_scene, capsys, value):
    scene, tri = soup_scene
    tri = tri.copy()
    tri[7, 0, 2] = value
    folder = motion(tmp_path, tri)
    code, err = run(capsys, scene, folder, tmp_path / "out")
    assert code == 2 and "Traceback" not in err, err
    assert f"{folder / 'frame_0000.obj'}: face 7 has a vertex coordinate of {abs(value):g}" in err
    assert "<= 1e+18" in err and not (tmp_path / "out").exists()


@pytest.mark.parametrize("collapse", ["one point", "each face to its first vertex"])
def test_a_frame_of_only_degenerate_triangles_is_refused(tmp_path, soup_scene, capsys, collapse):
    scene, tri = soup_scene
    tri = np.zeros_like(tri) if collapse == "one point" else np.repeat(tri[:, :1], 3, axis=1)
    folder = motion(tmp_path, tri)
    code, err = run(capsys, scene, folder, tmp_path / "out")
    assert code == 2 and "Traceback" not in err, err
    assert f"{folder / 'frame_0000.obj'}: all {len(tri):,} triangles of object 'donut_small' are degenerate" in err
    assert not (tmp_path / "out").exists()


def test_some_degenerate_triangles_still_import(tmp_path, soup_scene, capsys):
    """A frame with a few collapsed faces is a motion (T^-1 keeps their previous rotation and counts them)."""
    scene, tri = soup_scene
    tri = tri.copy()
    tri[:5] = tri[:5, :1]
    code, err = run(capsys, scene, motion(tmp_path, tri), tmp_path / "out")
    assert code == 0, err
    g = read_gaussians(tmp_path / "out" / "donut_small" / "frame_0000.ply")
    assert np.isfinite(g.means).all() and np.isfinite(g.rotations).all()


def test_the_checks_catch_the_rules_before(tmp_path, soup_scene, capsys, monkeypatch):
    """Without the two checks the huge coordinate is refused naming the scene's input file, and the collapsed frame
    is written as a file that gasp's reader refuses: the failures the checks above exist for."""
    scene, tri = soup_scene
    monkeypatch.setattr(soup, "MAX_MAGNITUDE", np.inf)
    monkeypatch.setattr(soup, "DEGENERATE_SHARE", 2.0)
    big = tri.copy()
    big[7, 0, 2] = 1e30
    code, err = run(capsys, scene, motion(tmp_path / "a", big), tmp_path / "a_out")
    assert code == 2 and "donut_small.ply: field 'means'" in err and "frame_0000.obj" not in err, err
    code, err = run(capsys, scene, motion(tmp_path / "b", np.zeros_like(tri)), tmp_path / "b_out")
    assert code == 0, err
    with pytest.raises(SceneError, match="lie at one point"):
        read_gaussians(tmp_path / "b_out" / "donut_small" / "frame_0000.ply")


# ------------------------------------------------------------------ a capture's cameras.json (gasp render --camera-index)

def camera_entry(**change) -> dict:
    """One graphdeco cameras.json entry (camera_to_JSON's keys), 64 x 48 px, 1 m above the origin, changed by
    ``change``."""
    c = {"id": 0, "img_name": "a", "width": 64, "height": 48, "position": [0.0, 0.0, 1.0],
         "rotation": np.eye(3).tolist(), "fx": 50.0, "fy": 50.0}
    return {**c, **change}


CAMERA_CASES = {   # was: an exit-1 ZeroDivisionError (fy 0, height 0); a camera of no file or index named (the rest)
    "fy 0": ({"fy": 0.0}, "expected a focal length fy > 0"),
    "fy negative": ({"fy": -50.0}, "expected a focal length fy > 0"),
    "fy nan": ({"fy": float("nan")}, "expected a focal length fy > 0"),
    "height 0": ({"height": 0}, "a width and height of 1 px or more"),
    "width 0": ({"width": 0}, "a width and height of 1 px or more"),
    # a zero rotation was reported as "position and look_at are the same point"
    "rotation zero": ({"rotation": np.zeros((3, 3)).tolist()}, "rotation: expected a proper rotation"),
    "rotation mirrored": ({"rotation": np.diag([1.0, 1.0, -1.0]).tolist()}, "rotation: expected a proper rotation"),
    "position nan": ({"position": [float("nan"), 0.0, 1.0]}, "position: expected finite"),
}


@pytest.mark.parametrize("case", sorted(CAMERA_CASES))
def test_a_camera_that_makes_no_picture_is_refused_naming_the_file_and_the_camera(tmp_path, case):
    from gasp_core.render.paths import graphdeco_camera
    change, expected = CAMERA_CASES[case]
    cams = tmp_path / "cameras.json"
    cams.write_text(json.dumps([camera_entry(), camera_entry(id=1, **change)]))
    assert graphdeco_camera(cams, 0).height == 48   # the first camera is a camera
    with pytest.raises(SceneError) as e:
        graphdeco_camera(cams, 1)
    assert str(e.value).startswith(f"{cams}: camera 1: ") and expected in str(e.value), str(e.value)


def test_the_camera_checks_catch_the_rules_before():
    """What the checks above stand in front of: a focal length of 0 divides by zero in the pose (an exit-1 bug from
    gasp render), and the rotation is now tested before the look-at point that a zero rotation puts on the
    camera."""
    from gasp_core.gs.camera import Camera
    with pytest.raises(ZeroDivisionError):
        Camera.from_pose(np.zeros(3), np.eye(3), 0.0, 64, 48)
    with pytest.raises(SceneError, match="proper rotation"):
        Camera.from_pose(np.zeros(3), np.zeros((3, 3)), 50.0, 64, 48)


# ------------------------------------------------------------------------------------ settle = true with no support

def settle_scene(tmp_path, donut_small, ground: bool, gravity: str) -> object:
    scene = tmp_path / "settle.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm", ground=ground,
                                extra_top=f"settle = true\ngravity = {gravity}\n"))
    return scene


def test_settle_with_nothing_to_rest_on_is_refused(tmp_path, donut_small, capsys):
    """Was: the body fell out of the domain while settling and run.json said ``settled: true`` (its points, out
    of the grid, had stopped moving)."""
    needs_package("gasp_warp_mpm")
    code, err = run_simulate(capsys, settle_scene(tmp_path, donut_small, False, "[0.0, 0.0, -9.81]"), tmp_path / "o")
    lines = [ln for ln in err.splitlines() if ln.startswith("gasp: error")]
    assert code == 2 and len(lines) == 1 and "Traceback" not in err, err
    assert "settle = true" in lines[0] and "nothing to rest on" in lines[0] and not (tmp_path / "o").exists()


def test_settle_without_gravity_needs_no_support(tmp_path, donut_small, capsys):
    needs_package("gasp_warp_mpm")
    code, err = run_simulate(capsys, settle_scene(tmp_path, donut_small, False, "[0.0, 0.0, 0.0]"), tmp_path / "o")
    assert code == 0, err
    assert json.loads((tmp_path / "o" / "run.json").read_text())["settle"]["settled"] is True


def test_a_body_that_leaves_the_domain_while_settling_has_not_settled(tmp_path, donut_small, capsys):
    """A ground, but gravity three times as strong across it as down: the donut slides off the ground's edge and out
    of the grid while settling. It is counted and the record says it did not settle."""
    needs_package("gasp_warp_mpm")
    code, err = run_simulate(capsys, settle_scene(tmp_path, donut_small, True, "[30.0, 0.0, -9.81]"), tmp_path / "o")
    assert code == 0, err
    record = json.loads((tmp_path / "o" / "run.json").read_text())["settle"]
    assert record["left_domain"] > 0 and record["settled"] is False, record
    assert f"settle: {record['left_domain']} point(s) left the domain while settling" in err


def test_the_settle_checks_catch_the_rules_before(tmp_path, donut_small, capsys, monkeypatch):
    """Without the support check the unsupported donut settles out of the domain and its record says ``settled``;
    the left-domain count is what now says otherwise."""
    needs_package("gasp_warp_mpm")
    import gasp_core.seam.settle as settle
    monkeypatch.setattr(settle, "check_settle", lambda info, setup: None)
    code, err = run_simulate(capsys, settle_scene(tmp_path, donut_small, False, "[0.0, 0.0, -9.81]"), tmp_path / "o")
    assert code == 0, err
    record = json.loads((tmp_path / "o" / "run.json").read_text())["settle"]
    assert record["residual_cells"] == 0.0 and record["left_domain"] > 0 and record["settled"] is False, record


def run_simulate(capsys, scene, out):
    code = main(["simulate", str(scene), "-o", str(out), "-q"])
    return code, capsys.readouterr().err


# ---------------------------------------------------------------- gasp compare / bench: --timeout 0, 1e10 frames

def test_a_timeout_of_0_is_refused_not_taken_as_the_default(tmp_path, donut_small, capsys):
    """Was: ``--timeout 0`` read as "not given", so each run had the default hour."""
    needs_package("distributed")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm"))
    for command in ("compare", "bench"):
        with pytest.raises(SystemExit) as done:   # round 102: argparse's type error, naming the flag
            main([command, str(scene), "-o", str(tmp_path / command), "--timeout", "0"])
        err = capsys.readouterr().err
        assert done.value.code == 2 and "argument --timeout: expected a positive finite number, got '0'" in err, \
            (command, err)
        assert not (tmp_path / command).exists()


@pytest.mark.parametrize("n_frames", [3, 10**10])
def test_a_study_run_past_the_work_bound_stops_after_its_first_frame(tmp_path, donut_small, n_frames):
    """Was: ``gasp compare --frames 10000000000`` ran on until each run's hour was up (keeping every frame's means).
    Both sides: a run of 3 frames is not stopped."""
    needs_package("distributed")
    needs_package("gasp_warp_mpm")
    from gasp_core.scene.spec import load_scene
    from gasp_studies.run import RunSpec, execute
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm"))
    rec = execute(RunSpec(load_scene(scene), "warp_mpm", {}, n_frames, "w"), capture=False).record
    if n_frames == 3:
        assert rec["status"] == "ok" and rec["frames_saved"] == 4, rec
    else:
        assert rec["status"] == "error" and rec["frames_saved"] == 1, rec
        assert "beyond the bound of 24 h" in rec["message"] and "--yes" not in rec["message"]


def test_gasp_benchs_strips_line_is_printed(tmp_path, donut_small, capsys):
    """Found beside the sweep: with progress on (as ``gasp bench`` runs) the strips' line raised ``NameError: name
    'sys' is not defined`` after every run of the sweep, so ``gasp bench`` ended in exit 1 ("a bug in gasp") and
    wrote no report. The default tier's check; the bench family's test (``test_studies.py``, progress on) runs it
    end to end."""
    needs_package("distributed")
    from gasp_core.scene.spec import load_scene
    from gasp_studies.bench_rank import bench_strips
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    lines = bench_strips(tmp_path, load_scene(scene), (0, 1), [], [], [], True)
    assert lines[0] == "## Frames" and "gasp bench: strips: skipped" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["-3", "1", "100000"])
def test_a_reference_grid_out_of_range_is_refused_before_any_run(tmp_path, donut_small, capsys, value):
    """Was: ``--reference-n-grid -3`` ran the whole sweep and its reference failed on the grid it was given."""
    needs_package("distributed")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=2, n_grid=16, engine="warp_mpm"))
    code = main(["bench", str(scene), "-o", str(tmp_path / "b"), "--reference-n-grid", value, "--quick"])
    err = capsys.readouterr().err
    assert code == 2 and f"--reference-n-grid): expected an integer in [8, 1024] as [domain] n_grid, got {value}" in err
    assert not (tmp_path / "b").exists()


@pytest.mark.parametrize("command", ["compare", "bench"])
@pytest.mark.parametrize("engines", ["", " , ,"])
def test_engines_naming_no_engine_is_refused(tmp_path, donut_small, capsys, command, engines):
    """Was: ``--engines ""`` ran every installed engine, as if the flag were not given."""
    needs_package("distributed")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=2, n_grid=16, engine="warp_mpm"))
    code = main([command, str(scene), "-o", str(tmp_path / "o"), "--engines", engines])
    err = capsys.readouterr().err
    assert code == 2 and "--engines: expected comma-separated engine names" in err, err
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("alpha", ["0.5", "0.999"])
def test_an_alpha_below_1_is_refused(tmp_path, donut_small, capsys, alpha):
    """Was: ``alpha = 0.5`` shrank every Gaussian at rest to half its size from frame 0 (the rule clamps an edge over
    alpha times its rest length, and every edge at rest is), without a word."""
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm", extra_object=f"alpha = {alpha}"))
    code, err = run_simulate(capsys, scene, tmp_path / "o")
    assert code == 2 and f"alpha = {alpha} (float); expected a stretch bound of at least 1" in err, err
    assert not (tmp_path / "o").exists()


def test_the_alpha_check_catches_the_rule_before():
    """Both sides of the bound, on the rule itself: at alpha 1 a triangle at rest keeps its scales; at 0.5 every one
    is halved, which a scene may no longer ask for."""
    from gasp_core.maps.games import alpha_rule
    tri = np.array([[[0.0, 0.0, 0.0], [0.02, 0.0, 0.0], [0.0, 0.01, 0.0]]])
    scales = np.array([[1e-6, 0.02, 0.01]])
    assert np.array_equal(alpha_rule(tri, tri, scales, scales, 1.0)[0], scales)
    assert np.allclose(alpha_rule(tri, tri, scales, scales, 0.5)[0][:, 1:], 0.5 * scales[:, 1:])
