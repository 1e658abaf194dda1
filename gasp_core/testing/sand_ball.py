"""Issue 53's sand column collapsing against a jelly ball (``docs/contact.md``, "Sand that slides on what it touches"):
the scene, built from physics, and the figures of its must-show, measured on the points.

The scene: a square sand column (side ``SIDE_C`` 6 cm, height ``HEIGHT_C`` 15 cm; E 3.5e5 Pa, nu 0.3, rho 1600,
friction angle 30 degrees: the sand of ``sand_column_collapse`` at the issue's angle) on a ground of friction
``MU_GROUND``, its fill at half a cell; a jelly ball (``R`` 5 cm, E 5e4 Pa, nu 0.3, rho 1000) resting on the ground
``GAP`` 5 mm beyond the column's +x face, in its path (or, ``light``, a ball of E 2e4 Pa and rho 300 touching it).
With ``surface`` the column's faces (not its base) also carry points ``SURFACE_SPACING`` 5 mm apart, each with the
volume of a 1 mm sheet of that spacing (the issue's "surface Gaussians 5 mm apart": light points at the surface).
``n_grid`` 32 on a 0.48 m domain (dx 15 mm), frames of 1/30 s.
The free pile is the same column with no ball.

Figures at the last frame (:func:`pair_figures`):

- ``steep``: the fraction of the sand's points within ``1 dx`` of the ball's surface where its slope exceeds 50
  degrees (polar angle from its top between 50 and 90 degrees): sand held on the ball's steep side;
- ``pile``: the sand's height against the ball (``h_pair_mm``: the 95th percentile of the heights of the sand within
  ``1.5 dx`` of the ball's surface and below its top) over the free pile's height (``h_free_mm``: the 99th
  percentile of the free run's sand heights); 1 = as high as the free pile. ``pile_here``: over the free pile's
  height where the ball stood (``h_free_here_mm``, the 95th percentile of the free sand within ``R + 1.5 dx`` of the
  ball's first axis), lower than the pile's top;
- ``depth_dx``: the deepest sand point inside the ball (its nominal radius about its current centroid), over dx;
- ``turn_deg``: the ball's rotation (Kabsch fit of its points, start to end), degrees.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, sphere_points

N_GRID, SIDE = 32, 0.48
DX = SIDE / N_GRID
SIDE_C, HEIGHT_C = 0.06, 0.15
R, GAP = 0.05, 0.005
MU_GROUND = 0.5
SURFACE_SPACING = 0.005
SAND = Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)
BALL = Material("jelly", E=5e4, nu=0.3, rho=1000.0)
#: The light ball (``light``): the jelly of ``jittered_ball_rest`` (E 2e4 Pa, rho 300), touching the column's face.
BALL_LIGHT = Material("jelly", E=2e4, nu=0.3, rho=300.0)
LO = np.array([-0.12, -SIDE / 2, -3 * DX])
#: The column's x range and the ball's centre (m).
COL_X = (0.0, SIDE_C)
BALL_C = np.array([SIDE_C + GAP + R, 0.0, R])


def _surface_points() -> np.ndarray:
    """Points ``SURFACE_SPACING`` apart on the column's four sides and its top (not its base)."""
    s = SURFACE_SPACING
    a = np.arange(s / 2, SIDE_C, s)
    z = np.arange(s / 2, HEIGHT_C, s)
    out = []
    for fixed in (0.0, SIDE_C):
        u, w = np.meshgrid(a - SIDE_C / 2, z, indexing="ij")
        out.append(np.stack([np.full(u.size, fixed), u.ravel(), w.ravel()], 1))
        out.append(np.stack([u.ravel() + SIDE_C / 2, np.full(u.size, fixed - SIDE_C / 2), w.ravel()], 1))
    u, w = np.meshgrid(a, a - SIDE_C / 2, indexing="ij")
    out.append(np.stack([u.ravel(), w.ravel(), np.full(u.size, HEIGHT_C)], 1))
    return np.concatenate(out)


