"""View-dependent colour (SH degree 1-3) that turns with each Gaussian, and camera paths for ``gasp render``.

Known answers: the 3DGS SH basis is orthonormal on the sphere; a scene turned rigidly and seen from a
camera turned the same way looks the same (only if the SH turn with the Gaussians); a graphdeco
``cameras.json`` entry projects points as the capture's own W2C matrix and focal length do. The
reference image ``tests/data/render_reference_pc_short.png`` was made once by the NumPy renderer
(128x96, SH degree 3, real data: ``tests/data/pc_short.ply``) and catches a renderer that drifts.
"""
import json
from pathlib import Path

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.io import read_gaussians
from gasp_core.gs.camera import Camera
from gasp_core.gs.sh import sh_basis
from gasp_core.gs.splat_numpy import splats_from_gaussians

DATA = Path(__file__).parent / "data"
PC_SHORT = DATA / "pc_short.ply"
REFERENCE = DATA / "render_reference_pc_short.png"
RENDER_EXTRA = 'the render extra (imageio) is not installed: python -m pip install -e ".[render]"'


def _fibonacci(n):
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], 1)


def _rotation(axis, deg):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    h = np.radians(deg) / 2
    return quat_to_rotmat(np.r_[np.cos(h), np.sin(h) * axis])


def test_sh_basis_is_orthonormal_on_the_sphere():
    Y = sh_basis(_fibonacci(40_000), 3)
    gram = 4 * np.pi * Y.T @ Y / len(Y)            # quadrature of Y_i Y_j over the sphere
    assert np.abs(gram - np.eye(16)).max() < 2e-3  # a constant 5 % off puts a diagonal entry 0.1 away


def _pc_short():
    return read_gaussians(PC_SHORT)


def _turned(g, Q):
    """The file ``g`` turned rigidly by ``Q`` about the origin (what a simulation's frame would hold)."""
    h = g.copy()
    h.means = g.means @ Q.T
    h.rotations = rotmat_to_quat(np.einsum("ij,njk->nik", Q, g.rotmats()))
    return h


def test_view_dependent_colour_turns_with_the_gaussians():
    g = _pc_short()
    assert g.sh_degree == 3
    Q = _rotation([0.3, -0.5, 0.8], 70.0)
    eye = np.array([0.4, -2.5, 1.5])
    before = splats_from_gaussians(g).seen_from(eye).rgb
    h = _turned(g, Q)
    after = splats_from_gaussians(h, rest_rotmats=g.rotmats()).seen_from(Q @ eye).rgb
    np.testing.assert_allclose(after, before, atol=2e-5)
    # without the turn the colours are not the same: the check above can fail
    wrong = splats_from_gaussians(h).seen_from(Q @ eye).rgb
    assert np.abs(wrong - before).max() > 0.02
    # a camera moved alone does change the colour (the SH are view-dependent)
    assert np.abs(splats_from_gaussians(g).seen_from(-eye).rgb - before).max() > 0.02


def test_placement_turns_the_view_direction_into_the_file_frame():
    g = _pc_short()
    R = _rotation([1, 0, 0], 90.0)                 # e.g. a -y-up file placed z up
    eye = np.array([0.4, -2.5, 1.5])
    want = splats_from_gaussians(g).seen_from(eye).rgb
    got = splats_from_gaussians(g, R, 2.0, [0.1, 0.2, 0.3]).seen_from(2.0 * R @ eye + [0.1, 0.2, 0.3]).rgb
    np.testing.assert_allclose(got, want, atol=2e-5)


def _reference_camera(g):
    c = 0.5 * (g.means.min(0) + g.means.max(0))
    return Camera(c + np.array([0.3, -2.2, 0.4]), c, 40.0, 128, 96)


@pytest.mark.parametrize("name", ["numpy", "cpu"])
def test_renderers_match_the_kept_reference_image(name):
    iio = pytest.importorskip("imageio.v3", reason=RENDER_EXTRA)
    from gasp_core.render.registry import get_renderer
    from gasp_core.render.run import to_uint8
    if name == "cpu":
        pytest.importorskip("numba", reason=RENDER_EXTRA.replace("imageio", "numba"))
    g = _pc_short()
    cam = _reference_camera(g)
    s = splats_from_gaussians(g)
    bg = np.array([0.2, 0.2, 0.2])
    img = to_uint8(get_renderer(name)(s.seen_from(cam.position), cam, bg)[0]).astype(int)
    ref = iio.imread(REFERENCE)[..., :3].astype(int)
    assert np.abs(img - ref).max() <= 2 and np.abs(img - ref).mean() < 0.05
    # degree-0 colour (the SH ignored) is visibly different: the reference holds the view dependence
    flat = to_uint8(get_renderer(name)(s, cam, bg)[0]).astype(int)
    assert np.abs(flat - ref).max() > 8


def _graphdeco_entry(R_w2c, T, fx, fy, w, h):
    """As graphdeco's ``utils/camera_utils.py: camera_to_JSON`` writes a camera (R there is C2W)."""
    Rt = np.eye(4)
    Rt[:3, :3], Rt[:3, 3] = R_w2c, T
    C2W = np.linalg.inv(Rt)
    return {"id": 0, "img_name": "x", "width": w, "height": h, "position": C2W[:3, 3].tolist(),
            "rotation": [r.tolist() for r in C2W[:3, :3]], "fy": fy, "fx": fx}


