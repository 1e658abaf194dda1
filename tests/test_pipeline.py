"""End to end: a cut of the real donut through T, the Taichi MPM engine and T^-1."""
import json

import numpy as np
import pytest
from gasp_testing import scene_text, needs_package
from plyfile import PlyData

from gasp_core.errors import GaspError
from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.gs.io import read_gaussians
from gasp_core.prepare.placed import UP_ROTATIONS
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene

needs_package("gasp_taichi_mpm")


def covariances(g):
    R = quat_to_rotmat(g.rotations)
    return np.einsum("nij,nj,nkj->nik", R, g.scales ** 2, R)


@pytest.fixture(scope="module")
def donut_run(tmp_path_factory, donut_small):
    tmp = tmp_path_factory.mktemp("run")
    scene = tmp / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=36))
    out = tmp / "out"
    res = simulate_scene(load_scene(scene), out, quiet=True)
    return donut_small, out, res


def test_frame_layout_and_run_json(donut_run):
    src, out, res = donut_run
    frames = sorted((out / "donut_small").glob("frame_*.ply"))
    assert len(frames) == 37
    run = json.loads((out / "run.json").read_text())
    assert run["engine"] == "taichi_mpm" and run["n_frames"] == 36
    assert len(run["frames"]) == 37 and all("sim_s" in f for f in run["frames"][1:])
    assert run["engine_stats"]["n_substeps"] >= 1
    assert run["objects"][0]["n_fill_points"] > 0
    assert not list(out.parent.glob(".out.partial-*"))


def test_frame0_is_the_input(donut_run):
    src, out, _ = donut_run
    a = read_gaussians(src)
    b = read_gaussians(out / "donut_small" / "frame_0000.ply")
    assert np.array_equal(a.means.astype(np.float32), b.means.astype(np.float32))
    ca, cb = covariances(a), covariances(b)
    scale = np.einsum("nii->n", ca)[:, None, None]
    assert np.abs(ca - cb).max() <= 1e-5 * scale.max()
    assert (np.abs(ca - cb) / scale).max() < 1e-5


def test_appearance_bit_for_bit_every_frame(donut_run):
    src, out, _ = donut_run
    a = PlyData.read(str(src))["vertex"].data
    for f in sorted((out / "donut_small").glob("frame_*.ply"))[::6]:
        b = PlyData.read(str(f))["vertex"].data
        assert b.dtype.names == a.dtype.names
        for k in a.dtype.names:
            if k.startswith(("f_", "opacity")):
                assert np.array_equal(a[k].view(np.uint32), b[k].view(np.uint32)), (f.name, k)


def test_donut_falls_lands_and_rests(donut_run):
    src, out, res = donut_run
    dx = res.summary["domain"]["dx"]
    z_min0 = read_gaussians(src).means[:, 2].min()
    zs, z_mins = [], []
    for f in sorted((out / "donut_small").glob("frame_*.ply")):
        m = read_gaussians(f).means
        assert np.all(np.isfinite(m))
        zs.append(m[:, 2].mean())
        z_mins.append(m[:, 2].min())
    zs = np.array(zs)
    # frame 0 in the file frame; world = file + (0, 0, 0.05 - z_min0)
    lift = 0.05 - z_min0
    # falls: after 0.1 s the centroid has dropped close to g t^2 / 2 = 4.9 cm
    assert zs[0] - zs[3] == pytest.approx(0.5 * 9.81 * 0.1 ** 2, rel=0.1)
    # lands and never passes through the ground by more than one cell
    assert min(z_mins) + lift > -dx
    # bounces and loses energy: the solid (filled) jelly is elastic and undamped, so it rebounds;
    # MPM's transfers dissipate, and the late bounces are less than half as high as the first
    assert np.ptp(zs[-6:]) < 0.5 * np.ptp(zs[3:9])
    assert zs[-1] + lift > 0


def test_overwrite_replaces_only_after_success(tmp_path, donut_small):
    scene = tmp_path / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=1))
    out = tmp_path / "o"
    simulate_scene(load_scene(scene), out, quiet=True)
    with pytest.raises(FileExistsError, match="exists"):
        simulate_scene(load_scene(scene), out, quiet=True)
    marker = out / "keep.txt"
    marker.write_text("not made by gasp")
    with pytest.raises(GaspError, match="not a gasp output"):   # never replaces what a run did not make
        simulate_scene(load_scene(scene), out, overwrite=True, quiet=True)
    assert marker.read_text() == "not made by gasp"
    marker.unlink()
    old = (out / "run.json").read_text()
    simulate_scene(load_scene(scene), out, overwrite=True, quiet=True)
    assert (out / "run.json").read_text() != old


def test_up_axis_and_scale_round_trip(tmp_path, donut_small):
    """A -Y-up, centimetre copy of the donut gives the same motion, written back in its own frame."""
    g = read_gaussians(donut_small)
    R = UP_ROTATIONS["-y"].T        # world -> file for a -Y-up file
    from gasp_core.gs.gaussians import rotmat_to_quat
    from gasp_core.gs.io import write_gaussians
    g2 = g.copy()
    g2.means = 100.0 * g.means @ R.T
    g2.scales = 100.0 * g.scales
    g2.rotations = rotmat_to_quat(R @ g.rotmats())
    cm = tmp_path / "donut_cm_minus_y.ply"
    write_gaussians(cm, g2)
    s1 = tmp_path / "a.toml"
    s1.write_text(scene_text(donut_small, n_frames=2))
    s2 = tmp_path / "b.toml"
    s2.write_text(scene_text(cm, n_frames=2).replace('up_axis = "+z"', 'up_axis = "-y"\nscale = 0.01'))
    simulate_scene(load_scene(s1), tmp_path / "o1", quiet=True)
    simulate_scene(load_scene(s2), tmp_path / "o2", quiet=True)
    a = read_gaussians(tmp_path / "o1" / "donut_small" / "frame_0002.ply")
    b = read_gaussians(tmp_path / "o2" / "donut_cm_minus_y" / "frame_0002.ply")
    back = (b.means / 100.0) @ R       # file (cm, -Y up) -> metres, Z up
    assert np.abs(back - a.means).max() < 2e-4  # float32 engine round-off, metres
    assert np.allclose(b.scales[:, 1:] / 100.0, a.scales[:, 1:], rtol=1e-3, atol=1e-7)
