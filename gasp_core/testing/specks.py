"""Passive surface points left away from the material (issue 66, "What a user sees": no speck away from every piece),
counted on the raw passive points the engine moves, before any rendering rule (``gasp_core.run.apart`` counts the
drawn Gaussians after :func:`~gasp_core.run.apart.hold_to_pieces`; this counts what the grid gather did).

A passive point is a *speck* at a frame when its position is further than ``reach`` (m; 1 ``dx`` by default) from
every material point. The brittle balls of :mod:`gasp_core.testing.scenes_pieces` get a skin of passive points here
(:func:`ball_with_skin`: a Fibonacci sphere at the ball's radius, inside 1 ``dx`` of the fill at rest), so the count is
0 at rest. Used by ``tests/test_passive_specks.py`` and ``benchmarks/passive_specks.py``.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.testing.helpers import box_points
from gasp_core.testing.scenes_pieces import ball_setup


def speck_distances(x: np.ndarray, passive: np.ndarray) -> np.ndarray:
    """Each finite passive row's distance (m) to the nearest finite material row of ``x`` (n, 3; m); ``passive``:
    (n,) bool."""
    x = np.asarray(x, np.float64)
    passive = np.asarray(passive, bool)
    mat = x[~passive]
    mat = mat[np.isfinite(mat).all(axis=1)]
    pas = x[passive]
    pas = pas[np.isfinite(pas).all(axis=1)]
    return cKDTree(mat).query(pas, k=1)[0]


def count_specks(x: np.ndarray, passive: np.ndarray, reach: float) -> tuple[int, float]:
    """``(specks, farthest)``: how many of the finite passive rows of ``x`` (n, 3; m) lie further than ``reach`` (m)
    from every finite material row, and the largest such distance over all passive rows (m)."""
    d = speck_distances(x, passive)
    return int((d > reach).sum()), float(d.max()) if len(d) else 0.0


def fibonacci_sphere(center, radius: float, n: int) -> np.ndarray:
    """``n`` points spread evenly over a sphere (n, 3; m)."""
    k = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * k / n)
    theta = math.pi * (1 + 5 ** 0.5) * k
    u = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], axis=1)
    return np.asarray(center, float) + radius * u


def ball_with_skin(speed: float, n_grid: int = 32, radius: float = 0.1, n_skin: int = 2000) -> SimSetup:
    """:func:`gasp_core.testing.scenes_pieces.ball_setup` with ``n_skin`` passive points on the sphere of ``radius``
    (the rows first, as rendered rows must be; volume 0), moving at the ball's speed."""
    s = ball_setup(speed, n_grid, radius)
    fill = np.asarray(s.x, np.float64)
    c = fill.mean(axis=0)
    skin = fibonacci_sphere(c, radius, n_skin)
    x = np.concatenate([skin, fill])
    v = np.concatenate([np.broadcast_to(np.asarray(s.v)[0], (n_skin, 3)), np.asarray(s.v)])
    return SimSetup(x=x, v=v, p_vol=np.concatenate([np.zeros(n_skin), s.p_vol]), body_id=0, materials=s.materials,
                    gravity=s.gravity, domain_lo=s.domain_lo, domain_hi=s.domain_hi, n_grid=s.n_grid,
                    frame_dt=s.frame_dt, boundaries=s.boundaries, options=dict(s.options, passive_every=1),
                    n_render=n_skin, passive=np.arange(len(x)) < n_skin)


def slab_by_a_spinning_point(omega: float = 100.0, n_grid: int = 32) -> SimSetup:
    """A jelly slab at rest (no gravity; fill spacing ``dx / 2``, its top fill layer at ``z_top``), a skin of passive
    points ``dx / 2`` above its top (spacing ``dx / 2`` over its middle), and one lone material point ``3.25 dx``
    above ``z_top`` over the slab's middle, at rest but spinning about z: ``C = omega [z]x`` (``omega`` rad/s), which
    APIC keeps for ever on an isolated point, so the nodes of its stencil carry ``omega`` times their offset (up to
    1.5 ``dx``). Its nodes (from ``z_top + 1.75 dx`` up) are not the slab's (up to ``z_top + 1.5 dx``): the slab does
    not feel it, but the skin's stencils reach its lowest nodes. Domain the unit cube, ``n_grid`` cells."""
    dx = 1.0 / n_grid
    fill, vol = box_points([0.3, 0.3, 0.3], [0.7, 0.7, 0.45], dx / 2)
    z_top = float(fill[:, 2].max())
    g = 0.5 + dx * (np.arange(-6, 7) / 2.0 + 0.25)
    skin = np.stack(np.meshgrid(g, g, [z_top + dx / 2], indexing="ij"), -1).reshape(-1, 3)
    lone = np.array([[0.5, 0.5, z_top + 3.25 * dx]])
    x = np.concatenate([skin, lone, fill])
    C = np.zeros((len(x), 3, 3))
    C[len(skin)] = [[0.0, -omega, 0.0], [omega, 0.0, 0.0], [0.0, 0.0, 0.0]]
    n = len(skin)
    return SimSetup(x=x, v=np.zeros_like(x), p_vol=np.r_[np.zeros(n), np.full(len(x) - n, vol)], body_id=0,
                    materials=[Material("jelly", E=1e5, nu=0.3, rho=500.0)], gravity=np.zeros(3),
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid, frame_dt=1e-3, n_render=n,
                    passive=np.arange(len(x)) < n, C=C, options={"passive_every": 1})


