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
