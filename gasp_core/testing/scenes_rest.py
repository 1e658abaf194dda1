"""Conformance scenes of a body at rest on a frictional ground (issue 17: "a resting body stays put").

Known answer: a body set down at rest on a ground with Coulomb friction ``mu`` stays where it is,
on flat ground and on ground tilted by ``theta < atan(mu)`` (static friction holds it: the
tangential load ``m g sin theta`` is below ``mu m g cos theta``). Its horizontal (on the tilted
ground: in-plane) centroid travel must stay within ``REST_TOL`` = 0.025 dx over ``REST_T`` = 2 s.

- ``rest_on_ground``: an elastic slab (4 x 4 x 2 dx, ``SLAB``) set on a ``ground`` with
  friction ``MU`` = 0.5 under plain gravity.
- ``rest_on_tilted_ground``: the same slab and ground with gravity turned by ``TILT_DEG`` = 15 deg
  about y (``tan 15 deg = 0.27 < mu``). Turning gravity rather than the ground keeps the test on
  the ``ground`` boundary every engine with ``ground`` has (no collider feature needed), and is the
  same mechanics: only the angle between gravity and the plane matters.

The slab is placed off the grid's symmetry (its centre 0.3 dx and 0.2 dx off a node column), so a
lattice-direction bias of the contact rule cannot cancel by symmetry. Its bottom points sit dx/4
above the ground (points at dx/2 spacing, cell-centred), so it settles by a fraction of a cell.
Domain: the default one of a 10 cm object (``SIDE`` = 0.3 m, ``n_grid`` = 16, the ground three cells
above its bottom), a few hundred points: a few seconds per engine.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, Check, check, GRAVITY, make_setup
from gasp_core.testing.kit import Requires, Scene, Trace

N_GRID = 16
#: Domain side, metres, and its corner: the default domain of a 10 cm object on a ground at z = 0
#: (gasp_core.prepare.assembly.default_domain: side = 3 x extent, the ground 3 cells above the bottom).
#: The side is not a power of two, so node heights are inexact in float32, as in real scenes.
SIDE = 0.3
DX = SIDE / N_GRID
LO = np.array([-SIDE / 2, -SIDE / 2, -3 * DX])
GROUND_H = 0.0
MU = 0.5
TILT_DEG = 15.0
REST_T = 2.0
FRAME_DT = 1.0 / 30.0
#: Allowed in-plane centroid travel, in dx (issue 17).
#: Within 3x of the largest error measured on an engine that passes (0.0089 dx on the tilted ground;
#: docs/tolerances.md).
REST_TOL = 0.025
#: Slab sides (x, y, z), metres: wide and low, so that neither slope nor settling can tip it.
SLAB = (4 * DX, 4 * DX, 2 * DX)
BODY = Material("jelly", E=1e5, nu=0.3, rho=1000.0)


def _gravity(tilt_deg: float) -> np.ndarray:
    """Gravity turned by ``tilt_deg`` about +y: its in-plane part points along +x."""
    th = math.radians(tilt_deg)
    return GRAVITY * np.array([math.sin(th), 0.0, -math.cos(th)])


def _build(tilt_deg: float):
    def build(info: EngineInfo):
        lx, ly, lz = SLAB
        lo = np.array([-lx / 2 + 0.3 * DX, -ly / 2 + 0.2 * DX, GROUND_H])
        x, p_vol = box_points(lo, lo + np.array(SLAB), DX / 2)
        return make_setup(x, p_vol, BODY, lo=LO, hi=LO + SIDE, n_grid=N_GRID, frame_dt=FRAME_DT, gravity=_gravity(tilt_deg),
                      boundaries=[Boundary("ground", height=GROUND_H, friction=MU)])
    return build


def _evaluate(tilt_deg: float):
    def evaluate(info: EngineInfo, tr: Trace) -> list[Check]:
        c = tr.centroid()
        d = c[:, :2] - c[0, :2]
        travel = np.linalg.norm(d, axis=1)
        f = int(np.argmax(travel))
        th = math.radians(tilt_deg)
        what = (f"largest in-plane centroid travel over {tr.t[-1]:.1f} s on a ground with friction {MU}"
                + (f" under gravity tilted {tilt_deg:g} deg (tan = {math.tan(th):.3f} < mu)" if tilt_deg else "")
                + f", in dx (at {tr.t[f]:.2f} s: x {d[f, 0] / DX:+.4f}, y {d[f, 1] / DX:+.4f} dx)")
        return [check("rest_drift", float(travel[f]) / DX, REST_TOL, what,
                       drift_x=float(d[-1, 0]), drift_y=float(d[-1, 1]), t_max=float(tr.t[f]))]
    return evaluate


_REQ = Requires(frozenset({"jelly"}), frozenset({"ground"}))
_N = round(REST_T / FRAME_DT)

SCENES_REST: list[Scene] = [
    Scene("rest_on_ground", f"an elastic slab (4 x 4 x 2 dx) at rest on a ground with friction {MU}: its "
          f"centroid moves less than {REST_TOL} dx in {REST_T:g} s",
          _REQ, _build(0.0), _N, _evaluate(0.0)),
    Scene("rest_on_tilted_ground", f"the slab on the same ground with gravity tilted {TILT_DEG:g} deg (tan = "
          f"{math.tan(math.radians(TILT_DEG)):.2f} < mu = {MU}, so it sticks): in-plane centroid travel below "
          f"{REST_TOL} dx in {REST_T:g} s",
          _REQ, _build(TILT_DEG), _N, _evaluate(TILT_DEG)),
]
