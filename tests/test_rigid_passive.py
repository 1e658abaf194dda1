"""A rigid body's passive points stay on its rigid pose (both MPM engines; found in round 28, fixed in round 29).

A rigid body's points are put on its pose ``c + R X0`` after each G2P; its passive points (a mesh's vertices in mesh
mode, the surface points with ``surface = "passive"``) must be too, or its Gaussians leave the body. On warp_mpm the
passive G2P ran after the substep's rigid launches and moved them by the grid: **12.8 mm off the pose after one
frame** of the cup (taichi_mpm: 1.5e-8 m). Now the pose is applied again after it (``RigidBodies.then_pose``).

Family: the bundled cup (``examples/cup_drop.toml``, mesh mode, rigid route; the engine alone, before any break) and
the bundled wooden donut (``examples/donut_wood.toml``) with ``surface = "passive"``. Checked: the body moved (over a
centimetre, so the fit is over real motion), and every point, passive or not, lies within 1e-6 m of the best rigid
fit of the material points' motion (Kabsch). The catch: the engine without the second pose (warp_mpm).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gasp_core.prepare.scene import prepare_scene
from gasp_core.scene.spec import load_scene
from gasp_core.seam.runner import RunStats, run_engine

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ENGINES = ["taichi_mpm", "warp_mpm"]
TOL = 1e-6   # m: float32 positions of a body a few decimetres across read about 1e-8 m off its fit


def scene(name: str, tmp_path: Path) -> Path:
    text = (EXAMPLES / f"{name}.toml").read_text().replace('"data/', f'"{EXAMPLES}/data/')
    if name == "donut_wood":
        text = text.replace("[[object]]\n", '[[object]]\nsurface = "passive"\n', 1)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def off_pose(engine: str, path: Path, frames: int = 2) -> tuple[float, float, int]:
    """(largest distance of a passive point from the material points' rigid fit (m), the body's largest move (m),
    passive points)."""
    prep = prepare_scene(load_scene(path), engine)
    s = prep.setup
    x0 = np.asarray(s.x, float)
    for rec in run_engine(prep.info, s, frames, RunStats()):
        x = np.asarray(rec.x, float)
    pas = np.asarray(s.passive, bool)
    mat = ~pas
    c0, c1 = x0[mat].mean(0), x[mat].mean(0)
    U, _, Vt = np.linalg.svd((x0[mat] - c0).T @ (x[mat] - c1))
    R = Vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
    res = np.linalg.norm(x - c1 - (x0 - c0) @ R.T, axis=1)
    return float(res[pas].max()), float(np.linalg.norm(x - x0, axis=1).max()), int(pas.sum())


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("name", ["cup_drop", "donut_wood"])
def test_a_rigid_body_s_passive_points_stay_on_its_pose(engine, name, tmp_path):
    pytest.importorskip(f"gasp_{engine}")
    off, moved, n_passive = off_pose(engine, scene(name, tmp_path))
    assert n_passive > 1000 and moved > 0.01
    assert off <= TOL, f"{engine}, {name}: passive points {1000 * off:.3f} mm off the rigid pose"


def test_the_check_catches_the_passive_g2p_after_the_pose(tmp_path, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    from gasp_warp_mpm.rigid import RigidBodies
    monkeypatch.setattr(RigidBodies, "then_pose", lambda self, launch: launch)
    off, _, _ = off_pose("warp_mpm", scene("cup_drop", tmp_path), 1)
    assert off > 1e-3