def pair_setup(ball: bool = True, surface: bool = False, options: dict | None = None, light: bool = False,
               rigid: bool = False) -> SimSetup:
    """The column (body 0, or 0 and its surface points) and the ball (the last body) on the ground; ``light``: the
    light ball (:data:`BALL_LIGHT`) touching the column instead; ``rigid``: the ball on the rigid route
    (``model = "rigid"``, ``docs/rigid.md``)."""
    lo = np.array([COL_X[0], -SIDE_C / 2, 0.0])
    xs, vs = box_points(lo, lo + np.array([SIDE_C, SIDE_C, HEIGHT_C]), DX / 2)
    xs_l, vol_l = [xs], [np.full(len(xs), vs)]
    if surface:
        xf = _surface_points()
        xs_l.append(xf)
        vol_l.append(np.full(len(xf), SURFACE_SPACING ** 2 * 1e-3))
    x = np.concatenate(xs_l)
    vol = np.concatenate(vol_l)
    body = np.zeros(len(x), int)
    mats = [SAND]
    if ball:
        c = BALL_C - np.array([GAP if light else 0.0, 0.0, 0.0])
        xb, vb = sphere_points(c + np.array([0.3 * DX, 0.2 * DX, 0.0]), R, DX / 2)
        x, vol = np.concatenate([x, xb]), np.concatenate([vol, np.full(len(xb), vb)])
        body = np.concatenate([body, np.ones(len(xb), int)])
        mats.append(replace(BALL_LIGHT if light else BALL, model="rigid") if rigid else BALL_LIGHT if light else BALL)
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=vol, body_id=body, materials=mats,
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=LO, domain_hi=LO + SIDE, n_grid=N_GRID,
                    frame_dt=1.0 / 30.0, boundaries=[Boundary("ground", height=0.0, friction=MU_GROUND)],
                    options=dict(options or {}))


def rotation_deg(x0: np.ndarray, x1: np.ndarray) -> float:
    """The angle (degrees) of the best-fit rotation taking the points ``x0`` to ``x1`` (Kabsch)."""
    a, b = x0 - x0.mean(0), x1 - x1.mean(0)
    u, _s, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return float(np.degrees(np.arccos(np.clip((np.trace(rot) - 1.0) / 2.0, -1.0, 1.0))))


def sand_reach(setup) -> float:
    """Half the sand's point spacing (m): ``0.5 * median(p_vol) ** (1/3)`` over the bodies but the last (the ball)."""
    body = np.asarray(setup.body_id)
    vol = np.broadcast_to(np.asarray(setup.p_vol, float), body.shape)
    return 0.5 * float(np.median(vol[body != body.max()])) ** (1.0 / 3.0)


def _near_ball(xs: np.ndarray, c: np.ndarray, band: float) -> np.ndarray:
    r = np.linalg.norm(xs - c, axis=1)
    return (r <= R + band) & (xs[:, 2] <= c[2] + R)


