"""Can a body carry itself? The Young's modulus a standing elastic body needs not to buckle under its own
weight, estimated from its filled solid (issue 28, item 6).

Model: the body is an elastic inverted pendulum on its own cross-sections. Lean it by a small angle
``theta`` as a rigid body about its base: at height ``z`` the part above (weight ``W(z)``, centroid
``z_c(z)``) loads the section with the moment ``theta W(z) (z_c(z) - z)``; the sections bend by
``M / (E I(z))`` per unit height (``I(z)``: the section's smaller principal second moment of area, m^4), so the
lean they give back is ``theta / E * integral W(z) (z_c(z) - z) / I(z) dz``. The body stands when that is below
``theta``:

    E_crit = integral_0^H W(z) (z_c(z) - z) / I(z) dz

from the top of its footprint (the lowest ``FOOT_SHARE`` of its height: the base it stands on; a rounded bottom's
tiny sections there would otherwise dominate) to its top. For a uniform column of height ``L`` this is
``0.97^3 W L^2 / (6 I)``; Greenhill's exact self-weight buckling load gives ``W L^2 / (7.84 I)``, so the estimate
errs on the safe side by about 20 %. A body whose centre of mass lies outside its footprint (the convex hull of
its lowest points) tips over at any ``E``. Only bodies that start standing on a ground are judged
(:func:`stand_warnings`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, Delaunay

#: Sections the height is cut into.
N_SECTIONS = 48
#: The footprint: the points within this share of the height above the lowest point.
FOOT_SHARE = 0.03
#: A body stands on a ground when its lowest point starts within this many cells above it.
STAND_GAP = 2.0


@dataclass
class StandEstimate:
    """:func:`stand_estimate`'s answer.

    Attributes
    ----------
    E_crit : float
        Pa; the body stands (does not buckle under its weight) above it.
    height : float
        m, along ``up``.
    com_height : float
        Centre of mass above the base, m.
    com_over_footprint : bool
        The centre of mass projects inside the footprint (else it tips at any ``E``).
    weakest_height : float
        Height of the section that matters most (largest ``M1 / I``), m above the base.
    """

    E_crit: float
    height: float
    com_height: float
    com_over_footprint: bool
    weakest_height: float


def stand_estimate(x: np.ndarray, p_vol: np.ndarray, rho: float, g: float = 9.81,
                   up=(0.0, 0.0, 1.0), foot_depth: float = 0.0) -> StandEstimate:
    """The Young's modulus a body standing on its base needs (the module's model).

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Points of the filled solid, metres.
    p_vol : ndarray, shape (n,)
        Their volumes, m^3.
    rho : float
        Density, kg/m^3.
    g : float
        Gravity, m/s^2.
    up : array-like, shape (3,)
        Unit vector against gravity.
    foot_depth : float
        The support the centre of mass is tested against: the points within ``max(FOOT_SHARE H, foot_depth)``
        (m) of the lowest (``gasp simulate`` passes the grid's ``dx``: a rounded base, such as a lying donut's,
        touches within a cell of its lowest point all round).

    Returns
    -------
    StandEstimate

    Raises
    ------
    ValueError
        Fewer than 4 points, or no volume.
    """
    x = np.asarray(x, dtype=np.float64)
    vol = np.asarray(p_vol, dtype=np.float64)
    if len(x) < 4 or not vol.sum() > 0:
        raise ValueError(f"stand_estimate: expected at least 4 points with volume, got {len(x)}")
    u = np.asarray(up, dtype=np.float64)
    u = u / np.linalg.norm(u)
    a = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    z = x @ u - float((x @ u).min())
    p = np.column_stack([x @ a, x @ b])
    H = float(z.max())
    edges = np.linspace(0.0, H, N_SECTIONS + 1)
    dz = edges[1] - edges[0]
    k = np.minimum((z / dz).astype(int), N_SECTIONS - 1)
    w = rho * g * vol
    M1 = np.zeros(N_SECTIONS)
    inv_I = np.zeros(N_SECTIONS)
    for s in range(N_SECTIONS):
        above = k >= s
        zs = edges[s]
        W = w[above].sum()
        M1[s] = W * (np.average(z[above], weights=w[above]) - zs) if W > 0 else 0.0
        sec = k == s
        if vol[sec].sum() <= 0:
            continue
        q = p[sec] - np.average(p[sec], axis=0, weights=vol[sec])
        I = (q.T * (vol[sec] / dz)) @ q                      # area second moments (m^4) of the section
        I_min = float(np.linalg.eigvalsh(I)[0])
        inv_I[s] = 1.0 / max(I_min, 1e-30)
    f = M1 * inv_I
    f[edges[:-1] < FOOT_SHARE * H] = 0.0   # the footprint's own sections: the base it stands on, not a column
    E_crit = float(np.sum(f) * dz)
    com = np.average(p, axis=0, weights=w)
    foot = p[z <= max(FOOT_SHARE * H, float(foot_depth)) + 1e-12]
    over = _inside_hull(foot, com)
    return StandEstimate(E_crit=E_crit, height=H, com_height=float(np.average(z, weights=w)),
                         com_over_footprint=over, weakest_height=float(edges[int(np.argmax(f))]))


def _inside_hull(pts: np.ndarray, q: np.ndarray) -> bool:
    """``q`` (2,) inside the convex hull of ``pts`` (m, 2); degenerate footprints (a line, a point) hold nothing."""
    if len(pts) < 3:
        return False
    try:
        hull = ConvexHull(pts)
    except Exception:   # collinear points: scipy's Qhull error
        return False
    return bool(Delaunay(pts[hull.vertices]).find_simplex(q) >= 0)


def stand_warning(name: str, est: StandEstimate, E: float) -> str | None:
    """One line for ``gasp simulate`` when the body cannot carry itself at ``E`` (Pa), else None."""
    if not est.com_over_footprint:
        return (f"object '{name}': its centre of mass ({est.com_height:.3g} m up) lies outside its footprint: "
                f"it tips over whatever its stiffness")
    if E < est.E_crit:
        return (f"object '{name}' (E = {E:.3g} Pa) is too soft to carry its own weight standing "
                f"({est.height:.3g} m tall, weakest {est.weakest_height:.3g} m up): it needs E of about "
                f"{est.E_crit:.2g} Pa (gasp_core.prepare.stand); it will sag or fall over")
    return None


def stand_warnings(materials, boundaries, gravity, x: np.ndarray, p_vol: np.ndarray, body_id: np.ndarray,
                   names, dx: float) -> list[str]:
    """:func:`stand_warning` for every elastic body (``jelly``, ``neo_hookean``) that starts standing on a ground
    (its lowest point within ``STAND_GAP`` cells of ``dx`` of it) under gravity; a body dropped from higher, or
    in free flight, carries nothing yet. One line per body that cannot carry itself."""
    from gasp_core.prepare.surface import ELASTIC
    g = np.asarray(gravity, dtype=np.float64)
    gn = float(np.linalg.norm(g))
    heights = [b.height for b in boundaries if b.kind == "ground"]
    if gn == 0.0 or not heights:
        return []
    out = []
    for i, m in enumerate(materials):
        sel = body_id == i
        if m.name not in ELASTIC or sel.sum() < 4 or not p_vol[sel].sum() > 0:
            continue
        if not any(abs(float(x[sel, 2].min()) - h) <= STAND_GAP * dx for h in heights):
            continue
        msg = stand_warning(names[i], stand_estimate(x[sel], p_vol[sel], m.rho, gn, -g / gn, foot_depth=dx), m.E)
        if msg:
            out.append(msg)
    return out

