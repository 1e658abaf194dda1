"""Where a granular body spreads on the ground, so that a default domain holds it (issue 53's sand column: the
default domain, the footprints padded by ``domain.padding``, let a 6 x 6 x 15 cm column run out of the grid at frame
8 on both grid engines).

A column of granular material of height ``H`` over the ground and equivalent radius ``r_i`` (the cylinder of that
height with the body's volume, its points' convex hull's ``V``: ``r_i = sqrt(V / (pi H))``; a 6 x 6 x 15 cm column
gets 3.4 cm, a guitar 1.1 m tall 12 cm, not the 21 cm of its footprint's box) collapses to a runout ``r_inf`` about its axis (Lube, Huppert, Sparks and
Hallworth 2004, "Axisymmetric collapses of granular columns", J. Fluid Mech. 508: ``r_inf / r_i - 1 = 1.24 a`` for
``a = H / r_i < 1.7`` and ``1.6 a^(1/2)`` above). :func:`runout_reach` gives the box of :data:`RUNOUT_SAFETY` times
that radius about the footprint's centre, at the ground, for each simulated sand body; a liquid or snow spreads by
other laws and is not covered (a stated ``[domain]`` holds it).

The same paper gives the deposit's final height at its centre, ``h_inf / r_i = 0.88 a^(1/6)`` for ``a > 0.74``
(below it the column keeps its height: ``h_inf = H``); :func:`pile_warnings` warns when that pile stands fewer than
:data:`PILE_CELLS` grid cells high, naming the ``n_grid`` that gives that many (issue 53: at n_grid 32 the column's
pile, 38 mm by the law, is 1.9 cells of 19.6 mm, and the pile against the jelly ball read 1.35-1.65 times the free
pile; at n_grid 48-64, 0.88-1.03, and at the 50 the warning names 1.04-1.17, ``benchmarks/sand_ball_pipeline.py``). The law's constants were not read from the
paper here (it was not reachable): they are the values its abstract is widely quoted with; the warning needs only
the pile's height to within a cell.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import ConvexHull, QhullError

#: Lube et al. 2004's laws (module notes): the crossover aspect ratio, and the factors of the two branches.
LUBE_A, LUBE_LOW, LUBE_HIGH = 1.7, 1.24, 1.6
#: The reach is this many times the law's runout: its experiments scatter by about 10 %, and a column carrying light
#: surface points (flat Gaussians 5 mm apart, benchmarks/sand_ball_pipeline.py) spread a thin sheet of them to 1.4
#: times it (it left a domain of 1.25 times at frame 22); the planar law holds the grid engines' bulk within 25 %
#: (the conformance scene ``sand_column_collapse``).
RUNOUT_SAFETY = 1.5
#: Materials that spread as a granular column does (a friction angle).
GRANULAR = ("sand",)
#: Lube et al. 2004's final-height law (module notes): ``h_inf / r_i = LUBE_H a^(1/6)`` above ``a = LUBE_H_A``.
LUBE_H, LUBE_H_A = 0.88, 0.74
#: Fewest grid cells a collapsed pile should stand before a warning: the quadratic B-spline stencil's width, so that
#: the pile's top has nodes of its own above the ground's (module notes: at 1.9 cells the pile against a ball read
#: 1.35-1.65 times the free pile's height, at 3 cells 1.04-1.17).
PILE_CELLS = 3


def column_runout(height: float, r_i: float) -> float:
    """Lube et al. 2004's runout radius ``r_inf`` (m) of a column ``height`` (m) tall of radius ``r_i`` (m) > 0."""
    a = height / r_i
    return r_i * (1.0 + (LUBE_LOW * a if a < LUBE_A else LUBE_HIGH * math.sqrt(a)))


def column_height(height: float, r_i: float) -> float:
    """Lube et al. 2004's final pile height ``h_inf`` (m) of a column ``height`` (m) tall of radius ``r_i`` (m) > 0: the
    column's own height up to ``a = H / r_i`` = :data:`LUBE_H_A`, ``0.88 a^(1/6) r_i`` above (never above ``H``)."""
    a = height / r_i
    return height if a <= LUBE_H_A else min(height, LUBE_H * r_i * a ** (1.0 / 6.0))


