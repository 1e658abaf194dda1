"""Taichi kernels of the MLS-MPM solver specified in ``docs/mpm.md``.

3D MLS-MPM, quadratic B-splines, APIC transfers (Hu et al. 2018), constitutive models of
taichi_elements / PhysGaussian. :class:`MPMSolver` owns the Taichi fields; ``ti.init`` must have
been called (by :class:`gasp_taichi_mpm.engine.TaichiMPMEngine`) before it is built.

Implementation notes (all algebraically identical to the spec; they change rounding only):

* **P2G without atomics on CPU.** The points (sorted by cell) are split into ``n_chunks`` contiguous
  chunks, a fixed number independent of the thread count and larger than it (the engine's
  ``n_point_chunks``): the threads take chunks as they finish the last, so the load balances itself.
  Chunk ``t`` scatters into its own grid copy ``grid_acc[t]`` with plain loads and stores. The grid
  update sums the copies in a fixed order, so a run repeats bit for bit for a fixed ``n_chunks``,
  whatever the thread count. On CUDA (or when the copies would not fit in memory) one copy is used
  and the scatter is atomic.
* **Active region.** Each chunk records the bounding box of the nodes it touched; the grid update
  visits only the union of those boxes and, at each node, reads and clears only the copies whose
  box holds it (a chunk of sorted points covers a few cells), so the copies are zero again for the
  next substep.
* **Fused transfers.** Within a frame, the G2P of substep ``s`` and the P2G of substep ``s + 1``
  run in one pass over the points (the grid velocity ``grid_v`` is a separate field from the
  accumulation copies, so no double buffering is needed).
* P2G adds ``(p_mass v - A fx dx) + A (i, j, k)^T dx`` per node, with ``A = affine``; G2P forms
  ``C = 4 inv_dx (sum_w w g (i,j,k)^T - v fx^T)``: the spec's ``dpos = ((i,j,k) - fx) dx`` expanded.
* Boundary masks (walls, ground, fixed regions) are turned into integer node-index ranges in
  float64 in Python; ties within 1e-9 cells count as exact ties.
"""
import math

import numpy as np
import taichi as ti

# Material codes and the per-body parameter columns (``MPMSolver.mat``) are gasp_core.toolkit.materials'.
from gasp_core.toolkit.points import ground_top_node
from gasp_core.toolkit.substeps import passive_schedule
from gasp_core.seam import SceneError
from gasp_core.toolkit.materials import (JELLY, LIQUID, METAL, N_PARAMS, NEO_HOOKEAN, P_ALPHA, P_ETA, P_HARDENING, P_K,
                                         P_LAM, P_MU, P_SOFTENING, P_THETA_C, P_THETA_S, P_YIELD, PLASTICINE, SAND, SNOW,
                                         VON_MISES_RADIUS)

_TIE = 1e-9  # cells: tolerance for ties when boundary tests become node-index ranges


def node_ranges(setup, dx: float):
    """Boundaries as node-index tests (float64, ties within 1e-9 cells are exact ties).

    Returns
    -------
    walls : list of (friction, lo_first (3 ints), hi_first (3 ints))
        Wall nodes along axis d are ``I_d < lo_first[d]`` (normal +e_d) and
        ``I_d >= hi_first[d]`` (normal -e_d).
    grounds : list of (friction, k_max)
        Ground nodes are ``I_z <= k_max``.
    regions : list of (ilo (3 ints), ihi (3 ints))
        Fixed nodes are ``ilo <= I <= ihi`` on every axis.
    """
    lo = setup.domain_lo
    hi = setup.domain_hi
    walls, grounds, regions = [], [], []
    for b in setup.boundaries:
        if b.kind == "walls":
            # X_d < lo_d + 3 dx  <=>  I_d < 3 ;  X_d > hi_d - 3 dx  <=>  I_d > (hi_d - lo_d)/dx - 3
            r = (hi - lo) / dx - 3.0
            hi_first = tuple(int(math.floor(r[d] + _TIE)) + 1 for d in range(3))
            walls.append((float(b.friction), (3, 3, 3), hi_first))
        elif b.kind == "ground":
            grounds.append((float(b.friction), ground_top_node(b.height, lo[2], dx)))
        elif b.kind == "fixed_region":
            a = (np.asarray(b.lo, float) - lo) / dx
            c = (np.asarray(b.hi, float) - lo) / dx
            regions.append((tuple(int(math.ceil(a[d] - _TIE)) for d in range(3)),
                            tuple(int(math.floor(c[d] + _TIE)) for d in range(3))))
    return walls, grounds, regions


