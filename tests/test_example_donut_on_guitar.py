"""examples/donut_on_guitar.toml: the donut comes to rest on the static guitar, whose Gaussians never change.

The guitar is a static object of the scene and the collider is made from it (its opaque Gaussians'
occupancy), so both share one placement. Two tiers, same real data (the trained donut and guitar):

- default: the example at ``n_grid = 32`` (dx = 15.6 mm) with the donut's ``core_fraction = 0.1``
  (4,562 core Gaussians simulated, the others follow them; 18,248 points instead of 152,426);
- slow: the example as shipped (``n_grid = 64``, minutes per engine).
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from plyfile import PlyData

from gasp_core.prepare.colliders import build_colliders
from gasp_core.gs.io import read_gaussians
from gasp_core.prepare.placement import prepare_object
from gasp_core.seam.plugins import engines
from gasp_core.scene.spec import load_scene

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "donut_on_guitar.toml"
#: The reduced run: the example's domain at half its resolution, a tenth of the donut simulated.
REDUCED_N_GRID, REDUCED_CORE_FRACTION = 32, 0.1


def contact_figures(scene, outdir: Path) -> dict:
    """Distances (m) of the donut's opaque Gaussians to the guitar collider over the run's frames.

    Returns ``min_distance`` (over all frames and Gaussians; negative = inside), ``rest_min_distance``
    (the same over the last 5 frames), ``lowest_distance`` (median distance of the lowest 1 % of
    Gaussians at the last frame), ``last_step`` (largest Gaussian displacement over the last frame),
    ``centroid_range`` (largest range of a centroid coordinate over the last 10 frames), ``dx``,
    ``n_frames``, and ``run_json`` (run.json's ``colliders``).
    """
    objects = [prepare_object(o) for o in scene.objects]
    donut = next(o for o in objects if not o.spec.static)
    run = json.loads((outdir / "run.json").read_text())
    dx = run["domain"]["dx"]
    col = build_colliders(scene, objects, dx)[0]
    frames = sorted((outdir / donut.name).glob("frame_*.ply"))
    opaque = 1.0 / (1.0 + np.exp(-donut.gaussians.opacities)) >= 0.5
    worlds = [donut.placement.to_world(read_gaussians(f).means[opaque]) for f in frames]
    d_min = min(float(col.distance(w).min()) for w in worlds)
    last = worlds[-1]
    low = last[:, 2] <= np.quantile(last[:, 2], 0.01)
    rest_min = min(float(col.distance(w).min()) for w in worlds[-5:])
    return {"min_distance": d_min, "rest_min_distance": rest_min,
            "lowest_distance": float(np.median(col.distance(last[low]))),
            "last_step": float(np.linalg.norm(worlds[-1] - worlds[-2], axis=1).max()),
            "centroid_range": float(np.ptp(np.array([w.mean(axis=0) for w in worlds[-10:]]), axis=0).max()),
            "dx": dx, "n_frames": len(frames) - 1, "run_json": run["colliders"]}


def check_guitar_unchanged(scene, outdir: Path) -> int:
    """Every frame of the static guitar is frame 0 byte for byte, and frame 0 holds the input's Gaussians.

    Returns the number of frames compared.
    """
    guitar = next(o for o in scene.objects if o.static)
    frames = sorted((outdir / guitar.file.name.removesuffix(".ply")).glob("frame_*.ply"))
    first = PlyData.read(str(frames[0]))["vertex"].data
    for f in frames[1:]:
        assert PlyData.read(str(f))["vertex"].data.tobytes() == first.tobytes(), f.name
    # frame 0 is the input: the compressed file's decoded values as float32 (scales are stored as
    # their logarithm, so they come back within float32 rounding)
    src, out = read_gaussians(guitar.file), read_gaussians(frames[0])
    assert src.n == out.n
    for k in ("means", "opacities"):
        assert np.array_equal(getattr(src, k).astype(np.float32), getattr(out, k).astype(np.float32)), k
    assert np.allclose(src.scales, out.scales, rtol=1e-6, atol=0.0)
    return len(frames)


def _engines_with_colliders(known: dict[str, str], run_known: bool = True) -> list:
    """Engines with the ``static_colliders`` feature; a known failure as a strict xfail, or left out."""
    return [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=known[n])) if n in known else n
            for n, e in sorted(engines().items()) if "static_colliders" in e.capabilities.features
            and (run_known or n not in known)]


def _assert_rests(f: dict) -> None:
    dx = f["dx"]
    # The guitar's surface is known to half a distance sample (dx / 4) and the grid contact acts on
    # nodes with phi <= 0: at rest no Gaussian is deeper than half a cell, on impact three quarters.
    assert f["rest_min_distance"] > -0.5 * dx
    assert f["min_distance"] > -0.75 * dx
    assert 0.0 <= f["lowest_distance"] <= 1.5 * dx  # resting on its surface (the limit)
    assert f["centroid_range"] < 0.5 * dx           # at rest: no drift, only the soft jelly's rocking
    (col,) = f["run_json"]
    assert col["source"] == "object:guitar.compressed" and col["motion"] is None and col["friction"] == 0.6
    assert col["n_contact_last"] > 0                # run.json sees the donut touching the guitar
    # run.json's depth counts every simulated point (triangle vertices and fill, not only the means):
    # within the cell over which grid engines resolve a contact (docs/colliders.md)
    assert 0.0 <= col["max_depth_dx"] < 1.0


#: Measured: MuJoCo collides with the guitar's convex hull, which spans the bridge: the donut rests
#: about 37 mm above the true surface, 4.88 dx in the full run (never inside: 1.16 dx above at the
#: deepest) and 2.36 dx in the reduced one. The reduced tier leaves it out (84 s for a known failure).
KNOWN = {"mujoco_flex": "rests on the guitar's convex hull: lowest Gaussians 4.88 dx above the surface (limit 1.5 dx)"}


def _run(engine: str, tmp_path: Path, reduced: bool):
    from gasp_core.run.pipeline import simulate_scene
    scene = load_scene(EXAMPLE)
    if reduced:
        objects = [o if o.static else dataclasses.replace(o, core_fraction=REDUCED_CORE_FRACTION)
                   for o in scene.objects]
        # the box 2 cm deeper: at n_grid 32 the floor (0.15 m) would lie 1.9 cells above lo z, where the particle
        # contact's ground layers (2 cells below the plane) leave the grid (refused since issue 38)
        lo = (*scene.domain.lo[:2], scene.domain.lo[2] - 0.02)
        scene = dataclasses.replace(scene, objects=objects,
                                    domain=dataclasses.replace(scene.domain, n_grid=REDUCED_N_GRID, lo=lo))
    simulate_scene(scene, tmp_path / "out", quiet=True, engine=engine)
    return scene


def _check_rests(engine: str, tmp_path: Path, reduced: bool) -> None:
    scene = _run(engine, tmp_path, reduced)
    assert check_guitar_unchanged(scene, tmp_path / "out") == scene.n_frames + 1
    f = contact_figures(scene, tmp_path / "out")
    print(engine, f)
    _assert_rests(f)


@pytest.mark.parametrize("engine", _engines_with_colliders(KNOWN, run_known=False))
def test_donut_rests_on_guitar_reduced(engine, tmp_path):
    _check_rests(engine, tmp_path, True)


@pytest.mark.slow
@pytest.mark.parametrize("engine", _engines_with_colliders(KNOWN))
def test_donut_rests_on_guitar(engine, tmp_path):
    _check_rests(engine, tmp_path, False)
