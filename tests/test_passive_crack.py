"""A passive surface point at a crack (issue 52): the one node with mass in its stencil is a far corner.

When a brittle body breaks, the material moves away from some of its surface points, and a passive point can be left
with a single node with mass in its 3x3x3 stencil, at a far corner where each axis's quadratic B-spline weight is
``0.5 (fx - 0.5)^2``. With ``fx = 0.51`` the node's weight is ``(0.5 * 0.01^2)^3 = 1.25e-13``. The passive G2P's
least-squares fit of ``C`` inverted the moment matrix ``S_rr`` unscaled, whose ridge is ``2.5e-5 wsum``: its
determinant, ``(3e-18)^3``, underflows f32, and the point's ``C`` and then its position went non-finite. This is
what stopped the brittle README donut at frame 3 on both MPM engines (docs/fracture.md). The fit is now made on the
moments per unit weight (divided by ``wsum``), which gives the same ``C`` wherever the old one was finite.

Known answer: one material point moving at ``V0`` with no stress and no gravity carries ``V0`` to every node of
its stencil (APIC with ``C = 0``), so a passive point that shares one node with it moves at ``V0``, and its ``C``
(the fit over a single node) is 0. Shown failing before the fix: both engines stopped with a non-finite position
or velocity in the first frame (run by hand with the two ``transfers.py`` of this commit reverted).
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Material, SimSetup

N_GRID = 16
DX = 1.0 / N_GRID
V0 = np.array([0.3, -0.2, 0.1])            # m/s
FRAME_DT = 1.0 / 300.0                     # s: the material moves 0.016 dx in a frame, so the shared node stays


def _mpm_engines():
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in ("taichi_mpm", "warp_mpm")]


def corner_setup(material: Material) -> SimSetup:
    """Two passive points at cell coordinates 5.51 and 5.545 on each axis (stencil nodes 5-7; node 7's weight
    1.25e-13 and 1.04e-9) and one material point at 8.0 (nodes 7-9): node 7 is the only node the stencils share.
    The two weights put the unscaled determinant at 0 in f32 (2e-52) and at a subnormal (1.8e-41), whose inverse
    overflows: one or the other broke each engine's ``inverse``."""
    x = np.array([[5.51, 5.51, 5.51], [5.545, 5.545, 5.545], [8.0, 8.0, 8.0]]) * DX
    return SimSetup(x=x, v=np.broadcast_to(V0, (3, 3)).copy(), p_vol=np.array([0.0, 0.0, (DX / 2) ** 3]), body_id=0,
                    materials=[material], gravity=np.zeros(3), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=N_GRID, frame_dt=FRAME_DT, n_render=2, passive=np.array([True, True, False]),
                    options={"threads": 1, "passive_every": 1})


MATERIALS = {"jelly": Material("jelly", E=1e5, nu=0.3, rho=500.0),
             "brittle": Material("brittle", E=2e5, nu=0.25, rho=300.0, tensile_strength=1e4, fracture_energy=50.0)}


def corner_run(name: str, kind: str) -> dict:
    """Three frames of :func:`corner_setup` on engine ``name``: the points' displacement (m) and velocity (m/s)."""
    s = corner_setup(MATERIALS[kind])
    e = build_engine(engines()[name], s)
    try:
        x0 = e.positions().astype(np.float64)
        for _ in range(3):
            e.step_frame()
        return {"moved": (e.positions() - x0).tolist(), "v": e.velocities().tolist()}
    finally:
        e.close()


@pytest.mark.parametrize("name", _mpm_engines())
def test_a_passive_point_seeing_one_far_corner_node_moves_with_it(name):
    """In a fresh process: once a taichi_mpm engine has run in a process, subnormal floats are flushed to zero
    there, the determinant is then exactly 0 and Warp's ``inverse`` returns a zero matrix, which hid warp_mpm's
    failure when this ran after the taichi_mpm case."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import test_passive_crack as t; "
            "print(json.dumps({k: t.corner_run(sys.argv[2], k) for k in t.MATERIALS}))")
    env = dict(os.environ, OMP_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", code, str(Path(__file__).parent), name], capture_output=True,
                         text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    runs = json.loads(out.stdout.strip().splitlines()[-1])
    want = V0 * 3 * FRAME_DT
    for kind, r in runs.items():
        moved, v = np.asarray(r["moved"]), np.asarray(r["v"])
        assert np.isfinite(moved).all() and np.isfinite(v).all(), kind
        # all three points translate by V0 t: within 1e-3 of the displacement and of V0 each way
        np.testing.assert_allclose(moved, np.broadcast_to(want, (3, 3)), rtol=0, atol=1e-3 * np.abs(want).max())
        np.testing.assert_allclose(v, np.broadcast_to(V0, (3, 3)), rtol=0, atol=1e-3 * np.abs(V0).max())
