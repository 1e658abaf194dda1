"""Round 101b's hostile inputs, each a hang, a silent guess or a line that named the wrong thing:

1. ``gasp view --host`` (and ``gasp studio --host``) with a host this machine cannot listen on (``256.1.1.1``,
   ``bad host``, another machine's address) hung for ever without a word: viser's server thread fails and its
   constructor waits on it. It is now refused in one line naming ``--host`` before any server starts;
2. ``gasp view --export ''`` started the server instead of writing a page (the empty name read as "not given");
3. ``gasp import-motion`` ordered a folder's frame files by the number ending their names and took two files with
   the same number (``frame_1.obj``, ``frame_01.obj``), or one with no number, in an order of its own, and per-object
   folders frame by frame by position even where their numbers differ; each is now refused naming the files;
4. an output name the filesystem takes (246 bytes) was refused with "File name too long" naming gasp's own
   temporary file (``.NAME.XXXXXXXX.tmp``, ``.NAME.partial-XXXXXXXX``): a file's temporary name is now cut to fit,
   and an output folder whose partial folder cannot fit is refused naming the option's folder and the length;
5. a file written into a folder that does not exist (``gasp place -o missing/x.png``) was refused naming the
   temporary file; it now names the output and its folder;
6. ``gasp compare --scheduler bogus:::1`` was "a bug in gasp" (exit 1); it is one line naming ``--scheduler``;
7. a ``--camera-path`` keyframe at ``"frame": true``, ``0.5`` or ``-3`` was rendered as frame 1, between frames or
   before the video; it is refused naming the file, the keyframe and the value;
8. ``gasp conform ENGINE --scenes ""`` ran every conformance scene (the empty list read as "not given");
9. ``gasp render --cameras FILE`` without ``--camera-index`` was ignored (the default camera rendered), and
   ``gasp render -o ''`` wrote ``RUN/render.mp4``; both are refused naming the option;
10. a scene saved with a UTF-8 byte-order mark (Notepad) was "not valid TOML: Invalid statement (at line 1,
    column 1)"; the mark is now skipped.

Each case takes a second or two (the ``--scheduler`` one a few, for Dask's import).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from gasp_testing import needs_package, scene_text

from gasp_core.cli.main import main
from gasp_core.fsutil import atomic_json, atomic_write
from gasp_core.gs.io import read_gaussians, write_gaussians


def one_error(err: str, code: int, *needles: str, expected: int = 2) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("gasp: warning:")]
    assert code == expected and len(lines) == 1 and lines[0].startswith("gasp: error:"), (code, err)
    assert "Traceback" not in err
    for n in needles:
        assert n in lines[0], (n, lines[0])
    return lines[0]


def mini_run(folder: Path, donut_small, n_frames: int = 2) -> Path:
    """A run folder as gasp simulate writes it (PLY frames, frames.json, run.json)."""
    run = folder / "run"
    (run / "obj").mkdir(parents=True)
    g = read_gaussians(donut_small)
    for f in range(n_frames):
        write_gaussians(run / "obj" / f"frame_{f:04d}.ply", g)
    objects = [{"name": "obj", "n_gaussians": g.n, "frames": [f"obj/frame_{f:04d}.ply" for f in range(n_frames)]}]
    placed = [{"name": "obj", "placement": {"R": np.eye(3).tolist(), "scale": 1.0, "t": [0.0, 0.0, 0.0]}}]
    atomic_json(run / "frames.json", {"format": "ply", "layout": "frames", "n_frames": n_frames, "objects": objects})
    atomic_json(run / "run.json", {"engine": "test", "frame_dt": 0.0333, "objects": placed})
    return run


def never_serve(*a, **k):
    raise AssertionError("the server was started")


# ------------------------------------------------------------------ 1, 2. gasp view: --host, --export ''

@pytest.mark.parametrize("host", ["256.1.1.1", "bad host", "10.255.255.1"])
def test_view_refuses_a_host_it_cannot_listen_on_before_serving(tmp_path, donut_small, capsys, monkeypatch, host):
    import gasp_core.render.viewer as viewer
    monkeypatch.setattr(viewer, "serve", never_serve)
    code = main(["view", str(mini_run(tmp_path, donut_small)), "--host", host, "--port", "0"])
    one_error(capsys.readouterr().err, code, f"--host {host!r}", "cannot listen")


def test_studio_refuses_a_host_it_cannot_listen_on(tmp_path, donut_small, capsys, monkeypatch):
    import gasp_core.studio.app as app
    monkeypatch.setattr(app, "serve", never_serve)
    code = main(["studio", str(donut_small), "--workdir", str(tmp_path / "w"), "--host", "256.1.1.1"])
    one_error(capsys.readouterr().err, code, "--host '256.1.1.1'")


def test_the_host_check_takes_this_machines_addresses():
    from gasp_core.render.commands import check_host
    check_host("127.0.0.1")
    check_host("0.0.0.0")
    check_host("localhost")


def test_view_export_of_an_empty_name_is_refused_not_served(tmp_path, donut_small, capsys, monkeypatch):
    import gasp_core.render.viewer as viewer
    monkeypatch.setattr(viewer, "serve", never_serve)
    code = main(["view", str(mini_run(tmp_path, donut_small)), "--export", ""])
    one_error(capsys.readouterr().err, code, "--export ''")


# ------------------------------------------------------------------ 3. gasp import-motion: frame numbers

@pytest.fixture(scope="module")
def two_object_soup(tmp_path_factory, donut_small):
    """A scene of the small donut twice and its exported rest soup's triangles per object."""
    d = tmp_path_factory.mktemp("hostile_101b")
    scene = d / "s.toml"
    second = scene_text(donut_small).split("[[object]]", 1)[1].replace("position = [0.0, 0.0, 0.05]",
                                                                       "position = [0.5, 0.0, 0.05]")
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16) + "\n[[object]]" + second)
    assert main(["export-soup", str(scene), "-o", str(d / "soup")]) == 0
    names = [p.stem for p in sorted((d / "soup").glob("*.obj"))]
    return scene, names


