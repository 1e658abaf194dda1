"""Scenes of rigid bodies among three or more (round 62, :mod:`gasp_core.mpm.rigid_pairs`, ``tests/test_rigid_three.py``,
``docs/rigid.md`` "Round 62: rigid bodies among three or more").

- :func:`blocks3`: three blocks, one on the other, on a ground (``model`` rigid or elastic per body): at rest
  (:func:`stack_setup`) or the top one thrown along +x on a frictionless ground (:func:`slide_setup`), or apart in
  the air (:func:`fall_setup`).
- :func:`mixed_setup`: a rigid block thrown along a jelly slab on a frictionless ground, a jelly cube resting on the
  slab beside its path.

Each block's points fill its box on a lattice of half a cell (``box_points``); blocks that touch share a face.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points

G = 9.81
SIDE = 0.48
#: The blocks of :func:`slide_setup` (m): the top 6 x 6 x 3 cm (``half`` its half-width), the middle 28 x 16 x 8 cm
#: (thick enough that the top and bottom blocks stay out of each other's reach at n_grid 24, ``colouring.reach``),
#: the bottom 32 x 20 x 3 cm, 8 cm inside the domain's sides (at 2.7 cells from the domain's side, the grid's edge
#: turned the middle block about y at 0.13 rad/s^2, n_grid 32).
MIDDLE_H = 0.08


def _setup(boxes, models, v0, n_grid, ground_mu, frictions, frame=1.0 / 60.0, lo_z=None, gravity=-G) -> SimSetup:
    """Blocks ``boxes`` ((lo, hi) each, m) of jelly (E 1e5 Pa, rho 1000) with ``models`` and ``frictions`` per body,
    the first thrown at ``v0`` (m/s, (3,)); a cube domain of side ``SIDE`` of ``n_grid`` cells, a ground at 0 of
    ``ground_mu`` (None: no ground)."""
    dx = SIDE / n_grid
    pts = [box_points(b0, b1, dx / 2) for b0, b1 in boxes]
    x = np.concatenate([p for p, _ in pts])
    v = np.zeros_like(x)
    v[:len(pts[0][0])] = v0
    mats = [Material("jelly", model=m, E=1.0e5, nu=0.3, rho=1000.0, friction=f) for m, f in zip(models, frictions)]
    lo = np.array([-0.20, -SIDE / 2, -3 * dx if lo_z is None else lo_z])
    s = SimSetup(x=x, v=v, p_vol=np.concatenate([np.full(len(p), pv) for p, pv in pts]),
                 body_id=np.concatenate([np.full(len(p), k) for k, (p, _) in enumerate(pts)]), materials=mats,
                 gravity=np.array([0.0, 0.0, gravity]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                 frame_dt=frame, boundaries=[] if ground_mu is None else [Boundary("ground", height=0.0,
                                                                                   friction=ground_mu)])
    s.n_render = 0
    return s


def slide_setup(n_grid: int = 32, mu: float | None = None, v0: float = 0.5, half: float = 0.03,
                models=("rigid",) * 3) -> SimSetup:
    """The top block (body 0, 2 ``half`` wide, 3 cm tall) thrown at ``v0`` along +x on the middle block (body 1) on
    the bottom block (body 2) lying on a frictionless ground; each body's ``friction`` ``mu`` (None: the default)."""
    h = MIDDLE_H
    boxes = [([-half, -half, 0.03 + h], [half, half, 0.06 + h]), ([-0.10, -0.08, 0.03], [0.18, 0.08, 0.03 + h]),
             ([-0.12, -0.10, 0.0], [0.20, 0.10, 0.03])]
    return _setup(boxes, models, [v0, 0.0, 0.0], n_grid, 0.0, [mu] * 3)


def stack_setup(n_grid: int = 32, size: float = 0.10, mu: float | None = None, models=("rigid",) * 3) -> SimSetup:
    """Three cubes of side ``size`` (m), 2 cm thick plates of it, one on the other centred, on a ground of friction
    0.5: body 0 the bottom (``size`` x ``size`` x 4 cm), body 1 the middle (0.8 ``size`` wide, 4 cm), body 2 the top
    (0.6 ``size`` wide, 4 cm), at rest."""
    boxes, z = [], 0.0
    for f in (1.0, 0.8, 0.6):
        a = f * size / 2
        boxes.append(([-a, -a, z], [a, a, z + 0.04]))
        z += 0.04
    return _setup(boxes, models, [0.0, 0.0, 0.0], n_grid, 0.5, [mu] * 3)


def fall_setup(n_grid: int = 32, gap_cells: float = 1.0) -> SimSetup:
    """Three rigid blocks (10 x 10 x 4 cm, 8 x 8 x 4, 6 x 6 x 4) one over the other, each ``gap_cells`` dx over the
    one below (within each other's reach: different fields, not touching), in the air at rest, no ground; they fall
    together."""
    dx = SIDE / n_grid
    boxes, z = [], 0.15
    for f in (0.10, 0.08, 0.06):
        boxes.append(([-f / 2, -f / 2, z], [f / 2, f / 2, z + 0.04]))
        z += 0.04 + gap_cells * dx
    return _setup(boxes, ("rigid",) * 3, [0.0, 0.0, 0.0], n_grid, None, [None] * 3)


def mixed_setup(n_grid: int = 32, mu: float | None = None, v0: float = 0.5) -> SimSetup:
    """A rigid 6 x 6 x 3 cm block (body 0) thrown at ``v0`` along +x on a jelly slab 32 x 16 x 3 cm (body 1) on a
    frictionless ground, a jelly cube of 5 cm (body 2) resting on the slab's far corner, beside the block's path."""
    boxes = [([-0.03, -0.03, 0.03], [0.03, 0.03, 0.06]), ([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03]),
             ([0.13, 0.02, 0.03], [0.18, 0.07, 0.08])]
    return _setup(boxes, ("rigid", "elastic", "elastic"), [v0, 0.0, 0.0], n_grid, 0.0, [mu] * 3)


def slide_closed_form(s) -> float:
    """Coulomb's slide (m) of body 0 on the others, which move as one on a frictionless ground: ``v0^2 / (2 mu g (1 +
    m0 / m_rest))``, ``mu`` the pair's (``combine_friction`` of bodies 0 and 1)."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    m0, rest = pm[body == 0].sum(), pm[body != 0].sum()
    v0 = float(np.asarray(s.v)[0, 0])
    mu = combine_friction(body_friction(s.materials[0]), body_friction(s.materials[1]))
    return v0 ** 2 / (2 * mu * G * (1 + m0 / rest))