def test_graphdeco_camera_projects_as_the_capture(tmp_path):
    from gasp_core.render.paths import graphdeco_camera
    R_w2c = _rotation([0.2, 1.0, -0.4], 35.0)
    T = np.array([0.1, -0.2, 3.0])
    f, w, h = 500.0, 320, 200
    path = tmp_path / "cameras.json"
    path.write_text(json.dumps([_graphdeco_entry(np.eye(3), [0, 0, 1], f, f, w, h),
                                _graphdeco_entry(R_w2c, T, f, f, w, h)]))
    pts = np.random.default_rng(0).normal(0, 0.3, (20, 3))
    pc = pts @ R_w2c.T + T
    want = np.stack([f * pc[:, 0] / pc[:, 2] + w / 2, f * pc[:, 1] / pc[:, 2] + h / 2], 1)
    cam = graphdeco_camera(path, 1)
    uv, z = cam.project_points(pts)
    np.testing.assert_allclose(uv, want, atol=1e-6)
    np.testing.assert_allclose(z, pc[:, 2], atol=1e-9)
    # placed: the same picture of the placed points (metres), at half the size
    Rp, sp, tp = _rotation([1, 0, 0], 90.0), 2.0, np.array([1.0, 2.0, 3.0])
    cam = graphdeco_camera(path, 1, {"R": Rp, "scale": sp, "t": tp}, w // 2, h // 2)
    uv, _ = cam.project_points(sp * pts @ Rp.T + tp)
    np.testing.assert_allclose(uv, want / 2, atol=1e-6)
    with pytest.raises(SceneError, match="has 2 cameras"):
        graphdeco_camera(path, 2)


def test_orbit_and_keyframe_paths(tmp_path):
    from gasp_core.render.paths import keyframe_path, orbit_path
    lo, hi = np.zeros(3), np.ones(3)
    cams = orbit_path(360.0)(lo, hi, 8, 64, 48, 40.0)
    d = np.array([c.position - 0.5 for c in cams])
    assert np.allclose(np.linalg.norm(d, axis=1), np.linalg.norm(d[0]))        # one radius
    az = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
    assert np.allclose(np.diff(np.unwrap(np.radians(az))), np.radians(45.0))   # 360 / 8 per frame
    f = tmp_path / "path.json"
    f.write_text(json.dumps({"keyframes": [{"frame": 0, "position": [2, 0, 1], "look_at": [0, 0, 0]},
                                           {"frame": 4, "position": [0, 2, 1], "look_at": [0, 0, 1]}]}))
    cams = keyframe_path(f)(lo, hi, 6, 64, 48, 40.0)
    np.testing.assert_allclose(cams[2].position, [1, 1, 1])
    np.testing.assert_allclose(cams[2].look_at, [0, 0, 0.5])
    np.testing.assert_allclose(cams[5].position, [0, 2, 1])                    # holds after the last key
    f.write_text("{}")
    with pytest.raises(SceneError, match="keyframes"):
        keyframe_path(f)


def test_render_cli_writes_beside_the_run_with_a_clear_line(donut_run, tmp_path, capsys):
    iio = pytest.importorskip("imageio.v3", reason=RENDER_EXTRA)
    from gasp_core.cli.main import main
    cams = tmp_path / "cameras.json"
    W2C = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])       # looking along +y, z up
    cams.write_text(json.dumps([_graphdeco_entry(W2C, -W2C @ np.array([0.0, -0.6, 0.05]), 60.0, 60.0, 64, 48)]))
    out = donut_run / "render.mp4"
    out.unlink(missing_ok=True)
    assert main(["render", str(donut_run), "-q", "--camera-index", "0", "--cameras", str(cams)]) == 0
    line = capsys.readouterr().out.strip().splitlines()[-1]
    assert line.startswith(f"wrote {out}: 15 frames of 64x48 px, plays 0.50 s at 30 fps (rendering took ")
    frames = iio.imread(out)
    assert frames.shape[1:3] == (48, 64)
    centre = frames[0][16:40, 20:44].astype(int)
    assert ((centre.max(axis=2) - centre.min(axis=2)) > 60).sum() > 20   # the donut is in front of this camera
    out.unlink()


def test_run_frames_carry_their_sh_frame(tmp_path):
    """A run folder whose frame 1 is frame 0 turned rigidly: seen from the turned camera it looks the same."""
    from gasp_core.gs.io import write_gaussians
    from gasp_core.render.run import load_run
    g = _pc_short()
    Q = _rotation([0.1, 0.9, 0.3], 50.0)
    (tmp_path / "obj").mkdir()
    write_gaussians(tmp_path / "obj" / "frame_0000.ply", g)
    write_gaussians(tmp_path / "obj" / "frame_0001.ply", _turned(g, Q))
    R = _rotation([1, 0, 0], 90.0)
    (tmp_path / "run.json").write_text(json.dumps({"frame_dt": 0.1, "engine": "x", "objects": [
        {"name": "obj", "placement": {"R": R.tolist(), "scale": 1.0, "t": [0.0, 0.0, 0.0]}}]}))
    run = load_run(tmp_path)
    eye = np.array([0.5, -3.0, 1.0])
    a = run.splats(0).seen_from(eye).rgb
    b = run.splats(1).seen_from(R @ Q @ R.T @ eye).rgb        # the turn Q in the file is R Q R^T in the world
    np.testing.assert_allclose(b, a, atol=1e-4)               # float32 PLY round trip of the rotations
    assert np.abs(run.splats(1).seen_from(eye).rgb - a).max() > 0.02
