"""The hold of a rigid body on the flowing points (issue 53 item 3, ``docs/contact.md``): a rigid body that shares a
scene with a body of the grid contact holds that body's points out of it as a moving collider does
(``docs/colliders.md`` "The hold").

Each such rigid body gets a signed distance field in its own rest frame (the frame of
:func:`gasp_core.mpm.rigid.body_frames`: its points relative to its centre of mass, rotation the identity),
built once at setup from its rest points (:func:`body_sdf`). After each G2P, with the body's pose of that substep
(centre ``c``, rotation ``R``, velocity ``V``, spin ``w``), a flowing point at ``x`` is mapped to ``X = R^T (x - c)``,
the field's trilinear ``phi`` and normal read there; inside (``phi < 0``) the point is put back on the surface along
the outward normal ``n = R grad phi / |grad phi|``, its approach relative to the body's velocity at that point
(``V + w x (x - c)``) removed and its slip reduced by Coulomb's friction of that approach (the collider rule
``collide``, coefficient :func:`gasp_core.mpm.fields.pair_frictions`: the body's own pair with the sand, round 42).
The point's momentum change ``m dv`` is given back to the body (``-m dv`` at ``x``, its angular part ``x x (-m dv)``
about the origin), added to the body's sums of its next projection: action and reaction, the momentum of the two
bodies kept.

:func:`hold_reference` is the NumPy reference of one point's hold.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from gasp_core.colliders.model import COL_META
from gasp_core.mpm.grid_tables import CM_FRICTION, CM_H, CM_NX, CM_OFFSET, CM_ORIGIN

#: Samples of a rigid body's distance field per grid cell: the field's surface is placed within half a sample
#: (1/16 dx) of the body's smoothed occupancy (the collider's 2 per cell, ``gasp_core.colliders.sdf.SDF_SPACING``,
#: would leave a quarter cell, most of the 0.3 dx the hold is for).
SAMPLES_PER_CELL = 8
#: The Gaussian that smooths a body's points into its occupancy, in point spacings (:func:`body_sdf`). On the 5 cm
#: ball of ``gasp_core.testing.sand_ball`` (a lattice of spacing dx/2 cut by the sphere) the surface lies -0.27 to
#: +0.20 dx from the sphere (median -0.03; the lattice's own steps); at 0.5 spacing -0.21 to +0.31 with stray
#: samples 1.3 dx in, at 1 spacing -0.31 to +0.16 (median -0.07: a convex body rounded inwards).
SMOOTHING = 0.75
#: Most samples of one body's field: a larger body's samples are spaced wider.
MAX_SAMPLES = 128 ** 3


def holding_bodies(rigid: np.ndarray, flows: np.ndarray) -> np.ndarray:
    """Per body, True for a rigid body that holds the flowing points out: every rigid body of a scene with a body of
    the grid contact that is not rigid (``flows``: ``gasp_core.mpm.contact.flowing_bodies``); all False
    otherwise. Shape (n_bodies,), bool."""
    rigid, flows = np.asarray(rigid, bool), np.asarray(flows, bool)
    return rigid & bool(np.any(flows & ~rigid))


def body_sdf(X: np.ndarray, vol: np.ndarray, dx: float) -> tuple[np.ndarray, np.ndarray, float]:
    """``(phi, origin, h)``: a body's signed distance (m, negative inside) on samples ``origin + (i, j, k) h`` from
    its points ``X`` (shape (n, 3), m, its frame) of volumes ``vol`` (m^3).

    The occupancy is the points' smoothed volume fraction over one half (each point's volume on its nearest sample,
    a Gaussian of :data:`SMOOTHING` times the median point spacing ``s = cbrt(vol)``: on a lattice fill of spacing
    ``s`` it is 1 inside, with ripples of ``exp(-2 pi^2 0.75^2)``, 2e-5, and it falls through one half half a spacing
    beyond a flat outer layer, where a fill's surface is); closed holes are filled; ``phi`` is the Euclidean distance
    to it outside and minus the distance to its outside inside, each less half a sample (as
    ``gasp_core.colliders.sdf.collider_from_splats``).
    ``h = dx / SAMPLES_PER_CELL`` (wider where the body would need more than :data:`MAX_SAMPLES`). Points whose
    volumes fill no sample give ``phi`` 1e30 everywhere: nothing held."""
    X, vol = np.asarray(X, np.float64), np.asarray(vol, np.float64)
    s = float(np.median(np.cbrt(vol)))
    sigma = SMOOTHING * s
    lo, hi = X.min(0), X.max(0)
    h = dx / SAMPLES_PER_CELL
    margin = 0.5 * s + 4.0 * sigma
    h = max(h, float(np.cbrt(np.prod(hi - lo + 2.0 * margin) / MAX_SAMPLES)))
    pad = margin + 2.0 * h
    origin = lo - pad
    shape = tuple(int(n) for n in np.ceil((hi - lo + 2.0 * pad) / h).astype(np.int64) + 1)
    rho = np.zeros(shape)
    idx = np.clip(np.rint((X - origin) / h).astype(np.int64), 0, np.asarray(shape) - 1)
    np.add.at(rho, tuple(idx.T), vol / h ** 3)
    rho = ndimage.gaussian_filter(rho, sigma / h, mode="constant", truncate=4.0)
    occ = ndimage.binary_fill_holes(rho > 0.5)
    if not occ.any():   # points too sparse for their volumes to fill a sample (no body to hold with)
        return np.full(shape, 1e30), origin, h
    out = ndimage.distance_transform_edt(~occ) * h
    ins = ndimage.distance_transform_edt(occ) * h
    return np.where(occ, -(ins - 0.5 * h), out - 0.5 * h), origin, h


def rigid_hold_tables(setup, dx: float, flows: np.ndarray):
    """The holding bodies' fields packed as the colliders' (``gasp_core.mpm.grid_tables.GridTables``), or None
    where no body holds (:func:`holding_bodies`): ``(row, sdf, grad, meta)``, ``row`` per body its row of ``meta``
    (-1: none; shape (n_bodies,), int32), ``sdf`` (N,) and ``grad`` (3N,) every field's samples (x-major), ``meta``
    rows of ``COL_META`` floats (origin in the body's rest frame, ``h``, ``nx, ny, nz``, offset, the Coulomb
    coefficient, the body's own pair's: :func:`gasp_core.mpm.fields.pair_frictions`)."""
    from gasp_core.mpm.fields import pair_frictions
    from gasp_core.mpm.rigid import body_frames, rigid_mask, step_view
    rigid = rigid_mask(setup.materials)
    hold = holding_bodies(rigid, flows)
    if not hold.any():
        return None
    body, vol = np.asarray(setup.body_id), np.asarray(setup.p_vol, np.float64)
    _c, X0, _i, _m = body_frames(setup.x, setup.p_mass, body, rigid)
    mu = pair_frictions(step_view(setup))   # per body: its pair's with the sand (round 42)
    row = np.full(len(rigid), -1, np.int32)
    sdf, grad, meta, off = [], [], [], 0
    for b in np.flatnonzero(hold):
        sel = (body == b) & (vol > 0.0)
        if not sel.any():
            continue
        phi, origin, h = body_sdf(X0[sel], vol[sel], dx)
        row[b] = len(meta)
        m = np.zeros(COL_META)
        m[CM_ORIGIN:CM_ORIGIN + 3], m[CM_H], m[CM_NX:CM_NX + 3] = origin, h, phi.shape
        m[CM_OFFSET], m[CM_FRICTION] = off, mu[b]
        meta.append(m)
        sdf.append(phi.ravel())
        grad.append(np.stack(np.gradient(phi, h), axis=-1).reshape(-1))
        off += phi.size
    if not meta:
        return None
    return row, np.concatenate(sdf), np.concatenate(grad), np.concatenate(meta)


def hold_setup(setup, dx: float, flows: np.ndarray, any_rigid: bool = True) -> tuple:
    """``(tables, pairs)``: :func:`rigid_hold_tables` (None without a rigid body, ``any_rigid`` False, or none that
    holds) and, where field A's sands bring several angles, the hold's coefficient per (A body, holding body),
    ``gasp_core.mpm.fields.hold_pairs`` (shape (n_bodies, n_bodies); None elsewhere: each body's row's, round 42)."""
    from gasp_core.mpm.fields import hold_pairs
    tables = rigid_hold_tables(setup, dx, flows) if any_rigid else None
    return tables, (hold_pairs(setup) if tables is not None else None)


def hold_reference(x, v, m: float, phi: float, n, V, w, c, mu: float):
    """One point's hold (the module's equations): ``(x, v, J)`` after it, ``J`` the impulse given back to the body
    (N s, ``-m dv``). ``phi`` (m) and ``n`` (unit, world) the body's distance and normal at ``x``; ``V``, ``w``,
    ``c`` its velocity, spin and centre; ``mu`` the Coulomb coefficient. A point outside (``phi >= 0``) is
    unchanged."""
    x, v, n = (np.asarray(a, np.float64) for a in (x, v, n))
    if phi >= 0.0:
        return x, v, np.zeros(3)
    vc = np.asarray(V, np.float64) + np.cross(w, x - np.asarray(c, np.float64))
    u = v - vc
    un = float(u @ n)
    if un < 0.0:
        ut = u - un * n
        lt = float(np.linalg.norm(ut))
        u = ut * max(0.0, 1.0 + mu * un / lt) if lt > 1e-30 else np.zeros(3)
    v_new = vc + u
    return x - phi * n, v_new, -m * (v_new - v)
