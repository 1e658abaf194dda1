"""Gravity and support from the scan (issue 54, item 1): the up vector of ``gasp_core/gs/support.py`` follows the
bundled real captures under random rotations (within 3 degrees, or unsure; never confidently wrong), the scene keys
``up = "auto"`` / ``up = [x, y, z]`` turn a file's up to world +z, and ``height = "auto"`` puts the kitchen's ground
on the pan its example measured by hand."""
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gasp_core.cli.main import main
from gasp_core.errors import SceneError
from gasp_core.gs.describe import describe
from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.io import read_gaussians
from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.gs.support import estimate_up, rotation_to_z
from gasp_core.prepare.ground import support_height
from gasp_core.prepare.placement import place, prepare_object
from gasp_core.scene.spec import ObjectSpec, load_scene
from gasp_testing import DONUT, GUITAR, ROOT

DATA = ROOT / "examples" / "data"
KITCHEN = DATA / "spinach_4.splatv"
TRAIN = DATA / "train-1000.ply"
#: Each capture's up as its source states it (file frame); None: not stated (the train slice: a 1000-splat sample
#: of a COLMAP scene), so any sure answer there is unverifiable and counts as a failure.
CAPTURES = {"donut": (DONUT, (0.0, 0.0, 1.0)), "guitar": (GUITAR, (0.0, -1.0, 0.0)),
            "kitchen": (KITCHEN, (0.0, -1.0, 0.0)), "train": (TRAIN, None)}
WITHIN = 3.0          # degrees: a sure answer must be this close
ROTATIONS = Rotation.random(20, random_state=54).as_matrix()


def _load(path: Path):
    if path.suffix == ".splatv":
        return splatv_at(*read_splatv(path), 0.5)
    return read_gaussians(path)


def _turned(g, R):
    return dataclasses.replace(g, means=g.means @ R.T, rotations=rotmat_to_quat(R @ quat_to_rotmat(g.rotations)))


def _angle(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


def _ours(g):
    return estimate_up(g).up


def _largest_variance_axis(g):
    """A broken estimator: the principal axis of largest variance, sure, signed towards the mean's side."""
    x = g.means - g.means.mean(axis=0)
    v = np.linalg.eigh(x.T @ x)[1][:, -1]
    return v * (1 if np.sum(x @ v > 0) >= len(x) / 2 else -1)


def _tilted(u, degrees=5.0):
    """A broken answer: ``u`` tilted by ``degrees`` (a bias the 3-degree check must catch)."""
    if u is None:
        return None
    k = np.cross(u, [1.0, 0, 0] if abs(u[0]) < 0.9 else [0, 1.0, 0])
    return Rotation.from_rotvec(np.radians(degrees) * k / np.linalg.norm(k)).as_matrix() @ u


def judge(answers, truth, rotations) -> tuple[list[str], int]:
    """Failures among ``answers`` (an estimator's unit up, or None for unsure, on the capture turned by each of
    ``rotations``): a sure answer more than :data:`WITHIN` degrees from the turned truth, or any sure answer where
    the truth is unknown; and the count of sure answers."""
    bad, sure = [], 0
    for i, (u, R) in enumerate(zip(answers, rotations)):
        if u is None:
            continue
        sure += 1
        if truth is None:
            bad.append(f"rotation {i}: sure ({np.round(u, 3).tolist()}) where the truth is unknown")
        elif _angle(u, R @ np.asarray(truth)) > WITHIN:
            bad.append(f"rotation {i}: {_angle(u, R @ np.asarray(truth)):.1f} degrees off")
    return bad, sure


def test_the_donut_is_found_under_rotations_and_the_judge_catches_broken_estimators():
    """The donut (Z up) under 3 of the rotations: sure each time, within 3 degrees. The same judge fails an
    estimator returning the largest-variance axis (the donut is wide: 90 degrees off) and ours tilted by 5
    degrees."""
    g, truth, Rs = _load(DONUT), CAPTURES["donut"][1], ROTATIONS[:3]
    turned = [_turned(g, R) for R in Rs]
    ours = [_ours(t) for t in turned]
    bad, sure = judge(ours, truth, Rs)
    assert not bad and sure == 3, bad
    assert len(judge([_largest_variance_axis(t) for t in turned], truth, Rs)[0]) == 3
    assert len(judge([_tilted(u) for u in ours], truth, Rs)[0]) == 3


@pytest.mark.slow
@pytest.mark.parametrize("name", list(CAPTURES))
def test_each_capture_under_20_rotations(name):
    """Each bundled real capture under 20 random rotations (seed 54): within 3 degrees or unsure, never sure and
    wrong. Figures (docs/info.md): the donut sure 20 of 20 (0.6 degrees off); the guitar sure 20 of 20 from its own
    axes (issue 68: unsure 20 of 20 before); the kitchen and the train unsure 20 of 20."""
    path, truth = CAPTURES[name]
    g = _load(path)
    bad, sure = judge([_ours(_turned(g, R)) for R in ROTATIONS], truth, ROTATIONS)
    assert not bad, bad
    assert sure == (20 if name in ("donut", "guitar") else 0)


def test_rotation_to_z_is_the_shortest_proper_turn():
    rng = np.random.default_rng(54)
    for u in [*rng.normal(size=(20, 3)), (0, 0, -1.0), (0, 0, 2.0), (0, -1.0, 0)]:
        R = rotation_to_z(u)
        assert np.allclose(R @ (np.asarray(u) / np.linalg.norm(u)), [0, 0, 1], atol=1e-12)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(R), 1.0)
    with pytest.raises(ValueError, match="no direction"):
        rotation_to_z((0, 0, 0))