def pair_figures(x0: np.ndarray, x1: np.ndarray, body: np.ndarray, free_x1: np.ndarray, reach: float = 0.0) -> dict:
    """The figures of the module's docstring from the start ``x0`` and end ``x1`` (setup order, the ball the last
    body), and the free pile's end ``free_x1`` (its sand in the same order as ``x1``'s sand). ``reach`` (m, default
    0: the points' centres) is added to ``depth_dx``: how far the sand's surface lies beyond its points, half their
    spacing for a fill (round 75: the flowing body's touch holds that surface, ``gasp_core.mpm.flow_reach``)."""
    ball = body == body.max()
    xs, xb = x1[~ball], x1[ball]
    c = xb.mean(0)
    rel = xs - c
    r = np.linalg.norm(rel, axis=1)
    polar = np.degrees(np.arccos(np.clip(rel[:, 2] / np.maximum(r, 1e-12), -1.0, 1.0)))
    steep = (r <= R + DX) & (polar >= 50.0) & (polar <= 90.0)
    near = _near_ball(xs, c, 1.5 * DX)
    c0 = x0[ball].mean(0)
    free_near = (np.linalg.norm(free_x1[:, :2] - c0[:2], axis=1) <= R + 1.5 * DX)
    h_pair = float(np.percentile(xs[near, 2], 95.0)) if near.any() else 0.0
    h_free = float(np.percentile(free_x1[free_near, 2], 95.0)) if free_near.any() else 0.0
    h_peak = float(np.percentile(free_x1[:, 2], 99.0))
    return {"steep": float(steep.mean()), "h_pair_mm": 1e3 * h_pair, "h_free_here_mm": 1e3 * h_free,
            "h_free_mm": 1e3 * h_peak, "pile_here": h_pair / h_free if h_free > 0 else float("inf"),
            "pile": h_pair / h_peak,
            "depth_dx": float((np.max(R - r) + reach) / DX), "turn_deg": rotation_deg(x0[ball], xb),
            "ball_travel_mm": 1e3 * float(np.linalg.norm((c - c0)[:2]))}


def gaussian_normals(rotmats: np.ndarray, scales: np.ndarray, means: np.ndarray) -> np.ndarray:
    """Outward unit normals (n, 3) of flat Gaussians: each one's thin axis (the column of ``rotmats`` (n, 3, 3), world
    frame, with the smallest of ``scales`` (n, 3), m; the pipeline's ball writes it as the first, r1), turned to point
    away from the centroid of ``means`` (n, 3), m. The surface's normal as the Gaussians carry it, not the sphere's."""
    k = np.argmin(scales, axis=1)
    n = rotmats[np.arange(len(k)), :, k]
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    out = np.einsum("ij,ij->i", n, means - means.mean(0))
    return np.where((out < 0.0)[:, None], -n, n)


def normal_depth_dx(sand: np.ndarray, surf: np.ndarray, normals: np.ndarray, dx: float, band: float = 2.0) -> float:
    """Issue 67's must-show figure: the deepest sand Gaussian below the ball's surface along its Gaussians' normals.

    ``sand`` (m, 3) the sand Gaussians' centres, ``surf`` (n, 3) the ball's surface Gaussians' centres and ``normals``
    (n, 3) their outward unit normals (:func:`gaussian_normals`), all in metres at the same frame; ``dx`` the run's
    cell (m). A sand Gaussian ``p`` counts when it lies within ``band`` dx of the ball's surface (``|p - c| < r + band
    dx``, ``c`` the ball's centroid, ``r`` its Gaussians' mean distance from it: any sand inside the ball counts); its
    depth is ``(s - p) . n`` for the ball Gaussian ``s`` nearest to it. Returns the largest depth over those, in dx
    (positive: below the surface; negative: the nearest sand stands that far off), ``-inf`` when no sand is within the
    band. The same idea on points: ``gasp_core.testing.snow.surface_depth_dx``. Raises ``ValueError`` on an empty
    ``surf``."""
    if len(surf) == 0:
        raise ValueError("no ball Gaussians")
    c = surf.mean(0)
    r = float(np.linalg.norm(surf - c, axis=1).mean())
    p = sand[np.linalg.norm(sand - c, axis=1) < r + band * dx]
    if not len(p):
        return -np.inf
    from scipy.spatial import cKDTree
    _, k = cKDTree(surf).query(p)
    return float(np.einsum("ij,ij->i", surf[k] - p, normals[k]).max() / dx)


