"""Shared fixtures: real data paths and small scenes cut from the real donut."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.io import read_gaussians, write_gaussians
from gasp_testing import DONUT


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