def columns(points_by_object, materials, ground: float | None):
    """``(k, height, r_i, lo, hi)`` per granular body ``k`` on the ground (the arguments of :func:`runout_reach`):
    its height over the ground and equivalent radius (m), its points' box (m, shape (3,) each)."""
    for k, (x, m) in enumerate(zip(points_by_object, materials)):
        if ground is None or m.name not in GRANULAR or len(x) == 0:
            continue
        lo, hi = x.min(axis=0), x.max(axis=0)
        height = float(hi[2]) - ground
        if height <= 0.0:
            continue
        try:
            volume = ConvexHull(x).volume
        except QhullError:   # flat or too few points: its footprint's box times its height
            volume = float((hi[0] - lo[0]) * (hi[1] - lo[1])) * height
        yield k, height, max(math.sqrt(volume / (math.pi * height)), 1e-9), lo, hi


def pile_warnings(names, points_by_object, materials, ground: float | None, dx: float, n_grid: int) -> list[str]:
    """Warnings (str) for each granular body whose pile after its collapse (:func:`column_height`) stands fewer than
    :data:`PILE_CELLS` cells of ``dx`` (m) high, naming the ``n_grid`` (the domain kept) that gives that many;
    ``names`` the objects' names, the other arguments :func:`runout_reach`'s. Empty when none."""
    out = []
    for k, height, r_i, _, _ in columns(points_by_object, materials, ground):
        h = column_height(height, r_i)
        if h < PILE_CELLS * dx:
            out.append(f"object '{names[k]}': its sand collapses to a pile about {h:.3g} m high (Lube et al. 2004), "
                       f"{h / dx:.1f} grid cells (dx = {dx:.3g} m); n_grid = {math.ceil(n_grid * PILE_CELLS * dx / h)} "
                       f"gives {PILE_CELLS}")
    return out


def runout_reach(points_by_object, materials, ground: float | None) -> np.ndarray:
    """The corners of the box each granular body can spread over on the ground, metres, shape (4 k, 3).

    Parameters
    ----------
    points_by_object : list of ndarray, shape (n_i, 3)
        Each simulated object's points at rest, metres (z up).
    materials : list of Material
        Their materials (:data:`GRANULAR` names spread).
    ground : float or None
        The lowest ground's height, metres; None: no ground, no reach (nothing to spread on).
    """
    out = []
    for _, height, r_i, lo, hi in columns(points_by_object, materials, ground):
        r = RUNOUT_SAFETY * column_runout(height, r_i)
        c = (lo[:2] + hi[:2]) / 2
        out += [[c[0] + sx * r, c[1] + sy * r, ground] for sx in (-1, 1) for sy in (-1, 1)]
    return np.array(out, float).reshape(-1, 3)


def widen(lo: np.ndarray, hi: np.ndarray, reach: np.ndarray, n_grid: int, stencil: float):
    """The cubic domain ``(lo, hi)`` (m) widened in x and y to hold ``reach`` (k, 3) with ``stencil`` cells to spare,
    its floor kept (a ground's rule); itself when it already does."""
    if not len(reach):
        return lo, hi
    side = float(np.max(hi - lo))
    need_lo = np.minimum(lo[:2], reach[:, :2].min(axis=0) - stencil * side / n_grid)
    need_hi = np.maximum(hi[:2], reach[:, :2].max(axis=0) + stencil * side / n_grid)
    if np.all(need_lo >= lo[:2]) and np.all(need_hi <= hi[:2]):
        return lo, hi
    side = max(side, float(np.max(need_hi - need_lo)) / (1.0 - 2.0 * stencil / n_grid))
    centre = (need_lo + need_hi) / 2
    new_lo = np.array([centre[0] - side / 2, centre[1] - side / 2, lo[2]])
    return new_lo, new_lo + side
