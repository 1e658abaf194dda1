"""Issue 41, hostile input to ``gasp simulate``: a stdout cut short (a reader that stops reading, a closed
stdout, a full device) ends without a traceback and never costs the run; a run that diverges keeps the
frames it wrote before the blow-up, as a run folder whose ``run.json`` says ``status: "diverged"``."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import scene_text

ENGINE = "warp_mpm"
N_FRAMES = 2


def command(*argv) -> list[str]:
    return [sys.executable, "-m", "gasp_core.cli.main", *map(str, argv)]


def gasp(*argv):
    return subprocess.run(command(*argv), capture_output=True, text=True, timeout=600)


def small_scene(tmp_path, donut_small, **kw) -> Path:
    p = tmp_path / "s.toml"
    p.write_text(scene_text(donut_small, **{"n_frames": N_FRAMES, "n_grid": 16, "engine": ENGINE,
                                            "engine_options": "{ }", **kw}))
    return p


def diverging_scene(tmp_path, donut_small) -> Path:
    """No ground and one substep a frame: the falling donut moves more than a cell a step at frame 6 (warp_mpm,
    n_grid 16; points that leave the grid slower drop out and are counted, tests/test_left_domain.py)."""
    return small_scene(tmp_path, donut_small, ground=False, n_frames=20, engine_options="{ n_substeps = 1 }")


def check_complete_run(out: Path, n_frames: int) -> None:
    """``out`` is a finished run folder: ``run.json`` with every frame, each frame's file readable."""
    from gasp_core.run.layout import open_frames
    run = json.loads((out / "run.json").read_text())
    assert "status" not in run and [r["frame"] for r in run["frames"]] == list(range(n_frames + 1))
    frames = open_frames(out)
    assert frames.n_frames == n_frames + 1
    for f in range(n_frames + 1):
        assert np.isfinite(frames.gaussians(f, 0).means).all()
    assert not list(out.parent.glob(f".{out.name}.partial-*"))


def errors_of(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("gasp: error:")]


# --- stdout cut short -------------------------------------------------------------------------------------


