"""Issue 67's must-show, as the issue words it: "A sand column against a jelly ball: no sand Gaussian more than 0.25 dx
below the ball's surface, measured along the ball's Gaussians' normals at the last frame" (round 73,
docs/contact.md "Round 73").

The figure (``gasp_core.testing.sand_ball.normal_depth_dx``): at the last frame, for each sand Gaussian within 2 dx
of the ball's surface, its depth ``(s - p) . n`` below the nearest ball Gaussian ``s``, ``n`` that Gaussian's outward
unit normal read from its rotation at that frame (its thin axis); the largest, in dx of the run. Positive: inside the
ball; negative: the nearest sand stands off.

- Default tier (seconds): the figure on hand-made Gaussians on a sphere, sand placed at known depths along the
  normals (each read back to 1e-9 dx, both signs), normals given inward turned outward, sand out of the band ignored.
- Slow tier: the user's path (``benchmarks/sand_ball_pipeline.py``: flat Gaussians written to PLY, run through
  ``gasp simulate``, 60 frames, 10 mm spacing) over :data:`FAMILY` (engines, n_grid, the ball's radius). Two-sided:
  ``-REACH_TOL <= figure <= DEPTH_TOL`` (no sand more than 0.25 dx inside; the nearest sand within 1 dx of the
  surface, so an engine holding the sand a cell off fails). Round 73 measured the misses (warp_mpm +0.376 at n_grid
  32, +0.395 at 36, +0.552 / +0.375 with a 35 mm ball; taichi_mpm +0.375 / +0.418): the sand's fill was held a
  quarter cell off the ball while its Gaussians, half a fill spacing further out, went in. Round 75's touch at the
  flowing body's surface (``gasp_core.mpm.flow_reach.FLOW_REACH``, docs/contact.md "Round 75") meets every row
  (:data:`MISSES` empty). The catch: the rule before (``FLOW_REACH`` off) fails the issue's scene on both engines
  (:func:`test_the_check_fails_with_the_touch_at_the_points`, run in process so the switch reaches the engine);
  the check on placed sand shows both sides failing (:func:`test_the_check_fails_on_sand_placed_past_either_limit`).
- Not a catch: the same scene with ``contact_fields = false`` (one velocity field, the no-slip before issue 53) PASSES
  this check (warp_mpm n_grid 36: -0.349 dx, n_grid 48: -0.461: the sand stuck to the ball's face stands off it); it
  fails the pile and steep checks instead (pile 1.93 times the free pile's height, 5.1 % steep;
  ``tests/test_contact_fields.py::test_the_checks_fail_with_one_field``).
"""
from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from gasp_testing import ROOT
from gasp_core.seam.plugins import engines
from gasp_core.testing.sand_ball import gaussian_normals, normal_depth_dx
from gasp_core.testing.scenes_passive import fibonacci_sphere

sys.path.insert(0, str(ROOT / "benchmarks"))
import sand_ball_pipeline as B  # noqa: E402

#: The issue's limit: no sand Gaussian deeper than this below the ball's surface (dx).
DEPTH_TOL = 0.25
#: The other side: the nearest sand within this of the surface (dx; the figure at least ``-REACH_TOL``).
REACH_TOL = 1.0
FRAMES, SPACING = 60, 0.01

#: Rows that miss: a strict xfail with the measured figure as the reason. Round 73's four (warp_mpm n_grid 32, the
#: 35 mm ball at 36 and 48, taichi_mpm 32: +0.376, +0.552, +0.375, +0.375 dx) met since round 75 (docs/contact.md).
MISSES: dict[tuple[str, int, float], str] = {}


def _row(engine: str, n_grid: int, r: float):
    marks = [pytest.mark.slow]
    if (engine, n_grid, r) in MISSES:
        marks.append(pytest.mark.xfail(strict=True, reason=MISSES[(engine, n_grid, r)]))
    return pytest.param(engine, n_grid, r, marks=marks, id=f"{engine}-n{n_grid}-r{1e3 * r:g}mm")


#: The family; the issue's own grid (n_grid 36, the 5 cm ball, both engines) is :func:`test_the_issues_scene`.
FAMILY = [_row("warp_mpm", n, B.R) for n in (32, 48, 64)] + [_row("warp_mpm", n, 0.035) for n in (36, 48)] \
    + [_row("taichi_mpm", 32, B.R)]


def _sphere(n: int = 600, r: float = 0.05):
    d = fibonacci_sphere(n)
    c = np.array([0.1, 0.0, r])
    # rotations whose first column is the normal, half of them pointing inward (the figure turns them out)
    e = np.cross(d, [0.3, 0.5, 0.8])
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    sign = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)[:, None]
    rot = np.stack([sign * d, e, np.cross(sign * d, e)], axis=2)
    scales = np.tile([1e-8, 0.006, 0.006], (n, 1))
    return c + r * d, rot, scales, d


