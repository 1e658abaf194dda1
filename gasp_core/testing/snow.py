"""Snow against solids and on slopes (issue 67 items 3 and 5, round 45; ``docs/contact.md`` "Round 45: snow"): the
scenes, built from the sand scenes' builders, and their figures.

Snow here is the project's ``snow`` material (Stomakhin et al. 2013, ``docs/mpm.md``): fixed corotated elasticity
scaled by ``exp(hardening (1 - Jp))``, its principal stretches clamped to ``[1 - theta_c, 1 + theta_s]``; the schema's
defaults (E 1e5 Pa, nu 0.3, rho 1000, hardening 10, theta_c 2.5e-2, theta_s 4.5e-3). It has no friction angle: with
``contact = "auto"`` it takes the grid contact, in a mixed scene the two-field contact with friction 0 against the
other body (``gasp_core.mpm.fields``), and the ground's ``friction`` on the ground (the grid's boundary rule).

- :func:`ball_setup`: ``gasp_core.testing.sand_ball.pair_setup`` (the 6 x 6 x 15 cm column beside the 5 cm jelly
  ball, 5 mm apart, ground friction 0.5, frames of 1/30 s) with the column made of :data:`SNOW`, on ``n_grid`` cells
  over the same 0.48 m box, the ball of radius ``r``. The snow column slumps (its lateral stretch under its own
  weight reaches ``theta_s``) and spreads against the ball.
- :func:`surface_depth_dx`: the deepest snow point below the ball's surface, measured along the ball's normals at the
  last frame (module function docstring), over dx; negative: the snow stands off.
- :func:`slope_setup`: ``tests/test_elastic_slope.py``'s block (6 x 6 x 2 cells of fill, 15 x 15 x 5 cm at n_grid 24
  in a 0.6 m box, on a ground of friction ``mu``, gravity tilted ``theta``) made of :data:`SNOW`, ``contact =
  "auto"`` (the grid contact). Known answer: Coulomb's block, ``a = g (sin theta - mu cos theta)`` where ``tan theta
  > mu``, stuck where ``tan theta < mu`` (``tests/slopes.py``).
"""
from __future__ import annotations

import math
import numpy as np

from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing import sand_ball as S
from gasp_core.testing.helpers import box_points, make_setup, sphere_points

#: The project's snow at the schema's defaults (Stomakhin et al. 2013's model; E 1e5 Pa, nu 0.3, rho 1000 kg/m^3).
SNOW = Material("snow")


def ball_setup(n_grid: int = S.N_GRID, r: float = S.R, options: dict | None = None,
               material: Material = SNOW) -> SimSetup:
    """``sand_ball.pair_setup()`` with the column (body 0) of ``material`` on ``n_grid`` cells (dx = 0.48 m /
    ``n_grid``) and the jelly ball (body 1) of radius ``r`` (m), still 5 mm beyond the column's face, touching the
    ground. ``options`` as ``pair_setup``'s (``{"contact_fields": False}``: one velocity field)."""
    dx = S.SIDE / n_grid
    lo = np.array([S.COL_X[0], -S.SIDE_C / 2, 0.0])
    xs, vs = box_points(lo, lo + np.array([S.SIDE_C, S.SIDE_C, S.HEIGHT_C]), dx / 2)
    centre = np.array([S.SIDE_C + S.GAP + r, 0.0, r]) + np.array([0.3 * dx, 0.2 * dx, 0.0])
    xb, vb = sphere_points(centre, r, dx / 2)
    x = np.concatenate([xs, xb])
    vol = np.concatenate([np.full(len(xs), vs), np.full(len(xb), vb)])
    body = np.concatenate([np.zeros(len(xs), int), np.ones(len(xb), int)])
    domain_lo = np.array([-0.12, -S.SIDE / 2, -3 * dx])
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=vol, body_id=body, materials=[material, S.BALL],
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=domain_lo, domain_hi=domain_lo + S.SIDE,
                    n_grid=n_grid, frame_dt=1.0 / 30.0,
                    boundaries=[Boundary("ground", height=0.0, friction=S.MU_GROUND)], options=dict(options or {}))


