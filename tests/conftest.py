"""Shared fixtures: real data paths and small scenes cut from the real donut."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.io import read_gaussians, write_gaussians

ROOT = Path(__file__).resolve().parents[1]
DONUT = ROOT / "examples" / "data" / "donut_v3dg.ply"
GUITAR = ROOT / "examples" / "data" / "guitar.compressed.ply"


@pytest.fixture(scope="session")
def donut():
    return read_gaussians(DONUT)


@pytest.fixture(scope="session")
def donut_small(tmp_path_factory, donut):
    """Every 16th Gaussian of the real donut (2,852 Gaussians), written as a graphdeco PLY."""
    path = tmp_path_factory.mktemp("data") / "donut_small.ply"
    write_gaussians(path, donut.subset(np.arange(0, donut.n, 16)))
    return path


def scene_text(ply: Path, n_frames: int = 10, n_grid: int = 24, engine: str = "taichi_mpm",
               extra_top: str = "", ground: bool = True, position_z: float = 0.05,
               material: str = 'name = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0',
               engine_options: str = "{ threads = 1 }", extra_object: str = "") -> str:
    """A donut-drop scene file's text, parametrised for tests."""
    boundary = '[[boundary]]\nkind = "ground"\nheight = 0.0\nfriction = 0.5\n' if ground else ""
    return f"""
frame_dt = 0.0333333
n_frames = {n_frames}
{extra_top}
[engine]
name = "{engine}"
options = {engine_options}

[domain]
n_grid = {n_grid}

{boundary}
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, {position_z}]
{extra_object}
[object.material]
{material}
"""


@pytest.fixture
def write_scene(tmp_path):
    def _write(text: str, name: str = "scene.toml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write