def copy_frames(soup: Path, folder: Path, name: str, files: list[str]) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    text = (soup / f"{name}.obj").read_text()
    for f in files:
        (folder / f).write_text(text)


@pytest.mark.parametrize("files, needles", [
    (["frame_1.obj", "frame_01.obj"], ["'frame_01.obj' and 'frame_1.obj' are both frame 1"]),
    (["frame_3.obj", "frame_3.ply"], ["both frame 3"]),
    (["rest.obj", "frame_0.obj", "frame_1.obj"], ["rest.obj", "ends in no frame number"]),
])
def test_frame_files_whose_order_is_a_guess_are_refused(tmp_path, two_object_soup, capsys, files, needles):
    scene, names = two_object_soup
    motion = tmp_path / "motion"
    for name in names:
        copy_frames(scene.parent / "soup", motion / name, name, [f for f in files if f.endswith(".obj")])
        for f in files:
            if f.endswith(".ply"):
                trimesh.load(scene.parent / "soup" / f"{name}.obj", process=False, force="mesh",
                             maintain_order=True).export(motion / name / f)
    code = main(["import-motion", str(scene), str(motion), "-o", str(tmp_path / "out")])
    one_error(capsys.readouterr().err, code, *needles)
    assert not (tmp_path / "out").exists()


def test_per_object_folders_numbering_other_frames_are_refused(tmp_path, two_object_soup, capsys):
    scene, names = two_object_soup
    motion = tmp_path / "motion"
    copy_frames(scene.parent / "soup", motion / names[0], names[0], ["frame_0.obj", "frame_1.obj", "frame_2.obj"])
    copy_frames(scene.parent / "soup", motion / names[1], names[1], ["frame_0.obj", "frame_2.obj", "frame_3.obj"])
    code = main(["import-motion", str(scene), str(motion), "-o", str(tmp_path / "out")])
    one_error(capsys.readouterr().err, code, "frame 1 is 'frame_1.obj'", "'frame_2.obj'")


def test_numbered_frames_still_import_in_their_order(tmp_path, two_object_soup, capsys):
    scene, names = two_object_soup
    motion = tmp_path / "motion"
    for name in names:
        copy_frames(scene.parent / "soup", motion / name, name, ["frame_10.obj", "frame_9.obj"])
    assert main(["import-motion", str(scene), str(motion), "-o", str(tmp_path / "out")]) == 0, capsys.readouterr()
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert [Path(f).name for f in run["frames"][0]["files"]] == ["frame_9.obj", "frame_9.obj"]


# ------------------------------------------------------------------ 4, 5. names and folders of what gasp writes

def test_a_long_file_name_the_filesystem_takes_is_written(tmp_path):
    path = tmp_path / ("a" * 250 + ".txt")
    atomic_write(path, lambda f: f.write(b"x"))
    assert path.read_bytes() == b"x" and [p.name for p in tmp_path.iterdir()] == [path.name]


def test_a_long_page_name_the_filesystem_takes_is_exported(tmp_path, donut_small, capsys):
    page = tmp_path / ("p" * 245 + ".html")
    assert main(["view", str(mini_run(tmp_path, donut_small)), "--export", str(page)]) == 0, capsys.readouterr()
    assert page.stat().st_size > 0


