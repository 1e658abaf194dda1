"""Scenes of rigid bodies among three or more (round 62, :mod:`gasp_core.mpm.rigid_pairs`,
``tests/test_rigid_three.py``, ``docs/rigid.md`` "Round 62: rigid bodies among three or more").

- :func:`blocks3`: three blocks, one on the other, on a ground (``model`` rigid or elastic per body): at rest
  (:func:`stack_setup`) or the top one thrown along +x on a frictionless ground (:func:`slide_setup`), or apart in
  the air (:func:`fall_setup`).
- :func:`mixed_setup`: a rigid block thrown along a jelly slab on a frictionless ground, a jelly cube resting on the
  slab beside its path.
- :func:`heap_setup`: many rigid blocks (columns of blocks on a ground, the top layer dropped onto them), the cost
  scene of round 63 (``benchmarks/rigid_pairs_cost.py``).

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
                models=("rigid",) * 3, push: bool = False) -> SimSetup:
    """The top block (body 0, 2 ``half`` wide, 3 cm tall) thrown at ``v0`` along +x on the middle block (body 1) on
    the bottom block (body 2) lying on a frictionless ground; each body's ``friction`` ``mu`` (None: the default).
    ``push``: at rest, pushed by an ``[[impulse]]`` (``add``, ``v0`` along x at t = 0 on a box around the top block
    only) instead of thrown."""
    from gasp_core.colliders.model import Impulse
    h = MIDDLE_H
    boxes = [([-half, -half, 0.03 + h], [half, half, 0.06 + h]), ([-0.10, -0.08, 0.03], [0.18, 0.08, 0.03 + h]),
             ([-0.12, -0.10, 0.0], [0.20, 0.10, 0.03])]
    s = _setup(boxes, models, [0.0 if push else v0, 0.0, 0.0], n_grid, 0.0, [mu] * 3)
    if push:   # the region: around the top block, from past the middle block's nodes (1.5 cells over its face)
        s.impulses = [Impulse("box", (v0, 0.0, 0.0), 0.0, 0.0, lo=(-half - 0.01, -half - 0.01, 0.03 + h + 1.6 * s.dx),
                              hi=(half + 0.01, half + 0.01, 0.07 + h))]
    return s


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


def fall_setup(n_grid: int = 32, gap_cells: float = 1.0, v_apart: float = 0.2) -> SimSetup:
    """Three rigid blocks (10 x 10 x 4 cm, 8 x 8 x 4, 6 x 6 x 4) one over the other, each ``gap_cells`` dx over the
    one below (within each other's reach: different fields, not touching), in the air, no ground, moving apart: the
    bottom at ``-v_apart`` m/s along z, the middle at rest, the top at ``+v_apart`` (bodies that shared a field would
    drag each other)."""
    dx = SIDE / n_grid
    boxes, z = [], 0.15
    for f in (0.10, 0.08, 0.06):
        boxes.append(([-f / 2, -f / 2, z], [f / 2, f / 2, z + 0.04]))
        z += 0.04 + gap_cells * dx
    s = _setup(boxes, ("rigid",) * 3, [0.0, 0.0, 0.0], n_grid, None, [None] * 3)
    s.v = np.array(np.broadcast_to(np.asarray(s.v, float), np.shape(s.x)))
    s.v[:, 2] = v_apart * (np.asarray(s.body_id) - 1.0)
    return s


def mixed_setup(n_grid: int = 32, mu: float | None = None, v0: float = 0.5) -> SimSetup:
    """A rigid 6 x 6 x 3 cm block (body 0) thrown at ``v0`` along +x on a jelly slab 32 x 16 x 3 cm (body 1) on a
    frictionless ground, a jelly cube of 5 cm (body 2) resting on the slab's far corner, beside the block's path."""
    boxes = [([-0.03, -0.03, 0.03], [0.03, 0.03, 0.06]), ([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03]),
             ([0.13, 0.02, 0.03], [0.18, 0.07, 0.08])]
    return _setup(boxes, ("rigid", "elastic", "elastic"), [v0, 0.0, 0.0], n_grid, 0.0, [mu] * 3)


def heap_setup(n_grid: int = 48, cols: int = 4, layers: int = 3, side: float = 0.04, height: float = 0.05,
               gap_cells: float = 4.0, drop: float = 0.5) -> SimSetup:
    """``cols x cols`` columns of ``layers`` rigid blocks (``side`` x ``side`` x ``height``, m; ``cols**2 *
    layers`` bodies) on a ground of friction 0.5, the columns ``gap_cells`` dx apart (beyond the colouring's reach at
    rest, as are a column's blocks two apart when ``height`` exceeds it: the reach graph is the columns' chains,
    bipartite). Each column's blocks lie one on the other, the top one ``drop``
    dx over the one below it, falling onto it. Round 63's cost scene (``docs/rigid.md`` "Round 63")."""
    dx = SIDE / n_grid
    pitch = side + gap_cells * dx
    x0 = 0.04 - 0.5 * (cols * side + (cols - 1) * gap_cells * dx)
    y0 = -0.5 * (cols * side + (cols - 1) * gap_cells * dx)
    boxes = []
    for i in range(cols):
        for j in range(cols):
            z = 0.0
            for k in range(layers):
                z += drop * dx if k == layers - 1 and k > 0 else 0.0
                lo = [x0 + i * pitch, y0 + j * pitch, z]
                boxes.append((lo, [lo[0] + side, lo[1] + side, z + height]))
                z += height
    return _setup(boxes, ("rigid",) * len(boxes), [0.0, 0.0, 0.0], n_grid, 0.5, [None] * len(boxes))


def slide_closed_form(s, v0: float | None = None) -> float:
    """Coulomb's slide (m) of body 0 on the others, which move as one on a frictionless ground: ``v0^2 / (2 mu g (1 +
    m0 / m_rest))``, ``mu`` the pair's (``combine_friction`` of bodies 0 and 1)."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    m0, rest = pm[body == 0].sum(), pm[body != 0].sum()
    v0 = float(np.asarray(s.v)[0, 0]) if v0 is None else float(v0)
    mu = combine_friction(body_friction(s.materials[0]), body_friction(s.materials[1]))
    return v0 ** 2 / (2 * mu * G * (1 + m0 / rest))


def _run(engine: str, s, T: float):
    """``(centres (frames + 1, n_bodies, 3), rotations (n_bodies,) deg, vz (n_bodies,), px (frames + 1,))``: the mass
    centres per frame over ``T`` (s), each body's turn at the end (deg; the best rotation of its points about its
    centre, Kabsch), its mean point velocity along z at the end, and the material's x momentum per frame (kg m/s)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    e = build_engine(get_engine(engine), s)
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    nb = len(s.materials)

    def centres(X):
        return np.array([(X[body == k] * pm[body == k, None]).sum(0) / pm[body == k].sum() for k in range(nb)])
    X0 = np.asarray(s.x, float)
    C, px = [centres(X0)], [float((pm * np.asarray(s.v, float)[:, 0]).sum())]
    for _ in range(round(T / s.frame_dt)):
        e.step_frame()
        C.append(centres(e.positions().astype(float)))
        px.append(float((pm * e.velocities().astype(float)[:, 0]).sum()))
    X, V = e.positions().astype(float), e.velocities().astype(float)
    turn = []
    for k in range(nb):
        a, b = X0[body == k] - C[0][k], X[body == k] - C[-1][k]
        u, _, vt = np.linalg.svd(b.T @ a)   # the best rotation b ~ R a (Kabsch)
        R = u @ vt
        turn.append(float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1)))))
    vz = np.array([float((V[body == k, 2] * pm[body == k]).sum() / pm[body == k].sum()) for k in range(nb)])
    e.close() if hasattr(e, "close") else None
    return np.array(C), np.array(turn), vz, np.array(px)


