"""Collider, force and impulse tables packed for grid (MPM) engines: what their kernels read each substep."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


from gasp_core.colliders.model import COL_META, COL_POSE, FALLOFFS, FORCE_ROW, IMPULSE_ROW, MODE_ROW


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
    b (3) = hi or (radius, 0, 0), mode (0 add, 1 set), dv (3)``.
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
        return any(self.forces[r * FORCE_ROW] == 0.0 for r in range(self.n_forces))

    @property
    def width(self) -> int:
        """Floats per substep in :func:`frame_table`: time, then a pose per collider, a weight per impulse."""
        return 1 + COL_POSE * self.n_colliders + self.n_impulses


def grid_tables(setup) -> GridTables:
    """Pack ``setup.colliders``, ``setup.forces`` and ``setup.impulses`` for grid kernels (see :class:`GridTables`)."""
    cols = list(getattr(setup, "colliders", []) or [])
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
            frows.append([0, *(f.speed * np.asarray(f.direction, float)), f.drag_factor, 0, 0, 0.0, 0.0, 0, m0, len(md)])
        else:
            frows.append([1, *f.point, 0, 0, 0, f.strength, f.radius, FALLOFFS.index(f.falloff), m0, 0])
        modes.append(md)
        m0 += len(md)
    irows = []
    for i in imps:
        a = i.lo if i.shape == "box" else i.centre
        b = i.hi if i.shape == "box" else (i.radius, 0.0, 0.0)
        irows.append([0 if i.shape == "box" else 1, *a, *b, 0 if i.mode == "add" else 1, *i.velocity_change])
    return GridTables(
        n_colliders=len(cols), n_forces=len(forces), n_impulses=len(imps),
        sdf=np.concatenate(sdf) if sdf else np.zeros(1), sdf_grad=np.concatenate(grad) if grad else np.zeros(3),
        col_meta=np.array(meta, float).reshape(-1) if meta else np.zeros(COL_META),
        forces=np.array(frows, float).reshape(-1) if frows else np.zeros(FORCE_ROW),
        modes=(np.concatenate(modes).reshape(-1) if m0 else np.zeros(MODE_ROW)),
        impulses=np.array(irows, float).reshape(-1) if irows else np.zeros(IMPULSE_ROW))


def frame_table(setup, t_start: float, n_substeps: int, dt: float) -> np.ndarray:
    """Time-dependent inputs of the grid kernels for the substeps of one frame, shape (n_substeps * width,), float64.

    Row ``s`` (substep starting at ``t = t_start + s dt``): ``t``, then per collider ``R`` (9,
    row-major), ``T`` (3), ``v`` (3), ``w`` (3) of :meth:`Collider.pose` at ``t``, then per
    impulse its :meth:`Impulse.weight` for ``[t, t + dt)``.
    """
    cols = list(getattr(setup, "colliders", []) or [])
    imps = list(getattr(setup, "impulses", []) or [])
    w = 1 + COL_POSE * len(cols) + len(imps)
    out = np.zeros((n_substeps, w))
    for s in range(n_substeps):
        t = t_start + s * dt
        row = [t]
        for c in cols:
            R, T, v, om = c.pose(t)
            row += [*R.ravel(), *T, *v, *om]
        row += [i.weight(t, dt) for i in imps]
        out[s] = row
    return out.reshape(-1)


