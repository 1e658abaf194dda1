"""Issue 21: SIGTERM, SIGINT and SIGHUP stop a run at a frame boundary and keep a resumable partial.

A polite stop (a scheduler's time limit, a closed terminal, Ctrl-C) must lose no more than ``kill -9``:
the finished frames, their checkpoint and a consistent ``run.json`` stay in the partial folder, the
run says so in one line and exits 130, and ``--resume`` continues bit for bit.
"""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from gasp_testing import scene_text, needs_package

from gasp_core.cli.main import main
from gasp_core.fsutil import CLAIM
from gasp_core.run import stop

needs_package("gasp_warp_mpm")

N_FRAMES = 6


def not_resolution(err: str) -> str:
    """``err`` without the scene's resolution warning: these tests run the donut at n_grid 16 for speed
    (3.3 cells across its thickness, :func:`gasp_core.prepare.checks.check_resolution` warns), and they
    check the stop's own line."""
    return "".join(ln for ln in err.splitlines(keepends=True) if "grid cells across" not in ln)


def gasp(*argv, cwd):
    return subprocess.run([sys.executable, "-m", "gasp_core.cli.main", *map(str, argv)], capture_output=True,
                          text=True, cwd=cwd, timeout=600)


def frames(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "donut_small").glob("frame_*.ply"))}


ENGINES = {"warp_mpm": "{ }", "taichi_mpm": "{ threads = 1 }"}   # deterministic settings


def write_scene(tmp_path: Path, donut_small: Path, n_frames: int = N_FRAMES, engine: str = "warp_mpm") -> Path:
    # frame_dt 0.1 s: ~95 substeps, about a tenth of a second per frame at n_grid 16, so that a signal sent
    # when frame 2 appears on disk lands well before the last frame
    text = scene_text(donut_small, n_frames=n_frames, n_grid=16, engine=engine, engine_options=ENGINES[engine])
    scene = tmp_path / "scene.toml"
    scene.write_text(text.replace("frame_dt = 0.0333333", "frame_dt = 0.1"))
    return scene


def stop_after(scene: Path, out: Path, sig: int, after: int) -> subprocess.CompletedProcess:
    """Run ``gasp simulate`` in a process and send ``sig`` once frame ``after`` is on disk."""
    cwd = out.parent
    proc = subprocess.Popen([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-o", str(out), "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=cwd)
    deadline = time.time() + 600
    while time.time() < deadline and proc.poll() is None:
        if list(cwd.glob(f".{out.name}.partial-*/donut_small/frame_{after:04d}.ply")):
            proc.send_signal(sig)
            break
        time.sleep(0.01)
    out_text, err = proc.communicate(timeout=600)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out_text, err)


