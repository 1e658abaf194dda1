"""Can a body carry itself? The Young's modulus a standing elastic body needs not to buckle or fall under its own
weight in an MPM simulation, estimated from its material points (issues 28 and 38, item 6).

One function, :func:`stand_estimate`, gives the value ``gasp simulate`` warns with and ``gasp info --rho`` reports:
it reads the body's points (those with ``p_vol > 0`` carry its weight; a passive surface's only mark its skin),
their volumes and the grid's ``dx``, so every command that builds the same points gets the same ``E``.

Model (source: Greenhill's self-weight column, Timoshenko & Gere, *Theory of Elastic Stability*, 1961, sec. 2.10,
generalised to a body whose section and load vary with height; the factors below are measured in this repo):

1. **Base and footprint.** The body stands on its lowest points. The points within ``h_b = max(FOOT_SHARE H,
   CONTACT_CELLS dx)`` of its lowest (``H``: its height) are the base the ground holds (the contact reaches about a
   cell: a rounded base, such as a lying donut's, touches all round within it); the convex hull of their
   horizontal positions is the footprint. A body whose centre of mass lies outside it tips over at any ``E``.
2. **Column.** Above ``h_b`` the body is a beam clamped on its base, free at its top, with per section (``N_SECTIONS``
   slices) the weight above it ``W(z)`` (N) and the smaller principal second moment of area ``I(z)`` (m^4). ``W`` and
   the section's area ``A`` come from the points' volumes (each point a cube of side ``p_vol^(1/3)``, spread over the
   slices it spans); the section's shape from all its points, a passive skin's included (squares of their side,
   rasterised, closed over one-cell gaps, holes filled), so a full model and a passive surface see the same solid.
   It buckles under its weight at the smallest ``E`` for which no bending shape ``theta(z)`` (the lean of the
   section, ``theta(h_b) = 0``) releases more weight than it stores in bending (Rayleigh):

       E_static = max_theta  integral W(z) theta(z)^2 dz  /  integral I(z) / s(z) theta'(z)^2 dz

   solved as a generalised eigenproblem on the sections. For a uniform column of height ``L`` above its base this
   is Greenhill's ``W L^2 / (7.837 I)`` (measured within 3 %).
3. **Thin parts** (``s(z)``): a part few material points across is softer in bending in MPM than its ``E`` says.
   ``s`` is interpolated in :data:`THIN_SOFTNESS` from the section's points across its weak axis
   (``sqrt(12 I / A)`` over the fill's spacing: the side that 90 % of the section's volume is under), measured on
   the conformance cantilever (``benchmarks/thin_softness.py``; the engine and figures:
   ``docs/tolerances.md``, "stand").
4. **Gravity switched on at once** (:data:`DYNAMIC_FACTOR`): a load applied as a step drives an undamped elastic
   body to twice its static deflection (the step response of any linear mode, ``1 - cos(w t)``; the same
   cantilever measured 2.00-2.27x where it is 3 or more points thick), so the sections must hold twice the
   static load:

       E_crit = DYNAMIC_FACTOR * E_static

On the figure of ``tests/test_stand.py`` (legs 2.5 cells thick) the threshold measured lies at 0.45-0.5 of
``E_crit``, at ``E_static``: the factor 2 is the margin (``benchmarks/results/stand_figure*.md``). On its scan-like
variant (round 39, docs/contact.md) the falls are not monotone in E below ``E_crit``, and forced elastic it leans
+0.03 to +1.15 deg at ``E_crit`` over four seeds (``auto`` takes the rigid limit there). Only bodies that start
standing on a ground are judged (:func:`stand_warnings`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh
from scipy.spatial import ConvexHull, Delaunay

#: Sections the column is cut into.
N_SECTIONS = 64
#: The base is at least this share of the height above the lowest point.
FOOT_SHARE = 0.03
#: ... and at least this many grid cells (the ground contact's reach).
CONTACT_CELLS = 1.0
#: A body stands on a ground when its lowest point starts within this many cells above it.
STAND_GAP = 2.0
#: The section's shape is rasterised on at most this many cells across the body.
MAX_CELLS = 400
#: Gravity switched on at once: the peak of a step response over its static value.
DYNAMIC_FACTOR = 2.0
#: Bending softness of a part (deflection over Timoshenko's) by its material points across its weak axis: the
#: largest over 1-2 points per cell per axis, cantilever at n_grid 32 (benchmarks/thin_softness.py; docs/tolerances.md).
THIN_SOFTNESS = ((1.0, 18.7), (2.0, 2.79), (3.0, 1.28), (4.0, 1.08), (5.0, 1.02), (6.0, 1.02), (8.0, 1.0))


@dataclass
class StandEstimate:
    """:func:`stand_estimate`'s answer.

    Attributes
    ----------
    E_crit : float
        Pa; the body stands above it in an MPM run with gravity on from the start (``DYNAMIC_FACTOR * E_static``).
    E_static : float
        Pa; the elastic column's buckling modulus under its weight applied slowly, thin parts' softness included.
    height : float
        m, along ``up``.
    com_height : float
        Centre of mass above the lowest point, m.
    com_over_footprint : bool
        The centre of mass projects inside the footprint (else it tips at any ``E``).
    weakest_height : float
        Height of the section that bends most in the buckling shape, m above the lowest point.
    softness : float
        The thin-part factor ``s`` at that section (1: thick).
    base_height : float
        ``h_b``, m: the base held by the ground.
    """

    E_crit: float
    E_static: float
    height: float
    com_height: float
    com_over_footprint: bool
    weakest_height: float
    softness: float
    base_height: float


def thin_softness(points_across: np.ndarray) -> np.ndarray:
    """:data:`THIN_SOFTNESS` interpolated (clamped at its ends): the factor by which a part ``points_across``
    material points thick is softer in bending in MPM (dimensionless, >= 1)."""
    n, s = np.array(THIN_SOFTNESS).T
    return np.interp(np.asarray(points_across, dtype=np.float64), n, s)


def stand_estimate(x: np.ndarray, p_vol: np.ndarray, rho: float, g: float = 9.81,
                   up=(0.0, 0.0, 1.0), dx: float = 0.0) -> StandEstimate:
    """The Young's modulus a body standing on its lowest points needs (the module's model).

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        The body's points, metres. Points with ``p_vol == 0`` (a passive surface) carry no weight; they mark the
        skin of its sections and its footprint.
    p_vol : ndarray, shape (n,) or float
        Their volumes, m^3.
    rho : float
        Density, kg/m^3.
    g : float
        Gravity, m/s^2.
    up : array-like, shape (3,)
        Unit vector against gravity.
    dx : float
        The grid spacing, m (0: no grid, the base is ``FOOT_SHARE`` of the height).

    Returns
    -------
    StandEstimate

    Raises
    ------
    ValueError
        Fewer than 4 points with volume.
    """
    x = np.asarray(x, dtype=np.float64)
    vol = np.broadcast_to(np.asarray(p_vol, dtype=np.float64), (len(x),))
    mass = vol > 0
    if mass.sum() < 4:
        raise ValueError(f"stand_estimate: expected at least 4 points with volume, got {int(mass.sum())}")
    u = np.asarray(up, dtype=np.float64)
    u = u / np.linalg.norm(u)
    a = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    p = np.column_stack([x @ a, x @ np.cross(u, a)])
    half = np.cbrt(vol) / 2                                # each point a cube of side p_vol^(1/3)
    z = x @ u - float((x @ u - half).min())                 # height above the body's lowest extent, m
    H = float((z + half).max())
    w = rho * g * vol
    h_b = min(max(FOOT_SHARE * H, CONTACT_CELLS * float(dx)), 0.5 * H)
    com = np.average(p[mass], axis=0, weights=w[mass])
    over = _inside_hull(p[z <= h_b + 1e-12], com)
    com_h = float(np.average(z[mass], weights=w[mass]))
    E_static, k, s_k = _buckling(z, p, vol, w, h_b, H)
    dz = (H - h_b) / N_SECTIONS
    return StandEstimate(E_crit=DYNAMIC_FACTOR * E_static, E_static=E_static, height=H, com_height=com_h,
                         com_over_footprint=over, weakest_height=h_b + (k + 0.5) * dz, softness=s_k, base_height=h_b)


def _shape_moment(q: np.ndarray, side: np.ndarray, cell: float) -> float:
    """Smaller principal second moment of area per area (m^2) of the solid section that the 2D points ``q`` (k, 2),
    each a square of ``side`` (m; at least ``cell``), cover: rasterised on cells of ``cell``, closed over one-cell
    gaps and with their holes filled, so that a skin of surface points over a sparse core (a full model) and a full
    fill under a passive skin give the same shape."""
    from scipy.ndimage import binary_closing, binary_fill_holes
    half = np.maximum(side, cell) / 2
    lo = (q - half[:, None]).min(axis=0) - 3 * cell
    # the cells whose centres lie inside each square: [i0, i1] x [j0, j1], stamped with a 2D difference array
    i0 = np.ceil((q - half[:, None] - lo) / cell - 0.5).astype(int)
    i1 = np.floor((q + half[:, None] - lo) / cell - 0.5).astype(int)
    i1 = np.maximum(i1, i0)                                 # a square smaller than a cell: its own cell
    occ = np.zeros(tuple(i1.max(axis=0) + 5), np.int64)
    np.add.at(occ, (i0[:, 0], i0[:, 1]), 1)
    np.add.at(occ, (i1[:, 0] + 1, i0[:, 1]), -1)
    np.add.at(occ, (i0[:, 0], i1[:, 1] + 1), -1)
    np.add.at(occ, (i1[:, 0] + 1, i1[:, 1] + 1), 1)
    occ = occ.cumsum(axis=0).cumsum(axis=1) > 0
    occ = binary_fill_holes(binary_closing(occ, np.ones((3, 3), bool)))
    ctr = np.argwhere(occ) * cell
    ctr = ctr - ctr.mean(axis=0)
    return float(np.linalg.eigvalsh(ctr.T @ ctr / len(ctr))[0]) + cell * cell / 12.0


def _buckling(z, p, vol, w, h_b: float, H: float) -> tuple[float, int, float]:
    """``E_static`` (Pa) of the column above ``h_b``, the index of its most bent section and that section's ``s``.
    A section's area and the weight above come from the points' volumes (each a cube of side ``p_vol^(1/3)``,
    spread over the slices it spans); its shape from all its points, a passive skin's included."""
    n = N_SECTIONS
    dz = (H - h_b) / n
    side = np.cbrt(vol)                                   # each point a cube of this side, m (0: no volume)
    lo, hi = z - side / 2, z + side / 2
    nodes = h_b + dz * np.arange(n + 1)
    mass = vol > 0
    W = np.array([np.sum(w[mass] * np.clip((hi[mass] - zk) / side[mass], 0.0, 1.0)) for zk in nodes])   # N
    extent = float(np.ptp(p, axis=0).max())
    # incommensurate with a lattice (its edges fall anywhere in a cell), at most MAX_CELLS across the body
    cell = max(float(np.median(side[mass])) / (2 * np.pi), extent / MAX_CELLS)
    I_eff, s_all = np.zeros(n), np.ones(n)
    for s in range(n):
        inside = (hi >= nodes[s]) & (lo < nodes[s + 1])
        v = np.zeros_like(vol)
        v[mass] = vol[mass] * np.clip(np.minimum(hi, nodes[s + 1]) - np.maximum(lo, nodes[s]), 0.0, None)[mass] / side[mass]
        if not v.sum() > 0:
            continue
        shape = _shape_moment(p[inside], side[inside], cell)
        A = v.sum() / dz
        order = np.argsort(side)                          # the fill's spacing: the side that 90 % of the volume
        spacing = float(side[order][np.searchsorted(np.cumsum(v[order]), 0.9 * v.sum())])   # is under (not a skin's)
        s_all[s] = float(thin_softness(np.sqrt(12.0 * shape) / spacing))
        I_eff[s] = A * shape / s_all[s]
    full = I_eff > 0
    if not full.any():
        raise ValueError("stand_estimate: no section of the body above its base holds any volume")
    idx = np.arange(n)      # a slice no point reaches (a gap in a sparse fill): the grid joins it, as its neighbours
    I_eff, s_all = np.interp(idx, idx[full], I_eff[full]), np.interp(idx, idx[full], s_all[full])
    # theta at nodes 1..n (theta_0 = 0 on the base): bending K, load G (trapezoid weights)
    K = np.zeros((n, n))
    for s in range(n):
        k = I_eff[s] / dz
        K[s, s] += k
        if s > 0:
            K[s - 1, s - 1] += k
            K[s - 1, s] -= k
            K[s, s - 1] -= k
    G = np.diag(W[1:] * dz * np.r_[np.ones(n - 1), 0.5])
    lam, vec = eigh(G, K)
    theta = np.r_[0.0, vec[:, -1]]
    bend = I_eff * np.diff(theta) ** 2
    k = int(np.argmax(bend))
    return float(lam[-1]), k, float(s_all[k])