def test_up_auto_places_a_turned_donut_upright():
    """``up = "auto"`` on the donut turned by a random rotation: its source's up lands on world +z within 3 degrees;
    ``up = [x, y, z]`` stated as that turned up does the same exactly; rotation composes after it."""
    R0 = ROTATIONS[0]
    g = _turned(_load(DONUT), R0)
    up_file = R0 @ np.array([0.0, 0, 1])
    pl = place(g, ObjectSpec(file=DONUT, up="auto"))
    assert _angle(pl.R @ up_file, [0, 0, 1]) < WITHIN
    pl = place(g, ObjectSpec(file=DONUT, up=tuple(up_file)))
    assert np.allclose(pl.R @ up_file, [0, 0, 1], atol=1e-9)
    pl = place(g, ObjectSpec(file=DONUT, up=tuple(up_file), rotation=(90.0, 0.0, 0.0)))
    assert np.allclose(pl.R @ up_file, [0, -1, 0], atol=1e-9)    # 90 degrees about world x takes +z to -y


def test_up_key_is_read_and_checked(tmp_path):
    def scene(obj: str) -> Path:
        p = tmp_path / "s.toml"
        p.write_text(f'[engine]\nname = "taichi_mpm"\n[[object]]\nfile = "{DONUT}"\n{obj}\n')
        return p
    assert load_scene(scene('up = "auto"')).objects[0].up == "auto"
    assert load_scene(scene("up = [0.1, -1, 0]")).objects[0].up == (0.1, -1.0, 0.0)
    assert load_scene(scene('up_axis = "-y"')).objects[0].up is None
    for bad, match in (('up = "+y"', "up = .*expected \"auto\" or a vector"),
                       ("up = [0, 0, 0]", "expected \"auto\" or a vector"),
                       ('up = [0, 0, 1]\nup_axis = "+z"', "both 'up' and 'up_axis'")):
        with pytest.raises(SceneError, match=match):
            load_scene(scene(bad))


def test_up_auto_refuses_an_unsure_scan():
    with pytest.raises(SceneError, match=r"up = \"auto\" is unsure .*state up = \[x, y, z\]"):
        place(_load(TRAIN), ObjectSpec(file=TRAIN, up="auto"))


