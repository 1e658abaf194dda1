"""Free fall through the whole pipeline (issue 17): a sphere of flat Gaussians 0.5 m above the ground,
one frame of ``gasp simulate`` on each installed engine.

Physics with a known answer: from rest, semi-implicit (symplectic) Euler with ``N`` substeps of ``dt``
drops ``sum_{n=1..N} n g dt^2 = g T^2 / 2 (1 + 1/N)`` in one frame ``T = N dt``. The written frame's
Gaussian means must drop exactly that (within 0.5 %: the float32 engines round at ~1e-5), with ``N``
read from ``run.json``. A one-substep lag (positions reported before the last update, as mujoco_flex did)
gives ``g T^2 / 2 (1 - 1/N)``, a relative error of ``2/N`` (3 % at ``N = 63``); a 5 % bias in ``g`` or
``T`` gives 5 % (10 %): both fail.
"""
from __future__ import annotations

import importlib.util
import json
import math

import numpy as np
import pytest

from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.maps.games import EPS
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene
from gasp_core.testing.helpers import GRAVITY as G
from gasp_core.testing.scenes_passive import fibonacci_sphere

R = 0.05            # sphere radius, m
N_GAUSSIANS = 600
T = 1.0 / 30.0      # frame_dt, s

ENGINES = [(e, m, opts) for e, m, opts in (
    ("warp_mpm", "gasp_warp_mpm", "{}"),
    ("taichi_mpm", "gasp_taichi_mpm", "{ threads = 1 }"),
    ("mujoco_flex", "gasp_mujoco_flex", "{}"),
) if importlib.util.find_spec(m) is not None]


def sphere_of_flat_gaussians(n: int = N_GAUSSIANS, radius: float = R) -> Gaussians:
    """``n`` flat Gaussians tangent to a sphere (Fibonacci points, thin axis along the outward normal),
    each covering its share ``4 pi R^2 / n`` of the surface."""
    normal = fibonacci_sphere(n)
    helper = np.where(np.abs(normal[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    t1 = np.cross(normal, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(normal, t1)
    rot = np.stack([normal, t1, t2], axis=2)                   # columns r1 (normal), r2, r3
    s = 0.5 * math.sqrt(4 * math.pi * radius ** 2 / n)
    scales = np.column_stack([np.full(n, EPS), np.full(n, s), np.full(n, s)])
    return Gaussians(means=radius * normal, scales=scales, rotations=rotmat_to_quat(rot),
                     opacities=np.full(n, 2.0, np.float32), sh_dc=np.full((n, 3), 0.5, np.float32))


@pytest.mark.parametrize("engine,module,options", ENGINES, ids=[e for e, _, _ in ENGINES])
def test_one_frame_of_free_fall_is_the_integrators_exact_drop(tmp_path, engine, module, options):
    ply = tmp_path / "sphere.ply"
    write_gaussians(ply, sphere_of_flat_gaussians())
    scene = tmp_path / "scene.toml"
    scene.write_text(f"""
frame_dt = {T!r}
n_frames = 1

[engine]
name = "{engine}"
options = {options}

[domain]
n_grid = 16

[[boundary]]
kind = "ground"
height = 0.0
friction = 0.5

[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, 0.5]

[object.material]
name = "jelly"
E = 2.0e4
nu = 0.3
rho = 300.0
""")
    out = tmp_path / "out"
    simulate_scene(load_scene(scene), out)
    n = json.loads((out / "run.json").read_text())["engine_stats"]["n_substeps"]
    z0 = read_gaussians(out / "sphere" / "frame_0000.ply").means[:, 2].mean()
    z1 = read_gaussians(out / "sphere" / "frame_0001.ply").means[:, 2].mean()
    exact = 0.5 * G * T ** 2 * (1.0 + 1.0 / n)
    rel = (z0 - z1) / exact - 1.0
    print(f"{engine}: N = {n}, drop {z0 - z1:.6f} m, exact {exact:.6f} m, error {rel:+.4%}")
    assert abs(rel) < 5e-3, (f"{engine}: frame 1 drops {z0 - z1:.6f} m, semi-implicit Euler with N = {n} "
                             f"gives {exact:.6f} m ({rel:+.3%}; a one-substep lag would be {-2 / (n + 1):+.2%})")