def _inside_hull(pts: np.ndarray, q: np.ndarray) -> bool:
    """``q`` (2,) inside the convex hull of ``pts`` (m, 2); degenerate footprints (a line, a point) hold nothing."""
    if len(pts) < 3:
        return False
    try:
        hull = ConvexHull(pts)
    except Exception:   # collinear points: scipy's Qhull error
        return False
    return bool(Delaunay(pts[hull.vertices]).find_simplex(q) >= 0)


def stand_warning(name: str, est: StandEstimate, E: float, rigid: bool = False) -> str | None:
    """One line for ``gasp simulate`` when the body cannot carry itself at ``E`` (Pa), else None. ``rigid``: the body
    runs as a rigid body (its material's ``model``, or the rigid limit ``model = "auto"`` chose:
    :func:`gasp_core.prepare.route.resolve_models`), which cannot sag or buckle: the line says so rather than that
    it will fall (it still tips where its centre of mass lies beyond its footprint)."""
    if not est.com_over_footprint:
        return (f"object '{name}': its centre of mass ({est.com_height:.3g} m up) lies outside its footprint (the "
                f"convex hull of its points within {est.base_height:.3g} m of the ground): it tips over whatever its "
                f"stiffness")
    if E < est.E_crit:
        thin = f", thin parts {est.softness:.2g}x softer in MPM" if est.softness > 1.05 else ""
        return (f"object '{name}' (E = {E:.3g} Pa) is too soft to carry its own weight standing"
                f"{' as an elastic body' if rigid else ''} "
                f"({est.height:.3g} m tall, weakest {est.weakest_height:.3g} m up): it needs E of about "
                f"{est.E_crit:.3g} Pa (buckling {est.E_static:.3g} Pa{thin}, x{DYNAMIC_FACTOR:g} for gravity "
                f"switched on at once; gasp_core.prepare.stand); "
                + ("it runs as a rigid body (run.json objects[].model), which stands: set its material's "
                   "model = \"elastic\" to simulate whether it sags or falls" if rigid else "it will sag or fall over"))
    return None


