"""``gasp place`` (issue 54 item 3): a picture of the scene as the run would start it, and the cost it names is the
run's own (the substeps a frame the engine then takes, the points it simulates)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from gasp_core.cli.main import main
from gasp_testing import needs_package, scene_text


def test_place_draws_the_scene_and_names_the_runs_own_cost(tmp_path, donut_small, write_scene, capsys):
    needs_package("matplotlib")
    import imageio.v3 as iio
    scene = write_scene(scene_text(donut_small, n_frames=1, n_grid=16))
    picture = tmp_path / "place.png"
    assert main(["place", str(scene), "-o", str(picture)]) == 0
    line = capsys.readouterr().out
    image = iio.imread(picture)
    assert image.ndim == 3 and image.shape[0] > 300 and image.shape[1] > 600
    assert (image[..., :3].std(axis=2) > 20).mean() > 0.002          # coloured pixels: the donut in its own colours
    # the run: the same points and the same substeps a frame as the picture says
    assert main(["simulate", str(scene), "-o", str(tmp_path / "run")]) == 0
    run = json.loads((tmp_path / "run" / "run.json").read_text())
    n_sub, points = run["engine_stats"]["n_substeps"], run["engine_stats"]["n_points"]
    assert f"{points:,} points, {n_sub} substeps a frame" in line


def test_place_refuses_to_overwrite_and_names_the_format(tmp_path, donut_small, write_scene, capsys):
    needs_package("matplotlib")
    scene = write_scene(scene_text(donut_small, n_frames=1, n_grid=16))
    picture = tmp_path / "place.png"
    picture.write_bytes(b"mine")
    assert main(["place", str(scene), "-o", str(picture)]) != 0
    assert "file exists" in capsys.readouterr().err and picture.read_bytes() == b"mine"
    assert main(["place", str(scene), "-o", str(tmp_path / "place.jpg")]) != 0
    assert "PNG" in capsys.readouterr().err
    assert main(["place", str(scene), "-o", str(picture), "--overwrite"]) == 0
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
