"""The grid's cell and the crack band a brittle body's cracks localise in (what :class:`~gasp_core.seam.setup.SimSetup`
derives from the domain and ``n_grid``; both are also read as ``gasp_core.seam.setup.grid_spacing`` and
``gasp_core.seam.setup.crack_band``), and which points have left the grid (:func:`left_grid`, also read as
``gasp_core.seam.runner.left_grid``)."""
from __future__ import annotations

import numpy as np


def grid_spacing(domain_lo, domain_hi, n_grid: int) -> float:
    """Grid spacing ``dx``, metres: the longest domain side divided by ``n_grid`` (the one formula)."""
    return float(np.max(np.asarray(domain_hi, dtype=np.float64) - np.asarray(domain_lo, dtype=np.float64))) / n_grid


def crack_band(dx: float, p_vol: np.ndarray, body_id: np.ndarray, n_bodies: int) -> np.ndarray:
    """Crack band width ``h`` of each body, metres, shape (n_bodies,), float64: the grid cell ``dx`` for every body
    with material points (0 for a body without any; ``p_vol`` and ``body_id``, shapes (n,), say which).

    ``h`` is the width a crack localises in (Bazant & Oh 1983, Materiaux et Constructions 16). In MLS-MPM a crack's
    velocity jump localises between two nodes: the points in that cell break through. Measured on the tension family
    (round 31, both engines): the work to separate ``G_f`` +1 to +7 % at n_grid 24 and 48 where ``dx + s`` gave -31 %
    at 48 (docs/fracture.md "The crack band"). Each free point's softening range is scaled by its weight on its cell
    (``gasp_core.mpm.materials.band_weight``, round 33): the cell breaks through as one on any point lattice."""
    h = np.zeros(n_bodies)
    pv = np.asarray(p_vol, np.float64)
    h[np.unique(np.asarray(body_id)[pv > 0])] = dx
    return h


def left_grid(x: np.ndarray, setup) -> np.ndarray:
    """Which points' quadratic B-spline stencil (3 nodes an axis from ``floor((x - lo)/dx - 0.5)``) no longer lies
    within the ``n_grid`` nodes of the grid of ``setup`` (a :class:`~gasp_core.seam.setup.SimSetup`): bool, shape
    (n,). The rule of the grid engines' transfers (MLS-MPM's ``base``, Hu et al. 2018); such a point drops out of an
    engine with the feature ``left_domain``."""
    base = np.floor((np.asarray(x, np.float64) - setup.domain_lo) / setup.dx - 0.5)
    return ((base < 0) | (base > setup.n_grid - 3)).any(axis=1)