def test_an_output_folder_whose_partial_folder_cannot_fit_is_refused_naming_it(tmp_path, donut_small, capsys):
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    out = tmp_path / ("b" * 246)
    code = main(["simulate", str(scene), "-o", str(out), "-q"])
    one_error(capsys.readouterr().err, code, str(out), "246 bytes", "at most 237")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_a_file_in_a_missing_folder_names_the_output_not_a_temporary_file(tmp_path):
    from gasp_core.fsutil import atomic_path
    for write in (lambda p: atomic_write(p, lambda f: f.write(b"x")), lambda p: atomic_path(p).__enter__()):
        with pytest.raises(FileNotFoundError) as e:
            write(tmp_path / "missing" / "x.png")
        assert str(e.value) == f"output '{tmp_path / 'missing' / 'x.png'}': folder '{tmp_path / 'missing'}' does " \
                               "not exist"


def test_place_into_a_missing_folder_is_one_line_naming_the_folder(tmp_path, donut_small, capsys):
    needs_package("matplotlib")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    code = main(["place", str(scene), "-o", str(tmp_path / "missing" / "x.png")])
    one_error(capsys.readouterr().err, code, "folder", "missing' does not exist")
    assert ".x." not in capsys.readouterr().err


# ------------------------------------------------------------------ 6. gasp compare --scheduler

def test_a_scheduler_that_is_not_an_address_is_one_line(tmp_path, donut_small, capsys):
    needs_package("distributed")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    code = main(["compare", str(scene), "--engines", "taichi_mpm", "-o", str(tmp_path / "c"),
                 "--scheduler", "bogus:::1"])
    one_error(capsys.readouterr().err, code, "--scheduler bogus:::1", "not an address")


# ------------------------------------------------------------------ 7. --camera-path frames

@pytest.mark.parametrize("frame", [True, 0.5, -3, "3"])
def test_a_keyframe_at_no_frame_of_the_video_is_refused(tmp_path, frame):
    from gasp_core.errors import SceneError
    from gasp_core.render.paths import keyframe_path
    path = tmp_path / "path.json"
    path.write_text(json.dumps({"keyframes": [{"frame": frame, "position": [1, 1, 1], "look_at": [0, 0, 0]}]}))
    with pytest.raises(SceneError, match=r"keyframe 0: frame = .*a whole number >= 0"):
        keyframe_path(path)


def test_a_whole_keyframe_frame_still_reads(tmp_path):
    from gasp_core.render.paths import keyframe_path
    path = tmp_path / "path.json"
    path.write_text(json.dumps({"keyframes": [{"frame": 0, "position": [1, 1, 1], "look_at": [0, 0, 0]},
                                              {"frame": 4.0, "position": [2, 1, 1], "look_at": [0, 0, 0]}]}))
    assert len(keyframe_path(path)(np.zeros(3), np.ones(3), 5, 32, 24, 40.0)) == 5


# ------------------------------------------------------------------ 8-10. an empty or ignored option, a BOM

def test_conform_with_scenes_naming_none_is_refused_not_run_whole(capsys, monkeypatch):
    import gasp_core.testing.scenes as scenes
    monkeypatch.setattr(scenes, "check_engine", never_serve)
    for value in ("", ", ,"):
        code = main(["conform", "taichi_mpm", "--scenes", value])
        one_error(capsys.readouterr().err, code, f"--scenes: expected comma-separated conformance scene names, "
                                                 f"got {value!r}")


def test_render_refuses_cameras_without_an_index_and_an_empty_output(tmp_path, donut_small, capsys):
    run = mini_run(tmp_path, donut_small)
    cams = tmp_path / "cameras.json"
    cams.write_text("[]")
    code = main(["render", str(run), "-o", str(tmp_path / "v.gif"), "--cameras", str(cams), "-q"])
    one_error(capsys.readouterr().err, code, "--cameras", "--camera-index N")
    code = main(["render", str(run), "-o", "", "-q"])
    one_error(capsys.readouterr().err, code, "-o ''")
    assert not (tmp_path / "v.gif").exists() and not (run / "render.mp4").exists()


def test_a_scene_saved_with_a_utf8_bom_reads_as_without(tmp_path, donut_small):
    from gasp_core.scene.spec import load_scene
    text = scene_text(donut_small, n_frames=1, n_grid=16)
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf" + text.encode())
    (tmp_path / "plain.toml").write_text(text)
    bom, plain = load_scene(tmp_path / "bom.toml"), load_scene(tmp_path / "plain.toml")
    assert (bom.n_frames, bom.frame_dt, len(bom.objects)) == (plain.n_frames, plain.frame_dt, len(plain.objects))
