"""Scenes of three solid bodies for round 61's colouring (``gasp_core.mpm.colouring``, ``tests/test_three_bodies.py``,
``docs/contact.md`` "Round 61: a field per body by colouring").

- :func:`stack3`: three jelly balls (R 5 cm) or cubes (side 10 cm) stacked on a ground in a frictionless tube (the
  ``stacked_gap`` scene's, ``gasp_core.testing.scenes_pairs``, with a third body), each 1.5 cells over the one below.
- :func:`slide3`: ``tests/test_block_on_block.py``'s two blocks (the lower 5 cm thick, not 3: the top and bottom
  blocks then stay out of each other's reach, ``colouring.reach``) on a third (48 x 20 x 3 cm) lying on a
  frictionless ground; the top block thrown at ``V0``.
- :func:`fall3`: ``gasp_core.testing.helpers.body_over_box``'s box and cube, and a ball above the cube, each gap
  ``gap_cells`` dx plus the frame's fall: nothing lands in the frame.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.setup import Boundary, Material, SimSetup  # noqa: F401 (SimSetup: the study's pair)
from gasp_core.testing.helpers import box_points, sphere_points
from gasp_core.testing.scenes_pairs import STACK_CLEAR, STACK_DROP, STACK_MAT, STACK_R, SIDE

G = 9.81


def stack3(shape: str = "ball", n_grid: int = 24, n: int = 3) -> SimSetup:
    """Three bodies of ``STACK_MAT`` (jelly E 1e5 Pa, rho 1000) stacked on a ground 4 cells over the floor, in a tube of
    frictionless walls ``STACK_CLEAR`` cells clear of their sides (3 cells inside the domain); ``shape`` "ball" (R
    ``STACK_R``) or "cube" (side ``2 STACK_R``); each starts ``STACK_DROP`` cells over the one below; points at half a
    cell; a 0.6 m tall domain of ``n_grid`` cells; ``n`` bodies (2: the two-body stack, the same measure). Body 0 at
    the bottom."""
    dx = SIDE / n_grid
    h = dx / 2
    if shape == "ball":
        a, p_vol = sphere_points(np.zeros(3), STACK_R, h)
    else:
        a, p_vol = box_points(-np.full(3, STACK_R), np.full(3, STACK_R), h)
    lo_a = a[:, 2].min() - h / 2
    half = STACK_R + STACK_CLEAR * dx + 3 * dx
    ground = 4 * dx
    step = 2 * STACK_R + STACK_DROP * dx
    x = np.concatenate([a + [half, half, ground - lo_a + k * step] for k in range(n)])
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=np.repeat(np.arange(n), len(a)), materials=[STACK_MAT] * n,
                    gravity=np.array([0.0, 0.0, -G]), domain_lo=np.zeros(3),
                    domain_hi=np.array([2 * half, 2 * half, SIDE]), n_grid=n_grid,
                    boundaries=[Boundary("ground", height=ground, friction=0.5), Boundary("walls", friction=0.0)],
                    frame_dt=1.0 / 30.0, n_render=0, options={"threads": 1})


def surface_gaps(x: np.ndarray, body: np.ndarray, p_vol, pairs=((0, 1), (1, 2))) -> list[float]:
    """Per pair of bodies the gap between their lattices' surfaces, m (``scenes_pairs.surface_gap``'s measure: the
    nearest two points less half of each one's spacing ``p_vol^(1/3)``; negative when they overlap)."""
    from scipy.spatial import cKDTree
    h = np.broadcast_to(np.cbrt(np.asarray(p_vol, np.float64)), body.shape)
    out = []
    for i, j in pairs:
        a, b = body == i, body == j
        d, k = cKDTree(x[a]).query(x[b])
        m = int(np.argmin(d))
        out.append(float(d[m] - 0.5 * (h[b][m] + h[a][k[m]])))
    return out


