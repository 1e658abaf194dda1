"""The donut shatter example (``examples/donut_shatter.toml``, issue 52, docs/fracture.md) on both MPM engines.

The README donut as a brittle biscuit landing at the speed of a 1 m drop breaks into pieces and the run finishes
with every frame finite. Measured (2026-11-26, issue 66: pieces are the parts come apart by a grid cell, crumbs under
0.1 % of the mass apart): 8 pieces at frame 6 on both engines, 4 of them of 5 % or more, and 414-415 crumbs (by the
damage alone before: 15 (taichi_mpm) and 17 (warp_mpm); with the band ``dx`` before that, 6 and 7; docs/fracture.md). Before the passive G2P's fit was scaled per unit weight
(``tests/test_passive_crack.py``) taichi_mpm stopped at frame 5 with a passive surface point non-finite, so this
check failed there (run by hand; at the example's first parameters, E 200 kPa and f_t 12 kPa, both engines stopped
at frame 3). No Gaussian's largest scale grows past alpha (1.5) times its rest value at any frame; with the rule
effectively off (alpha = 100, run by hand) the largest grew 12.7x at frame 1 and reached the cap 100x at frame 3.
Slow tier (about 20 s on taichi_mpm, 35 s on warp_mpm).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from gasp_core.gs.io import read_gaussians
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene
from gasp_testing import needs_package

SCENE = Path(__file__).resolve().parents[1] / "examples" / "donut_shatter.toml"
N_FRAMES = 6
#: A piece counts when it holds at least this share of the donut's mass (the crumbs of one or a few points do not).
BIG = 0.05


#: Since the fill gives the cells at the faces their shares (issue 66 item 3, the default from 2026-11-26) the biscuit
#: is 10 % lighter (0.548 kg) and does not come apart within 6 frames on either engine: 1 piece and no crumb at every
#: frame 0-6 (warp_mpm and taichi_mpm), 3 pieces and 46 crumbs at frame 10 (taichi_mpm); before, 4 pieces at frame 3
#: and 8 at frame 6. Cause measured (``benchmarks/studies/donut_shatter_fill.py``, docs/fracture.md): not the brittle
#: model, the crack band or the shares' light volumes, but the whole-cell fill's flat base, a layer of 468 whole cells
#: at one height (108 of them under the Gaussians' surface) the tube landed on: undamaged, 84 % of its volume passed
#: f_t in the landing against 34 % on the shares' curved underside (rebound 3.34 against 4.05 m/s). The shatter came
#: from a shape the capture does not show; no physics fix restores it. A strict xfail until the example is re-posed.
SHARES_NO_SHATTER = pytest.mark.xfail(strict=True, reason="with the fill's shares the biscuit stays one piece for 6 "
                                      "frames on both engines (1 piece at frames 0-6; 3 at frame 10)")


@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@SHARES_NO_SHATTER
def test_the_donut_shatters_into_three_or_more_pieces_and_stays_finite(engine, tmp_path):
    needs_package(f"gasp_{engine}")
    res = simulate_scene(load_scene(SCENE), tmp_path / "out", n_frames=N_FRAMES, engine=engine, quiet=True)
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert "diverged" not in run and len(run["frames"]) == N_FRAMES + 1, run.get("diverged")
    total = run["frames"][0]["piece_mass"][0]
    last = run["frames"][-1]
    # mass is shared out, none lost: the pieces' and the crumbs' (issue 66)
    assert sum(last["piece_mass"]) + last["debris_mass"] == pytest.approx(total, rel=1e-9)
    big = [m for m in last["piece_mass"] if m >= BIG * total]
    assert len(big) >= 3, last["piece_mass"][:6]
    assert run["frames"][1]["pieces"] < last["pieces"]                          # it broke on landing, not at rest
    alpha = run["objects"][0]["alpha"]
    for o in res.summary["objects"]:
        files = sorted((tmp_path / "out" / o["name"]).glob("frame_*.ply"))
        rest = read_gaussians(files[0]).scales.max(axis=1)
        for f in files:
            g = read_gaussians(f)
            assert np.isfinite(g.means).all() and np.isfinite(g.scales).all(), f.name
            # the control rule (paper Eq. alpha_rule): no Gaussian's largest scale past alpha times its rest value
            grown = g.scales.max(axis=1) / rest
            assert grown.max() <= alpha * (1 + 1e-5), (f.name, float(grown.max()))


def test_the_donut_shatters_on_the_guitar(tmp_path):
    """``examples/donut_shatter_on_guitar.toml`` (the biscuit thrown onto the static guitar's collider), taichi_mpm,
    6 frames: every frame finite, crumbs come off it and the count never falls (measured: 1 piece at every frame,
    0, 0, 0, 0, 4, 6, 6 crumbs; the frames-only count also 1: it cracks but nothing has moved a grid cell off), the
    mass shared out, the guitar's Gaussians written unchanged, the control rule holding on the donut."""
    needs_package("gasp_taichi_mpm")
    scene = SCENE.with_name("donut_shatter_on_guitar.toml")
    simulate_scene(load_scene(scene), tmp_path / "out", n_frames=N_FRAMES, quiet=True)
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert "diverged" not in run and len(run["frames"]) == N_FRAMES + 1, run.get("diverged")
    total, last = run["frames"][0]["piece_mass"][0], run["frames"][-1]
    # it cracks but does not come apart by a grid cell (issue 66: pieces are what has come apart; 3 pieces of 5 % by
    # the damage alone before): 1 piece with crumbs off it, as the frames alone count it (1 at every frame)
    assert last["pieces"] >= 1 and last["debris"] >= 1, (last["pieces"], last["debris"])
    counts = [r["pieces"] + r["debris"] for r in run["frames"]]
    assert all(b >= a for a, b in zip(counts, counts[1:])), counts
    assert all(sum(r["piece_mass"]) + r["debris_mass"] == pytest.approx(total, rel=1e-9) for r in run["frames"])
    guitar, donut = run["objects"]
    g_files = sorted((tmp_path / "out" / guitar["name"]).glob("frame_*.ply"))
    assert np.array_equal(read_gaussians(g_files[0]).means, read_gaussians(g_files[-1]).means)
    files = sorted((tmp_path / "out" / donut["name"]).glob("frame_*.ply"))
    rest = read_gaussians(files[0]).scales.max(axis=1)
    for f in files:
        g = read_gaussians(f)
        assert np.isfinite(g.means).all(), f.name
        assert (g.scales.max(axis=1) / rest).max() <= donut["alpha"] * (1 + 1e-5), f.name
