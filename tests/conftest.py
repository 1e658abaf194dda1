"""Shared fixtures: real data paths and small scenes cut from the real donut."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_testing import DONUT, biscuit_scene_text, needs_package


@pytest.fixture(scope="session")
def donut():
    return read_gaussians(DONUT)


@pytest.fixture(scope="session")
def donut_small(tmp_path_factory, donut):
    """Every 16th Gaussian of the real donut (2,852 Gaussians), written as a graphdeco PLY."""
    path = tmp_path_factory.mktemp("data") / "donut_small.ply"
    write_gaussians(path, donut.subset(np.arange(0, donut.n, 16)))
    return path


@pytest.fixture
def write_scene(tmp_path):
    def _write(text: str, name: str = "scene.toml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


@pytest.fixture(scope="session")
def donut_run(tmp_path_factory):
    """A short real run for the renderer tests: the donut dropped 5 cm onto the ground, taichi_mpm,
    n_grid 24, 14 frames, no interior fill, jelly (falls for 4 frames, lands, and at this coarse grid
    keeps bouncing: the resting check runs on the README example, ``-m slow``)."""
    needs_package("gasp_taichi_mpm")
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    from gasp_testing import scene_text
    d = tmp_path_factory.mktemp("render_run")
    toml = d / "scene.toml"
    toml.write_text(scene_text(DONUT, n_frames=14, n_grid=24, engine_options="{ threads = 2 }",
                               extra_object="fill = false"))
    simulate_scene(load_scene(toml), d / "run", quiet=True)
    return d / "run"


@pytest.fixture(scope="session")
def broken_run(tmp_path_factory, donut_small):
    """The donut_small biscuit broken on landing: 2 frames on warp_mpm (about 5 s; tests/test_split_pieces.py,
    tests/test_export_crack_faces.py): 1 piece at frames 0-2, with 0, 0 and 30 crumbs (issue 66: only what has come
    apart; 1, 11 and 13 pieces by the damage alone before), crack faces shown from frame 1."""
    needs_package("gasp_warp_mpm")
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    tmp = tmp_path_factory.mktemp("pieces")
    (tmp / "scene.toml").write_text(biscuit_scene_text(donut_small, 2, 4.43))
    simulate_scene(load_scene(tmp / "scene.toml"), tmp / "run", quiet=True)
    return tmp / "run"