def stopped_run(tmp_path: Path, donut_small: Path, sig: int = signal.SIGHUP) -> tuple[Path, Path]:
    """``(scene, out)`` of a 3-frame run stopped by ``sig`` once frame 1 is on disk (exit 130)."""
    scene = write_scene(tmp_path, donut_small, n_frames=3)
    out = tmp_path / "out"
    r = stop_after(scene, out, sig, 1)
    assert r.returncode == 130, r.stderr
    return scene, out


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_sigterm_after_2_of_6_frames_resumes_bit_identical(tmp_path, donut_small, engine):
    needs_package(f"gasp_{engine}")
    scene = write_scene(tmp_path, donut_small, engine=engine)
    ref = tmp_path / "ref"
    r = gasp("simulate", scene, "-o", ref, "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr

    out = tmp_path / "out"
    r = stop_after(scene, out, signal.SIGTERM, 2)
    lines = not_resolution(r.stderr).strip().splitlines()
    assert r.returncode == 130 and len(lines) == 1, r.stderr
    assert lines[0].startswith("gasp: stopped by SIGTERM after frame ") and "--resume" in lines[0], lines[0]
    (partial,) = tmp_path.glob(".out.partial-*")
    record = json.loads((partial / "run.json").read_text())        # a consistent record of what was kept
    kept = record["stopped"]["after_frame"]
    assert record["stopped"]["signal"] == "SIGTERM" and 2 <= kept < N_FRAMES
    assert [f["frame"] for f in record["frames"]] == list(range(kept + 1))
    assert sorted(frames(partial)) >= [f"frame_{i:04d}.ply" for i in range(kept + 1)]
    assert not list(partial.rglob("*.tmp")) and (partial / ".gasp-checkpoint.npz").exists()
    assert "stopped" in (out / CLAIM).read_text()

    # a plain rerun names the stopped run; --resume continues it bit for bit
    r = gasp("simulate", scene, "-o", out, "-q", cwd=tmp_path)
    assert r.returncode == 2 and "stopped or killed" in r.stderr and "--discard" in r.stderr, r.stderr
    (partial / "..gasp-checkpoint.npz.x1y2.tmp").write_bytes(b"\0" * 1000)   # as a kill -9 mid-write leaves it
    r = gasp("simulate", scene, "-o", out, "-q", "--resume", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    run = json.loads((out / "run.json").read_text())
    assert run["resumed_after_frame"] == kept and "stopped" not in run
    assert frames(out) == frames(ref) and len(frames(out)) == N_FRAMES + 1
    assert not list(tmp_path.glob(".out.*")) and not list(out.rglob("*.tmp"))


@pytest.mark.parametrize("flag", ["--discard", "--overwrite"])
def test_discard_or_overwrite_throws_the_partial_away(tmp_path, donut_small, flag):
    scene = write_scene(tmp_path, donut_small, n_frames=3)
    out = tmp_path / "out"
    r = stop_after(scene, out, signal.SIGHUP, 1)
    assert r.returncode == 130 and "stopped by SIGHUP" in r.stderr, r.stderr
    r = gasp("simulate", scene, "-o", out, "-q", flag, "--frames", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert not list(tmp_path.glob(".out.*")) and len(frames(out)) == 2
    assert json.loads((out / "run.json").read_text())["n_frames"] == 1


@pytest.mark.parametrize("flag", ["--discard", "--overwrite"])
def test_a_users_file_in_the_stopped_runs_folder_survives(tmp_path, donut_small, flag):
    # issue 41: a file the user put in the hidden partial folder was deleted by --discard and --overwrite, exit 0
    scene, out = stopped_run(tmp_path, donut_small)
    (partial,) = tmp_path.glob(".out.partial-*")
    (partial / "notes.txt").write_text("mine")
    r = gasp("simulate", scene, "-o", out, "-q", flag, "--frames", "1", cwd=tmp_path)
    err = not_resolution(r.stderr).strip()
    assert r.returncode == 2 and "\n" not in err and flag in err and "notes.txt" in err and partial.name in err, err
    assert (partial / "notes.txt").read_text() == "mine" and (partial / "donut_small" / "frame_0001.ply").exists()
    (partial / "notes.txt").unlink()                       # moved out: the same command then throws the run away
    r = gasp("simulate", scene, "-o", out, "-q", flag, "--frames", "1", cwd=tmp_path)
    assert r.returncode == 0 and not partial.exists(), r.stderr


def test_discard_refused_for_a_users_file_says_why(tmp_path, donut_small):
    # issue 41: the refusal said "pass --discard", though it was passed
    scene, out = stopped_run(tmp_path, donut_small)
    (out / "mine.txt").write_text("mine")
    r = gasp("simulate", scene, "-o", out, "-q", "--discard", "--frames", "1", cwd=tmp_path)
    err = not_resolution(r.stderr).strip()
    assert r.returncode == 2 and "\n" not in err and "--discard refuses" in err and "mine.txt" in err, err
    assert "pass --resume" not in err and (out / "mine.txt").read_text() == "mine"


def test_a_truncated_checkpoint_is_one_line(tmp_path, donut_small, capsys):
    scene, out = stopped_run(tmp_path, donut_small, signal.SIGINT)
    (partial,) = tmp_path.glob(".out.partial-*")
    ck = partial / ".gasp-checkpoint.npz"
    ck.write_bytes(ck.read_bytes()[: ck.stat().st_size // 2])      # as a kill -9 on a full disk can leave it
    assert main(["simulate", str(scene), "-o", str(out), "-q", "--resume"]) == 2
    err = capsys.readouterr().err
    err = not_resolution(err)
    assert err.count("\n") == 1 and err.startswith("gasp: error: cannot resume") and "truncated" in err, err
    assert "--discard" in err


def test_a_long_frame_is_interrupted_at_once_and_a_short_one_finished():
    """The handler: inside a short frame it only records the signal; in a long frame, outside the frame
    loop, or on a second signal it raises :class:`Stopped` at once; the handlers in place before come back
    (SIGINT's is not always Python's default: a background job inherits SIG_IGN)."""
    before = signal.getsignal(signal.SIGINT)
    with stop.handlers():
        stop.frame_started(0.01)
        os.kill(os.getpid(), signal.SIGTERM)
        assert stop.requested() == "SIGTERM"
        with pytest.raises(stop.Stopped, match="SIGTERM"):
            os.kill(os.getpid(), signal.SIGTERM)                   # a second signal
    with stop.handlers():
        stop.frame_started(stop.LONG_FRAME_S * 2)
        with pytest.raises(stop.Stopped):
            os.kill(os.getpid(), signal.SIGHUP)
        stop.frame_started(None)                                   # not in the frame loop
        with pytest.raises(stop.Stopped):
            os.kill(os.getpid(), signal.SIGINT)
    assert signal.getsignal(signal.SIGINT) is before


def test_a_stop_before_any_checkpoint_keeps_nothing(tmp_path, donut_small, capsys, monkeypatch):
    """Ctrl-C while preparing: nothing finished, nothing kept, the folder given back."""
    scene = write_scene(tmp_path, donut_small, n_frames=2)

    def interrupt(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr("gasp_core.run.pipeline.resume_mod.fingerprint", interrupt)
    assert main(["simulate", str(scene), "-o", str(tmp_path / "out"), "-q"]) == 130
    assert not_resolution(capsys.readouterr().err) == "gasp: interrupted by SIGINT; no partial output was kept\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]


def test_viewer_stopped_by_sigterm_says_so(donut_run, tmp_path):
    """Issue 33: ``gasp view`` is stopped by SIGTERM with one line that fits a viewer (it writes nothing, so
    "no partial output was kept" would not fit), exit 130."""
    pytest.importorskip("viser", reason="the view extra is not installed: pip install -e '.[view]'")
    import socket
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    p = subprocess.Popen([sys.executable, "-m", "gasp_core.cli.main", "view", str(donut_run), "--port", str(port)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path)
    deadline = time.time() + 120
    while time.time() < deadline:   # serving once the port accepts a connection
        try:
            socket.create_connection(("127.0.0.1", port), timeout=1).close()
            break
        except OSError:
            time.sleep(0.5)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    lines = [ln for ln in err.splitlines() if ln.startswith("gasp:")]
    assert p.returncode == 130, err
    assert lines == ["gasp: viewer stopped by SIGTERM"], err
