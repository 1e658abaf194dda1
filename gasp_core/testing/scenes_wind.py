"""Conformance scene of wind as a drag law (:class:`gasp_core.colliders.model.ForceField` ``wind``).

- ``wind``: a light cube (side ``WIND_L``) under gravity in air of density ``RHO_AIR`` with drag
  coefficient ``CD``, face on to the flow. Quadratic drag ``F = 1/2 rho_air C_d A |u - v| (u - v)``
  with the frontal area ``A = L^2`` gives the terminal velocity (relative to the air)

      ``v_t = sqrt(2 m g / (rho_air C_d A)) = sqrt(2 rho L g / (rho_air C_d))``,

  and from rest relative to the air ``v_rel(t) = v_t tanh(g t / v_t)``. To keep the body in the box
  the air rises at ``u = v_t`` and the cube starts rising with it (relative velocity 0: a release from
  rest in still air, seen from a frame moving up at ``v_t``); it slows and hovers. The check: the
  relative velocity over the last ``WIND_AVG`` frames is ``v_t`` within ``WIND_TOL`` (a 5 % bias in
  the drag force moves it by 2.5 %; a wind applied as an acceleration never settles), and halfway
  (``t = v_t / g``: ``tanh 1 = 0.762``) it follows the tanh within ``WIND_TOL`` of ``v_t``.
  The cube's density is chosen for ``v_t = WIND_VT``; no buoyancy.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.colliders.model import ForceField
from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check, GRAVITY, make_setup
from gasp_core.testing.kit import Requires, Scene, Trace

N_GRID = 32
DX = 1.0 / N_GRID
WIND_L = 0.25                  # m, cube side (8 dx)
RHO_AIR = 1.2                  # kg/m^3
CD = 1.0
WIND_VT = 1.0                  # m/s: the terminal velocity the cube's density is chosen for
WIND_RHO = WIND_VT ** 2 * RHO_AIR * CD / (2.0 * GRAVITY * WIND_L)      # 0.245 kg/m^3
WIND_T = 0.5                   # s simulated: 4.9 v_t / g (tanh 4.9 = 0.9999)
WIND_FRAME = 0.02
WIND_AVG = 5                   # frames averaged at the end
#: Relative tolerance on the terminal (and halfway) velocity, as a share of v_t.
WIND_TOL = 0.03


def _build_wind(info: EngineInfo) -> SimSetup:
    x, p_vol = box_points((0.375, 0.375, 0.2), (0.375 + WIND_L, 0.375 + WIND_L, 0.2 + WIND_L), DX / 2)
    # stiff enough that the cube barely jiggles: a soft one (E 50 Pa) wobbles sideways, and the side
    # faces then catch the relative wind too (v_rel 0.941 at E 50, 0.982 at 500, 0.991 at 2000 on an MLS-MPM engine)
    mat = Material("jelly", E=2000.0, nu=0.3, rho=WIND_RHO)
    setup = make_setup(x, p_vol, mat, n_grid=N_GRID, v=np.tile([0.0, 0.0, WIND_VT], (len(x), 1)),
                   gravity=(0.0, 0.0, -GRAVITY), frame_dt=WIND_FRAME)
    setup.forces = [ForceField("wind", direction=(0.0, 0.0, 1.0), speed=WIND_VT, air_density=RHO_AIR,
                               drag_coefficient=CD)]
    return setup


def _eval_wind(info: EngineInfo, tr: Trace) -> list[Check]:
    vz = np.einsum("i,fi->f", tr.p_mass, tr.v[:, :, 2]) / tr.p_mass.sum()     # body velocity, m/s
    v_rel = WIND_VT - vz                                                      # falling speed relative to the air
    end = float(v_rel[-WIND_AVG:].mean())
    k = int(np.argmin(np.abs(tr.t - WIND_VT / GRAVITY)))
    want_mid = WIND_VT * math.tanh(GRAVITY * tr.t[k] / WIND_VT)
    return [check("terminal_velocity", abs(end / WIND_VT - 1.0), WIND_TOL,
                   f"|v_rel / v_t - 1| over the last {WIND_AVG} frames ({end:.4f} m/s vs v_t {WIND_VT:g} m/s)",
                   v_rel=end, v_t=WIND_VT),
            check("approach", abs(v_rel[k] - want_mid) / WIND_VT, WIND_TOL,
                   f"|v_rel - v_t tanh(g t / v_t)| / v_t at t = {tr.t[k]:.2f} s ({v_rel[k]:.4f} vs {want_mid:.4f} m/s)",
                   v_rel=float(v_rel[k]), expected=want_mid)]


SCENES_WIND: list[Scene] = [
    Scene("wind", f"light cube under gravity in air (quadratic drag, rho_air {RHO_AIR}, C_d {CD}, A = L^2): "
          f"terminal velocity sqrt(2 m g / (rho_air C_d A)) = {WIND_VT} m/s and the tanh approach within "
          f"{WIND_TOL:.0%}", Requires(frozenset({"jelly"}), features=frozenset({"wind"})), _build_wind,
          round(WIND_T / WIND_FRAME), _eval_wind),
]
