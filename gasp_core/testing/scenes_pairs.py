"""Conformance scenes of contact between a body and what it meets, each with a known answer (issue 53 item 6).

- ``restitution_wood`` and ``restitution_steel``: a 10 cm ball on the rigid route (``Material.model = "rigid"``,
  the feature ``rigid_limit``) of hardwood (E 1e10 Pa, rho 700) or steel (E 2e11 Pa, rho 7850), its lowest point
  ``DROP`` = 0.2 m over a ground (friction 0.5), dropped from rest. Known answer: the coefficient of restitution the
  materials give on a hard floor (``gasp_core.toolkit.restitution.body_restitution``: 0.55 and 0.93, the figures of
  rigid-body engines' material tables; the ground's own restitution 1), read from the rebound's apex:
  ``e = sqrt(h1 / h0)`` with ``h0`` the drop and ``h1`` the lowest point's highest height over the ground between the
  first and the second contact (a free flight: no air, no spin). Frames of 1/120 s put the sampled apex within
  ``g (dt/2)^2 / 2`` = 0.09 mm of the true one (0.15 % of the wood ball's 60 mm rebound).
  Tolerance ``E_TOL`` = 0.015 absolute: a 5 % bias in ``e`` (0.0275 for wood, 0.047 for steel) fails it even beside
  the largest error measured on an engine that passes (the rigid route on both MLS-MPM engines: wood 0.5443, -0.0057;
  steel 0.9284, -0.0016; from the free flights ``tests/test_restitution.py`` reads 0.555 and 0.931).
  Before issue 53 both balls read 0.75-0.855, whatever the material.

The ball is the one of ``tests/test_restitution.py`` (a lattice of two points a cell side in a 0.6 m box at
n_grid 24: 268 points).
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import Check, check, GRAVITY, make_setup, sphere_points
from gasp_core.testing.kit import Requires, Scene, Trace

N_GRID = 24
SIDE = 0.6
DX = SIDE / N_GRID
RADIUS = 0.05
GROUND = 0.05
DROP = 0.2
FRAME_DT = 1.0 / 120.0
#: Frames: the fall (0.20 s), the contact and the steel ball's flight to its apex (0.19 s) and back.
N_FRAMES = 72
E_TOL = 0.015
SUBSTANCES = {"wood": dict(E=1.0e10, nu=0.3, rho=700.0), "steel": dict(E=2.0e11, nu=0.3, rho=7850.0)}


def _build(substance: str):
    def build(info: EngineInfo):
        x, p_vol = sphere_points(np.zeros(3), RADIUS, DX / 2)
        x = x + [SIDE / 2, SIDE / 2, GROUND + DROP - x[:, 2].min()]
        mat = Material("jelly", model="rigid", **SUBSTANCES[substance])
        return make_setup(x, p_vol, mat, lo=np.zeros(3), hi=np.full(3, SIDE), n_grid=N_GRID, frame_dt=FRAME_DT,
                          boundaries=[Boundary("ground", height=GROUND, friction=0.5)])
    return build


def rebound(low: np.ndarray, level: float) -> tuple[float, int, int]:
    """``(h1, first_contact, apex_frame)``: the highest of ``low`` (the lowest point's height over the ground per
    frame, m) between the first frame within ``level`` (m) of the ground and the next one after it has risen over
    ``level``; NaN when the body never touches or never leaves the ground."""
    hit = np.flatnonzero(low <= level)
    if not len(hit):
        return float("nan"), -1, -1
    up = np.flatnonzero((low > level) & (np.arange(len(low)) > hit[0]))
    if not len(up):
        return float("nan"), int(hit[0]), -1
    again = np.flatnonzero((low <= level) & (np.arange(len(low)) > up[0]))
    end = int(again[0]) if len(again) else len(low)
    k = up[0] + int(np.argmax(low[up[0]:end]))
    return float(low[k]), int(hit[0]), k


def _evaluate(substance: str):
    def evaluate(info: EngineInfo, tr: Trace) -> list[Check]:
        from gasp_core.toolkit.restitution import body_restitution
        asked = body_restitution(Material("jelly", **SUBSTANCES[substance]))
        low = np.array([x[:, 2].min() for x in tr.x]) - GROUND
        h0 = float(low[0])
        h1, hit, apex = rebound(low, 0.25 * DX)
        e = math.sqrt(max(h1, 0.0) / h0) if np.isfinite(h1) else float("nan")
        what = (f"|e - e_materials|, e = sqrt(h1/h0) from the rebound's apex (h0 {1e3 * h0:.1f} mm, h1 "
                f"{1e3 * h1:.2f} mm at {apex * FRAME_DT:.3f} s, contact from {hit * FRAME_DT:.3f} s; e {e:.4f}, the "
                f"materials' {asked:.2f} on a hard floor; signed {e - asked:+.4f})")
        return [check("restitution", abs(e - asked), E_TOL, what, e=e, asked=asked, signed=e - asked)]
    return evaluate


_REQ = Requires(frozenset({"jelly"}), frozenset({"ground"}), frozenset({"rigid_limit"}))

SCENES_PAIRS: list[Scene] = [
    Scene(f"restitution_{name}", f"a 10 cm {name} ball on the rigid route dropped {DROP:g} m on a hard ground "
          f"(E {SUBSTANCES[name]['E']:.0e} Pa, rho {SUBSTANCES[name]['rho']:g}): the rebound's apex gives the "
          f"materials' restitution within {E_TOL}", _REQ, _build(name), N_FRAMES, _evaluate(name))
    for name in ("wood", "steel")
]