def measure_rest(engine: str, s, T: float = 1.2, settle: float = 0.2) -> dict:
    """A stack at rest (:func:`stack_setup`): ``sink`` (m, per body), the centre's fall over the first ``settle`` s;
    ``creep`` (m, per body), its largest move over the next ``T - settle`` s; ``gap`` (m, per pair bottom up), the
    change of the centres' separation along z over the whole run; ``turn`` (deg, per body)."""
    C, turn, _, _ = _run(engine, s, T)
    k = round(settle / s.frame_dt)
    creep = np.abs(C[k:] - C[k]).max(axis=(0, 2))
    gap = (C[-1, 1:, 2] - C[-1, :-1, 2]) - (C[0, 1:, 2] - C[0, :-1, 2])
    return {"sink": C[0, :, 2] - C[k, :, 2], "creep": creep, "gap": gap, "turn": turn}


def measure_slide(engine: str, s, T: float = 0.3) -> dict:
    """A thrown top block (:func:`slide_setup`, :func:`mixed_setup`): ``slide`` (m), the change of the separation of
    bodies 0 and 1 along x over ``T``; ``closed`` (m), :func:`slide_closed_form`; ``momentum``, the bodies' total
    x momentum at the end (over the last 0.1 s) over the throw's, less 1; ``v`` (m/s per body) their x velocities
    then; ``turn`` (deg per body). A push by an ``[[impulse]]`` (``slide_setup``'s ``push``) gives the grid nodes in
    its region its change, so the block takes part of it: the throw is then the x momentum after the first frame
    (``v0`` that over body 0's mass, ``closed`` for that ``v0``)."""
    C, turn, _, px = _run(engine, s, T)
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    k = round(0.1 / s.frame_dt)
    v = (C[-1, :, 0] - C[-1 - k, :, 0]) / (k * s.frame_dt)
    m = np.array([pm[body == b].sum() for b in range(len(s.materials))])
    p0 = px[1] if s.impulses else float(m[0] * np.asarray(s.v)[0, 0])
    closed = slide_closed_form(s, p0 / m[0] if s.impulses else None)
    return {"slide": float((C[-1, 0, 0] - C[-1, 1, 0]) - (C[0, 0, 0] - C[0, 1, 0])), "closed": closed,
            "momentum": float((m * v).sum() / p0 - 1.0), "v": v, "turn": turn, "v0": p0 / m[0]}