def test_the_figure_reads_known_depths_along_the_normals():
    surf, rot, scales, d = _sphere()
    n = gaussian_normals(rot, scales, surf)
    assert np.allclose(n, d, atol=1e-12)
    dx = 0.01
    for depth in (0.3, 0.1, -0.4, -1.5):
        sand = np.concatenate([surf[[7, 300]] - (depth * dx) * d[[7, 300]],           # at the depth
                               surf[[9, 400]] - (depth - 0.2) * dx * d[[9, 400]],    # shallower
                               [[5.0, 5.0, 5.0]]])                                  # far off: ignored
        assert normal_depth_dx(sand, surf, n, dx) == pytest.approx(depth, abs=1e-9)
    assert normal_depth_dx(np.array([[5.0, 5.0, 5.0]]), surf, n, dx) == -math.inf
    with pytest.raises(ValueError):
        normal_depth_dx(surf, surf[:0], n[:0], dx)


def _pair(engine: str, n_grid: int, r: float, tmp_path, options: dict | None = None) -> dict:
    """The pair run (no free pile: the figure needs none) through ``gasp simulate``; its :func:`B.normal_depth`."""
    if engine not in engines() or engines()[engine].unavailable_reason() is not None:
        pytest.skip(f"{engine} not available")
    path = B.scene(tmp_path, SPACING, engine, FRAMES, True, n_grid, r, options)
    out = tmp_path / "out"
    _, err = B.simulate(path, out)
    assert err is None, err
    f = B.normal_depth(out)
    assert f["frames"] == FRAMES, f
    return f


def _fails(f: dict) -> str | None:
    d = f["normal_depth_dx"]
    if d > DEPTH_TOL:
        return f"sand {d:.3f} dx below the ball's surface (limit {DEPTH_TOL})"
    if d < -REACH_TOL:
        return f"the nearest sand {-d:.3f} dx off the ball's surface (limit {REACH_TOL})"
    return None


@pytest.mark.parametrize("engine,n_grid,r", FAMILY)
def test_no_sand_below_the_balls_surface_along_its_normals(engine, n_grid, r, tmp_path):
    f = _pair(engine, n_grid, r, tmp_path)
    assert _fails(f) is None, (_fails(f), f)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_issues_scene(engine, tmp_path):
    """The must-show's scene at the issue's n_grid 36 (docs/must_shows.md names this test). Round 73: +0.395 dx
    (warp_mpm) and +0.418 (taichi_mpm); round 75: -0.010 and +0.022."""
    f = _pair(engine, 36, B.R, tmp_path)
    assert _fails(f) is None, (_fails(f), f)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_check_fails_with_the_touch_at_the_points(engine, tmp_path, monkeypatch):
    """The catch of round 75's rule: the issue's scene with the flowing body's touch at its points' centres
    (``gasp_core.mpm.flow_reach.FLOW_REACH`` off, the rule of rounds 37-74) fails the depth check (round 73: +0.395 dx on
    warp_mpm, +0.418 on taichi_mpm). ``gasp simulate`` in this process (``gasp_core.cli.main.main``), so the switch
    reaches the engine."""
    from gasp_core.cli.main import main
    from gasp_core.mpm import flow_reach as F
    if engine not in engines() or engines()[engine].unavailable_reason() is not None:
        pytest.skip(f"{engine} not available")
    monkeypatch.setattr(F, "FLOW_REACH", False)
    path = B.scene(tmp_path, SPACING, engine, FRAMES, True, 36, B.R)
    out = tmp_path / "out"
    assert main(["simulate", str(path), "-o", str(out), "-q"]) == 0
    f = B.normal_depth(out)
    assert f["frames"] == FRAMES, f
    assert _fails(f) is not None and f["normal_depth_dx"] > DEPTH_TOL, f


def test_the_check_fails_on_sand_placed_past_either_limit():
    """The two-sided check on the figure: sand 0.2625 dx inside the surface (5 % past the limit) fails, 0.24 passes;
    the nearest sand 1.05 dx off (5 % past the reach limit) fails, 0.95 passes."""
    surf, rot, scales, d = _sphere()
    n = gaussian_normals(rot, scales, surf)
    dx = 0.01
    for depth, ok in ((0.2625, False), (0.24, True), (-1.05, False), (-0.95, True)):
        sand = surf[[11, 250]] - (depth * dx) * d[[11, 250]]
        f = {"normal_depth_dx": normal_depth_dx(sand, surf, n, dx)}
        assert (_fails(f) is None) == ok, (depth, f)
