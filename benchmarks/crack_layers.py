"""The work to separate read on the layers that hold the crack (issue 66, round 44; docs/fracture.md "Round 44", "The
work to separate at 30 deg").

The family's measure (``tension_family.run_case``) is ``int sigma_c dw``: ``sigma_c`` the nominal stress of the crack's
layer, ``w`` the inelastic opening of the layers 2 cells either side of it. It reads the crack's own softening only
where one layer holds the crack, so that layer's stress is the band's: ``sigma_c`` falls to 0 as the band breaks,
whatever the rest of the specimen does. An oblique specimen's layers are slabs normal to its axis ``a``. At 30 deg
about z the world-aligned fill's crack runs along the grid's x planes instead (its normal 6 deg from x, 36 deg from
``a``, 2:1 dog-bone at n_grid 24), across 4 to 5 axial layers, none of which breaks through (their mean ``d`` at most
0.81). The most damaged one's stress is then partly its intact material's, still loaded while the specimen snaps back,
and the measure picks up part of the snap-back's energy (``benchmarks/studies/work_budget.py``).

So the work is read on the family of layers one of which the crack breaks through: the axial slabs where one does
(every aligned case, and 45 deg), else the fill's own x planes (slabs ``h`` wide around the world lattice's planes),
whose force along the axis is ``sum (a . P e_x) V / h`` (the traction on an x plane, ``P e_x``, over its section,
``V / h``) and whose positions, rest and current, are their points' mean ``x . a``.
"""
from __future__ import annotations

import numpy as np

import crack_place as cp
import tension_family as tf
import tension_oblique as to


def x_planes(x0: np.ndarray, pv: np.ndarray, h: float) -> np.ndarray:
    """Each point's x plane of the world fill (n,) int (-1: no volume): the slab ``h`` (m) wide around one of the
    fill grid's planes, found from a point of a whole cell (the largest ``p_vol``), as ``user_tension.layers``."""
    whole = pv >= (1 - 1e-6) * pv.max()
    ref = x0[whole][0, 0]
    k = np.round((x0[:, 0] - ref) / h).astype(int)
    return np.where(pv > 0, k - int(k[pv > 0].min()), -1)


def work_to_separate(force: np.ndarray, pos: np.ndarray, lx: np.ndarray, area: np.ndarray, crack: int,
                     span: np.ndarray, a_gauge: float) -> float:
    """``int sigma_c dw`` (J/m^2): ``force`` (frames, k) each layer's force along the axis (N), ``pos`` (frames, k)
    its mean axial position (m), ``lx`` (k,) its rest one (m), ``area`` (k,) the specimen's section there (m^2);
    ``sigma_c`` the ``crack`` layer's force over ``a_gauge`` (m^2); ``w`` the stretch between the ``span``'s end
    layers less its rest length and each layer's elastic ``force / (area E)`` share, trapezoid over the frames."""
    elastic = (force[:, span[:-1]] / area[span[:-1]] / tf.E * np.diff(lx[span])).sum(axis=1)
    w = pos[:, span[-1]] - pos[:, span[0]] - (lx[span[-1]] - lx[span[0]]) - elastic
    sig_c = force[:, crack] / a_gauge
    return float(np.sum(0.5 * (sig_c[1:] + sig_c[:-1]) * np.diff(w)))


def crack_zone(dmean: np.ndarray, lx: np.ndarray, free: np.ndarray, dx: float) -> tuple[int, np.ndarray]:
    """The crack's layer (:func:`crack_place.crack_layer`: the free one most damaged at the end of ``dmean``
    (frames, k), the first to get there where several tie) and its zone: the free layers whose rest axial ``lx``
    (k,) lies within 2 cells (``dx``, m) of it."""
    crack = cp.crack_layer(dmean, free)
    return crack, np.flatnonzero(free & (np.abs(lx - lx[crack]) <= 2 * dx + 1e-9))


def x_plane_work(out: dict, xl: np.ndarray, pts: tuple, sp: tf.Specimen, dx: float, held: tuple) -> tuple | None:
    """The work to separate and the dissipation (J/m^2, over the gauge's section) read on the fill's x planes
    (``xl`` each point's, :func:`x_planes`; ``user_oblique.record``'s ``force_x``, ``pos_x``, ``dmean_x``);
    ``pts``: the points' ``(p_vol, rest x (n, 3), axis a, final d, dissipation Dp (J))``; ``held``: the faces (x,
    m). None where no free plane breaks through (all its volume at ``d >= 0.9``)."""
    pv, x0, a, d, Dp = pts
    xli, nx, w = np.maximum(xl, 0), int(xl.max()) + 1, np.where(xl >= 0, pv, 0.0)
    vol = np.bincount(xli, w, nx)
    lx = np.bincount(xli, ((x0 - to.CENTRE) @ a + sp.length / 2) * w, nx) / np.maximum(vol, 1e-300)
    free = (vol > 0) & (to.layer_reach(x0[xl >= 0], xl[xl >= 0], nx, *held) > 0)
    if not np.any(free & (np.bincount(xli, (d >= 0.9) * w, nx) >= vol * (1 - 1e-9))):
        return None
    crack, span = crack_zone(out["dmean_x"], lx, free, dx)
    work = work_to_separate(out["force_x"], out["pos_x"], lx, sp.area(lx + tf.X0), crack, span, sp.gauge_w ** 2)
    return work, float(np.bincount(xli, Dp, nx)[span].sum() / sp.gauge_w ** 2)