def measure_slide_mu(engine: str, s, T: float = 0.15, until: float = 0.2) -> dict:
    """Round 67: Coulomb's law itself on the thrown top block (:func:`slide_setup`): the friction impulse over the
    normal one while it slides. ``mu`` = ``-m0 dVx / (m0 (dVz + g dt))`` from the throw (t = 0) to the last frame
    before its slip on the others (their velocity from the momentum kept, ``(P - m0 Vx) / m_rest``, as
    :func:`slide_closed_form` moves them as one) first falls under ``until`` of the throw: body 0's x and z velocities
    (its points' mass-weighted means, a rigid block's), the normal impulse from its vertical momentum's balance. The
    slide's length also reads the normal load's course (the jelly rings under the block at n_grid 32, the block loses
    its load for frames, and its slip overshoots to -0.04 m/s before it sticks: ``docs/rigid.md`` "Round 67: the
    sandwich's slide"); this ratio does not. ``mu_closed`` the pair's ``mu`` (``combine_friction``); ``frames`` the
    frames of the phase; ``slip`` (m/s per frame)."""
    from gasp_core.mpm.fields import body_friction, combine_friction
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    e = build_engine(get_engine(engine), s)
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    m0, rest = pm[body == 0], float(pm[body != 0].sum())
    v0 = float(np.asarray(s.v)[0, 0])
    P = float(m0.sum()) * v0
    V, slip = [], []
    for _ in range(round(T / s.frame_dt)):
        e.step_frame()
        V.append(m0 @ e.velocities().astype(float)[body == 0] / m0.sum())
        slip.append(V[-1][0] - (P - float(m0.sum()) * V[-1][0]) / rest)
    e.close() if hasattr(e, "close") else None
    V, slip = np.array(V), np.array(slip)
    k = int(np.argmax(slip < until * v0)) - 1 if np.any(slip < until * v0) else len(slip) - 1
    t = (k + 1) * s.frame_dt
    mu = (v0 - V[k, 0]) / (V[k, 2] + G * t) if k >= 0 else float("nan")
    return {"mu": float(mu), "mu_closed": combine_friction(body_friction(s.materials[0]), body_friction(s.materials[1])),
            "frames": k + 1, "slip": slip}


def measure_fall(engine: str, s, T: float = 0.1) -> dict:
    """Blocks in the air (:func:`fall_setup`): ``vz`` (m/s per body) their mean velocity along z after ``T`` and
    ``expect`` (m/s per body) ``v0_z - g T``."""
    _, _, vz, _ = _run(engine, s, T)
    v0 = np.array([float(np.asarray(s.v)[np.asarray(s.body_id) == b, 2].mean()) for b in range(len(s.materials))])
    return {"vz": vz, "expect": v0 - G * round(T / s.frame_dt) * s.frame_dt}


def measure_heap(engine: str, s, T: float = 0.3, settle: float = 0.1) -> dict:
    """A heap (:func:`heap_setup`): ``creep`` (m, per body), the largest move of its centre from ``settle`` s to ``T``
    (the top blocks have landed by then); ``turn`` (deg, per body) over the run; ``drop`` (m, per body) its centre's
    fall over the first ``settle`` s."""
    C, turn, _, _ = _run(engine, s, T)
    k = round(settle / s.frame_dt)
    return {"creep": np.abs(C[k:] - C[k]).max(axis=(0, 2)), "turn": turn, "drop": C[0, :, 2] - C[k, :, 2]}

