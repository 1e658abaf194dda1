"""examples/donut_on_guitar.toml: the donut comes to rest on the static guitar collider (slow: minutes per engine)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gasp_core.colliders import build_colliders
from gasp_core.io import read_gaussians
from gasp_core.placement import prepare_object
from gasp_core.plugins import engines
from gasp_core.scene import load_scene

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "donut_on_guitar.toml"


def contact_figures(scene_path: Path, outdir: Path) -> dict:
    """Distances (m) of the donut's opaque Gaussians to the guitar collider over the run's frames.

    Returns ``min_distance`` (over all frames and Gaussians; negative = inside), ``rest_min_distance``
    (the same over the last 5 frames), ``lowest_distance``
    (median distance of the lowest 1 % of Gaussians at the last frame), ``last_step`` (largest
    Gaussian displacement over the last frame), ``centroid_range`` (largest range of a centroid coordinate over the last 10 frames), ``dx``, ``n_frames``.
    """
    scene = load_scene(scene_path)
    obj = prepare_object(scene.objects[0])
    dx = float(np.max(np.array(scene.domain.hi) - np.array(scene.domain.lo))) / scene.domain.n_grid
    col = build_colliders(scene, [], dx)[0]
    frames = sorted((outdir / obj.name).glob("frame_*.ply"))
    opaque = 1.0 / (1.0 + np.exp(-obj.gaussians.opacities)) >= 0.5
    worlds = [obj.placement.to_world(read_gaussians(f).means[opaque]) for f in frames]
    d_min = min(float(col.distance(w).min()) for w in worlds)
    last = worlds[-1]
    low = last[:, 2] <= np.quantile(last[:, 2], 0.01)
    rest_min = min(float(col.distance(w).min()) for w in worlds[-5:])
    return {"min_distance": d_min, "rest_min_distance": rest_min, "lowest_distance": float(np.median(col.distance(last[low]))),
            "last_step": float(np.linalg.norm(worlds[-1] - worlds[-2], axis=1).max()),
            "centroid_range": float(np.ptp(np.array([w.mean(axis=0) for w in worlds[-10:]]), axis=0).max()), "dx": dx,
            "n_frames": len(frames) - 1}


#: Measured: MuJoCo collides with the guitar's convex hull, which spans the bridge: the donut rests
#: 4.88 dx above the true surface (never inside: 1.16 dx above at the deepest).
KNOWN = {"mujoco_flex": "rests on the guitar's convex hull: lowest Gaussians 4.88 dx above the surface (limit 1.5 dx)"}


@pytest.mark.slow
@pytest.mark.parametrize("engine", [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=KNOWN[n]))
                                    if n in KNOWN else n for n, e in sorted(engines().items())
                                    if "static_colliders" in e.capabilities.features])
def test_donut_rests_on_guitar(engine, tmp_path):
    from gasp_core.pipeline import simulate_scene
    simulate_scene(load_scene(EXAMPLE), tmp_path / "out", progress=False, engine=engine)
    f = contact_figures(EXAMPLE, tmp_path / "out")
    print(engine, f)
    dx = f["dx"]
    # The guitar's surface is known to half a distance sample (dx / 4) and the grid contact acts on
    # nodes with phi <= 0: at rest no Gaussian is deeper than half a cell (taichi_mpm: 0.27 dx), on
    # impact three quarters (taichi_mpm: 0.50 dx).
    assert f["rest_min_distance"] > -0.5 * dx
    assert f["min_distance"] > -0.75 * dx
    assert 0.0 <= f["lowest_distance"] <= 1.5 * dx  # resting on its surface
    assert f["centroid_range"] < 0.5 * dx           # at rest: no drift, only the soft jelly's rocking