def speck_run(name: str, setup: SimSetup, n_frames: int, reach: float | None = None) -> dict:
    """Run ``setup`` on engine ``name`` for ``n_frames`` frames; per frame (0 .. n_frames) ``specks`` and ``farthest``
    (:func:`count_specks` at ``reach``, default ``setup.dx``), ``specks_1.5`` and ``specks_3`` (at 1.5 and 3 times
    ``reach``) and ``vmax``, the material points' fastest speed (m/s);
    with ``dx`` (m), ``dt`` (the substep, s; the frame where the engine gives none) and ``n_passive``."""
    reach = setup.dx if reach is None else reach
    passive = np.asarray(setup.passive, bool)
    out = {"specks": [], "specks_1.5": [], "specks_3": [], "farthest": [], "vmax": [], "dx": float(setup.dx),
           "n_passive": int(passive.sum())}

    def count(x, v):
        d = speck_distances(x, passive)
        out["specks"].append(int((d > reach).sum()))
        out["specks_1.5"].append(int((d > 1.5 * reach).sum()))
        out["specks_3"].append(int((d > 3 * reach).sum()))
        out["farthest"].append(float(d.max()))
        vm = np.linalg.norm(np.asarray(v, np.float64)[~passive], axis=1)
        out["vmax"].append(float(np.nanmax(vm)))

    count(setup.x, np.broadcast_to(setup.v, np.shape(setup.x)))
    e = build_engine(engines()[name], setup)
    try:
        for _ in range(n_frames):
            e.step_frame()
            count(np.asarray(e.positions(), np.float64), e.velocities())
        out["dt"] = float(e.stats().get("dt", setup.frame_dt))
    finally:
        e.close()
    return out


def crumb_with_vertices(rate: float = 40.0, n_grid: int = 32, speed: float = 1.0, kind: str = "stretch") -> SimSetup:
    """One lone material point (a crumb: a jelly of ``E`` 10 Pa, so its own stress barely acts over the run) moving
    at ``speed`` m/s along x with an affine velocity gradient ``C`` (1/s; APIC keeps an isolated point's ``C``),
    ``kind`` ``"stretch"`` (``rate`` times the identity) or ``"shear"`` (``rate`` in the xy and yx entries), and 8
    passive vertices at ``0.6 dx`` along the diagonals around it, as a shed crumb's vertices. Its nodes carry ``v_p +
    C (x_i - x_p)``; a vertex that reads that field away from the crumb leaves it. Domain the unit cube, no gravity,
    ``n_grid`` cells, the crumb at (0.3, 0.5, 0.5) off the nodes."""
    if kind not in ("stretch", "shear"):
        raise ValueError(f"kind: 'stretch' or 'shear', got {kind!r}")
    dx = 1.0 / n_grid
    crumb = np.array([0.3 + 0.3 * dx, 0.5 + 0.2 * dx, 0.5 + 0.1 * dx])
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)
    verts = crumb + 0.6 * dx * signs / np.sqrt(3.0)
    x = np.concatenate([verts, crumb[None]])
    C = np.zeros((len(x), 3, 3))
    C[-1] = rate * np.eye(3) if kind == "stretch" else [[0.0, rate, 0.0], [rate, 0.0, 0.0], [0.0, 0.0, 0.0]]
    v = np.zeros_like(x)
    v[:, 0] = speed
    n = len(verts)
    return SimSetup(x=x, v=v, p_vol=np.r_[np.zeros(n), (dx / 2) ** 3], body_id=0,
                    materials=[Material("jelly", E=10.0, nu=0.3, rho=1000.0)], gravity=np.zeros(3),
                    domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=n_grid, frame_dt=1e-3, n_render=n,
                    passive=np.arange(len(x)) < n, C=C, options={"passive_every": 1})
