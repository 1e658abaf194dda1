"""Tier with PlayCanvas splat-transform (npm): it opens every file of a run written as spz, sog and compressed PLY,
and it reads the .splat / .ksplat files of tests/formats_testing.py as our readers do."""
import json
import os
import shutil
import subprocess

import numpy as np
import pytest
from formats_testing import write_ksplat, write_splat
from gasp_testing import scene_text, needs_package

from gasp_core.cli.main import main
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.io import read_gaussians

INSTALL = "npm install -g @playcanvas/splat-transform (or set GASP_SPLAT_TRANSFORM to its path)"
if shutil.which("node") is None:
    pytest.skip(f"node is not installed: apt-get install -y nodejs npm, then {INSTALL}", allow_module_level=True)
ST = os.environ.get("GASP_SPLAT_TRANSFORM") or shutil.which("splat-transform")
if ST is None:
    pytest.skip(f"splat-transform is not installed: {INSTALL}", allow_module_level=True)
pytest.importorskip("gsply", reason="gsply is not installed: pip install -e '.[formats]'")

SELECT = "select = { box = { lo = [-1.0, -1.0, -1.0], hi = [0.0, 1.0, 1.0] } }"


def converted(src, tmp_path):
    """``src`` as splat-transform reads it, written by it as a graphdeco PLY, its columns as a Gaussians.

    Read with plyfile: splat-transform writes an alpha of 1 as the logit +inf, which GASP's PLY reader refuses.
    """
    from plyfile import PlyData
    out = tmp_path / f"{src.name.replace('.', '_')}_st.ply"
    r = subprocess.run([ST, "-q", "-w", str(src), str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr + r.stdout
    v = PlyData.read(str(out))["vertex"].data
    rest = sorted((n for n in v.dtype.names if n.startswith("f_rest_")), key=lambda n: int(n[7:]))
    q = np.stack([v[f"rot_{i}"] for i in range(4)], 1).astype(np.float64)
    sh_rest = np.stack([v[n] for n in rest], 1).reshape(len(v), 3, -1).transpose(0, 2, 1) if rest else None

    def cols(*names):
        return np.stack([v[n] for n in names], 1)

    return Gaussians(means=cols("x", "y", "z"), scales=np.exp(cols("scale_0", "scale_1", "scale_2")),
                     rotations=q / np.linalg.norm(q, axis=1, keepdims=True), opacities=np.clip(v["opacity"], -40, 40),
                     sh_dc=cols("f_dc_0", "f_dc_1", "f_dc_2"), sh_rest=sh_rest)


def alpha(g):
    return 1 / (1 + np.exp(-g.opacities.astype(np.float64)))


def same(ours, theirs, pos_tol=1e-6, rot_tol=1e-5):
    assert ours.n == theirs.n
    ext = max(np.ptp(ours.means, axis=0).max(), 1.0)
    assert np.abs(ours.means - theirs.means).max() <= pos_tol * ext
    assert np.minimum(np.abs(ours.rotations - theirs.rotations).max(1),
                      np.abs(ours.rotations + theirs.rotations).max(1)).max() <= rot_tol
    assert np.abs(np.log(ours.scales) - np.log(theirs.scales)).max() <= 1e-5
    assert np.abs(ours.sh_dc - theirs.sh_dc).max() <= 1e-5
    assert np.abs(alpha(ours) - alpha(theirs)).max() <= 1e-5   # logits differ at 0 and 1: -/+40 here, 1e-6 there
    if ours.sh_rest.size:
        assert np.abs(ours.sh_rest - theirs.sh_rest).max() <= 1e-5


@pytest.fixture(scope="module")
def train():
    from pathlib import Path
    return read_gaussians(Path(__file__).resolve().parents[1] / "examples" / "data" / "train-1000.ply")


def test_splat_reads_as_in_splat_transform(tmp_path, train):
    write_splat(tmp_path / "t.splat", train)
    # splat-transform decodes a rotation byte as b / 127.5 - 1, antimatter15's viewer (ours) as (b - 128) / 128
    same(read_gaussians(tmp_path / "t.splat"), converted(tmp_path / "t.splat", tmp_path), rot_tol=0.01)


@pytest.mark.parametrize("level", [0, 1])
def test_ksplat_reads_as_in_splat_transform(tmp_path, train, level):
    write_ksplat(tmp_path / "t.ksplat", train, level=level)
    same(read_gaussians(tmp_path / "t.ksplat"), converted(tmp_path / "t.ksplat", tmp_path))


@pytest.mark.parametrize("fmt", ["spz", "sog", "compressed_ply"])
def test_every_file_of_a_run_opens_in_splat_transform(tmp_path, donut_small, fmt):
    """A split-layout run (half of the donut moving): the rest file and every frame open, as GASP reads them."""
    needs_package("gasp_taichi_mpm")
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=1, n_grid=16, extra_object=SELECT))
    assert main(["simulate", str(scene), "-o", str(tmp_path / "o"), "--format", fmt, "-q"]) == 0
    o = json.loads((tmp_path / "o" / "frames.json").read_text())["objects"][0]
    for rel in [o["rest"], *o["frames"]]:
        path = tmp_path / "o" / rel
        # positions: splat-transform decodes in float32
        same(read_gaussians(path), converted(path, tmp_path), pos_tol=1e-6, rot_tol=1e-4)
