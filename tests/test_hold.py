"""A run held after its first frame (``gasp simulate --hold FILE``, :mod:`gasp_core.run.hold`): the studio starts
the run its user is about to ask for, and Run releases it (issue 39, the studio's first frame)."""
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from gasp_testing import needs_package, scene_text
from plyfile import PlyData

from gasp_core.run import hold, stop
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene


def _means(path):
    v = PlyData.read(str(path))["vertex"]
    return np.stack([v["x"], v["y"], v["z"]], axis=1)


def _start(scene, out, hold_file):
    cmd = [sys.executable, "-m", "gasp_core", "simulate", str(scene), "-o", str(out), "--json", "--hold",
           str(hold_file)]
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)


def _until_frame(proc, frame: int) -> None:
    for line in proc.stdout:
        e = json.loads(line)
        assert e.get("event") != "error", e
        if e.get("event") == "frame" and e.get("frame") == frame:
            return
    raise AssertionError(f"the run ended before frame {frame}: {proc.stderr.read()[-2000:]}")


@pytest.fixture
def small_scene(write_scene, donut_small):
    needs_package("gasp_warp_mpm")
    return write_scene(scene_text(donut_small, n_frames=3, n_grid=16, engine="warp_mpm"))


def test_a_held_run_waits_after_frame_1_and_goes_on_as_if_it_had_not(tmp_path, small_scene):
    """Held: frame 1's files on disk, nothing more for a second; released: the run ends with the frames of a run
    never held (bit for bit) and ``held_s`` in run.json. A hold that does not wait writes frame 2 while held."""
    hold_file = tmp_path / "hold"
    hold_file.touch()
    proc = _start(small_scene, tmp_path / "held", hold_file)
    try:
        _until_frame(proc, 1)
        partial = next(tmp_path.glob(".held.partial-*"))
        t0 = time.monotonic()
        while not list(partial.glob("*/frame_0001.ply")) and time.monotonic() - t0 < 30:
            time.sleep(0.05)     # the frame event comes as its files are handed to the writer
        assert list(partial.glob("*/frame_0001.ply"))
        time.sleep(1.0)
        assert proc.poll() is None
        assert not list(partial.glob("*/frame_0002.ply")), "frame 2 written while the run was held"
        hold_file.unlink()
        assert proc.wait(timeout=300) == 0, proc.stderr.read()[-2000:]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    record = json.loads((tmp_path / "held" / "run.json").read_text())
    assert record["held_s"] >= 1.0
    simulate_scene(load_scene(small_scene), tmp_path / "straight", quiet=True)
    for a in (tmp_path / "straight").glob("*/frame_0003.ply"):
        b = tmp_path / "held" / a.parent.name / a.name
        assert np.array_equal(_means(a), _means(b))


def test_a_held_run_stopped_keeps_frame_1_for_resume(tmp_path, small_scene):
    """SIGTERM while held (the studio's user chose otherwise): exit 130, frame 1 kept for ``--resume``."""
    hold_file = tmp_path / "hold"
    hold_file.touch()
    proc = _start(small_scene, tmp_path / "held", hold_file)
    try:
        _until_frame(proc, 1)
        os.killpg(proc.pid, signal.SIGTERM)
        assert proc.wait(timeout=60) == 130
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    kept = json.loads(next(tmp_path.glob(".held.partial-*/run.json")).read_text())
    assert kept["stopped"] == {"signal": "SIGTERM", "after_frame": 1}


def test_the_hold_is_bounded(tmp_path, small_scene, monkeypatch):
    """A front end that never releases its run: the run stops after :data:`MAX_HOLD_S` (here 0.3 s), its frame 1
    kept, instead of waiting for ever."""
    monkeypatch.setattr(hold, "MAX_HOLD_S", 0.3)
    hold_file = tmp_path / "hold"
    hold_file.touch()
    with stop.handlers(), pytest.raises(stop.Stopped, match="hold running out") as e:
        simulate_scene(load_scene(small_scene), tmp_path / "held", quiet=True, hold=str(hold_file))
    assert e.value.frame == 1 and e.value.kept is not None


def test_wait_returns_once_the_file_is_gone(tmp_path):
    """The wait itself: no file, no wait; a file removed after 0.2 s, a wait of 0.2 s (not the bound)."""
    assert hold.wait(tmp_path / "absent") < 0.05
    f = tmp_path / "hold"
    f.touch()
    import threading
    threading.Timer(0.2, f.unlink).start()
    waited = hold.wait(f, max_s=5.0)
    assert 0.15 < waited < 1.0