#: The sliding block (:func:`slide_setup`): a 6 x 6 x 3 cm block of the sand on a 40 x 16 x 3 cm jelly slab (E 2e5 Pa,
#: rho 1000; held on the ground, friction 0.5, by its weight: it carries 2.6 times the block's friction).
SLAB = Material("jelly", E=2e5, nu=0.3, rho=1000.0)
#: The solid block of :func:`slide_setup` ``solid=True``: the slab's jelly (a block that keeps its shape), on a grid of
#: :data:`SOLID_N_GRID` over the same box (the block 8 x 8 x 4 cells: at 32 its 2-cell thickness reads friction 16-20 %
#: high, docs/contact.md "Friction between bodies").
SOLID_N_GRID = 64


def slide_setup(v0: float, options: dict | None = None, ground: bool = False, solid: bool = False,
                slab_h: float = 0.03) -> SimSetup:
    """The block (body 0) thrown along +x at ``v0`` (m/s) over the slab (body 1, ``slab_h`` m thick: 3 cm, or
    :data:`COULOMB_SLAB_H`), touching it at rest.

    Coulomb's law on the block's whole base decelerates its mass centre at ``mu g`` while all of it slides forward
    (only the slab pushes on it): a block that keeps its shape (``solid``: the jelly, ``mu`` the two soft bodies'
    :data:`gasp_core.mpm.fields.SOLID_FRICTION`) stops after ``v0^2 / (2 mu g)`` (:func:`slide_travel`). A sand
    block spreads as it slides (its back slips backwards once it slows, and friction there pushes it on), so its
    answer is measured: ``ground=True`` throws it along the ground itself, no slab, the ground's friction the sand's
    ``tan(phi)``: the grid's boundary rule with the same coefficient (the solid block there stops within 0.4 % of
    Coulomb's travel)."""
    n_grid = SOLID_N_GRID if solid else N_GRID
    dx = SIDE / n_grid
    lo = np.array([-0.12, -SIDE / 2, -3 * dx])
    base = 0.0 if ground else slab_h
    xs, vs = box_points([-0.03, -0.03, base], [0.03, 0.03, base + 0.03], dx / 2)
    xb, vb = (np.zeros((0, 3)), 0.0) if ground else box_points([-0.08, -0.08, 0.0], [0.32, 0.08, slab_h], dx / 2)
    x = np.concatenate([xs, xb])
    v = np.zeros_like(x)
    v[:len(xs), 0] = v0
    mats = [SLAB if solid else SAND] + ([] if ground else [SLAB])
    bounds = [Boundary("ground", height=0.0,
                       friction=float(np.tan(np.radians(SAND.friction_angle))) if ground else MU_GROUND)]
    return SimSetup(x=x, v=v, p_vol=np.concatenate([np.full(len(xs), vs), np.full(len(xb), vb)]),
                    body_id=np.concatenate([np.zeros(len(xs), int), np.ones(len(xb), int)]), materials=mats,
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                    frame_dt=1.0 / 30.0, boundaries=bounds, options=dict(options or {}))


def slide_travel(x0: np.ndarray, x1: np.ndarray, setup: SimSetup) -> float:
    """The block's mass-centre travel along x (m) from ``x0`` to ``x1`` (setup order)."""
    sel = np.asarray(setup.body_id) == 0
    m = setup.p_mass[sel]
    return float((m @ x1[sel, 0] - m @ x0[sel, 0]) / m.sum())


#: The slab of :func:`coulomb_ratio`'s scene (m): 3 cells at n_grid 32. On the 3 cm slab (2 cells) the ratio read
#: 4.9-7.8 % over ``mu`` from the throw (frames 1-3: 1.2-2.3 %), and the stiff slab's travel 6 %, until round 41
#: (docs/contact.md "Round 41": the slab's middle node layer, with no normal of its own, and its ground friction
#: braking the sand there); now within 0.1 % on both (``tests/test_thin_support.py``).
COULOMB_SLAB_H = 0.045


