"""Issue 54 item 8: a big capture with a small selection is written ``split`` by default, and ``gasp simulate`` says
before the run how much it will write.

The capture is the bundled real donut tiled 11 times along x (one donut selected, 10 unselected: the rows that never
move outnumber those that move 10 to 1, :data:`gasp_core.run.layout.SPLIT_RATIO`). The same run is made with the
default layout and with ``--layout frames`` (today's default for ``ply``): the bytes on disk are the estimate said
before the run (exactly, for ``ply``), the default writes what never moves once, and both read back as the same
frames.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package

from gasp_core.cli.main import main
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.run.layout import SPLIT_RATIO, choose_layout, open_frames

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"
COPIES = 11
SPACING = 0.4     # metres between the copies' centres along x (the donut is about 0.2 m across)


def tiled_capture(path: Path, every: int = 8) -> Gaussians:
    """Every ``every``-th Gaussian of the real donut, ``COPIES`` times along x, as one graphdeco PLY."""
    g = read_gaussians(DONUT).subset(np.arange(0, 45_624, every))
    shift = np.zeros((COPIES, 1, 3))
    shift[:, 0, 0] = SPACING * np.arange(COPIES)
    tile = lambda a: np.concatenate([a] * COPIES)   # noqa: E731
    big = Gaussians(means=(g.means[None] + shift).reshape(-1, 3), scales=tile(g.scales), rotations=tile(g.rotations),
                    opacities=tile(g.opacities), sh_dc=tile(g.sh_dc), sh_rest=tile(g.sh_rest),
                    extra={k: tile(v) for k, v in g.extra.items()})
    write_gaussians(path, big)
    return g


def scene(tmp: Path, g: Gaussians) -> Path:
    lo, hi = g.means.min(axis=0) - 0.01, g.means.max(axis=0) + 0.01       # the first copy, file frame
    text = f"""
frame_dt = 0.0333333
n_frames = 2
[engine]
name = "warp_mpm"
[domain]
n_grid = 24
[[boundary]]
kind = "ground"
[[object]]
file = "capture.ply"
up_axis = "+z"
recentre = false
select = {{ box = {{ lo = {lo.tolist()}, hi = {hi.tolist()} }} }}
[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
"""
    path = tmp / "capture.toml"
    path.write_text(text)
    return path


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file() and p.suffix in (".ply", ".npy"))


def test_the_layout_rule_is_two_sided():
    assert choose_layout("ply", SPLIT_RATIO * 1000, 1000) == "split"
    assert choose_layout("ply", SPLIT_RATIO * 1000 - 1, 1000) == "frames"      # just under: as before
    assert choose_layout("glb", 10 ** 9, 1) == "frames"                        # players load whole files
    assert choose_layout("spz", 0, 1000) == "split"                            # the compressed default


def test_a_big_capture_writes_what_never_moves_once_and_says_so_first(tmp_path, capsys):
    needs_package("gasp_warp_mpm")
    g = tiled_capture(tmp_path / "capture.ply")
    path = scene(tmp_path, g)
    runs = {}
    for name, extra in (("default", []), ("frames", ["--layout", "frames"])):
        out = tmp_path / name
        code = main(["simulate", str(path), "-o", str(out), "--json", *extra])
        events = [json.loads(line) for line in capsys.readouterr().out.splitlines() if line.startswith("{")]
        assert code == 0, events
        start = next(e for e in events if e["event"] == "start")
        runs[name] = (out, start)
    (split, s_start), (frames, f_start) = runs["default"], runs["frames"]
    assert s_start["layout"] == "split" and f_start["layout"] == "frames"
    # the bytes said before the run are the bytes on disk (ply rows have a fixed size)
    for out, start in runs.values():
        assert start["output_bytes"] == folder_bytes(out), (out, start)
    # what never moves is written once: 3 frames of 1 copy + the 10 others once, against 3 frames of all 11
    moving, rows = g.n, COPIES * g.n
    expect = (3 * moving + (rows - moving)) / (3 * rows)
    ratio = folder_bytes(split) / folder_bytes(frames)
    assert ratio == pytest.approx(expect, rel=0.02), ratio
    # and the frames read back the same
    a, b = open_frames(split), open_frames(frames)
    for frame in range(3):
        ga, gb = a.gaussians(frame, 0), b.gaussians(frame, 0)
        np.testing.assert_array_equal(ga.means, gb.means)
        np.testing.assert_array_equal(ga.rotations, gb.rotations)
        np.testing.assert_array_equal(ga.scales, gb.scales)