def _rotation(x0: np.ndarray, x1: np.ndarray) -> np.ndarray:
    """The best-fit rotation (3, 3) taking the points ``x0`` to ``x1`` about their centroids (Kabsch)."""
    a, b = x0 - x0.mean(0), x1 - x1.mean(0)
    u, _s, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def surface_depth_dx(x0: np.ndarray, x1: np.ndarray, body: np.ndarray, r: float, dx: float,
                     reach: float = 0.0) -> float:
    """The deepest point of body 0 (the snow) below the surface of the last body (the ball, radius ``r`` m), in units
    of ``dx`` (m), at the end ``x1`` (n, 3) of a run that started at ``x0`` (n, 3), both in metres, setup order.

    The ball's surface: its points in the outer layer at the start (``|x0 - c0| > r - dx / 2``), each carried to the
    end, with its normal the start's radial direction turned by the ball's best-fit rotation, and the surface
    ``r - |x0 - c0|`` beyond the point along it (the lattice's outer layer sits inside the sphere). A snow point's
    depth is ``(s - p) . n`` for the surface point ``s`` nearest to it; the figure is the largest over the snow
    points that lie within ``2 dx`` of the surface (positive: inside the ball; negative: the nearest snow stands
    off). ``reach`` (m, default 0: the points' centres): how far the snow's surface lies beyond its points toward the
    ball, half their spacing for a fill (round 75: the flowing body's touch holds that surface, not the centres,
    ``gasp_core.mpm.flow_reach``); it is added to every depth. ``-inf`` when no snow point comes within 2 dx. Raises
    ``ValueError`` if the ball has no points."""
    ball = body == body.max()
    if not ball.any():
        raise ValueError("no ball points")
    b0, b1 = x0[ball], x1[ball]
    c0 = b0.mean(0)
    r0 = np.linalg.norm(b0 - c0, axis=1)
    outer = r0 > r - dx / 2
    n = ((b0[outer] - c0) / r0[outer, None]) @ _rotation(b0, b1).T
    surf = b1[outer] + n * (r - r0[outer])[:, None]
    snow = x1[body == 0]
    near = np.linalg.norm(snow - b1.mean(0), axis=1) < r + 2 * dx
    if not near.any():
        return -math.inf
    p = snow[near]
    k = np.argmin(((p[:, None, :] - surf[None, :, :]) ** 2).sum(-1), axis=1)
    depth = np.einsum("ij,ij->i", surf[k] - p, n[k])
    return float((depth.max() + reach) / dx)


#: The slope scene's grid, box (m), ground height (m) and frame rate (1/s): ``tests/test_rigid_slope.py``'s.
SLOPE_N_GRID, SLOPE_SIDE, SLOPE_GROUND, SLOPE_FPS = 24, 0.6, 0.05, 60


def slope_setup(theta: float, mu: float, n_grid: int = SLOPE_N_GRID, material: Material = SNOW,
                options: dict | None = None) -> SimSetup:
    """The block of the module docstring (15 x 15 x 5 cm whatever ``n_grid``: 6 x 6 x 2 cells at 24) of
    ``material`` on a ground of friction ``mu``, gravity (9.81 m/s^2) tilted ``theta`` degrees towards +x."""
    dx0 = SLOPE_SIDE / SLOPE_N_GRID
    dx = SLOPE_SIDE / n_grid
    side = np.array([6 * dx0, 6 * dx0, 2 * dx0])
    lo = np.array([4.3 * dx0, SLOPE_SIDE / 2 - side[1] / 2 + 0.2 * dx0, SLOPE_GROUND])
    x, p_vol = box_points(lo, lo + side, dx / 2)
    t = math.radians(theta)
    s = make_setup(x, p_vol, material, gravity=(9.81 * math.sin(t), 0.0, -9.81 * math.cos(t)), lo=np.zeros(3),
                   hi=np.full(3, SLOPE_SIDE), n_grid=n_grid, frame_dt=1.0 / SLOPE_FPS,
                   boundaries=[Boundary("ground", height=SLOPE_GROUND, friction=mu)], options=dict(options or {}))
    s.n_render = 0
    return s


__all__ = ["SNOW", "ball_setup", "surface_depth_dx", "slope_setup"]
