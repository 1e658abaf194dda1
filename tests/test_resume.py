"""Resume: kill -9 a run at a random frame, then --resume: at most one frame recomputed, frames bit for bit."""
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.cli.main import main
from gasp_core.fsutil import CLAIM

ENGINES = {"warp_mpm": "{ }", "taichi_mpm": "{ threads = 1 }"}   # deterministic settings


def frames(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "donut_small").glob("frame_*.ply"))}


def kill_9_after(scene: Path, out: Path, kill_after: int) -> int:
    """Run ``gasp simulate scene -o out`` in a process, kill -9 it once more than ``kill_after`` frames and a
    checkpoint are on disk; the index of the last frame written."""
    cwd = out.parent
    # its own Taichi kernel cache: killed while holding the cache's lock, it would leave a stale lock file
    # that makes every later Taichi process of the session warn "Lock ... ticache.lock failed"
    env = {**os.environ, "TI_OFFLINE_CACHE_FILE_PATH": str(out.parent / f"ticache-{out.name}")}
    proc = subprocess.Popen([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "-q"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=cwd, env=env)
    deadline = time.time() + 600
    partial, written = None, 0
    while time.time() < deadline and proc.poll() is None:
        parts = list(cwd.glob(f".{out.name}.partial-*"))
        if parts and len(list((parts[0] / "donut_small").glob("frame_*.ply"))) > kill_after \
                and (parts[0] / ".gasp-checkpoint.npz").exists():
            partial = parts[0]
            os.kill(proc.pid, signal.SIGKILL)
            written = len(list((partial / "donut_small").glob("frame_*.ply"))) - 1   # last frame on disk
            break
        time.sleep(0.05)
    proc.wait()
    assert partial is not None, "the run ended before it could be killed"
    assert (out / CLAIM).exists() and not (out / "run.json").exists()
    return written


@pytest.mark.parametrize("engine", sorted(ENGINES))
def test_kill_9_then_resume_is_bit_identical(engine, tmp_path, donut_small, capsys):
    needs_package(f"gasp_{engine}")
    n_frames = 8
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=n_frames, n_grid=16, engine=engine,
                                engine_options=ENGINES[engine]))
    # All three runs (reference, killed, resumed) in fresh processes: with the reference inside the pytest
    # process, after the taichi case had run in it, warp's frames differed in the last bits (cause not
    # isolated: a standalone taichi-then-warp script in one process repeats bit for bit).
    ref = tmp_path / "ref"
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(ref), "-q"],
                   check=True, capture_output=True, cwd=tmp_path)

    out = tmp_path / "out"
    kill_after = random.Random(7).randint(2, n_frames - 2)       # frames written before the kill
    written = kill_9_after(scene, out, kill_after)

    # without --resume the folder is refused, naming the killed run
    assert main(["simulate", str(scene), "-o", str(out), "-q"]) == 2
    assert "--resume" in capsys.readouterr().err

    resumed = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "-q",
                              "--resume"], capture_output=True, text=True, cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    import json
    run = json.loads((out / "run.json").read_text())
    # the checkpoint of a frame is written right after its PLYs: at most the last frame on disk (and the
    # one in flight, never written) is computed again
    assert run["resumed_after_frame"] >= written - 1 >= kill_after - 1
    assert frames(out) == frames(ref)
    assert not list(tmp_path.glob(".out.partial-*"))


def test_a_collider_mesh_changed_after_the_kill_refuses_the_resume(tmp_path, donut_small, capsys):
    """The fingerprint stands for every file the run reads (prepare.scene.input_files), collider meshes too."""
    needs_package("gasp_warp_mpm")
    trimesh = needs_package("trimesh")
    mesh = tmp_path / "box.obj"
    trimesh.creation.box(extents=(0.2, 0.2, 0.05)).export(mesh)
    scene = tmp_path / "scene.toml"
    collider = f'[[collider]]\nmesh = "{mesh.name}"\nposition = [1.0, 1.0, 0.0]\n'
    scene.write_text(scene_text(donut_small, n_frames=8, n_grid=16, engine="warp_mpm", engine_options="{ }")
                     + collider)
    out = tmp_path / "out"
    kill_9_after(scene, out, 2)
    trimesh.creation.box(extents=(0.3, 0.2, 0.05)).export(mesh)   # the collider changed between kill and resume
    assert main(["simulate", str(scene), "-o", str(out), "-q", "--resume"]) == 2
    err = "\n".join(l for l in capsys.readouterr().err.strip().splitlines()
                    if not l.startswith("gasp: warning:"))                # n_grid 16: the resolution warning
    assert "cannot resume" in err and "input file" in err and "\n" not in err, err
    assert not (out / "run.json").exists()


def test_a_large_state_checkpoints_every_few_frames_and_still_resumes_bit_for_bit(tmp_path, donut_small, capsys):
    """With ``GASP_CHECKPOINT_MB`` below a third of the state's size a checkpoint is written every third frame (issue
    65: a 16M-point body's 1.6 GB state every frame); a run killed after it resumes from the last one, frames bit for
    bit as an uninterrupted run's."""
    needs_package("gasp_taichi_mpm")
    from gasp_core.run.resume import checkpoint_every
    n_frames = 8
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=n_frames, n_grid=16, engine="taichi_mpm",
                                engine_options=ENGINES["taichi_mpm"]))
    ref = tmp_path / "ref"
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(ref), "-q"],
                   check=True, capture_output=True, cwd=tmp_path)
    import json
    n_points = json.loads((ref / "run.json").read_text())["engine_stats"]["n_points"]
    state_mb = n_points * 25 * 4 / 2 ** 20    # x, v, C, F, Jp in f32
    os.environ["GASP_CHECKPOINT_MB"] = str(state_mb / 2.5)
    try:
        assert checkpoint_every({"x": np.zeros((n_points, 25), np.float32)}) == 3
        sparse = tmp_path / "sparse"
        subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(sparse), "-q"],
                       check=True, capture_output=True, cwd=tmp_path)
        rows = json.loads((sparse / "run.json").read_text())["frames"]
        assert [r["frame"] for r in rows if "checkpoint_s" in r] == [1, 3, 6]   # not every frame (or none)
        assert frames(sparse) == frames(ref)
        out = tmp_path / "out"
        written = kill_9_after(scene, out, 5)
        resumed = subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out),
                                  "-q", "--resume"], capture_output=True, text=True, cwd=tmp_path)
    finally:
        del os.environ["GASP_CHECKPOINT_MB"]
    assert resumed.returncode == 0, resumed.stderr
    after = json.loads((out / "run.json").read_text())["resumed_after_frame"]
    assert after in (1, 3, 6) and after <= written    # the checkpoints: frame 1 (it measures the state), then every 3rd
    assert frames(out) == frames(ref)
