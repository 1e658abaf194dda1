"""Conformance scenes of colliders and force fields with known answers (:mod:`gasp_core.colliders.model`).

- ``incline_slide`` / ``incline_stick``: an elastic block on a static box collider tilted by
  ``INCLINE_DEG``; with Coulomb friction ``mu`` below ``tan(theta)`` it slides with
  ``a = g (sin theta - mu cos theta)``, above it stays put. ``incline_slide`` uses a cube,
  ``incline_stick`` a flat slab (``SLAB``: 8 x 4 x 2 dx, so that it cannot tip: its weight's line
  stays over its base up to ``atan(4) = 76`` deg), and ``incline_stick_cube`` the cube, which a rigid
  cube's statics also hold still (it tips only beyond ``atan(1) = 45`` deg).
- ``pusher``: a box collider moving at ``PUSH_SPEED`` along x pushes a block over a ground with
  friction; in the long run the block can neither fall behind the pusher (no penetration) nor
  run ahead of it (friction stops it), so its mean speed is the pusher's.
(The ``wind`` scene is in :mod:`gasp_core.testing.scenes_wind`.)

All use the domain ``[0, 1]^3`` at ``n_grid = 32`` and points at ``dx / 2``.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.colliders.model import Motion
from gasp_core.colliders.sdf import box_collider, SDF_SPACING
from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check, GRAVITY, make_setup
from gasp_core.testing.kit import Requires, Scene, Trace

N_GRID = 32
DX = 1.0 / N_GRID
BLOCK = Material("jelly", E=1e5, nu=0.3, rho=1000.0)

# --- block on an inclined plane -------------------------------------------------------------
INCLINE_DEG = 25.0
MU_SLIDE, MU_STICK = 0.2, 0.8          # tan(25 deg) = 0.466
INCLINE_T = 0.4                        # s simulated
#: Relative error allowed on the sliding acceleration (two-sided). The block starts with its surface (half a point
#: spacing beyond its outer points) on the slope. Measured (quadratic fit of the centroid over 0.1-0.4 s): -0.065 %
#: on the particle contact, +0.19 % with the grid rule on the collider (``contact = "grid"``), -0.41 % on a
#: non-MPM engine (per engine: docs/tolerances.md). Until issue 38's tightening the block started a quarter cell above the
#: slope and fell onto it: the MPM engines ran 0.82 % slow (0.95 % with ``KAPPA`` 2), which was taken for the soft
#: penalty's, and the tolerance was 1.25 %. 0.75 % is 1.85x the worst; friction 5 % off moves a by 3.75 %.
INCLINE_TOL = 0.0075
#: Largest travel down the slope (dx) of the stuck bodies, over 0.4 s. Measured (the body set on the slope): the slab
#: 0.0006-0.00125 dx on the particle contact (0.0053 without the balance, 0.023 with the grid rule), the cube
#: 0.019-0.021 dx, turning 0.8 deg (0.057 without the balance; the grid rule 0.36 dx, turning 6.4 deg; per engine:
#: docs/tolerances.md). Each limit is about 3x the worst particle contact's: the balance-less and grid contacts
#: fail them. (0.5 dx until issue 38, when the bodies fell
#: a quarter cell onto the slope and slid 0.29-0.34 dx on the particle contact while in the air.)
STICK_TOL = {"slab": 0.004, "cube": 0.06}


def _incline_frame():
    th = math.radians(INCLINE_DEG)
    n = np.array([math.sin(th), 0.0, math.cos(th)])             # outward normal of the slope's top face
    s = np.array([math.cos(th), 0.0, -math.sin(th)])            # down the slope
    R = np.array([[math.cos(th), 0.0, math.sin(th)], [0.0, 1.0, 0.0], [-math.sin(th), 0.0, math.cos(th)]])
    return n, s, R


#: Block sides (along the slope, across, normal to it), metres: the cube and the slab.
CUBE = (0.125, 0.125, 0.125)
SLAB = (0.25, 0.125, 0.0625)


def _build_incline(mu: float, size=CUBE) -> SimSetup:
    n, s, R = _incline_frame()
    top = np.array([0.45, 0.5, 0.45])                          # centre of the slope's top face
    half = np.array([0.8, 0.6, 0.1])
    col = box_collider(half, SDF_SPACING * DX, name="incline", friction=mu, position=top - half[2] * n,
                       rotation=R)
    Ls, Ly, Ln = size
    local, p_vol = box_points((-Ls / 2, -Ly / 2, 0.0), (Ls / 2, Ly / 2, Ln), DX / 2)  # its surface on the slope
    start = top - 0.08 * s                                      # upslope of the face centre
    x = start + local[:, :1] * s + local[:, 1:2] * np.array([0.0, 1.0, 0.0]) + local[:, 2:] * n
    setup = make_setup(x, p_vol, BLOCK, n_grid=N_GRID, frame_dt=0.02)
    setup.colliders = [col]
    return setup


def _tilt_deg(x0: np.ndarray, x1: np.ndarray) -> float:
    """Angle (degrees) of the best-fit rotation from ``x0`` to ``x1`` (Kabsch, centroids removed)."""
    U, _, Vt = np.linalg.svd((x0 - x0.mean(axis=0)).T @ (x1 - x1.mean(axis=0)))
    R = (U @ Vt).T
    if np.linalg.det(R) < 0:
        U[:, -1] *= -1
        R = (U @ Vt).T
    return math.degrees(math.acos(float(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))))


def _eval_incline(mu: float, stick_tol: float = 0.0):
    def evaluate(info: EngineInfo, tr: Trace) -> list[Check]:
        n, s, _ = _incline_frame()
        th = math.radians(INCLINE_DEG)
        c = tr.centroid()
        along = (c - c[0]) @ s
        t = tr.t
        checks = []
        if mu < math.tan(th):
            expected = GRAVITY * (math.sin(th) - mu * math.cos(th))
            late = t >= 0.1                                      # after settling onto the slope
            a_fit = 2.0 * np.polyfit(t[late], along[late], 2)[0]
            checks.append(check("slide_acceleration", abs(a_fit - expected) / expected, INCLINE_TOL,
                                 f"|a - g (sin th - mu cos th)| / expected (a = {a_fit:.3f}, expected "
                                 f"{expected:.3f} m/s^2, mu = {mu})", a=a_fit, expected=expected,
                                 signed=(a_fit - expected) / expected))
        else:
            free = 0.5 * GRAVITY * math.sin(th) * t[-1] ** 2
            tilt = _tilt_deg(tr.x[0], tr.x[-1])
            checks.append(check("stick_displacement", float(abs(along[-1])) / DX, stick_tol,
                                f"|centroid travel down the slope| after {t[-1]:.2f} s, in dx (frictionless "
                                f"it would be {free / DX:.0f} dx; mu = {mu} > tan th = {math.tan(th):.3f}; "
                                f"block turned {tilt:.1f} deg)", tilt_deg=tilt))
        depth = float(np.max(-((tr.x[-1] - (np.array([0.45, 0.5, 0.45]))) @ n)))
        checks.append(check("penetration", depth / DX, 1.0, "deepest point below the slope's surface at the end, "
                            "in dx"))
        return checks
    return evaluate


# --- pusher ---------------------------------------------------------------------------------
PUSH_SPEED = 0.5
GROUND_H = 3 * DX
PUSH_T = 0.6
#: Relative error allowed on the block's mean speed over the last 0.3 s. Measured: -2.3 to -2.4 % on the MPM
#: engines (the block 0.488 m/s; docs/tolerances.md); 7 % is 3x the worst (8 % until issue 38's tightening).
PUSH_TOL = 0.07


def _build_pusher(info: EngineInfo) -> SimSetup:
    L = 0.125
    lo = np.array([0.35, 0.5 - L / 2, GROUND_H])
    x, p_vol = box_points(lo, lo + L, DX / 2)
    half = np.array([0.05, 0.12, 0.08])
    gap = 0.03
    centre = np.array([lo[0] - gap - half[0], 0.5, GROUND_H + half[2] + DX])
    col = box_collider(half, SDF_SPACING * DX, name="pusher", friction=0.0, position=centre,
                       motion=Motion(velocity=(PUSH_SPEED, 0.0, 0.0)))
    setup = make_setup(x, p_vol, BLOCK, n_grid=N_GRID, frame_dt=0.02,
                       boundaries=[Boundary("ground", height=GROUND_H, friction=0.3)])
    setup.colliders = [col]
    return setup


def _eval_pusher(info: EngineInfo, tr: Trace) -> list[Check]:
    c = tr.centroid()
    t = tr.t
    late = t >= t[-1] - 0.3
    speed = (c[late][-1, 0] - c[late][0, 0]) / (t[late][-1] - t[late][0])
    col = tr.setup.colliders[0]
    inside = max(float(-np.min(col.distance(tr.x[f], t[f]))) for f in range(len(t)))
    return [check("block_speed", abs(speed - PUSH_SPEED) / PUSH_SPEED, PUSH_TOL,
                  f"|mean block speed over the last 0.3 s - pusher speed| / pusher speed (block "
                  f"{speed:.4f} m/s, pusher {PUSH_SPEED} m/s)", speed=speed),
            check("pusher_penetration", inside / DX, 1.0, "deepest point inside the pusher over the run, in dx")]


SCENES_COLLIDERS: list[Scene] = [
    Scene("incline_slide", f"elastic block on a static box collider tilted {INCLINE_DEG:g} deg, friction "
          f"{MU_SLIDE}: slides with a = g (sin th - mu cos th) within {INCLINE_TOL:.0%}",
          Requires(frozenset({"jelly"}), features=frozenset({"static_colliders"})),
          lambda info: _build_incline(MU_SLIDE), round(INCLINE_T / 0.02), _eval_incline(MU_SLIDE)),
    Scene("incline_stick", f"a flat slab (8 x 4 x 2 dx) on the same slope with friction {MU_STICK} > tan th: "
          f"moves less than {STICK_TOL['slab']:g} dx",
          Requires(frozenset({"jelly"}), features=frozenset({"static_colliders"})),
          lambda info: _build_incline(MU_STICK, SLAB), round(INCLINE_T / 0.02),
          _eval_incline(MU_STICK, STICK_TOL["slab"])),
    Scene("incline_stick_cube", f"the cube on the same slope with friction {MU_STICK} > tan th (a rigid cube "
          f"tips only beyond 45 deg): moves less than {STICK_TOL['cube']:g} dx",
          Requires(frozenset({"jelly"}), features=frozenset({"static_colliders"})),
          lambda info: _build_incline(MU_STICK), round(INCLINE_T / 0.02),
          _eval_incline(MU_STICK, STICK_TOL["cube"])),
    Scene("pusher", f"box collider moving at {PUSH_SPEED} m/s pushes a block over a ground with friction: "
          f"block's mean speed = pusher's within {PUSH_TOL:.0%}",
          Requires(frozenset({"jelly"}), frozenset({"ground"}), features=frozenset({"moving_colliders"})),
          _build_pusher, round(PUSH_T / 0.02), _eval_pusher),
]