def stand_warnings(materials, boundaries, gravity, x: np.ndarray, p_vol: np.ndarray, body_id: np.ndarray,
                   names, dx: float) -> list[str]:
    """:func:`stand_warning` for every elastic body (``jelly``, ``neo_hookean``) that starts standing on a ground
    (its lowest point within ``STAND_GAP`` cells of ``dx`` of it) under gravity; a body dropped from higher, or
    in free flight, carries nothing yet. One line per body that cannot carry itself; ``materials`` with their models
    resolved (a ``model == "rigid"`` body gets :func:`stand_warning`'s rigid line)."""
    from gasp_core.prepare.surface import ELASTIC
    g = np.asarray(gravity, dtype=np.float64)
    gn = float(np.linalg.norm(g))
    heights = [b.height for b in boundaries if b.kind == "ground"]
    if gn == 0.0 or not heights:
        return []
    out = []
    for i, m in enumerate(materials):
        sel = body_id == i
        if m.name not in ELASTIC or (p_vol[sel] > 0).sum() < 4:
            continue
        if not any(abs(float(x[sel, 2].min()) - h) <= STAND_GAP * dx for h in heights):
            continue
        msg = stand_warning(names[i], stand_estimate(x[sel], p_vol[sel], m.rho, gn, -g / gn, dx=dx), m.E,
                            rigid=getattr(m, "model", "auto") == "rigid")
        if msg:
            out.append(msg)
    return out
