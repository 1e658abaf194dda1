"""Run layouts: the 'split' layout writes static objects and unselected rows once, frames.json lists the files,
and open_frames (gasp render, gasp view) gives back the same frames as the complete 'frames' layout."""
import json

import numpy as np
import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.cli.main import main
from gasp_core.errors import SceneError
from gasp_core.run.layout import open_frames
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene

needs_package("gasp_taichi_mpm")

SELECT = "select = { box = { lo = [-1.0, -1.0, -1.0], hi = [0.0, 1.0, 1.0] } }"   # file x <= 0 moves


def static_object(ply) -> str:
    return f'\n[[object]]\nfile = "{ply}"\nposition = [0.5, 0.0, 0.0]\nstatic = true\n'


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory, donut_small):
    """The same scene (half of a donut moving, a static donut beside it) in both layouts, PLY files."""
    tmp = tmp_path_factory.mktemp("layout")
    scene = tmp / "scene.toml"
    text = scene_text(donut_small, n_frames=3, n_grid=16, extra_object=SELECT)
    scene.write_text(text + static_object(donut_small))
    runs = {}
    for layout in ("frames", "split"):
        simulate_scene(load_scene(scene), tmp / layout, quiet=True, layout=layout)
        runs[layout] = tmp / layout
    return runs


def test_split_writes_what_does_not_move_once(two_runs):
    out = two_runs["split"]
    manifest = json.loads((out / "frames.json").read_text())
    assert manifest["format"] == "ply" and manifest["layout"] == "split" and manifest["n_frames"] == 4
    moving, static = manifest["objects"]
    assert static["static"] == f"{static['name']}/static.ply" and static["frames"] == []
    assert sorted(p.name for p in (out / static["name"]).iterdir()) == ["static.ply"]
    assert moving["rest"] == f"{moving['name']}/rest.ply" and len(moving["frames"]) == 4
    rows = np.load(out / moving["moving_rows"])
    assert 0 < len(rows) < moving["n_gaussians"]
    sizes = [(out / f).stat().st_size for f in moving["frames"]]
    full = (two_runs["frames"] / moving["frames"][0]).stat().st_size
    assert max(sizes) < 0.75 * full                        # the frames hold the moving rows only


def test_both_layouts_read_back_the_same_frames(two_runs):
    a, b = open_frames(two_runs["frames"]), open_frames(two_runs["split"])
    assert a.n_frames == b.n_frames == 4
    for frame in (0, 3):
        for k in (0, 1):
            ga, gb = a.gaussians(frame, k), b.gaussians(frame, k)
            assert ga.n == gb.n
            for field in ("means", "scales", "rotations", "opacities", "sh_dc"):
                assert np.array_equal(getattr(ga, field), getattr(gb, field)), (frame, k, field)


def test_render_reads_the_split_layout(two_runs):
    from gasp_core.render.run import load_run
    run = load_run(two_runs["split"])
    s0, s3 = run.splats(0), run.splats(3)
    assert len(s0.means) == len(s3.means) and not np.array_equal(s0.means, s3.means)


def test_a_run_without_manifest_still_reads(two_runs, tmp_path):
    """Runs written before frames.json: <object>/frame_*.ply, listed by run.json."""
    import shutil
    old = tmp_path / "old"
    shutil.copytree(two_runs["frames"], old)
    (old / "frames.json").unlink()
    f = open_frames(old)
    assert f.n_frames == 4 and f.gaussians(2, 0).n == open_frames(two_runs["frames"]).gaussians(2, 0).n
    shutil.rmtree(old / f.manifest["objects"][1]["name"])
    with pytest.raises(SceneError, match="no frame_\\*.ply files for object"):
        open_frames(old)


def test_cli_format_choice_is_checked(tmp_path, donut_small, capsys):
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16))
    with pytest.raises(SystemExit) as e:
        main(["simulate", str(scene), "-o", str(tmp_path / "o"), "--format", "jpeg", "-q"])
    assert e.value.code == 2
    assert "invalid choice: 'jpeg'" in capsys.readouterr().err


def test_spz_run_frames_read_in_gsply(tmp_path, donut_small):
    gsply = pytest.importorskip("gsply", reason="gsply is not installed: pip install -e '.[formats]'")
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=2, n_grid=16, extra_object=SELECT))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "o"), "--format", "spz", "-q"]) == 0
    manifest = json.loads((tmp_path / "o" / "frames.json").read_text())
    o = manifest["objects"][0]
    rows = np.load(tmp_path / "o" / o["moving_rows"])
    assert [len(gsply.read_spz(tmp_path / "o" / f)) for f in o["frames"]] == [len(rows)] * 3
    assert len(gsply.read_spz(tmp_path / "o" / o["rest"])) == o["n_gaussians"] - len(rows)
    assert open_frames(tmp_path / "o").gaussians(2, 0).n == o["n_gaussians"]


def test_kill_9_then_resume_a_split_run(tmp_path, donut_small):
    """--resume continues a split run: the rest file is kept, the frames equal an uninterrupted run."""
    import os
    import signal
    import subprocess
    import sys
    import time
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=6, n_grid=16, extra_object=SELECT))
    cmd = [sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-q", "--layout", "split", "-o"]
    subprocess.run([*cmd, str(tmp_path / "ref")], check=True, capture_output=True, cwd=tmp_path)
    # the run killed here may hold Taichi's kernel cache lock: a cache of its own keeps a stale lock file
    # from making every later Taichi process in the session warn "Lock ... ticache.lock failed"
    env = {**os.environ, "TI_OFFLINE_CACHE_FILE_PATH": str(tmp_path / "ticache")}
    proc = subprocess.Popen([*cmd, str(tmp_path / "out")], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            cwd=tmp_path, env=env)
    deadline, killed = time.time() + 600, False
    while time.time() < deadline and proc.poll() is None:
        parts = list(tmp_path.glob(".out.partial-*"))
        if parts and len(list((parts[0] / "donut_small").glob("frame_*.ply"))) > 2 \
                and (parts[0] / ".gasp-checkpoint.npz").exists():
            os.kill(proc.pid, signal.SIGKILL)
            killed = True
            break
        time.sleep(0.05)
    proc.wait()
    assert killed, "the run ended before it could be killed"
    r = subprocess.run([*cmd, str(tmp_path / "out"), "--resume"], capture_output=True, text=True, cwd=tmp_path,
                       env=env)
    assert r.returncode == 0, r.stderr
    assert json.loads((tmp_path / "out" / "run.json").read_text())["resumed_after_frame"] >= 2
    a, b = open_frames(tmp_path / "ref"), open_frames(tmp_path / "out")
    assert a.manifest == b.manifest
    for frame in range(7):
        assert np.array_equal(a.gaussians(frame, 0).means, b.gaussians(frame, 0).means), frame
