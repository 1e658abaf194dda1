"""Conformance scene of passive surface points on a spinning body (``SimSetup.passive``).

- ``passive_spin``: an elastic sphere of radius ``SPIN_R = 3.6 dx`` spins at ``OMEGA = pi`` rad/s
  about z (no gravity) for one full turn (2 s), with passive points on its surface. A massless point
  on a rigidly turning body keeps its distance to the axis, so the passive points' mean distance to
  the centre stays ``SPIN_R``; within ``PASSIVE_SPIN_TOL`` (0.06 %). Engines with the option
  ``passive_every`` run with ``PASSIVE_EVERY = 4`` (the README's setting): a passive point moved in
  a straight line between gathers drifts outward, by ``exp(pi omega (m - 1) dt) - 1`` a turn
  (measured 5.7 % at m = 4 and 14 % at m = 8 before the affine advance of
  :func:`gasp_core.mpm.substeps.passive_schedule`). The sphere's own centrifugal stretch,
  ``~rho omega^2 R^2 / E``, is 0.04 % here.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check
from gasp_core.testing.kit import Requires, Scene, Trace

N_GRID = 16
DX = 1.0 / N_GRID
SPIN_R = 3.6 * DX
OMEGA = math.pi                 # rad/s about z
N_SURFACE = 300                 # passive points (Fibonacci sphere)
PASSIVE_EVERY = 4
#: Relative tolerance on the passive points' mean radius over one turn. Measured: 0.0146 % on the MPM engines
#: (``passive_every`` 4), 0.0194 % on a non-MPM one (docs/tolerances.md); 0.06 % is 3x the worst (issue 38's
#: tightening; issue 17 set 0.5 %).
PASSIVE_SPIN_TOL = 6e-4
SPIN_FRAMES = 60                # 2 s at 1/30 s: one turn


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors, shape (n, 3) (golden-angle spiral)."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    th = math.pi * (1.0 + 5.0 ** 0.5) * i
    return np.stack([np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)], axis=1)


def spin_setup(info: EngineInfo | None = None, every: int = PASSIVE_EVERY) -> SimSetup:
    """The ``passive_spin`` setup: passive rows first (``n_render`` of them), then the material fill."""
    c = np.full(3, 0.5)
    x, p_vol = box_points(c - SPIN_R, c + SPIN_R, DX / 2)
    x = x[np.linalg.norm(x - c, axis=1) <= SPIN_R - DX / 4]
    surf = c + SPIN_R * fibonacci_sphere(N_SURFACE)
    xs = np.concatenate([surf, x])
    om = np.array([0.0, 0.0, OMEGA])
    W = np.array([[0.0, -OMEGA, 0.0], [OMEGA, 0.0, 0.0], [0.0, 0.0, 0.0]])
    feats = info.capabilities.features if info is not None else frozenset()
    C = np.broadcast_to(W, (len(xs), 3, 3)).copy() if "initial_C" in feats else None
    opts = {}
    if info is not None and any(o.name == "passive_every" for o in info.options):
        opts["passive_every"] = every
    return SimSetup(x=xs, v=np.cross(om, xs - c), p_vol=np.r_[np.zeros(N_SURFACE), np.full(len(x), p_vol)],
                    body_id=0, materials=[Material("jelly", E=1e5, nu=0.3, rho=500.0)], gravity=np.zeros(3),
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=N_GRID, frame_dt=1.0 / 30.0,
                    n_render=N_SURFACE, passive=np.r_[np.ones(N_SURFACE, bool), np.zeros(len(x), bool)], C=C,
                    options=opts)


def _eval_spin(info: EngineInfo, tr: Trace) -> list[Check]:
    c = np.full(3, 0.5)
    r = np.linalg.norm(tr.x[:, tr.setup.passive] - c, axis=2)        # (frames, n_surface)
    r0 = float(r[0].mean())
    worst = float(np.abs(r.mean(axis=1) / r0 - 1.0).max())
    return [check("passive_radius", worst, PASSIVE_SPIN_TOL,
                   f"max over frames of |mean passive radius / R - 1| over one turn (end {r[-1].mean() / r0 - 1:+.4%}; "
                   f"passive_every {(tr.setup.options or {}).get('passive_every', 'n/a')})",
                   end=float(r[-1].mean() / r0 - 1.0))]


SCENES_PASSIVE: list[Scene] = [
    Scene("passive_spin", f"sphere (R = 3.6 dx) spinning at pi rad/s for one turn with passive surface points "
          f"(passive_every = {PASSIVE_EVERY} where offered): their mean radius within {PASSIVE_SPIN_TOL:.2%}",
          Requires(frozenset({"jelly"}), features=frozenset({"passive_points"})), spin_setup, SPIN_FRAMES,
          _eval_spin),
]
