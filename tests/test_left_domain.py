"""Issue 66 item 6: points that leave the domain drop out where they are and are counted (run.json ``left_domain``),
not a reason to stop the run (feature ``left_domain``; docs/mpm.md "Points that leave the domain").

A jelly block flies at ``vx`` through a domain without walls or gravity: a free body keeps its velocity, so a point
leaves the grid (its stencil's base past ``n_grid - 3``) in the frame its rest ``x + vx t`` passes
``lo + (n_grid - 1.5) dx``. The count after every frame is that closed form (frames where a lattice layer lies
within a quarter spacing of the line are skipped: a layer's crossing there is a matter of rounding), the points that
left stay where they left, and the others fly on at ``vx``. Before, the first point out stopped the run
(``CAUSE_LEFT_DOMAIN``): a broken engine that does so, and a count by the domain box instead of the grid, are caught.
Over two grids, two speeds and both MPM engines.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.errors import EngineDivergence
from gasp_core.seam.setup import Material
from gasp_core.seam import runner
from gasp_core.seam.runner import RunStats, run_engine
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.kit import resolve_engine

ENGINES = ("taichi_mpm", "warp_mpm")
FRAMES, FPS = 12, 30.0
CASES = [(16, 1.5), (24, 2.5)]       # (n_grid, vx m/s)


def _flight(engine: str, n_grid: int, vx: float):
    """The block's setup, its frames' positions (FRAMES + 1, n, 3) and each frame's ``left_domain`` count."""
    info = resolve_engine(engine)
    dx = 1.0 / n_grid
    spacing = 0.5 * dx
    x, p_vol = box_points([0.45, 0.4, 0.4], [0.65, 0.6, 0.6], spacing)
    setup = make_setup(x, p_vol, Material(name="jelly", E=2e4, nu=0.3, rho=300.0), v=np.array([vx, 0.0, 0.0]),
                       gravity=(0.0, 0.0, 0.0), n_grid=n_grid, frame_dt=1.0 / FPS, options={"threads": 1})
    stats, xs, counts = RunStats(), [x.copy()], []
    for rec in run_engine(info, setup, FRAMES, stats):
        xs.append(rec.x)
        counts.append(stats.left_domain)
    return setup, np.stack(xs), counts, spacing


def problems(engine: str, n_grid: int, vx: float) -> list[str]:
    """What is wrong with the flight (empty: nothing), as lines with the figures."""
    try:
        setup, xs, counts, spacing = _flight(engine, n_grid, vx)
    except EngineDivergence as e:
        return [f"the run stopped: {e}"]
    out = []
    line = setup.domain_lo[0] + (n_grid - 1.5) * setup.dx
    layers = np.unique(np.round(setup.x[:, 0], 9))
    gone_at = np.full(len(setup.x), FRAMES + 1)
    for k in range(1, FRAMES + 1):
        reach = setup.x[:, 0] + vx * k / FPS
        if np.min(np.abs(layers + vx * k / FPS - line)) < 0.25 * spacing:
            continue
        want = int((reach >= line).sum())
        if counts[k - 1] != want:
            out.append(f"frame {k}: left_domain {counts[k - 1]}, the closed form {want}")
        gone_at[(reach >= line) & (gone_at > k)] = k
    stays = gone_at <= FRAMES - 2
    if stays.any() and np.abs(xs[-1][stays] - xs[gone_at[stays] + 1, stays]).max() > 0:
        out.append("points that left moved on")
    flying = gone_at > FRAMES
    dx_run = xs[-1][flying, 0] - setup.x[flying, 0]
    if flying.any() and np.abs(dx_run / (vx * FRAMES / FPS) - 1).max() > 0.02:
        out.append(f"the points in the grid flew {dx_run.min():.4f}-{dx_run.max():.4f} m, "
                   f"expected {vx * FRAMES / FPS:.4f}")
    if max(counts) == 0:
        out.append("no point left (the case tests nothing)")
    return out


@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("n_grid, vx", CASES)
def test_points_that_leave_drop_out_and_are_counted(engine, n_grid, vx):
    assert problems(engine, n_grid, vx) == []


def test_the_check_catches_a_run_that_stops_and_a_count_by_the_box(monkeypatch):
    """The old rule (the first point out stops the run) and a count of the points beyond the domain's box (which
    the grid's stencil leaves a cell and a half earlier) both fail the check."""
    from gasp_taichi_mpm.engine import TaichiMPMEngine
    with monkeypatch.context() as m:
        m.setattr(TaichiMPMEngine, "_fast", lambda self, v: True)
        assert any("stopped" in p for p in problems("taichi_mpm", *CASES[0]))
    with monkeypatch.context() as m:
        m.setattr(runner, "left_grid", lambda x, s: ((x < s.domain_lo) | (x > s.domain_hi)).any(axis=1))
        assert any("left_domain" in p for p in problems("taichi_mpm", *CASES[0]))


def test_gasp_simulate_records_left_domain_and_warns_once(tmp_path, capsys, write_scene, donut_small):
    """The real donut (every 16th Gaussian) falls with no ground out of the bottom of its domain: the run writes every
    frame (exit 0), run.json's per-frame ``left_domain`` never decreases and ends above 0, and one warning says so."""
    import json

    from gasp_core.cli.main import main
    from gasp_testing import scene_text
    out = tmp_path / "out"
    code = main(["simulate", str(write_scene(scene_text(donut_small, ground=False, n_frames=12, n_grid=16))),
                 "-o", str(out), "-q"])
    err = capsys.readouterr().err
    assert code == 0, err
    left = [row["left_domain"] for row in json.loads((out / "run.json").read_text())["frames"][1:]]
    assert len(left) == 12 and left[-1] > 0 and all(b >= a for a, b in zip(left, left[1:])), left
    assert err.count("left the domain") == 1, err