def coulomb_ratio(v: np.ndarray, setup: SimSetup, f0: int, f1: int, body: int = 0) -> float:
    """Coulomb's law read on the block (body ``body``, 0 unless told) between frames ``f0`` and ``f1``: its
    horizontal momentum lost over
    the normal impulse its support gave it, ``-(V_x(f1) - V_x(f0)) / (g T + V_z(f1) - V_z(f0))`` (``V`` its mass
    centre's velocity from the points' ``v``, shape (n_frames + 1, n, 3), m/s; ``T`` the time between the frames;
    ``g`` = -``setup.gravity[2]``), dimensionless. Only the support (a body or the ground) pushes on the block besides
    gravity, so while the whole base slides forward Coulomb's law makes it the support's ``mu``, however the block
    deforms: a slump that lowers the normal load (the sand block spreading) lowers both impulses alike.

    Raises
    ------
    ValueError
        ``f1 <= f0`` or a frame outside ``v``."""
    if not 0 <= f0 < f1 < len(v):
        raise ValueError(f"coulomb_ratio: frames f0 {f0}, f1 {f1}: expected 0 <= f0 < f1 <= {len(v) - 1}")
    sel = np.asarray(setup.body_id) == body
    m = setup.p_mass[sel]
    vc = np.einsum("i,fij->fj", m, v[[f0, f1]][:, sel]) / m.sum()
    g = -float(setup.gravity[2])
    return float(-(vc[1, 0] - vc[0, 0]) / (g * (f1 - f0) * setup.frame_dt + vc[1, 2] - vc[0, 2]))


def two_slab_setup(v0: float, mus=(0.3, 1.0), options: dict | None = None, model: str = "") -> SimSetup:
    """Two :func:`slide_setup` slabs side by side (round 42, ``docs/contact.md`` "Round 42: several bodies' frictions
    in field B"): bodies 1 and 3, each 40 x 16 x 4.5 cm (:data:`COULOMB_SLAB_H`), ``y`` in [-0.16, 0] and [0, 0.16] m
    (touching along ``y = 0``), their ``friction`` ``mus`` (dimensionless; a board and a rubber mat), ``model``
    ``"rigid"`` for rigid slabs (else the jelly's own); a sand block
    (bodies 0 and 2, 6 x 6 x 3 cm) thrown along +x at ``v0`` (m/s) on each, centred 8 cm from the seam. Field B is
    both slabs, field A both blocks: each block's :func:`coulomb_ratio` (``body`` 0 or 2) reads its own pair's
    ``sqrt(tan(phi) mu)``."""
    dx = SIDE / N_GRID
    lo = np.array([-0.12, -SIDE / 2, -3 * dx])
    h = COULOMB_SLAB_H
    xs, ys, xb, yb = [], [], [], []
    for y0 in (-0.08, 0.08):
        pts, vs = box_points([-0.03, y0 - 0.03, h], [0.03, y0 + 0.03, h + 0.03], dx / 2)
        xs.append(pts)
        pts, vb = box_points([-0.08, y0 - 0.08, 0.0], [0.32, y0 + 0.08, h], dx / 2)
        xb.append(pts)
    parts = [xs[0], xb[0], xs[1], xb[1]]
    x = np.concatenate(parts)
    v = np.zeros_like(x)
    v[:len(xs[0]), 0] = v0
    v[len(xs[0]) + len(xb[0]):2 * len(xs[0]) + len(xb[0]), 0] = v0
    slabs = [replace(SLAB, friction=float(mu), **({"model": model} if model else {})) for mu in mus]
    mats = [SAND, slabs[0], SAND, slabs[1]]
    return SimSetup(x=x, v=v, p_vol=np.concatenate([np.full(len(q), vs if i % 2 == 0 else vb)
                                                    for i, q in enumerate(parts)]),
                    body_id=np.concatenate([np.full(len(q), i, int) for i, q in enumerate(parts)]), materials=mats,
                    gravity=np.array([0.0, 0.0, -9.81]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=N_GRID,
                    frame_dt=1.0 / 30.0, boundaries=[Boundary("ground", height=0.0, friction=MU_GROUND)],
                    options=dict(options or {}))
