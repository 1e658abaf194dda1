"""A brittle run stopped (as by SIGTERM or Ctrl-C) and resumed labels its pieces as one never stopped (issue 66,
item 4): its cut links, last labels and which of them are pieces go into the checkpoint
(:meth:`gasp_core.run.pieces.PieceTracker.state`). The donut_small biscuit (``tests/conftest.py``) thrown onto the
ground at 7 m/s on warp_mpm, 7 frames, stopped at frame 5 (while it breaks): every ``pieces_NNNN.npy`` byte for byte and every
``run.json`` row's ``pieces``, ``piece_mass``, ``debris`` and ``debris_mass`` equal to an uninterrupted run's; the
same after kill -9 in its own process (slow: 16 s), as ``tests/test_resume.py`` kills a jelly run. Shown to catch a
resume that does not restore the tracker's state."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from gasp_testing import biscuit_scene_text, needs_package

#: Round 55: under round 54's step (cfl_rule "sum") the biscuit breaks later: pieces 1, 1, 1, 1, 1, 2, 4, 6 at frames
#: 0-7 (it had broken by frame 3 before), so the run is stopped at frame 5 and runs to 7, to stop it while it breaks.
N_FRAMES, STOP_FRAME = 7, 5
KEYS = ("pieces", "piece_mass", "debris", "debris_mass")


def scene_text(ply: Path) -> str:
    """tests/conftest.py's brittle biscuit thrown down at 7 m/s for N_FRAMES frames."""
    return biscuit_scene_text(ply, N_FRAMES, 7.0)


def pieces_of(run: Path) -> tuple[dict, list]:
    files = {p.name: p.read_bytes() for p in sorted((run / "donut_small").glob("pieces_*.npy"))}
    rows = [{k: r[k] for k in KEYS} for r in json.loads((run / "run.json").read_text())["frames"]]
    return files, rows


def stopped_and_resumed(tmp_path: Path, scene: Path) -> Path:
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.run.stop import Stopped
    from gasp_core.scene.spec import load_scene

    def interrupt(frame, gs):
        if frame == STOP_FRAME:
            raise KeyboardInterrupt

    out = tmp_path / "out"
    with pytest.raises(Stopped):
        simulate_scene(load_scene(scene), out, quiet=True, on_frame=interrupt)
    simulate_scene(load_scene(scene), out, quiet=True, resume=True)
    return out


def test_a_stopped_and_resumed_run_writes_the_pieces_of_one_never_stopped(tmp_path, donut_small):
    needs_package("gasp_warp_mpm")
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small))
    simulate_scene(load_scene(scene), tmp_path / "ref", quiet=True)
    ref = pieces_of(tmp_path / "ref")
    assert len(ref[0]) == N_FRAMES + 1 and ref[1][-1]["pieces"] > ref[1][STOP_FRAME]["pieces"] > 1, ref[1]
    assert pieces_of(stopped_and_resumed(tmp_path, scene)) == ref


def test_the_resume_check_catches_a_checkpoint_without_the_pieces(tmp_path, donut_small, monkeypatch):
    """The tracker's state not restored (a resumed run starting from no cut link): its pieces differ (measured: 13
    pieces at frame 4 against 40, the count falling from 32; the fragments had met again)."""
    needs_package("gasp_warp_mpm")
    from gasp_core.run.pieces import PieceTracker
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small))
    simulate_scene(load_scene(scene), tmp_path / "ref", quiet=True)
    monkeypatch.setattr(PieceTracker, "restore", lambda self, state: None)
    files, rows = pieces_of(stopped_and_resumed(tmp_path, scene))
    ref_files, ref_rows = pieces_of(tmp_path / "ref")
    assert (files, rows) != (ref_files, ref_rows)


@pytest.mark.slow
def test_a_brittle_run_killed_9_and_resumed_writes_the_pieces_of_one_never_stopped(tmp_path, donut_small):
    """As ``tests/test_resume.py``'s kill -9, on the brittle biscuit: every run in its own process."""
    import subprocess
    import sys
    from test_resume import kill_9_after
    needs_package("gasp_warp_mpm")
    scene = tmp_path / "s.toml"
    scene.write_text(scene_text(donut_small))
    run = [sys.executable, "-m", "gasp_core.cli.main", "simulate", str(scene), "-q", "-o"]
    subprocess.run(run + [str(tmp_path / "ref")], check=True, capture_output=True, cwd=tmp_path)
    kill_9_after(scene, tmp_path / "out", 3)
    resumed = subprocess.run(run + [str(tmp_path / "out"), "--resume"], capture_output=True, text=True, cwd=tmp_path)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((tmp_path / "out" / "run.json").read_text())["resumed_after_frame"] >= 2
    assert pieces_of(tmp_path / "out") == pieces_of(tmp_path / "ref")
