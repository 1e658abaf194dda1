"""The points of a grid (MPM) engine: those held by ``fixed_region`` boundaries, their order by grid cell,
their mass statistics and the passive points no material carries any more."""
from __future__ import annotations

import itertools
import math
from typing import Any, Iterable

import numpy as np

from gasp_core.seam.passive import mass_properties
from gasp_core.seam.setup import Boundary


#: Cells: a boundary plane within this of a node layer passes through it (ties are exact ties).
NODE_TIE = 1e-9


def ground_top_node(height: float, domain_lo_z: float, dx: float) -> int:
    """The highest node layer of a ``ground``: nodes with ``k <= ground_top_node(...)`` are ground nodes.

    The test ``X_z <= height`` of docs/mpm.md, decided once in float64 on the node index, so that
    the node lying on the plane is a ground node in every engine and at every precision. (Decided
    per node in float32, ``lo + k dx`` lands a few 1e-9 m above or below the plane by rounding, and
    the ground moves by a whole cell: the body then sinks one cell deeper and rocks.)

    Parameters
    ----------
    height, domain_lo_z : float
        Ground height and the grid origin's z, metres.
    dx : float
        Cell size, metres.

    Returns
    -------
    int
        ``floor((height - domain_lo_z) / dx + NODE_TIE)``; negative when the ground is below the grid.
    """
    return int(math.floor((float(height) - float(domain_lo_z)) / float(dx) + NODE_TIE))


def fixed_mask(x: np.ndarray, boundaries: Iterable[Boundary]) -> np.ndarray:
    """Points held still: those inside the box ``[lo, hi]`` (closed) of any ``fixed_region``.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Initial positions, metres.
    boundaries : iterable of Boundary

    Returns
    -------
    ndarray, shape (n,), bool
    """
    x = np.asarray(x, dtype=np.float64)
    mask = np.zeros(len(x), dtype=bool)
    for b in boundaries:
        if b.kind == "fixed_region":
            mask |= np.all((x >= np.asarray(b.lo, float)) & (x <= np.asarray(b.hi, float)), axis=1)
    return mask


def cell_order(x: np.ndarray, domain_lo: np.ndarray, dx: float, n_grid: int) -> np.ndarray:
    """Stable order of the points by flat grid-cell index ``(i n_grid + j) n_grid + k``.

    Scatter and gather then touch neighbouring memory (cache locality); being stable, the order
    is the same on every run. Cells are ``floor((x - domain_lo) * (1 / dx))`` clipped to the grid;
    a non-finite position counts as cell 0.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Positions, metres.
    domain_lo : ndarray, shape (3,)
        Grid origin, metres.
    dx : float
        Grid spacing, metres.
    n_grid : int

    Returns
    -------
    ndarray, shape (n,), int64
        ``order[i]`` is the index in ``x`` of the i-th point in cell order.
    """
    X = (np.asarray(x, dtype=np.float64) - domain_lo) * (1.0 / dx)
    with np.errstate(invalid="ignore"):
        c = np.clip(np.nan_to_num(np.floor(X), nan=0.0), 0, n_grid - 1).astype(np.int64)
    key = (c[:, 0] * n_grid + c[:, 1]) * n_grid + c[:, 2]
    return np.argsort(key, kind="stable")


def material_first_order(setup, dx: float) -> tuple[np.ndarray, int]:
    """Point order of a grid engine: material points by cell, then passive points by cell.

    Parameters
    ----------
    setup : SimSetup
        ``setup.passive`` marks the passive rows (G2P only).
    dx : float
        Grid spacing, metres.

    Returns
    -------
    order : ndarray, shape (n,), int64
        ``order[i]`` is the setup row of the engine's i-th point (:func:`cell_order` within each group).
    n_material : int
        Engine points ``[:n_material]`` are material points.
    """
    if setup.passive is None:
        return cell_order(setup.x, setup.domain_lo, dx, setup.n_grid), len(setup.x)
    mat = np.flatnonzero(~setup.passive)
    pas = np.flatnonzero(setup.passive)
    order = np.concatenate([mat[cell_order(setup.x[mat], setup.domain_lo, dx, setup.n_grid)],
                            pas[cell_order(setup.x[pas], setup.domain_lo, dx, setup.n_grid)]])
    return order, len(mat)


def engine_mass_stats(x: np.ndarray, p_mass: np.ndarray) -> dict[str, Any]:
    """``mass`` (kg), ``centre_of_mass`` (m) and ``inertia`` (kg m^2, about the centre of mass) of a grid
    engine's points, for its ``stats()``.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Current positions, metres, read back from the engine.
    p_mass : ndarray, shape (n,)
        The point masses the engine's P2G scatters, kg, read back from the engine in the same
        order (passive points hold 0).
    """
    return mass_properties(x, p_mass)


def stranded_passive(x: np.ndarray, grid_m: np.ndarray, domain_lo: np.ndarray, dx: float) -> int:
    """How many passive points see no node with mass in their quadratic stencil (27 nodes).

    Such a point gathers no velocity (it stays where it is) because the material has moved away
    from it: a surface left hanging where sand or liquid flowed off. Engines report it in
    ``stats()`` as ``passive_stranded``, from the last grid update.

    Parameters
    ----------
    x : ndarray, shape (m, 3)
        Passive points, metres.
    grid_m : ndarray, shape (n_grid, n_grid, n_grid)
        Node masses of the last grid update, kg (index ``[i, j, k]`` = node at ``lo + (i, j, k) dx``).
    domain_lo : ndarray, shape (3,)
        Grid origin, metres.
    dx : float
        Grid spacing, metres.
    """
    if len(x) == 0:
        return 0
    ng = grid_m.shape[0]
    base = np.floor((np.asarray(x, np.float64) - domain_lo) / dx - 0.5).astype(np.int64)
    has = grid_m > 0
    seen = np.zeros(len(x), bool)
    for o in itertools.product(range(3), repeat=3):
        idx = np.clip(base + np.array(o), 0, ng - 1)
        seen |= has[idx[:, 0], idx[:, 1], idx[:, 2]]
    return int((~seen).sum())
