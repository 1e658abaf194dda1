"""The donut shatter example (``examples/donut_shatter.toml``, issue 52, docs/fracture.md) on both MPM engines.

The README donut as a brittle biscuit landing at the speed of a 1 m drop breaks into pieces and the run finishes
with every frame finite. Measured (2026-11-25, the crack band ``dx + p_vol^(1/3)``): 15 (taichi_mpm) and 17
(warp_mpm) pieces at frame 6 (with the band ``dx`` before: 6 and 7, the five largest 0.163, 0.149, 0.125, 0.111 and
0.054 kg of 0.608 kg on both; docs/fracture.md). Before the passive G2P's fit was scaled per unit weight
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


@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
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
    6 frames: every frame finite, at least 3 pieces of 5 % of the mass or more (measured 0.379, 0.185 and 0.044 of
    0.612 kg at frame 6), the guitar's Gaussians written unchanged, the control rule holding on the donut."""
    needs_package("gasp_taichi_mpm")
    scene = SCENE.with_name("donut_shatter_on_guitar.toml")
    simulate_scene(load_scene(scene), tmp_path / "out", n_frames=N_FRAMES, quiet=True)
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    assert "diverged" not in run and len(run["frames"]) == N_FRAMES + 1, run.get("diverged")
    total, last = run["frames"][0]["piece_mass"][0], run["frames"][-1]
    assert len([m for m in last["piece_mass"] if m >= BIG * total]) >= 3, last["piece_mass"][:6]
    guitar, donut = run["objects"]
    g_files = sorted((tmp_path / "out" / guitar["name"]).glob("frame_*.ply"))
    assert np.array_equal(read_gaussians(g_files[0]).means, read_gaussians(g_files[-1]).means)
    files = sorted((tmp_path / "out" / donut["name"]).glob("frame_*.ply"))
    rest = read_gaussians(files[0]).scales.max(axis=1)
    for f in files:
        g = read_gaussians(f)
        assert np.isfinite(g.means).all(), f.name
        assert (g.scales.max(axis=1) / rest).max() <= donut["alpha"] * (1 + 1e-5), f.name
