"""The command line: one-line errors, non-zero exits and no partial output for bad input."""
import json
import shutil
import subprocess

import numpy as np
import pytest
from gasp_testing import DONUT, scene_text, needs_package
from plyfile import PlyData, PlyElement

from gasp_core.cli.main import main


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def assert_clean_failure(code, err, out_dir, *needles):
    assert code != 0
    lines = [l for l in err.strip().splitlines() if l.startswith("gasp: error:")]
    assert len(lines) == 1, err
    for n in needles:
        assert n in lines[0], lines[0]
    assert not out_dir.exists()
    assert not list(out_dir.parent.glob(f".{out_dir.name}.partial-*"))


def write_ply(path, arrays: dict):
    dtype = [(k, "f4") for k in arrays]
    n = len(next(iter(arrays.values())))
    data = np.empty(n, dtype=dtype)
    for k, v in arrays.items():
        data[k] = v
    PlyData([PlyElement.describe(data, "vertex")]).write(str(path))


@pytest.fixture(scope="module")
def donut_fields():
    v = PlyData.read(str(DONUT))["vertex"].data
    return {k: np.asarray(v[k]) for k in v.dtype.names}


def test_truncated_ply(tmp_path, capsys, write_scene):
    bad = tmp_path / "truncated.ply"
    raw = DONUT.read_bytes()
    bad.write_bytes(raw[: len(raw) // 2])
    code, _, err = run(capsys, "simulate", write_scene(scene_text(bad)), "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "truncated.ply")


def test_ply_without_scales(tmp_path, capsys, write_scene, donut_fields):
    bad = tmp_path / "noscale.ply"
    write_ply(bad, {k: v for k, v in donut_fields.items() if not k.startswith("scale_")})
    code, _, err = run(capsys, "simulate", write_scene(scene_text(bad)), "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "noscale.ply", "scale")


def test_nan_positions(tmp_path, capsys, write_scene, donut_fields):
    bad = tmp_path / "nan.ply"
    f = dict(donut_fields)
    f["y"] = f["y"].copy()
    f["y"][123] = np.nan
    write_ply(bad, f)
    code, _, err = run(capsys, "simulate", write_scene(scene_text(bad)), "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "nan.ply", "123")


def test_mistyped_scene_key(tmp_path, capsys, write_scene):
    text = scene_text(DONUT).replace("n_grid = 24", "n_gird = 24")
    code, _, err = run(capsys, "simulate", write_scene(text), "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "n_gird", "n_grid")


def test_mistyped_material_key(tmp_path, capsys, write_scene):
    text = scene_text(DONUT, material='name = "jelly"\nyoung = 1e4')
    code, _, err = run(capsys, "simulate", write_scene(text), "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "young", "'E'")


def test_unknown_engine(tmp_path, capsys, write_scene):
    code, _, err = run(capsys, "simulate", write_scene(scene_text(DONUT, engine="bullet_sph")),
                       "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "bullet_sph", "installed engines")


def test_existing_output_without_overwrite(tmp_path, capsys, write_scene):
    out = tmp_path / "out"
    out.mkdir()
    (out / "precious.txt").write_text("keep me")
    code, _, err = run(capsys, "simulate", write_scene(scene_text(DONUT)), "-o", out, "-q")
    assert code != 0 and "--overwrite" in err and len(err.strip().splitlines()) == 1
    assert (out / "precious.txt").read_text() == "keep me"


def test_unsupported_material_names_capable_engines(tmp_path, capsys, write_scene):
    needs_package("gasp_mujoco_flex")
    text = scene_text(DONUT, engine="mujoco_flex", material='name = "sand"')
    code, _, err = run(capsys, "simulate", write_scene(text), "-o", tmp_path / "out", "-q")
    assert_clean_failure(code, err, tmp_path / "out", "mujoco_flex", "sand", "taichi_mpm")


def test_divergence_is_reported_with_frame_and_keeps_the_frames_before_it(tmp_path, capsys, write_scene, donut_small):
    """No ground and one substep a frame: the falling donut moves more than a cell a step by frame 5 (a point that
    leaves the grid slower drops out and is counted: tests/test_left_domain.py); the run stops and says so, and the
    frames before the blow-up stay in the output folder (issue 41: they were deleted; tests/test_hostile_41.py)."""
    needs_package("gasp_taichi_mpm")
    text = scene_text(donut_small, ground=False, n_frames=20, n_grid=16, engine_options="{ threads = 1, n_substeps = 1 }")
    out = tmp_path / "out"
    code, _, err = run(capsys, "simulate", write_scene(text), "-o", out, "-q")
    assert code == 3
    lines = [l for l in err.strip().splitlines() if l.startswith("gasp: error:")]
    assert len(lines) == 1 and "frame" in lines[0] and "time step" in lines[0] and str(out) in lines[0], err
    record = json.loads((out / "run.json").read_text())
    assert record["status"] == "diverged" and record["diverged"]["frame"] == len(record["frames"])
    assert not list(tmp_path.glob(".out.partial-*"))


def test_engines_lists_installed(capsys):
    code, out, _ = run(capsys, "engines")
    assert code == 0
    needs_package("gasp_taichi_mpm")
    assert "taichi_mpm  (gasp-taichi-mpm" in out and "jelly" in out


def test_engines_give_a_speed_or_not_measured_on_each_device(capsys):
    """Issue 65 item 5: every listed device of every engine has a speed line, a measured figure with its source or
    "not measured"; taichi_mpm's CUDA line is the measured one."""
    import re
    code, out, _ = run(capsys, "engines")
    assert code == 0
    needs_package("gasp_taichi_mpm")
    for block in re.split(r"\n(?=\S)", out):
        devices = re.search(r"devices:\s+([^;]+);", block)
        if devices:
            for d in devices.group(1).split(", "):
                line = re.search(rf"speed on {d}: (.+)", block)
                assert line and ("not measured" in line.group(1) or re.search(r"\d", line.group(1))), (block, d)
    tm = out[out.index("taichi_mpm  ("):]
    assert re.search(r"speed on cuda: README donut 0\.\d+ s a frame on an H100", tm)


def test_a_speed_for_a_device_the_engine_does_not_list_is_refused():
    from gasp_core.seam import Capabilities, EngineInfo
    caps = Capabilities(materials=frozenset({"jelly"}), boundaries=frozenset(), devices=frozenset({"cpu"}),
                        precisions=frozenset({"f32"}))
    EngineInfo(name="x", factory=lambda s: None, capabilities=caps, speed={"cpu": "1 s a frame"})
    with pytest.raises(ValueError, match="speed given for device"):
        EngineInfo(name="x", factory=lambda s: None, capabilities=caps, speed={"cuda": "1 s a frame"})


def test_info_on_real_files(capsys):
    code, out, _ = run(capsys, "info", DONUT)
    assert code == 0
    assert "45624" in out and "up_axis" in out and "flat" in out


def test_console_script_exit_status(tmp_path):
    exe = shutil.which("gasp")
    if exe is None:
        pytest.skip("the gasp console script is not on PATH (package not installed)")
    p = subprocess.run([exe, "simulate", str(tmp_path / "missing.toml"), "-o", str(tmp_path / "o")],
                       capture_output=True, text=True)
    assert p.returncode == 2 and p.stderr.startswith("gasp: error:") and "missing.toml" in p.stderr


def test_the_wait_for_the_first_frame_is_said(tmp_path, capsys, write_scene, donut_small):
    """Issue 39: a first run sat at 0 % for a minute with no word. With the progress bar, gasp simulate says that the
    engine builds (its kernels compile on a first run) before it does, and how long frame 1 took once it is done."""
    needs_package("gasp_warp_mpm")
    from gasp_core.run.report import BUILDING
    text = scene_text(donut_small, n_frames=1, n_grid=16, engine="warp_mpm")
    code, _, err = run(capsys, "simulate", write_scene(text), "-o", tmp_path / "out")
    assert code == 0, err
    lines = [line for line in err.replace("\r", "\n").splitlines() if line.strip() and "warning:" not in line]
    assert lines[0] == BUILDING.format(engine="warp_mpm"), lines      # before the bar's 0 %
    built = [line for line in lines if line.startswith("gasp: warp_mpm: frame 1 after ")]
    assert len(built) == 1 and float(built[0].split(" after ")[1].split(" s")[0]) > 0, lines
