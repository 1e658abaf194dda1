"""Collider, force and impulse tables packed for grid (MPM) engines: what their kernels read each substep."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


from gasp_core.colliders.model import COL_META, COL_POSE, FALLOFFS, FORCE_ROW, IMPULSE_ROW, MODE_ROW

# --------------------------------------------------------------------------- named columns the kernels read
# Both grid engines index the flat tables below with these names (row sizes: gasp_core.colliders.model).
#: ``col_meta`` row (:data:`COL_META` floats): SDF origin (3, m), spacing h (m), samples nx, ny, nz, offset of the
#: collider's first sample in ``sdf`` (``3 *`` that in ``sdf_grad``), Coulomb friction.
CM_ORIGIN, CM_H, CM_NX, CM_NY, CM_NZ, CM_OFFSET, CM_FRICTION = 0, 3, 4, 5, 6, 7, 8
#: ``forces`` row (:data:`FORCE_ROW` floats): kind (0 wind, 1 attractor), c (3: wind velocity, m/s, or attractor
#: point, m), drag factor 1/2 rho_air C_d (kg/m^3), strength (m/s^2), radius (m), falloff (index of FALLOFFS),
#: first mode row and mode count in ``modes``.
FR_KIND, FR_C, FR_DRAG, FR_STRENGTH, FR_RADIUS, FR_FALLOFF, FR_MODE_START, FR_MODE_COUNT = 0, 1, 4, 7, 8, 9, 10, 11
#: ``forces`` kinds, and the falloff code of an attractor falling as 1/r^2 outside its radius.
FORCE_WIND, FORCE_ATTRACTOR = 0, 1
FALLOFF_INVERSE_SQUARE = FALLOFFS.index("inverse_square")
#: ``modes`` row (:data:`MODE_ROW` floats, ``ForceField.modes``): wave vector k (3, 1/m), amplitude A (3, m/s),
#: phase (rad), omega (rad/s).
MD_K, MD_A, MD_PHASE, MD_OMEGA = 0, 3, 6, 7
#: ``impulses`` row (:data:`IMPULSE_ROW` floats): shape (0 box, 1 sphere), a (3: lo or centre, m), b (3: hi or
#: (radius, 0, 0), m), mode (0 add, 1 set, 2 set ``constrain = "along"``), dv (3, m/s).
IM_SHAPE, IM_A, IM_B, IM_MODE, IM_DV = 0, 1, 4, 7, 8
#: ``impulses`` shapes and modes.
IMPULSE_BOX, IMPULSE_SPHERE = 0, 1
IMPULSE_ADD, IMPULSE_SET = 0, 1
#: A set impulse with ``constrain = "along"`` (round 44, docs/colliders.md): it imposes only the velocity component
#: along ``a = dv / |dv|``, ``v = (I - a a^T) v_free + a a^T v_held``; every reader of a set box tests ``mode !=
#: IMPULSE_ADD`` for "a set box", so this mode is one to all of them, and the ones that impose project.
IMPULSE_SET_ALONG = 2
#: A row of :func:`frame_table` (``GridTables.width`` floats): time (s), then :data:`COL_POSE` floats per collider
#: from ``FT_POSES``, then one weight per impulse (:func:`impulse_weight`).
FT_TIME, FT_POSES = 0, 1
#: A ``set`` impulse's weight while it acts is ``SET_ON + f``, ``f`` in [0, 1] its ramp factor
#: (:meth:`~gasp_core.colliders.model.Impulse.ramp_factor`), and 0 outside its window: the kernels test ``w > 0`` for
#: on/off (so ``f = 0`` still holds the region, at rest) and impose ``v = (w - SET_ON) dv``.
SET_ON = 1.0
#: A set box's ghost nodes (``points.MIRROR_CELLS``) take their image nodes by mass (round 37, docs/fracture.md "The
#: set box's bursts"): each lends ``v_set + min(1, m_image / m_ghost) (v_image - v_set)``, not ``v_image`` at full
#: weight whenever it has any mass. A switch (read when the engines build their kernels) to run the old rule as a catch.
MIRROR_BY_MASS = True
#: A ``fixed_region``'s ghost nodes (a clamp's, held at 0) take their image nodes by the same share, ``min(1, m_image
#: / m_ghost) v_image`` (round 40, docs/fracture.md "Round 40: the clamp's face"): with every image node at full
#: weight a node of tiny mass and large speed past the clamp's face crushed its held points' ``F`` (singular value
#: 0.0008 on the oblique 1.5:1 at n_grid 48). A switch (read when the engines build their kernels) for the catch.
FIXED_BY_MASS = True
#: A set box's point near its face gathers its image gradient (``image_C``) from the image's stencil nodes by the same
#: share (round 40, docs/fracture.md "Round 40"): node ``J`` lends ``v_set + min(1, m_J / m_K) (v_J - v_set)``, ``K``
#: the node nearest ``J``'s mirror image across the face (the ghost that takes it), not ``v_J`` at full weight. A
#: switch (read when the engines build their kernels) to run the old rule as a catch.
IMAGE_BY_MASS = True
#: The passive points' gather (round 38, docs/fracture.md "Round 38"): off, the engines' gather (each node by its
#: B-spline weight, renormalised over the nodes with mass; their own round 37 variants). On, each node by its weight
#: times its mass ``w = N m``: the mean velocity at the weights' centroid ``x_bar``, plus the gradient fitted by
#: mass-weighted least squares about ``x_bar``, ``G = S_vr M^+``, read at the point, ``v = v_bar + G (x_p - x_bar)``,
#: ``C = G``; ``M^+`` keeps only the eigen-directions of the moment ``M = sum w (x - x_bar)(x - x_bar)^T / sum w``
#: (cells^2) the material spans (:data:`PASSIVE_SPAN_MOMENT`). A switch read when the engines build their kernels.
PASSIVE_SPANNED = True
#: A direction is spanned where its moment in mass, ``lam sum w`` (kg cells^2), is above the most one material point
#: can give: a lone point's nodes hold ``N_i m_p``, so a passive point reads weights ``N_i(x) N_i(x_p) m_p``, whose
#: sum along an axis is at most 19/32 (both at a node) and whose moment at most 1/8 cell^2 (both half-way between
#: two nodes): ``(19/32)^2 / 8 = 361/8192`` times ``m_p`` along any direction. So no gradient is read from a single
#: point's own affine field (an isolated point keeps its ``C`` for ever under APIC) nor from a node of tiny mass (a
#: corner of 1e-15 kg adds 1e-15 kg cells^2 at most), and where two or more points span a direction it is fitted.
PASSIVE_SPAN_MOMENT = 361.0 / 8192.0
#: With :data:`PASSIVE_SPANNED`, where its mean is read (round 39, docs/fracture.md "Round 39"). ``"weights"``: at the
#: ``N m`` weights' centroid ``x_bar`` (round 38). ``"material"``: at the material's centroid ``x_m = sum m x / sum m``
#: over the stencil's nodes by their mass alone, ``v = v_m + G (x_p - x_m)``. ``"unspanned"`` (the rule): round 38's
#: plus ``f r``, ``r = v_m - v_bar - G (x_m - x_bar)`` what the spanned fit misses at the material's centroid and ``f =
#: |P_u d|^2 / |d|^2`` the share of ``d = x_m - x_bar`` along the directions the material does not span (``P_u = I - M^+
#: M``): over a lone crumb (nothing spanned) the material's centroid, where all three are spanned round 38's. The
#: nodes of one crumb carry its own ``C`` (``v_p + C (x_i - x_p)``); by ``N m`` their centroid lies between the crumb
#: and the passive point, so a point over a lone crumb read the crumb's ``C`` there and left it (the oblique 2:1's
#: farthest vertex). A rigid field reads the same every way. A switch read when the engines build their kernels.
PASSIVE_MEAN_AT = "unspanned"
#: The values :data:`PASSIVE_MEAN_AT` takes.
PASSIVE_MEANS = ("weights", "material", "unspanned")
#: A collider's pose block (:data:`COL_POSE` floats): R (9, row-major), T (3, m), v (3, m/s), omega (3, rad/s).
PO_R, PO_T, PO_V, PO_W = 0, 9, 12, 15


# --------------------------------------------------------------------------- grid-engine tables
@dataclass
class GridTables:
    """Flat float64 arrays the grid kernels read (static for the run).

    ``sdf`` (N,) and ``sdf_grad`` (3N,) concatenate every collider's samples (x-major);
    ``col_meta`` rows of :data:`COL_META`: ``origin (3), h, nx, ny, nz, offset, friction``;
    ``forces`` rows of :data:`FORCE_ROW`: ``kind (0 wind, 1 attractor), c (3) = mean wind velocity
    (m/s) or attractor point, (drag factor 1/2 rho_air C_d (kg/m^3) for wind, 0, 0), strength, radius,
    falloff (0 none, 1 inverse_square), mode start, mode count``; ``modes`` rows of :data:`MODE_ROW` (:meth:`ForceField.modes`);
    ``impulses`` rows of :data:`IMPULSE_ROW`: ``shape (0 box, 1 sphere), a (3) = lo or centre,
    b (3) = hi or (radius, 0, 0), mode (0 add, 1 set, 2 set along), dv (3)``.
    """

    n_colliders: int
    n_forces: int
    n_impulses: int
    sdf: np.ndarray
    sdf_grad: np.ndarray
    col_meta: np.ndarray
    forces: np.ndarray
    modes: np.ndarray
    impulses: np.ndarray

    @property
    def any(self) -> bool:
        return bool(self.n_colliders or self.n_forces or self.n_impulses)

    @property
    def has_wind(self) -> bool:
        """Whether any force row is a wind (kind 0): the engines then gather the windward area per node."""
        return any(self.forces[r * FORCE_ROW + FR_KIND] == FORCE_WIND for r in range(self.n_forces))

    @property
    def width(self) -> int:
        """Floats per substep in :func:`frame_table`: time, then a pose per collider, a weight per impulse."""
        return FT_POSES + COL_POSE * self.n_colliders + self.n_impulses


def grid_tables(setup) -> GridTables:
    """Pack ``setup.colliders``, ``setup.forces`` and ``setup.impulses`` for grid kernels (see :class:`GridTables`)."""
    cols = list(getattr(setup, "colliders", []) or [])
    if cols:   # round 89: the field held out to the round rigid bodies' radius (their centres read it)
        from gasp_core.colliders.sdf import padded
        from gasp_core.mpm.round_ground import collider_reach
        reach = collider_reach(setup)
        cols = [padded(c, reach) for c in cols] if reach > 0.0 else cols
    forces = list(getattr(setup, "forces", []) or [])
    imps = list(getattr(setup, "impulses", []) or [])
    sdf, grad, meta = [], [], []
    off = 0
    for c in cols:
        sdf.append(c.phi.ravel())
        grad.append(c.grad.reshape(-1, 3).ravel())
        meta.append([*c.origin, c.h, *c.phi.shape, off, c.friction])
        off += c.phi.size
    frows, modes = [], []
    m0 = 0
    for f in forces:
        md = f.modes()
        if f.kind == "wind":
            frows.append([FORCE_WIND, *(f.speed * np.asarray(f.direction, float)), f.drag_factor, 0, 0, 0.0, 0.0, 0, m0, len(md)])
        else:
            frows.append([FORCE_ATTRACTOR, *f.point, 0, 0, 0, f.strength, f.radius, FALLOFFS.index(f.falloff), m0, 0])
        modes.append(md)
        m0 += len(md)
    irows = []
    for i in imps:
        a = i.lo if i.shape == "box" else i.centre
        b = i.hi if i.shape == "box" else (i.radius, 0.0, 0.0)
        mode = IMPULSE_ADD if i.mode == "add" else (IMPULSE_SET_ALONG if getattr(i, "constrain", "all") == "along"
                                                    else IMPULSE_SET)
        irows.append([IMPULSE_BOX if i.shape == "box" else IMPULSE_SPHERE, *a, *b, mode, *i.velocity_change])
    return GridTables(
        n_colliders=len(cols), n_forces=len(forces), n_impulses=len(imps),
        sdf=np.concatenate(sdf) if sdf else np.zeros(1), sdf_grad=np.concatenate(grad) if grad else np.zeros(3),
        col_meta=np.array(meta, float).reshape(-1) if meta else np.zeros(COL_META),
        forces=np.array(frows, float).reshape(-1) if frows else np.zeros(FORCE_ROW),
        modes=(np.concatenate(modes).reshape(-1) if m0 else np.zeros(MODE_ROW)),
        impulses=np.array(irows, float).reshape(-1) if irows else np.zeros(IMPULSE_ROW))


def count_along(ex) -> int:
    """Set impulses with ``constrain = "along"`` in the tables ``ex`` (None: none): the engines build their
    projections (:data:`IMPULSE_SET_ALONG`) only where there is one, so every other scene runs the kernels of before."""
    if ex is None or not ex.n_impulses:
        return 0
    rows = np.asarray(ex.impulses, float).reshape(-1, IMPULSE_ROW)[:ex.n_impulses]
    return int(np.sum(rows[:, IM_MODE] == IMPULSE_SET_ALONG))


def impulse_weight(imp, t: float, dt: float) -> float:
    """Impulse ``imp``'s entry in the time table for the substep ``[t, t + dt)``: ``add``, the share of its
    ``velocity_change`` given then (:meth:`~gasp_core.colliders.model.Impulse.weight`); ``set``, ``SET_ON`` plus its
    ramp factor at the substep's midpoint while it acts, else 0 (:data:`SET_ON`)."""
    w = imp.weight(t, dt)
    if imp.mode != "set":
        return w
    return SET_ON + imp.ramp_factor(t + 0.5 * dt) if w > 0.0 else 0.0