def slide3(n_grid: int = 48, friction: float | None = None, v0: float = 0.5, options=None) -> SimSetup:
    """``tests/test_block_on_block.py``'s scene with a third block: a 6 x 6 x 3 cm block (body 0) thrown at ``v0``
    (m/s) along +x on a 40 x 16 x 5 cm block (body 1) on a 48 x 20 x 3 cm block (body 2) lying on a frictionless
    ground; jelly E 1e5 Pa, rho 1000, each body's ``friction`` (None: the default); a 0.48 m grid of ``n_grid``
    cells, 60 frames a second."""
    side = 0.48
    dx = side / n_grid
    lo = np.array([-0.12, -side / 2, -3 * dx])
    blocks = [([-0.03, -0.03, 0.08], [0.03, 0.03, 0.11]), ([-0.08, -0.08, 0.03], [0.32, 0.08, 0.08]),
              ([-0.10, -0.10, 0.0], [0.38, 0.10, 0.03])]
    pts = [box_points(b0, b1, dx / 2) for b0, b1 in blocks]
    x = np.concatenate([p for p, _ in pts])
    v = np.zeros_like(x)
    v[:len(pts[0][0]), 0] = v0
    mats = [Material("jelly", E=1.0e5, nu=0.3, rho=1000.0, friction=friction) for _ in range(3)]
    s = SimSetup(x=x, v=v, p_vol=np.concatenate([np.full(len(p), pv) for p, pv in pts]),
                 body_id=np.concatenate([np.full(len(p), k) for k, (p, _) in enumerate(pts)]), materials=mats,
                 gravity=np.array([0.0, 0.0, -G]), domain_lo=lo, domain_hi=lo + side, n_grid=n_grid,
                 frame_dt=1.0 / 60.0, boundaries=[Boundary("ground", height=0.0, friction=0.0)],
                 options=dict(options or {}))
    s.n_render = 0
    return s


def fall3(gap_cells: float, n_grid: int = 32, frame: float = 1.0 / 30.0) -> SimSetup:
    """A jelly box (18 x 18 x 6 cm, rho 700) on a ground, a jelly cube (8 cm) over it and a jelly ball (R 5 cm) over
    the cube, each ``gap_cells`` dx plus the frame's free fall ``g t^2 / 2`` above the body below, at rest
    (``gasp_core.testing.helpers.body_over_box``'s box and cube); a 0.6 m grid of ``n_grid`` cells."""
    from gasp_core.testing.helpers import body_over_box
    dx = 0.6 / n_grid
    gap = gap_cells * dx + 0.5 * G * frame ** 2
    s, nb = body_over_box("cube", 0.09, n_grid, gap)
    h = dx / 2
    g = np.mgrid[-0.05:0.05:h, -0.05:0.05:h, -0.05:0.05:h].reshape(3, -1).T + h / 2
    top = s.x[nb:, 2].max() + h / 2 + gap
    ball = g[np.linalg.norm(g, axis=1) <= 0.05] + np.array([0.0, 0.0, top + 0.05])
    x = np.vstack([s.x, ball])
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=np.full(len(x), h ** 3),
                    body_id=np.r_[np.asarray(s.body_id), np.full(len(ball), 2)],
                    materials=[*s.materials, Material("jelly")], gravity=s.gravity, domain_lo=s.domain_lo,
                    domain_hi=s.domain_hi, n_grid=n_grid, boundaries=s.boundaries, frame_dt=frame)


def land3(n_grid: int = 32, drop: float = 0.10) -> SimSetup:
    """A jelly slab (40 x 20 x 6 cm, rho 1000) on a ground (friction 0.5), a jelly cube (6 cm) resting on its left end
    (half a cell over it) and a jelly ball (R 5 cm) ``drop`` m over its right end, at rest: the ball is out of every
    body's reach at the start (``colouring.reach``) and lands on the slab (a body that meets another later in the run:
    round 61's colouring made again per frame, ``colouring.RECOLOUR``). E 1e5 Pa; a 0.6 m grid of ``n_grid`` cells,
    30 frames a second. Bodies: 0 the slab, 1 the cube, 2 the ball."""
    dx = 0.6 / n_grid
    h = dx / 2
    slab, _ = box_points((-0.2, -0.1, 0.0), (0.2, 0.1, 0.06), h)
    cube, _ = box_points((-0.17, -0.03, 0.06 + dx / 2), (-0.11, 0.03, 0.12 + dx / 2), h)
    ball, _ = sphere_points(np.array([0.1, 0.0, 0.06 + drop + 0.05]), 0.05, h)
    x = np.vstack([slab, cube, ball])
    mat = Material("jelly", E=1e5, nu=0.3, rho=1000.0)
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=np.full(len(x), h ** 3),
                    body_id=np.r_[np.zeros(len(slab), int), np.ones(len(cube), int), np.full(len(ball), 2)],
                    materials=[mat] * 3, gravity=np.array([0.0, 0.0, -G]), domain_lo=np.array([-0.3, -0.3, -0.02]),
                    domain_hi=np.array([0.3, 0.3, 0.58]), n_grid=n_grid,
                    boundaries=[Boundary("ground", height=0.0, friction=0.5)], frame_dt=1.0 / 30.0)