def test_json_into_a_reader_that_stops_after_one_line_stops_quietly_and_resumes(tmp_path, donut_small):
    """``gasp simulate --json | head -n 1``: the reader closes the pipe after the first line. No traceback, exit
    141 as a Unix tool killed by SIGPIPE, the run stopped at a frame boundary (not run to its end for nobody) with
    its frames kept, and ``--resume`` finishes it."""
    pytest.importorskip(f"gasp_{ENGINE}")
    out = tmp_path / "out"
    scene = small_scene(tmp_path, donut_small)
    p = subprocess.Popen(command("simulate", scene, "-o", out, "--json"), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    first = p.stdout.readline()
    p.stdout.close()                      # head -n 1 exits: the next write gets EPIPE
    err = p.stderr.read().decode()
    code = p.wait(timeout=600)
    assert json.loads(first)["event"] in ("warning", "start")
    assert "Traceback" not in err and "Exception ignored" not in err, err
    assert code == 141, err
    assert not errors_of(err), err
    (partial,) = tmp_path.glob(".out.partial-*")              # stopped: its frames kept for --resume
    kept = sorted(partial.glob("*/frame_*.ply"))
    assert 1 <= len(kept) < N_FRAMES + 1 and not (out / "run.json").exists()
    r = gasp("simulate", scene, "-o", out, "--resume", "-q")
    assert r.returncode == 0, r.stderr
    check_complete_run(out, N_FRAMES)


def test_json_with_stdout_closed_is_one_line_and_the_run_finishes(tmp_path, donut_small):
    """``gasp simulate ... --json >&-``: Python starts with ``sys.stdout`` None (it raised AttributeError); now one
    ``gasp: error:`` line naming stdout, exit 2, and the frames all written."""
    pytest.importorskip(f"gasp_{ENGINE}")
    out = tmp_path / "out"
    line = " ".join(f"'{a}'" for a in command("simulate", small_scene(tmp_path, donut_small), "-o", out, "--json"))
    p = subprocess.run(["sh", "-c", f"{line} >&-"], capture_output=True, text=True, timeout=600)
    assert "Traceback" not in p.stderr and "Exception ignored" not in p.stderr, p.stderr
    assert p.returncode == 2, p.stderr
    errors = errors_of(p.stderr)
    assert len(errors) == 1 and "stdout" in errors[0] and "closed" in errors[0], p.stderr
    assert str(out) in errors[0]
    check_complete_run(out, N_FRAMES)


@pytest.mark.parametrize("json_lines", [True, False], ids=["json", "console"])
def test_stdout_on_a_full_device_is_one_line_and_the_run_finishes(tmp_path, donut_small, json_lines):
    """``> /dev/full``: every write to stdout fails with ENOSPC (a traceback, or Python's 'Exception ignored' at
    exit); now one ``gasp: error:`` line naming stdout and the cause, exit 2, and the frames all written."""
    pytest.importorskip(f"gasp_{ENGINE}")
    if not Path("/dev/full").exists():
        pytest.skip("no /dev/full on this system")
    out = tmp_path / "out"
    with open("/dev/full", "w") as full:
        p = subprocess.run(command("simulate", small_scene(tmp_path, donut_small), "-o", out, "-q",
                                   *(["--json"] if json_lines else [])),
                           stdout=full, stderr=subprocess.PIPE, text=True, timeout=600)
    assert "Traceback" not in p.stderr and "Exception ignored" not in p.stderr, p.stderr
    assert p.returncode == 2, p.stderr
    errors = errors_of(p.stderr)
    assert len(errors) == 1 and "stdout" in errors[0] and "No space left on device" in errors[0], p.stderr
    check_complete_run(out, N_FRAMES)


# --- a run that diverges ------------------------------------------------------------------------------------


def test_a_diverged_run_keeps_its_frames_before_the_blow_up(tmp_path, donut_small):
    """The frames before the blow-up are the user's result: they stay in the output folder, a run folder whose
    run.json records the divergence; the command still exits 3 with one line, which names the folder."""
    pytest.importorskip(f"gasp_{ENGINE}")
    from gasp_core.run.layout import open_frames
    scene, out = diverging_scene(tmp_path, donut_small), tmp_path / "out"
    r = gasp("simulate", scene, "-o", out, "-q")
    assert r.returncode == 3, r.stderr
    errors = errors_of(r.stderr)
    assert len(errors) == 1 and "diverged at frame" in errors[0] and "Traceback" not in r.stderr, r.stderr
    run = json.loads((out / "run.json").read_text())
    assert run["status"] == "diverged"
    k = run["diverged"]["frame"]
    assert k >= 2 and "time step" in run["diverged"]["cause"] and f"frame {k}" in run["diverged"]["message"]
    assert f"frame {k}" in errors[0] and f"frames 0-{k - 1}" in errors[0] and str(out) in errors[0], errors[0]
    assert [row["frame"] for row in run["frames"]] == list(range(k))
    frames = open_frames(out)
    assert frames.n_frames == k
    for f in range(k):
        assert np.isfinite(frames.gaussians(f, 0).means).all()
    assert not list(tmp_path.glob(".out.partial-*")) and not (out / ".gasp-claim").exists()
    assert not [p for p in out.iterdir() if "checkpoint" in p.name]

    # the kept frames are never replaced unasked, and --resume says in one line that a blow-up is not resumed
    again = gasp("simulate", scene, "-o", out, "-q")
    assert again.returncode == 2 and len(errors_of(again.stderr)) == 1 and "--overwrite" in again.stderr
    resumed = gasp("simulate", scene, "-o", out, "-q", "--resume")
    assert resumed.returncode == 2 and "Traceback" not in resumed.stderr, resumed.stderr
    assert len(errors_of(resumed.stderr)) == 1 and "diverged" in resumed.stderr, resumed.stderr
    assert json.loads((out / "run.json").read_text()) == run


def test_a_diverged_run_under_json_names_the_kept_frames_in_its_error_event(tmp_path, donut_small):
    pytest.importorskip(f"gasp_{ENGINE}")
    out = tmp_path / "out"
    r = gasp("simulate", diverging_scene(tmp_path, donut_small), "-o", out, "--json")
    assert r.returncode == 3, r.stderr
    last = json.loads(r.stdout.splitlines()[-1])
    assert last["event"] == "error" and last["status"] == 3 and str(out) in last["message"]
    assert last["output"] == str(out.resolve()) and last["run_json"] == str((out / "run.json").resolve())
    assert json.loads((out / "run.json").read_text())["status"] == "diverged"
