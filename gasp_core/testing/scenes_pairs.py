"""Conformance scenes of contact between a body and what it meets, each with a known answer (issue 53 item 6).

- ``restitution_wood`` and ``restitution_steel``: a 10 cm ball on the rigid route (``Material.model = "rigid"``,
  the feature ``rigid_limit``) of hardwood (E 1e10 Pa, rho 700) or steel (E 2e11 Pa, rho 7850), its lowest point
  ``DROP`` = 0.2 m over a ground (friction 0.5), dropped from rest. Known answer: the coefficient of restitution the
  materials give on a hard floor (``gasp_core.mpm.restitution.body_restitution``: 0.55 and 0.93, the figures of
  rigid-body engines' material tables; the ground's own restitution 1), read from the rebound's apex:
  ``e = sqrt(h1 / h0)`` with ``h0`` the drop and ``h1`` the lowest point's highest height over the ground between the
  first and the second contact (a free flight: no air, no spin). Frames of 1/120 s put the sampled apex within
  ``g (dt/2)^2 / 2`` = 0.09 mm of the true one (0.15 % of the wood ball's 60 mm rebound).
  Tolerance ``E_TOL`` = 0.015 absolute: a 5 % bias in ``e`` (0.0275 for wood, 0.047 for steel) fails it even beside
  the largest error measured on an engine that passes (the rigid route on both MLS-MPM engines: wood 0.5443, -0.0057;
  steel 0.9284, -0.0016; from the free flights ``tests/test_restitution.py`` reads 0.555 and 0.931).
  Before issue 53 both balls read 0.75-0.855, whatever the material.

- ``rigid_rest``: a hardwood slab (6 x 6 x 2 cells, on the rigid route) let go with the bottom of its lowest points'
  volumes ``REST_DROP`` = 0.5 dx over a ground with friction 0.5 (as ``rest_gap``: set down touching, it would stay where it
  was put: put 0.2 dx into the ground, a resting rigid body stays there, docs/contact.md), placed off the grid's symmetry, for ``REST_T`` = 3 s. Known answer: it stays
  where it is (issue 53 item 2: a rigid donut slid 15 mm/s on one engine, another rocked 3-10 degrees and turned 12.8
  degrees by itself). Checks: the centroid's horizontal travel under ``RIGID_TRAVEL_TOL`` = 0.025 dx (the elastic
  slab's ``REST_TOL``), its turn under ``RIGID_TURN_TOL`` = 0.1 degree, and the bottom of its lowest points' volumes
  (their centres less half their spacing) within ``RIGID_GAP_TOL`` = 0.02 dx of the ground at the end, above or
  below (no hover, no sinking; issue 53 asks 0.1 dx of a capture's lowest Gaussians).

- ``stacked_gap``: two jelly balls (R 5 cm, E 1e5 Pa, lattice points at dx / 2) stacked on a ground in a square
  tube of frictionless ``walls`` ``STACK_CLEAR`` = 0.25 dx clear of their sides, the top one let go ``STACK_DROP`` =
  1.5 dx over the bottom one. The tube keeps the top ball above the bottom one: a ball balanced on a ball is an
  unstable equilibrium, and in the open a contact with Coulomb friction lets it roll off (it should: one velocity
  field only held it there by gluing the two; docs/contact.md); frictionless walls carry none of its weight.
  Known answer: soft bodies in contact touch at their surfaces; the gap between them (the nearest points of the two
  less half of each one's spacing: the lattices' surfaces), averaged over the last ``STACK_AVG_T`` s of ``STACK_T``
  s, is within ``STACK_GAP_TOL`` = 0.25 dx of 0, above or below (issue 53 item 5's limit; a shared grid node couples
  two bodies about a cell apart, so a single-velocity MPM grid holds them ~0.84 dx apart; the MLS-MPM engines' two
  velocity fields for two soft bodies, ``gasp_core.mpm.fields.soft_pair``, rest them -0.13 to -0.15 dx).

The restitution ball is the one of ``tests/test_restitution.py`` (a lattice of two points a cell side in a 0.6 m box at
n_grid 24: 268 points).
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, Check, check, make_setup, sphere_points
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
        from gasp_core.mpm.restitution import body_restitution
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


REST_T = 3.0
REST_DROP = 0.5
RIGID_TRAVEL_TOL = 0.025
RIGID_TURN_TOL = 0.1
#: 3x the worst passing engine's error (-0.006 dx on both MLS-MPM engines); issue 53 asks 0.1 dx on a capture.
RIGID_GAP_TOL = 0.02
#: The slab's sides, m, in cells of the restitution scenes' grid.
SLAB = (6 * DX, 6 * DX, 2 * DX)


def _build_rest(info: EngineInfo):
    lo = np.array([SIDE / 2 - SLAB[0] / 2 + 0.3 * DX, SIDE / 2 - SLAB[1] / 2 + 0.2 * DX, GROUND + REST_DROP * DX])
    x, p_vol = box_points(lo, lo + np.array(SLAB), DX / 2)
    mat = Material("jelly", model="rigid", **SUBSTANCES["wood"])
    s = make_setup(x, p_vol, mat, lo=np.zeros(3), hi=np.full(3, SIDE), n_grid=N_GRID, frame_dt=1.0 / 30.0,
                   boundaries=[Boundary("ground", height=GROUND, friction=0.5)])
    s.n_render = 0   # a fill: its surface lies half a spacing beyond its outer points (no rendered row rests on it)
    return s


def _turn_deg(x0: np.ndarray, x1: np.ndarray) -> float:
    """The rotation angle (degrees) of the best rigid fit from ``x0`` to ``x1`` (Kabsch)."""
    a, b = x0 - x0.mean(axis=0), x1 - x1.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    r = (u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt).T
    return math.degrees(math.acos(np.clip((np.trace(r) - 1) / 2, -1.0, 1.0)))


def _eval_rest(info: EngineInfo, tr: Trace) -> list[Check]:
    c = tr.centroid()
    travel = np.linalg.norm(c[:, :2] - c[0, :2], axis=1)
    f = int(np.argmax(travel))
    turns = [_turn_deg(tr.x[0], x) for x in tr.x]
    k = int(np.argmax(turns))
    z = np.sort(tr.x[-1][:, 2] - 0.5 * np.cbrt(tr.setup.p_vol))
    low = float(z[:max(1, round(0.01 * len(z)))].mean() - GROUND)
    return [check("rigid_travel", float(travel[f]) / DX, RIGID_TRAVEL_TOL,
                  f"largest horizontal centroid travel of the rigid slab at rest over {tr.t[-1]:.1f} s (at "
                  f"{tr.t[f]:.2f} s), friction 0.5, in dx", t_max=float(tr.t[f])),
            check("rigid_turn", turns[k], RIGID_TURN_TOL,
                  f"largest rotation of the rigid slab from its start (at {tr.t[k]:.2f} s), degrees", t_max=float(tr.t[k])),
            check("rigid_gap", abs(low) / DX, RIGID_GAP_TOL,
                  f"|mean height over the ground of the bottom of its lowest 1 % of points' volumes| at {tr.t[-1]:.1f} s, "
                  f"in dx (signed {low / DX:+.3f} dx)", signed=low / DX)]


SCENES_PAIRS.append(Scene("rigid_rest", f"a hardwood slab on the rigid route set down on a ground (friction 0.5) "
                          f"stays put for {REST_T:g} s: travel under {RIGID_TRAVEL_TOL} dx, turn under "
                          f"{RIGID_TURN_TOL} deg, resting within {RIGID_GAP_TOL} dx of the ground",
                          _REQ, _build_rest, round(REST_T * 30), _eval_rest))


#: Two soft balls stacked (``stacked_gap``): radius, m, Young's modulus, Pa, density, kg/m^3, and the limit on the
#: gap between their surfaces, dx (issue 53 item 5).
STACK_R = 0.05
STACK_MAT = Material("jelly", E=1e5, nu=0.3, rho=1000.0)
STACK_GAP_TOL = 0.25
STACK_T = 1.0
#: The stacked scene's ground, m: 4 cells over the domain's floor (an engine may keep 3 cells clear of its faces).
STACK_GROUND = 4 * DX
#: The gap is averaged over the run's last this many seconds (the top ball still rocks on the bottom one: on the
#: MLS-MPM engines the gap swings 0.70-0.86 dx from 0.7 s to 1.5 s).
STACK_AVG_T = 0.5
#: The top ball starts this many cells over the bottom one (its fall shows where the contact stops it).
STACK_DROP = 1.5
#: The tube's frictionless walls stand this many cells clear of the balls' sides (a ball balanced on a ball is an
#: unstable equilibrium: in the open, a contact with Coulomb friction lets the top one roll off, docs/contact.md).
STACK_CLEAR = 0.25


def _build_stack(info: EngineInfo | None):
    from gasp_core.seam.setup import SimSetup
    from gasp_core.testing.helpers import wall_margin
    h = DX / 2
    a, p_vol = sphere_points(np.zeros(3), STACK_R, h)
    lo_a = a[:, 2].min() - h / 2                     # the bottom of the lowest points' volumes
    # the tube: frictionless walls STACK_CLEAR cells clear of the balls' sides (the walls' planes lie
    # wall_margin inside the domain's faces: 3 dx on a grid engine)
    half = STACK_R + STACK_CLEAR * DX + (wall_margin(info, DX) if info is not None else 3 * DX)
    bottom = a + [half, half, STACK_GROUND - lo_a]
    top = a + [half, half, STACK_GROUND - lo_a + 2 * STACK_R + STACK_DROP * DX]
    x = np.concatenate([bottom, top])
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=np.repeat([0, 1], len(a)), materials=[STACK_MAT, STACK_MAT],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=np.zeros(3),
                    domain_hi=np.array([2 * half, 2 * half, SIDE]), n_grid=N_GRID,
                    boundaries=[Boundary("ground", height=STACK_GROUND, friction=0.5), Boundary("walls", friction=0.0)],
                    frame_dt=1.0 / 30.0, n_render=0)


def surface_gap(x: np.ndarray, body: np.ndarray, p_vol) -> float:
    """The gap between bodies 0 and 1, m: the nearest distance between a point of one and a point of the other, less
    half of each one's spacing ``p_vol^(1/3)`` (a lattice's surface lies half a spacing beyond its outer points);
    negative when they overlap."""
    from scipy.spatial import cKDTree
    h = np.broadcast_to(np.cbrt(np.asarray(p_vol, np.float64)), body.shape)
    a, b = body == 0, body == 1
    d, k = cKDTree(x[a]).query(x[b])
    i = int(np.argmin(d))
    return float(d[i] - 0.5 * (h[b][i] + h[a][k[i]]))


def _eval_stack(info: EngineInfo, tr: Trace) -> list[Check]:
    body = np.asarray(tr.setup.body_id)
    last = tr.t >= tr.t[-1] - STACK_AVG_T - 1e-9
    gaps = np.array([surface_gap(x, body, tr.setup.p_vol) for x in tr.x[last]]) / DX
    gap = float(gaps.mean())
    return [check("stack_gap", abs(gap), STACK_GAP_TOL,
                  f"|gap between the stacked balls' surfaces| over the last {STACK_AVG_T:g} s of {tr.t[-1]:.1f} s "
                  f"(nearest points less half of each one's spacing, mean of {last.sum()} frames; range "
                  f"{gaps.min():+.3f} to {gaps.max():+.3f}), in dx (signed {gap:+.3f} dx)", signed=gap)]


SCENES_PAIRS.append(Scene("stacked_gap", f"two jelly balls (R {STACK_R:g} m, E {STACK_MAT.E:g} Pa) stacked on a "
                          f"ground in a frictionless tube: after {STACK_T:g} s their surfaces meet within "
                          f"{STACK_GAP_TOL} dx (issue 53 item 5)",
                          Requires(frozenset({"jelly"}), frozenset({"ground", "walls"})), _build_stack,
                          round(STACK_T * 30), _eval_stack))