def test_kitchen_ground_auto_is_the_pan_measured_by_hand(tmp_path):
    """``height = "auto"``: the support beneath the selected spinach within 1 cm of the ground the example
    measured by hand (the pan's bottom, world z = -0.565 m); measured -0.5692 m."""
    src = (ROOT / "examples" / "kitchen_spinach.toml").read_text()
    hand = -0.565      # the example's [[boundary]] until the ground under a selection became the default (issue 54)
    p = tmp_path / "kitchen.toml"
    p.write_text(src.replace('"data/spinach_4.splatv"', f'"{KITCHEN}"') + '\n[[boundary]]\nkind = "ground"\n'
                 'height = "auto"\n')
    scene = load_scene(p)
    assert scene.boundaries[0].height == "auto"
    h, how = support_height(prepare_object(scene.objects[0]))
    assert abs(h - hand) <= 0.01, (h, hand, how)


def test_gasp_info_json_carries_the_up_vector(capsys):
    d = json.loads(json.dumps(describe(DONUT)))      # what gasp info --json prints first
    assert _angle(d["up_vector"], [0, 0, 1]) < WITHIN and d["up_confidence"] >= 0.5
    assert np.allclose(d["support_plane"]["normal"], d["up_vector"])
    assert main(["info", str(TRAIN)]) == 0
    out = capsys.readouterr().out
    assert "up_vector: unsure" in out and "support_plane: None" in out


@pytest.mark.slow
def test_kitchen_runs_with_its_ground_from_the_scan(tmp_path):
    """End to end: the kitchen example with a ground of ``height = "auto"`` and friction 0.6, 1 frame; run.json records
    the resolved ground. (Since issue 54 the example states no ``[[boundary]]``, its ground the support found on its
    own; round 55 found this test still replacing the old line, so the ground it checked was that default one, friction
    0.5: the stated ground is now added, as the test meant.)"""
    import subprocess
    import sys
    src = (ROOT / "examples" / "kitchen_spinach.toml").read_text()
    assert "\n[[boundary]]" not in src
    ground = '\n[[boundary]]\nkind = "ground"\nheight = "auto"\nfriction = 0.6\n'
    p = tmp_path / "kitchen.toml"
    p.write_text(src.replace('"data/spinach_4.splatv"', f'"{KITCHEN}"').replace("\n[[object]]", ground + "\n[[object]]", 1))
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(p), "-o", str(tmp_path / "out"),
                    "--frames", "1", "-q"], check=True, cwd=ROOT)
    rec = json.loads((tmp_path / "out" / "run.json").read_text())
    (ground,) = [b for b in rec["boundaries"] if b["kind"] == "ground"]
    assert abs(ground["height"] - (-0.565)) <= 0.01 and ground["friction"] == 0.6


def test_cameras_confirm_veto_or_decide(tmp_path):
    """A graphdeco cameras.json beside the file: upright cameras agreeing with the plane keep it; cameras whose
    mean up is 90 degrees away veto it (unsure); on an unsure scan, upright cameras decide alone."""
    from gasp_core.gs.support import camera_up, with_cameras

    def cams(up):       # every camera upright about ``up``: its y axis (down) is -up
        up = np.asarray(up, float)
        side = np.cross(up, [0.3, 0.5, 0.1])
        side /= np.linalg.norm(side)
        R = np.stack([side, -up, np.cross(side, -up)], axis=1)      # columns: camera x, y, z in the world
        p = tmp_path / "cameras.json"
        p.write_text(json.dumps([{"rotation": R.tolist(), "position": [0, 0, 0]}] * 3))
        return camera_up(p)
    e = estimate_up(_load(DONUT))
    assert np.allclose(cams((0, 0, 1)), (0, 0, 1))
    assert with_cameras(e, cams((0, 0, 1))).up is not None
    assert with_cameras(e, cams((1, 0, 0))).up is None
    t = with_cameras(estimate_up(_load(TRAIN)), cams((0, -1, 0)))
    assert np.allclose(t.up, (0, -1, 0)) and t.confidence == pytest.approx(1.0)
    (tmp_path / "cameras.json").write_text("[]")
    with pytest.raises(SceneError, match="no cameras"):
        camera_up(tmp_path / "cameras.json")