@ti.data_oriented
class MPMSolver:
    """Fields and kernels of one simulation.

    Parameters
    ----------
    x, v : ndarray, shape (n, 3), float64
        Positions (metres) and velocities (m/s), already in the solver's point order.
    C0 : ndarray, shape (n, 3, 3)
        Initial APIC velocity gradient, 1/s (``SimSetup.C``; zeros when it is None).
    p_mass, p_vol : ndarray, shape (n,)
        kg and m^3.
    body : ndarray, shape (n,), int32
        Body index into ``params``/``kinds``.
    fixed : ndarray, shape (n,), bool
        Points held still (started inside a fixed region).
    jp0 : ndarray, shape (n,)
        Initial Jp (``gasp_core.toolkit.materials.initial_Jp``: 0 for plasticine, 1 otherwise).
    params : ndarray, shape (n_bodies, N_PARAMS)
        ``gasp_core.toolkit.materials.material_table``.
    kinds : sequence of int
        Material code per body (``gasp_core.toolkit.materials.MATERIAL_CODES`` values).
    n_grid : int
    lo : ndarray, shape (3,)
        Grid origin (domain_lo), metres.
    dx, dt : float
    gravity : ndarray, shape (3,)
    walls, grounds, regions
        From :func:`node_ranges`.
    real : taichi dtype
        ``ti.f32`` or ``ti.f64``.
    n_chunks : int
        Number of point chunks / private grid copies (taken by the CPU threads in turn); ignored with ``atomic``.
    atomic : bool
        Scatter with atomics into one grid copy and visit the whole grid (CUDA).
    n_material : int, optional
        Points ``[:n_material]`` are material points; the rest (``SimSetup.passive``) are passive:
        G2P only (velocity and position from the grid), no P2G, stress, ``F`` or ``C``. Default all
        are material. Their touched-node box is added to their chunk's box, so the grid update
        visits every node they read.
    """

    def __init__(self, *, x, v, C0, p_mass, p_vol, body, fixed, jp0, params, kinds, n_grid, lo, dx, dt,
                 gravity, walls, grounds, regions, real, n_chunks, atomic, extras=None, time_table=None, n_substeps=1,
                 n_material=None, passive_every=1, flip=0.0):
        n = len(x)
        self.n = n
        self.n_material = n if n_material is None else int(n_material)
        self.has_passive = self.n_material < n
        self.real = real
        self.n_grid = int(n_grid)
        self.atomic = bool(atomic)
        self.n_chunks = 1 if self.atomic else int(n_chunks)
        self.kinds = frozenset(int(k) for k in kinds)
        self.multi_kind = len(self.kinds) > 1
        self.any_fixed = bool(np.any(fixed))
        self.viscous = bool(np.any(np.asarray(params)[:, P_ETA] > 0))
        self.flip = float(flip)   # AFLIP blend (gasp_core.toolkit.transfer); > 0: grid_acc also sums the APIC momentum
        self.acc_width = 7 if self.flip > 0 else 4
        self.n_walls, self.n_grounds, self.n_regions = len(walls), len(grounds), len(regions)
        self._allocate_points(len(kinds))
        self._allocate_grid()
        self._allocate_boundaries()

        np_real = np.float32 if real == ti.f32 else np.float64
        self._upload_points(np_real, x=x, v=v, C0=C0, p_mass=p_mass, p_vol=p_vol, body=body, fixed=fixed,
                            jp0=jp0, params=params, kinds=kinds)
        # dt, dx and 1 / dx (computed in float64), each rounded once to the working precision
        self.dt[None], self.dx[None], self.inv_dx[None] = np.array([dt, dx, 1.0 / dx], np_real)
        self._passive_every = int(passive_every)
        self._np_real = np_real
        self._passive_plan: tuple[int, list] = (0, [])   # (n_substeps, per-substep weight pair or None)
        self.lo[None] = [float(a) for a in lo]
        self.gravity[None] = [float(a) for a in gravity]
        self._upload_boundaries(walls, grounds, regions)
        self.grid_acc.fill(0)
        self.grid_v.fill(0)
        self._split_chunks()
        self._init_box()
        self._setup_extras(extras, time_table, np_real, n_substeps)
        if self.has_passive:
            self.passive_box()

    def _allocate_points(self, n_bodies: int) -> None:
        """Per-point fields (x, v, C, F, Jp, p_mass, p_vol, body, fixed) and per-body fields (kind, mat).

        Field sizes are rounded up so that Taichi's offline cache (keyed on the kernel IR and the field
        layout) is hit by scenes of similar size; the live count is a field."""
        real = self.real
        cap = max(1024, 1 << (self.n - 1).bit_length())
        self.x = ti.Vector.field(3, real, shape=cap)
        self.v = ti.Vector.field(3, real, shape=cap)
        self.C = ti.Matrix.field(3, 3, real, shape=cap)
        self.F = ti.Matrix.field(3, 3, real, shape=cap)
        self.Jp = ti.field(real, shape=cap)
        self.p_mass = ti.field(real, shape=cap)
        self.p_vol = ti.field(real, shape=cap)
        self.body = ti.field(ti.i32, shape=cap)
        self.fixed = ti.field(ti.i8, shape=cap)
        bcap = max(4, 1 << (n_bodies - 1).bit_length())
        self.kind = ti.field(ti.i32, shape=bcap)
        self.mat = ti.Vector.field(N_PARAMS, real, shape=bcap)

    def _allocate_grid(self) -> None:
        """Grid copies, grid velocity and mass, touched-node boxes, point chunks and the step scalars."""
        real, ng = self.real, self.n_grid
        self.grid_acc = ti.Vector.field(self.acc_width, real, shape=(self.n_chunks, ng, ng, ng))
        self.grid_v0 = ti.Vector.field(3, real, shape=(ng, ng, ng) if self.flip > 0 else (1, 1, 1))  # AFLIP's v_i^n
        self.grid_v = ti.Vector.field(3, real, shape=(ng, ng, ng))
        # node mass of the last grid update, read by the passive points' G2P (only with passive points)
        self.grid_m = ti.field(real, shape=(ng, ng, ng) if self.has_passive else (1, 1, 1))
        self.box = ti.Vector.field(3, ti.i32, shape=(self.n_chunks, 2))  # touched node box per chunk
        self.plane_chunks = ti.Vector.field(2, ti.i32, shape=ng)  # first and last chunk whose box reaches I_x
        self.n_out = ti.field(ti.i32, shape=())  # out-of-grid point-substeps since last reset
        self.n_points = ti.field(ti.i32, shape=())
        self.chunk_lo = ti.field(ti.i32, shape=self.n_chunks)
        self.chunk_hi = ti.field(ti.i32, shape=self.n_chunks)
        self.n_total = ti.field(ti.i32, shape=())
        self.pchunk_lo = ti.field(ti.i32, shape=self.n_chunks)   # passive points of each chunk
        self.pchunk_hi = ti.field(ti.i32, shape=self.n_chunks)
        self.pbox = ti.Vector.field(3, ti.i32, shape=(self.n_chunks, 2))  # passive points' node box
        self.dt = ti.field(real, shape=())       # substep, s
        self.dx = ti.field(real, shape=())       # node spacing, m
        self.inv_dx = ti.field(real, shape=())   # 1 / dx, 1/m
        # substeps of the passive points' full interval [0] and last interval [1]
        # (gasp_core.toolkit.substeps.passive_schedule)
        self.passive_substeps = ti.field(ti.i32, shape=2)
        self.lo = ti.Vector.field(3, real, shape=())
        self.gravity = ti.Vector.field(3, real, shape=())

    def _allocate_boundaries(self) -> None:
        """Friction and node ranges of at most 4 boundaries of each kind (walls, ground, fixed_region).

        Raises SceneError with more."""
        real, nb = self.real, 4
        self.wall_fric = ti.field(real, shape=nb)
        self.wall_hi_first = ti.Vector.field(3, ti.i32, shape=nb)
        self.ground_fric = ti.field(real, shape=nb)
        self.ground_kmax = ti.field(ti.i32, shape=nb)
        self.reg_lo = ti.Vector.field(3, ti.i32, shape=nb)
        self.reg_hi = ti.Vector.field(3, ti.i32, shape=nb)
        if max(self.n_walls, self.n_grounds, self.n_regions) > nb:
            raise SceneError(f"engine 'taichi_mpm': at most {nb} boundaries of each kind (walls, ground, "
                             f"fixed_region); got {self.n_walls}, {self.n_grounds}, {self.n_regions}")

    def _upload_points(self, np_real, *, x, v, C0, p_mass, p_vol, body, fixed, jp0, params, kinds) -> None:
        """The points' and bodies' arrays into their fields (padding rows zero; F the identity)."""
        def put(field, arr, dtype, fill=0):
            a = np.asarray(arr, dtype)
            shape = tuple(field.shape) + a.shape[1:]
            buf = np.full(shape, fill, dtype)
            buf[:len(a)] = a
            field.from_numpy(buf)

        put(self.x, x, np_real)
        put(self.v, v, np_real)
        put(self.F, np.broadcast_to(np.eye(3), (self.n, 3, 3)), np_real)
        put(self.C, C0, np_real)
        put(self.Jp, jp0, np_real)
        put(self.p_mass, p_mass, np_real)
        put(self.p_vol, p_vol, np_real)
        put(self.body, body, np.int32)
        put(self.fixed, fixed, np.int8)
        put(self.kind, kinds, np.int32)
        put(self.mat, params, np_real)
        self.n_points[None] = self.n_material
        self.n_total[None] = self.n

    def _upload_boundaries(self, walls, grounds, regions) -> None:
        """:func:`node_ranges`' walls, grounds and regions into their fields."""
        for i, (fr, _, hi_first) in enumerate(walls):
            self.wall_fric[i] = fr
            self.wall_hi_first[i] = hi_first
        for i, (fr, kmax) in enumerate(grounds):
            self.ground_fric[i] = fr
            self.ground_kmax[i] = kmax
        for i, (rlo, rhi) in enumerate(regions):
            self.reg_lo[i] = rlo
            self.reg_hi[i] = rhi

    def _split_chunks(self) -> None:
        """Material points and passive points each split into ``n_chunks`` contiguous chunks."""
        bounds = np.linspace(0, self.n_material, self.n_chunks + 1).round().astype(np.int32)
        self.chunk_lo.from_numpy(bounds[:-1].copy())
        self.chunk_hi.from_numpy(bounds[1:].copy())
        pb = np.linspace(self.n_material, self.n, self.n_chunks + 1).round().astype(np.int32)
        self.pchunk_lo.from_numpy(pb[:-1].copy())
        self.pchunk_hi.from_numpy(pb[1:].copy())

    def get(self, field) -> np.ndarray:
        """A particle field as NumPy, first ``n`` rows (solver order)."""
        return field.to_numpy()[:self.n]

    def set(self, field, arr) -> None:
        """Overwrite the first ``n`` rows of a particle field (solver order)."""
        buf = field.to_numpy()
        buf[:self.n] = arr
        field.from_numpy(buf)

    # ------------------------------------------------------------------ driver
    def _passive_at(self, n_substeps: int) -> list:
        """Per substep of a frame: None, or which interval (0 full, 1 last) moves the passive
        points after its grid update (:func:`gasp_core.toolkit.substeps.passive_schedule`)."""
        if not self.has_passive:
            return [None] * n_substeps
        if self._passive_plan[0] != n_substeps:
            plan = passive_schedule(n_substeps, self._passive_every, float(self.dt[None]))
            dt = float(self.dt[None])
            ms = list(dict.fromkeys(int(round((weight_prev + weight_now) / dt))   # substeps per interval
                                    for _substep, weight_prev, weight_now in plan))
            ms += ms[-1:] * (2 - len(ms))
            self.passive_substeps.from_numpy(np.array(ms, np.int32))
            at = [None] * n_substeps
            for substep, weight_prev, weight_now in plan:
                at[substep] = ms.index(int(round((weight_prev + weight_now) / dt)))
            self._passive_plan = (n_substeps, at)
        return self._passive_plan[1]

    def substeps(self, n_substeps: int) -> None:
        """Advance ``n_substeps`` substeps (P2G, grid update, G2P each), no host sync in between.

        Passive points (``n_material < n``) are moved after a grid update (every one, or every
        ``passive_every``-th and the frame's last: :func:`gasp_core.toolkit.substeps.passive_schedule`), by the
        grid velocity that already holds the forces, colliders and boundaries, so they follow the
        material and respect what it respects; they add nothing to the grid. With colliders, forces
        or impulses the frame's time table is loaded first and the substep index set before each P2G."""
        at = self._passive_at(n_substeps)
        if self.has_extras:
            self.ex_tab.from_numpy(self._time_table().astype(self._ex_np))
            self.ex_step[None] = 0
        self.g2p_p2g(0)
        for s in range(n_substeps - 1):
            self.grid_update()
            if at[s] is not None:
                self.g2p_passive(at[s])
            if self.has_extras:
                self.ex_step[None] = s + 1
            self.g2p_p2g(1)
        self.grid_update()
        self.g2p()
        if at[-1] is not None:
            self.g2p_passive(at[-1])

    # ------------------------------------------------------------------ colliders, forces, impulses
    def _setup_extras(self, ex, time_table, np_real, n_substeps) -> None:
        """Fields of :func:`gasp_core.toolkit.grid_tables.grid_tables` (``ex``); none when ``ex`` is None or empty."""
        self.has_extras = ex is not None and ex.any
        # wind: per node sum_p p_vol grad N_ip (m^2), the windward area its drag acts on (private copies as grid_acc)
        self.has_wind = bool(self.has_extras and ex.has_wind)
        ng = self.n_grid
        self.grid_g = ti.Vector.field(3, self.real, shape=(self.n_chunks, ng, ng, ng) if self.has_wind else (1, 1, 1, 1))
        if not self.has_extras:
            return
        self._ex_np = np_real
        self._time_table = time_table
        self.n_col, self.n_force, self.n_imp, self.ex_width = ex.n_colliders, ex.n_forces, ex.n_impulses, ex.width
        for name, arr in (("ex_sdf", ex.sdf), ("ex_grad", ex.sdf_grad), ("ex_meta", ex.col_meta),
                          ("ex_forces", ex.forces), ("ex_modes", ex.modes), ("ex_imps", ex.impulses)):
            f = ti.field(self.real, shape=len(arr))
            f.from_numpy(np.asarray(arr, np_real))
            setattr(self, name, f)
        self.ex_tab = ti.field(self.real, shape=n_substeps * self.ex_width)
        self.ex_step = ti.field(ti.i32, shape=())

    @ti.func
    def _collide_n(self, v, n, mu_b):
        """taichi_elements' separate collider with Coulomb friction, unit normal ``n`` (any direction)."""
        vn = v.dot(n)
        out = v
        if vn < 0.0:
            vt = v - vn * n
            lt = vt.norm()
            if lt > 1e-30:
                out = vt * ti.max(0.0, 1.0 + mu_b * vn / lt)
            else:
                out = ti.Vector.zero(self.real, 3)
        return out

    @ti.func
    def _extras(self, I, v, m, gsurf):
        """Forces, impulses, then colliders at node ``I`` (docs/colliders.md; the same order as warp_mpm):
        :meth:`_forces`, :meth:`_impulses`, :meth:`_colliders` at the node's position and the substep's row
        of the time table."""
        dt = self.dt[None]
        X = self.lo[None] + self.dx[None] * ti.Vector([ti.cast(I[0], self.real), ti.cast(I[1], self.real),
                                                       ti.cast(I[2], self.real)])
        base = self.ex_step[None] * self.ex_width
        t = self.ex_tab[base]
        v = self._forces(X, v, m, gsurf, t, dt)
        v = self._impulses(X, v, base)
        return self._colliders(X, v, base)

    @ti.func
    def _forces(self, X, v, m, gsurf, t, dt):
        """Wind and point forces on velocity ``v`` of the node at ``X`` (time ``t``, substep ``dt``).

        Wind is quadratic drag on the windward surface, ``F = 1/2 rho_air C_d A |w| w``, ``w = u - v``,
        ``A = max(0, gsurf . w / |w|)`` (``gsurf = sum_p p_vol grad N_ip``, m^2; node mass ``m``, kg),
        applied implicitly in the drag rate ``k = F / (m |w|)``: ``v += w dt k / (1 + dt k)``."""
        for f in range(self.n_force):
            r = f * 12
            a = ti.Vector.zero(self.real, 3)
            if self.ex_forces[r] == 0.0:
                u = ti.Vector([self.ex_forces[r + 1], self.ex_forces[r + 2], self.ex_forces[r + 3]])
                m0 = ti.cast(self.ex_forces[r + 10], ti.i32)
                for mm in range(m0, m0 + ti.cast(self.ex_forces[r + 11], ti.i32)):
                    q = mm * 8
                    k = ti.Vector([self.ex_modes[q], self.ex_modes[q + 1], self.ex_modes[q + 2]])
                    A = ti.Vector([self.ex_modes[q + 3], self.ex_modes[q + 4], self.ex_modes[q + 5]])
                    u += A * ti.sin(k.dot(X) + self.ex_modes[q + 7] * t + self.ex_modes[q + 6])
                wrel = u - v
                wn = wrel.norm()
                if wn > 0.0:
                    area = ti.max(0.0, gsurf.dot(wrel) / wn)
                    kdt = dt * self.ex_forces[r + 4] * area * wn / m
                    v += (kdt / (1.0 + kdt)) * wrel
            else:
                d = ti.Vector([self.ex_forces[r + 1], self.ex_forces[r + 2], self.ex_forces[r + 3]]) - X
                rr = d.norm()
                strength = self.ex_forces[r + 7]
                radius = self.ex_forces[r + 8]
                mag = strength * rr / radius
                if rr >= radius:
                    mag = strength
                    if self.ex_forces[r + 9] == 1.0:
                        mag = strength * (radius / rr) * (radius / rr)
                if rr > 0.0:
                    a = d * (mag / rr)
            v += dt * a
        return v

    @ti.func
    def _impulses(self, X, v, base):
        """Impulses (box or sphere regions, weight from the time table row at ``base``) on ``v`` at ``X``."""
        for q in range(self.n_imp):
            r = q * 11
            inside = False
            c = ti.Vector([self.ex_imps[r + 1], self.ex_imps[r + 2], self.ex_imps[r + 3]])
            b = ti.Vector([self.ex_imps[r + 4], self.ex_imps[r + 5], self.ex_imps[r + 6]])
            if self.ex_imps[r] == 0.0:
                inside = (X >= c).all() and (X <= b).all()
            else:
                inside = (X - c).norm() <= b[0]
            w = self.ex_tab[base + 1 + 18 * self.n_col + q]
            if inside and w > 0.0:
                dv = ti.Vector([self.ex_imps[r + 8], self.ex_imps[r + 9], self.ex_imps[r + 10]])
                if self.ex_imps[r + 7] == 0.0:
                    v += w * dv
                else:
                    v = dv
        return v

    @ti.func
    def _colliders(self, X, v, base):
        """Colliders on ``v`` at ``X``: trilinear signed distance in the collider's frame (pose and velocity
        from the time table row at ``base``); inside (``phi <= 0``), :meth:`_collide_n` relative to the
        collider's velocity with the outward normal."""
        for c in range(self.n_col):
            r = c * 9
            p0 = base + 1 + 18 * c
            R = ti.Matrix([[self.ex_tab[p0 + 0], self.ex_tab[p0 + 1], self.ex_tab[p0 + 2]],
                           [self.ex_tab[p0 + 3], self.ex_tab[p0 + 4], self.ex_tab[p0 + 5]],
                           [self.ex_tab[p0 + 6], self.ex_tab[p0 + 7], self.ex_tab[p0 + 8]]])
            T = ti.Vector([self.ex_tab[p0 + 9], self.ex_tab[p0 + 10], self.ex_tab[p0 + 11]])
            h = self.ex_meta[r + 3]
            org = ti.Vector([self.ex_meta[r], self.ex_meta[r + 1], self.ex_meta[r + 2]])
            nx = ti.cast(self.ex_meta[r + 4], ti.i32)
            ny = ti.cast(self.ex_meta[r + 5], ti.i32)
            nz = ti.cast(self.ex_meta[r + 6], ti.i32)
            off = ti.cast(self.ex_meta[r + 7], ti.i32)
            u = (R.transpose() @ (X - T) - org) / h
            if (u[0] >= 0.0 and u[1] >= 0.0 and u[2] >= 0.0 and u[0] <= nx - 1.0 and u[1] <= ny - 1.0
                    and u[2] <= nz - 1.0):
                i0 = ti.min(ti.cast(ti.floor(u[0]), ti.i32), nx - 2)
                j0 = ti.min(ti.cast(ti.floor(u[1]), ti.i32), ny - 2)
                k0 = ti.min(ti.cast(ti.floor(u[2]), ti.i32), nz - 2)
                fx = u - ti.Vector([ti.cast(i0, self.real), ti.cast(j0, self.real), ti.cast(k0, self.real)])
                phi = ti.cast(0.0, self.real)
                g = ti.Vector.zero(self.real, 3)
                for di, dj, dk in ti.static(ti.ndrange(2, 2, 2)):
                    wgt = ((fx[0] if di else 1.0 - fx[0]) * (fx[1] if dj else 1.0 - fx[1])
                           * (fx[2] if dk else 1.0 - fx[2]))
                    idx = off + ((i0 + di) * ny + (j0 + dj)) * nz + (k0 + dk)
                    phi += wgt * self.ex_sdf[idx]
                    g += wgt * ti.Vector([self.ex_grad[3 * idx], self.ex_grad[3 * idx + 1], self.ex_grad[3 * idx + 2]])
                gl = g.norm()
                if phi <= 0.0 and gl > 0.0:
                    n = R @ (g / gl)
                    vl = ti.Vector([self.ex_tab[p0 + 12], self.ex_tab[p0 + 13], self.ex_tab[p0 + 14]])
                    om = ti.Vector([self.ex_tab[p0 + 15], self.ex_tab[p0 + 16], self.ex_tab[p0 + 17]])
                    vc = vl + om.cross(X - T)
                    v = vc + self._collide_n(v - vc, n, self.ex_meta[r + 8])
        return v

    # ------------------------------------------------------------------ helpers
    @ti.kernel
    def _init_box(self):
        for t in range(self.n_chunks):
            self.box[t, 0] = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
            self.box[t, 1] = ti.Vector([-1, -1, -1])

    @ti.func
    def _base_fx(self, xp):
        X = (xp - self.lo[None]) * self.inv_dx[None]
        base = ti.cast(ti.floor(X - 0.5), ti.i32)
        ok = base.min() >= 0 and base.max() <= self.n_grid - 3
        fx = X - ti.cast(base, self.real)
        return base, fx, ok

    @ti.func
    def _weights(self, fx):
        return [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]

    @ti.func
    def _udvt(self, U, d, V):
        D = ti.Matrix.zero(self.real, 3, 3)
        D[0, 0] = d[0]
        D[1, 1] = d[1]
        D[2, 2] = d[2]
        return U @ D @ V.transpose()

    @ti.func
    def _fixed_corotated(self, F, U, V, mu, lam):
        R = U @ V.transpose()
        J = F.determinant()
        return 2.0 * mu * (F - R) @ F.transpose() + ti.Matrix.identity(self.real, 3) * (lam * J * (J - 1.0))

    @ti.func
    def _rotation(self, F):
        """``U V^T`` of the SVD with proper rotations: the rotation closest to F.

        For ``det F > 0`` this is the polar factor, found by Higham's scaled Newton iteration
        ``X <- (g X + X^-T / g) / 2`` (Higham 1986, "Computing the polar decomposition"), which is
        several times cheaper than Taichi's ``ti.svd`` on CPU; it stops when the step is below
        ``sqrt`` of the target accuracy (quadratic convergence). Otherwise ``ti.svd``.
        """
        R = ti.Matrix.zero(self.real, 3, 3)
        if F.determinant() > 0.0:
            X = F
            tol = ti.static(3e-4 if self.real == ti.f32 else 1e-8)
            scale = True
            for it in range(24):
                det = X.determinant()
                cof = ti.Matrix([
                    [X[1, 1] * X[2, 2] - X[1, 2] * X[2, 1], X[1, 2] * X[2, 0] - X[1, 0] * X[2, 2],
                     X[1, 0] * X[2, 1] - X[1, 1] * X[2, 0]],
                    [X[0, 2] * X[2, 1] - X[0, 1] * X[2, 2], X[0, 0] * X[2, 2] - X[0, 2] * X[2, 0],
                     X[0, 1] * X[2, 0] - X[0, 0] * X[2, 1]],
                    [X[0, 1] * X[1, 2] - X[0, 2] * X[1, 1], X[0, 2] * X[1, 0] - X[0, 0] * X[1, 2],
                     X[0, 0] * X[1, 1] - X[0, 1] * X[1, 0]]])
                inv_t = cof / det  # X^-T
                g = 1.0
                if scale:
                    g = ti.sqrt(ti.sqrt(inv_t.norm_sqr() / X.norm_sqr()))
                X_new = 0.5 * (g * X + inv_t / g)
                delta = (X_new - X).norm()
                X = X_new
                if delta < 1e-2:
                    scale = False
                if delta < tol:
                    break
            R = X
        else:
            U, S, V = ti.svd(F, self.real)
            R = U @ V.transpose()
        return R

    @ti.func
    def _sym_eig(self, A):
        """Eigen-decomposition ``A = V diag(lam) V^T`` of a symmetric 3x3 matrix, V a rotation.

        Cyclic Jacobi rotations (Golub & Van Loan, "Matrix Computations", Sec. 8.5), stopped when
        the off-diagonal part is below the working precision relative to the diagonal.
        """
        V = ti.Matrix.identity(self.real, 3)
        tol = ti.static(1e-14 if self.real == ti.f32 else 1e-30)  # squared, relative
        for sweep in range(12):
            off = A[0, 1] ** 2 + A[0, 2] ** 2 + A[1, 2] ** 2
            if off <= tol * (A[0, 0] ** 2 + A[1, 1] ** 2 + A[2, 2] ** 2):
                break
            for pqr in ti.static([(0, 1, 2), (0, 2, 1), (1, 2, 0)]):
                p, q, r = ti.static(pqr[0], pqr[1], pqr[2])
                apq = A[p, q]
                if apq != 0.0:
                    theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                    t = 1.0 / (ti.abs(theta) + ti.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                    c = 1.0 / ti.sqrt(t * t + 1.0)
                    s = t * c
                    A[p, p] -= t * apq
                    A[q, q] += t * apq
                    A[p, q] = 0.0
                    A[q, p] = 0.0
                    arp = A[r, p]
                    arq = A[r, q]
                    A[r, p] = c * arp - s * arq
                    A[p, r] = A[r, p]
                    A[r, q] = s * arp + c * arq
                    A[q, r] = A[r, q]
                    for k in ti.static(range(3)):
                        vkp = V[k, p]
                        vkq = V[k, q]
                        V[k, p] = c * vkp - s * vkq
                        V[k, q] = s * vkp + c * vkq
        return V, ti.Vector([A[0, 0], A[1, 1], A[2, 2]])

    @ti.func
    def _svd(self, F):
        """``F = U diag(sig) V^T`` with U, V rotations (docs/mpm.md: a reflection is carried by
        the sign of a singular value).

        For ``det F > 0``: polar ``F = R S`` (:meth:`_rotation`), ``S = V diag(sig) V^T`` by Jacobi,
        ``U = R V`` - several times cheaper than ``ti.svd`` on CPU. Otherwise ``ti.svd``. The
        singular values are not sorted; every use here is an isotropic function of them.
        """
        U = ti.Matrix.identity(self.real, 3)
        V = ti.Matrix.identity(self.real, 3)
        sig = ti.Vector.zero(self.real, 3)
        if F.determinant() > 0.0:
            R = self._rotation(F)
            S = R.transpose() @ F
            S = 0.5 * (S + S.transpose())
            V, sig = self._sym_eig(S)
            U = R @ V
        else:
            U0, S0, V0 = ti.svd(F, self.real)
            U = U0
            V = V0
            sig = ti.Vector([S0[0, 0], S0[1, 1], S0[2, 2]])
        return U, sig, V

    @ti.func
    def _hencky_tau(self, U, eps, mu, lam):
        tr = eps.sum()
        d = 2.0 * mu * eps + lam * tr
        return self._udvt(U, d, U)

    @ti.func
    def _constitutive(self, p, F):
        """Return mapping and Kirchhoff stress (docs/mpm.md table). Writes F[p], Jp[p]; returns tau."""
        b = self.body[p]
        prm = self.mat[b]
        mu = prm[P_MU]
        lam = prm[P_LAM]
        kind = self.kind[b]
        if ti.static(not self.multi_kind):
            kind = ti.static(next(iter(self.kinds)))
        tau = ti.Matrix.zero(self.real, 3, 3)
        Jp = self.Jp[p]
        eye = ti.Matrix.identity(self.real, 3)
        if ti.static(JELLY in self.kinds):
            if kind == JELLY:
                R = self._rotation(F)
                J = F.determinant()
                tau = 2.0 * mu * (F - R) @ F.transpose() + eye * (lam * J * (J - 1.0))
        if ti.static(NEO_HOOKEAN in self.kinds):
            if kind == NEO_HOOKEAN:
                J = F.determinant()
                tau = mu * (F @ F.transpose() - eye) + eye * (lam * ti.log(ti.max(J, 1e-6)))
        if ti.static(SNOW in self.kinds):
            if kind == SNOW:
                h = ti.exp(prm[P_HARDENING] * (1.0 - Jp))
                U, sig, V = self._svd(F)
                sig_c = ti.min(ti.max(sig, 1.0 - prm[P_THETA_C]), 1.0 + prm[P_THETA_S])
                Jp *= (sig[0] * sig[1] * sig[2]) / (sig_c[0] * sig_c[1] * sig_c[2])
                F = self._udvt(U, sig_c, V)
                tau = self._fixed_corotated(F, U, V, mu * h, lam * h)
        if ti.static(METAL in self.kinds or PLASTICINE in self.kinds or SAND in self.kinds):
            if kind == METAL or kind == PLASTICINE or kind == SAND:
                U, sig, V = self._svd(F)
                eps = ti.log(ti.max(sig, 1e-4))
                tr = eps.sum()
                e = eps - tr / 3.0
                ne = e.norm()
                if kind == SAND:
                    if tr >= 0.0:
                        eps = ti.Vector.zero(self.real, 3)
                    else:
                        dg = ne + (3.0 * lam + 2.0 * mu) / (2.0 * mu) * tr * prm[P_ALPHA]
                        if dg > 0.0:
                            eps -= dg * e / ne
                    F = self._udvt(U, ti.exp(eps), V)
                else:
                    yield_stress = prm[P_YIELD]
                    if kind == PLASTICINE:
                        yield_stress = prm[P_YIELD] * ti.max(0.0, 1.0 - prm[P_SOFTENING] * Jp)
                    dg = ne - VON_MISES_RADIUS * yield_stress / (2.0 * mu)   # ||dev tau|| <= sqrt(2/3) Y
                    if dg > 0.0:
                        eps -= dg * e / ne
                        F = self._udvt(U, ti.exp(eps), V)
                    if kind == PLASTICINE:
                        Jp += ti.max(dg, 0.0)
                tau = self._hencky_tau(U, eps, mu, lam)
        if ti.static(LIQUID in self.kinds):
            if kind == LIQUID:
                J = F.determinant()
                F = eye * ti.pow(J, 1.0 / 3.0)
                tau = eye * (prm[P_K] * J * (J - 1.0))
        self.F[p] = F
        self.Jp[p] = Jp
        return tau

    @ti.func
    def _acc_val(self, mv, m, mv_apic):
        """What a point adds to a node of grid_acc per unit weight: momentum, mass (and the APIC momentum with flip)."""
        if ti.static(self.flip > 0):
            return ti.Vector([mv[0], mv[1], mv[2], m, mv_apic[0], mv_apic[1], mv_apic[2]])
        else:
            return ti.Vector([mv[0], mv[1], mv[2], m])

    @ti.func
    def _p2g_point(self, p, t, bmin, bmax):
        """Scatter point p into grid copy t; returns the updated touched-node box."""
        base, fx, ok = self._base_fx(self.x[p])
        if not ok:
            ti.atomic_add(self.n_out[None], 1)
        else:
            dt = self.dt[None]
            inv_dx = self.inv_dx[None]
            C = self.C[p]
            F = (ti.Matrix.identity(self.real, 3) + dt * C) @ self.F[p]
            tau = self._constitutive(p, F)
            if ti.static(self.viscous):   # Kelvin-Voigt: J 2 eta sym(grad v), C = grad v (docs/dissipation.md)
                tau += (self.mat[self.body[p]][P_ETA] * F.determinant()) * (C + C.transpose())
            m = self.p_mass[p]
            dx = self.dx[None]
            affine = (-dt * self.p_vol[p] * 4.0 * inv_dx * inv_dx) * tau + m * C
            A = affine * dx
            S = (affine - m * C) * dx   # the stress part of A (AFLIP sums the momentum without it)
            mv0 = m * self.v[p] - A @ fx
            w = self._weights(fx)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                weight = w[i][0] * w[j][1] * w[k][2]
                mv = mv0
                if ti.static(i > 0):
                    mv += ti.static(float(i)) * ti.Vector([A[0, 0], A[1, 0], A[2, 0]])
                if ti.static(j > 0):
                    mv += ti.static(float(j)) * ti.Vector([A[0, 1], A[1, 1], A[2, 1]])
                if ti.static(k > 0):
                    mv += ti.static(float(k)) * ti.Vector([A[0, 2], A[1, 2], A[2, 2]])
                val = weight * self._acc_val(mv, m, mv - S @ (ti.Vector([float(i), float(j), float(k)]) - fx))
                node = base + ti.Vector([i, j, k])
                if ti.static(self.atomic):
                    self.grid_acc[0, node] += val
                else:
                    self.grid_acc[t, node] = self.grid_acc[t, node] + val
                if ti.static(self.has_wind):
                    # p_vol grad N_ip: d N / d x_node per axis is (1.5 - fx, 2 (fx - 1), 0.5 - fx) inv_dx
                    dw = [1.5 - fx, 2.0 * (fx - 1.0), 0.5 - fx]
                    gv = (self.p_vol[p] * inv_dx) * ti.Vector([dw[i][0] * w[j][1] * w[k][2], w[i][0] * dw[j][1] * w[k][2],
                                                               w[i][0] * w[j][1] * dw[k][2]])
                    if ti.static(self.atomic):
                        self.grid_g[0, node] += gv
                    else:
                        self.grid_g[t, node] = self.grid_g[t, node] + gv
            bmin = ti.min(bmin, base)
            bmax = ti.max(bmax, base + 2)
        return bmin, bmax

    @ti.func
    def _g2p_point(self, p):
        base, fx, ok = self._base_fx(self.x[p])
        if ok:
            w = self._weights(fx)
            new_v = ti.Vector.zero(self.real, 3)
            B = ti.Matrix.zero(self.real, 3, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                weight = w[i][0] * w[j][1] * w[k][2]
                gv = weight * self.grid_v[base + ti.Vector([i, j, k])]
                new_v += gv
                if ti.static(i > 0):
                    B[0, 0] += ti.static(float(i)) * gv[0]
                    B[1, 0] += ti.static(float(i)) * gv[1]
                    B[2, 0] += ti.static(float(i)) * gv[2]
                if ti.static(j > 0):
                    B[0, 1] += ti.static(float(j)) * gv[0]
                    B[1, 1] += ti.static(float(j)) * gv[1]
                    B[2, 1] += ti.static(float(j)) * gv[2]
                if ti.static(k > 0):
                    B[0, 2] += ti.static(float(k)) * gv[0]
                    B[1, 2] += ti.static(float(k)) * gv[1]
                    B[2, 2] += ti.static(float(k)) * gv[2]
            new_C = (4.0 * self.inv_dx[None]) * (B - new_v.outer_product(fx))
            v_p = new_v
            if ti.static(self.flip > 0):   # AFLIP: v_PIC(new) + alpha (v_p - v_PIC(old))
                old_v = ti.Vector.zero(self.real, 3)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    old_v += w[i][0] * w[j][1] * w[k][2] * self.grid_v0[base + ti.Vector([i, j, k])]
                v_p = new_v + self.flip * (self.v[p] - old_v)
            if ti.static(self.any_fixed):
                if self.fixed[p] != 0:
                    new_v = ti.Vector.zero(self.real, 3)
                    v_p = new_v
                    new_C = ti.Matrix.zero(self.real, 3, 3)
            self.v[p] = v_p
            self.C[p] = new_C
            self.x[p] += self.dt[None] * new_v

    # ------------------------------------------------------------------ kernels
    @ti.kernel
    def g2p(self):
        """G2P alone (last substep of a frame)."""
        for p in range(self.n_points[None]):
            self._g2p_point(p)

    @ti.kernel
    def g2p_p2g(self, with_g2p: ti.i32):
        """G2P of one substep (if ``with_g2p``) fused with the P2G of the next."""
        if ti.static(self.atomic):
            for p in range(self.n_points[None]):
                if with_g2p:
                    self._g2p_point(p)
                self._p2g_point(p, 0, ti.Vector([0, 0, 0]), ti.Vector([0, 0, 0]))
        else:
            ti.loop_config(block_dim=1)
            for t in range(self.n_chunks):
                bmin = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
                bmax = ti.Vector([-1, -1, -1])
                if ti.static(self.has_passive):   # nodes the passive points will read
                    bmin = self.pbox[t, 0]
                    bmax = self.pbox[t, 1]
                for p in range(self.chunk_lo[t], self.chunk_hi[t]):
                    if with_g2p:
                        self._g2p_point(p)
                    bmin, bmax = self._p2g_point(p, t, bmin, bmax)
                self.box[t, 0] = bmin
                self.box[t, 1] = bmax

    @ti.func
    def _g2p_passive_point(self, p, pair):
        """A passive point: velocity ``v`` and affine velocity gradient ``C`` from the grid (no F, no P2G).

        Only nodes that received mass count, with the weights renormalised over them: a surface point
        half a spacing outside the material sees empty nodes (velocity 0, not the material's) in its
        stencil, which would hold it back. ``C`` is the weighted least-squares fit of those nodes'
        velocities (APIC's ``C`` on a full stencil). The point then advances over the ``m = passive_substeps[pair]``
        substeps since its last gather through the affine field
        ``v(y, k) = v_prev + (k/m)(v_new - v_prev) + (C_prev + (k/m)(C_new - C_prev)) y``,
        ``y += dt v(y, k)`` for ``k = 1..m`` (:func:`gasp_core.toolkit.substeps.passive_schedule`), so it turns with
        the material; ``m = 1`` is plain G2P."""
        base, fx, ok = self._base_fx(self.x[p])
        if not ok:
            ti.atomic_add(self.n_out[None], 1)
        else:
            w = self._weights(fx)
            new_v = ti.Vector.zero(self.real, 3)
            wsum = ti.cast(0.0, self.real)
            rbar = ti.Vector.zero(self.real, 3)
            Svr = ti.Matrix.zero(self.real, 3, 3)
            Srr = ti.Matrix.zero(self.real, 3, 3)
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                node = base + ti.Vector([i, j, k])
                if self.grid_m[node] > 0.0:
                    wn = w[i][0] * w[j][1] * w[k][2]
                    r = ti.Vector([ti.static(float(i)), ti.static(float(j)), ti.static(float(k))], self.real) - fx
                    gv = self.grid_v[node]
                    new_v += wn * gv
                    wsum += wn
                    rbar += wn * r
                    Svr += wn * gv.outer_product(r)
                    Srr += wn * r.outer_product(r)
            new_C = ti.Matrix.zero(self.real, 3, 3)
            if wsum > 0.0:
                new_v /= wsum
                rbar /= wsum
                # centred moments; a tiny ridge (1e-4 of a full stencil's wsum / 4) where the nodes with mass are planar
                Svr -= wsum * new_v.outer_product(rbar)
                Srr += ti.Matrix.identity(self.real, 3) * (2.5e-5 * wsum) - wsum * rbar.outer_product(rbar)
                new_C = self.inv_dx[None] * (Svr @ Srr.inverse())
            v_prev = self.v[p]
            C_prev = self.C[p]
            if ti.static(self.any_fixed):
                if self.fixed[p] != 0:
                    new_v = ti.Vector.zero(self.real, 3)
                    new_C = ti.Matrix.zero(self.real, 3, 3)
                    v_prev = new_v
                    C_prev = new_C
            m = self.passive_substeps[pair]
            dt = self.dt[None]
            y = ti.Vector.zero(self.real, 3)
            for kk in range(m):
                t = ti.cast(kk + 1, self.real) / ti.cast(m, self.real)
                y += dt * (v_prev + t * (new_v - v_prev) + (C_prev + t * (new_C - C_prev)) @ y)
            self.x[p] += y
            self.v[p] = new_v + new_C @ y
            self.C[p] = new_C

    @ti.func
    def _passive_chunk(self, t, move: ti.template(), pair):
        """(G2P and) the node box of chunk t's passive points, for the next grid update."""
        bmin = ti.Vector([self.n_grid, self.n_grid, self.n_grid])
        bmax = ti.Vector([-1, -1, -1])
        for p in range(self.pchunk_lo[t], self.pchunk_hi[t]):
            if ti.static(move):
                self._g2p_passive_point(p, pair)
            base, _fx, ok = self._base_fx(self.x[p])
            if ok:
                bmin = ti.min(bmin, base)
                bmax = ti.max(bmax, base + 2)
        self.pbox[t, 0] = bmin
        self.pbox[t, 1] = bmax

    @ti.kernel
    def g2p_passive(self, pair: ti.i32):
        """G2P of the passive points with weight pair ``pair`` (and, on private grids, their node box
        for the next grid update)."""
        if ti.static(self.atomic):
            for p in range(self.n_points[None], self.n_total[None]):
                self._g2p_passive_point(p, pair)
        else:
            ti.loop_config(block_dim=1)
            for t in range(self.n_chunks):
                self._passive_chunk(t, True, pair)

    @ti.kernel
    def passive_box(self):
        """The passive points' node box per chunk, at the start."""
        ti.loop_config(block_dim=1)
        for t in range(self.n_chunks):
            self._passive_chunk(t, False, 0)

    @ti.func
    def _friction(self, v, d: ti.template(), sign: ti.template(), mu_b):
        """:meth:`_collide_n` with the axis normal ``sign * e_d`` (walls and grounds)."""
        n = ti.Vector.zero(self.real, 3)
        n[d] = sign
        return self._collide_n(v, n, mu_b)

    @ti.kernel
    def grid_update(self):
        """Sum the copies over the touched box, clear them, velocity + gravity + boundaries -> grid_v."""
        ng = self.n_grid
        lo = ti.Vector([0, 0, 0])
        hi = ti.Vector([ng - 1, ng - 1, ng - 1])
        if ti.static(not self.atomic):
            lo = ti.Vector([ng, ng, ng])
            hi = ti.Vector([-1, -1, -1])
            for t in ti.static(range(self.n_chunks)):
                lo = ti.min(lo, self.box[t, 0])
                hi = ti.max(hi, self.box[t, 1])
        ext = ti.max(hi - lo + 1, 0)
        if ti.static(not self.atomic):
            for i in range(ng):   # the chunks whose box reaches node plane I_x = i: first and last
                first, last = self.n_chunks, -1
                for t in ti.static(range(self.n_chunks)):
                    if self.box[t, 0][0] <= i and i <= self.box[t, 1][0]:
                        first = ti.min(first, t)
                        last = t
                self.plane_chunks[i] = ti.Vector([first, last])
        count = ext[0] * ext[1] * ext[2]
        for idx in range(count):
            I = lo + ti.Vector([idx // (ext[1] * ext[2]), (idx // ext[2]) % ext[1], idx % ext[2]])
            acc = ti.Vector.zero(self.real, self.acc_width)
            gsurf = ti.Vector.zero(self.real, 3)
            if ti.static(self.atomic):
                acc = self.grid_acc[0, I]
                self.grid_acc[0, I] = ti.Vector.zero(self.real, self.acc_width)
                if ti.static(self.has_wind):
                    gsurf = self.grid_g[0, I]
                    self.grid_g[0, I] = ti.Vector.zero(self.real, 3)
            else:
                # copy t is zero outside its chunk's box: read and clear, in chunk order, only the copies that hold I
                span = self.plane_chunks[I[0]]
                for t in range(span[0], span[1] + 1):
                    if (I >= self.box[t, 0]).all() and (I <= self.box[t, 1]).all():
                        acc += self.grid_acc[t, I]
                        self.grid_acc[t, I] = ti.Vector.zero(self.real, self.acc_width)
                        if ti.static(self.has_wind):
                            gsurf += self.grid_g[t, I]
                            self.grid_g[t, I] = ti.Vector.zero(self.real, 3)
            v = ti.Vector.zero(self.real, 3)
            if acc[3] > 0.0:
                v = ti.Vector([acc[0], acc[1], acc[2]]) / acc[3] + self.dt[None] * self.gravity[None]
                if ti.static(self.has_extras):
                    v = self._extras(I, v, acc[3], gsurf)
                for b in ti.static(range(self.n_walls)):
                    mu_b = self.wall_fric[b]
                    hi_first = self.wall_hi_first[b]
                    for d in ti.static(range(3)):
                        if I[d] < 3:
                            v = self._friction(v, d, 1.0, mu_b)
                        if I[d] >= hi_first[d]:
                            v = self._friction(v, d, -1.0, mu_b)
                for b in ti.static(range(self.n_grounds)):
                    if I[2] <= self.ground_kmax[b]:
                        v = self._friction(v, 2, 1.0, self.ground_fric[b])
                for b in ti.static(range(self.n_regions)):
                    if (I >= self.reg_lo[b]).all() and (I <= self.reg_hi[b]).all():
                        v = ti.Vector.zero(self.real, 3)
            self.grid_v[I] = v
            if ti.static(self.flip > 0):
                v0 = ti.Vector.zero(self.real, 3)
                if acc[3] > 0.0:
                    v0 = ti.Vector([acc[4], acc[5], acc[6]]) / acc[3]
                self.grid_v0[I] = v0
            if ti.static(self.has_passive):
                self.grid_m[I] = acc[3]

    @ti.kernel
    def reset_out(self):
        self.n_out[None] = 0