def frame_table(setup, t_start: float, n_substeps: int, dt: float) -> np.ndarray:
    """Time-dependent inputs of the grid kernels for the substeps of one frame, shape (n_substeps * width,), float64.

    Row ``s`` (substep starting at ``t = t_start + s dt``): ``t``, then per collider ``R`` (9,
    row-major), ``T`` (3), ``v`` (3), ``w`` (3) of :meth:`Collider.pose` at ``t``, then per
    impulse its :func:`impulse_weight` for ``[t, t + dt)``.
    """
    cols = list(getattr(setup, "colliders", []) or [])   # their poses only: :func:`grid_tables`' padding keeps them
    imps = list(getattr(setup, "impulses", []) or [])
    w = 1 + COL_POSE * len(cols) + len(imps)
    out = np.zeros((n_substeps, w))
    for s in range(n_substeps):
        t = t_start + s * dt
        row = [t]
        for c in cols:
            R, T, v, om = c.pose(t)
            row += [*R.ravel(), *T, *v, *om]
        row += [impulse_weight(i, t, dt) for i in imps]
        out[s] = row
    return out.reshape(-1)



def substep_table(setup, t: float, dt: float, size: int) -> np.ndarray:
    """One substep's row of :func:`frame_table` (the substep ``[t, t + dt)``, s) as row 0 of an engine's time table of
    ``size`` floats (the rest zero), float64, shape (size,): for a frame whose substeps the state chooses one at a
    time (``gasp_core.mpm.state_step``), loaded before each with the table's substep index at 0.

    Raises
    ------
    ValueError
        ``size`` smaller than one row (``GridTables.width``).
    """
    row = frame_table(setup, t, 1, dt)
    if size < len(row):
        raise ValueError(f"substep_table: size {size} is smaller than one row of the time table ({len(row)} floats)")
    out = np.zeros(size)
    out[:len(row)] = row
    return out

def passive_span_mass(p_mass: np.ndarray, p_vol: np.ndarray) -> float:
    """The spanned passive gather's cutoff (kg cells^2): :data:`PASSIVE_SPAN_MOMENT` times the heaviest material
    point's mass (``p_mass`` over the rows with ``p_vol > 0``; shapes (n,), kg and m^3); 0 without material."""
    m, live = np.asarray(p_mass, np.float64), np.asarray(p_vol, np.float64) > 0
    return float(PASSIVE_SPAN_MOMENT * np.max(m[live])) if live.any() else 0.0


def passive_mean_at() -> str:
    """:data:`PASSIVE_MEAN_AT`, checked against :data:`PASSIVE_MEANS` (raises ``ValueError`` naming the switch)."""
    if PASSIVE_MEAN_AT not in PASSIVE_MEANS:
        raise ValueError(f"grid_tables.PASSIVE_MEAN_AT: one of {PASSIVE_MEANS}, got {PASSIVE_MEAN_AT!r}")
    return PASSIVE_MEAN_AT
