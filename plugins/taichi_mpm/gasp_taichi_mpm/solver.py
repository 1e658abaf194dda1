"""The MLS-MPM solver specified in ``docs/mpm.md`` on Taichi: :class:`MPMSolver` owns the fields, their
allocation and the order of the kernels in a frame.

3D MLS-MPM, quadratic B-splines, APIC transfers (Hu et al. 2018), constitutive models of taichi_elements /
PhysGaussian. The kernels live in files by concern, the same files as the Warp plugin, each a mixin of
:class:`MPMSolver`: :mod:`~gasp_taichi_mpm.transfers` (stencil, P2G, G2P, passive G2P),
:mod:`~gasp_taichi_mpm.constitutive` (stresses, return mappings, polar, SVD), :mod:`~gasp_taichi_mpm.grid` (the grid
update and its boundaries), :mod:`~gasp_taichi_mpm.colliders` (the collider rule, signed-distance colliders) and
:mod:`~gasp_taichi_mpm.forces` (forces, impulses, their tables). ``ti.init`` must have been called (by
:class:`gasp_taichi_mpm.engine.TaichiMPMEngine`) before it is built.

Implementation notes (all algebraically identical to the spec; they change rounding only):

* **Coloured block P2G on CPU** (``coloured``; :mod:`~gasp_taichi_mpm.transfers`). The material points are
  sorted by grid block (4 nodes a side) at the start of every frame and every ``SORT_EVERY`` substeps
  (a stable counting sort in Taichi), then G2P + P2G run in 8 passes, one per colour (the parity of the
  block index on each axis), each a flat parallel loop in which one thread scatters a whole block with
  plain adds into the single grid ``grid_mv[0]``. Same-colour blocks are a block apart, so their stencils
  never share a node; a point that drifted more than a cell out of its block since the sort is scattered
  after the 8 passes, serially. Every node's sum is then in a fixed order (colour, block, sorted point),
  so the grid is the same on any thread count (the contact balance's impulse sums are not: engine.py); the
  sort at a frame's start depends only on the positions, so ``--resume`` repeats bit for bit where the run does.
  On CUDA the scatter is atomic. (The grid update still takes private grid copies per chunk, ``n_chunks > 1``.)
* **Active region.** The P2G records the bounding box of the nodes it touched; the grid update
  visits only that box and clears it, so the grid is zero again for the next substep.
* **Implicit viscosity.** With a viscous material, a backward-Euler viscous step on the grid runs between P2G and the
  grid update (:mod:`~gasp_taichi_mpm.viscosity`): no viscous step limit; then a mixed scene's two-field contact.
* **Fused transfers.** Within a frame, the G2P of substep ``s`` and the P2G of substep ``s + 1`` run in one pass over
  the points (``grid_v`` is a separate field from the accumulation copies: no double buffering).
* P2G adds ``(p_mass v - A fx dx) + A (i, j, k)^T dx`` per node, with ``A = affine``; G2P forms
  ``C = 4 inv_dx (sum_w w g (i,j,k)^T - v fx^T)``: the spec's ``dpos = ((i,j,k) - fx) dx`` expanded.
* Boundary masks (walls, ground, fixed regions) are integer node-index ranges, found in float64 in Python; ties
  within 1e-9 cells count as exact ties.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm import grid_tables
from gasp_core.mpm.substeps import passive_schedule
from gasp_core.seam import SceneError
from gasp_core.mpm.contact import collider_grid_depth
from gasp_core.mpm.materials import N_PARAMS, P_ETA

from .colliders import Colliders
from .constitutive import Constitutive
from .balance import Balance
from .balance_gpu import BalanceGPU
from .cells import Cells
from .checks import FrameChecks
from .contact import Contact
from .fields import Fields
from .forces import Forces, count_set_boxes
from .grid import GridUpdate
from .mid_stress import MidStress, stress_flags
from .rigid import Rigid
from .rigid_hold import RigidHold
from .rigid_collider import RigidCollider
from .schedule.coloured import SORT_EVERY, ColouredP2G  # noqa: F401 (SORT_EVERY: benchmarks/bench_threads.py)
from .schedule.fixed import FixedPointP2G
from .schedule.ordered import OrderedCPU
from .schedule.tiles import TileP2G
from .transfers import Transfers
from .viscosity import ImplicitViscosity


@ti.data_oriented
class MPMSolver(MidStress, RigidCollider, Transfers, ColouredP2G, TileP2G, FixedPointP2G, Constitutive, GridUpdate, Colliders, Forces, Contact, Balance,
                BalanceGPU, Rigid, Fields, Cells, RigidHold, FrameChecks, OrderedCPU):
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
        Initial Jp (``gasp_core.mpm.materials.initial_Jp``: 0 for plasticine, 1 otherwise).
    params : ndarray, shape (n_bodies, N_PARAMS)
        ``gasp_core.mpm.materials.material_table``.
    kinds : sequence of int
        Material code per body (``gasp_core.mpm.materials.MATERIAL_CODES`` values).
    n_grid : int
    lo, gravity : ndarray, shape (3,)
        Grid origin (domain_lo), metres; m/s^2.
    dx, dt : float
    walls, grounds, regions
        From :func:`node_ranges`. ``planes``: ``gasp_core.mpm.contact.contact_planes`` (with ``p_contact``).
    real : taichi dtype
        ``ti.f32`` or ``ti.f64``.
    n_chunks : int
        Number of point chunks / private grid copies (taken by the CPU threads in turn); ignored with ``atomic``.
    atomic : bool
        Scatter with atomics into one grid copy and visit the whole grid (CUDA).
    coloured : bool
        Coloured block P2G (CPU; ``n_chunks`` must be 1 and ``atomic`` False).
    n_material : int, optional
        Points ``[:n_material]`` are material points; the rest (``SimSetup.passive``) are passive:
        G2P only (velocity and position from the grid), no P2G, stress, ``F`` or ``C``. Default all
        are material. Their touched-node box is added to their chunk's box, so the grid update
        visits every node they read.
    passive_bounds : (ndarray, ndarray[, float]), optional
        The box (m, shape (3,) each) the passive points are held in after each update and its floor's friction
        (``gasp_core.mpm.points.passive_bounds``, ``passive_floor_friction``; 0); default unbounded.
    rigid_frames : tuple, optional
        ``(rigid, centre, X0, inertia0, mass)``: which bodies are rigid and their rest frames
        (``gasp_core.mpm.rigid.body_frames``, ``X0`` in solver order); the rigid bodies' points are projected
        onto a rigid motion after every G2P (:mod:`gasp_taichi_mpm.rigid`). Default none.
    hold, box_hold : ndarray, shape (n_bodies,), bool, optional
        The bodies held out of the colliders, and in ``passive_bounds``' box, after G2P (``Colliders.allocate_hold``).
    gpu : bool, optional
        The GPU schedule (:mod:`gasp_taichi_mpm.schedule`; implies ``atomic``): no loop over points, nodes or list
        entries on one thread. Default the CPU schedule. ``tiles``: with it on CUDA, the tiled P2G in shared memory
        (:mod:`gasp_taichi_mpm.schedule.tiles`; not with wind, whose gradients it does not sum). ``deterministic``:
        with it, the P2G in fixed point (:mod:`gasp_taichi_mpm.schedule.fixed`; never tiled).
    """

    def __init__(self, *, x, v, C0, p_mass, p_vol, body, fixed, jp0, params, kinds, n_grid, lo, dx, dt,
                 gravity, walls, grounds, regions, real, n_chunks, atomic, extras=None, time_table=None, n_substeps=1,
                 n_material=None, passive_every=1, flip=0.0, coloured=False, p_contact=None, passive_bounds=None,
                 rigid_frames=None, contact_reach=None, body_mass=None, n_colc=0, planes=None, mixed=None, fields=None,
                 hold=None, box_hold=None, gpu=False, tiles=False, deterministic=False, sort_every=1, touch_speed=0.0,
                 mid_stress=False):
        n, self.touch_speed_in, (self.mid_stress, self.trap_stress) = len(x), float(touch_speed), stress_flags(mid_stress)
        self.n = n
        self.n_material = n if n_material is None else int(n_material)
        self.has_passive = self.n_material < n
        self.real = real
        self.n_grid = int(n_grid)
        self.gpu = bool(gpu)   # the GPU schedule (gasp_taichi_mpm.schedule): every loop parallel, atomic P2G
        self.atomic = bool(atomic) or self.gpu
        self.n_chunks = 1 if self.atomic else int(n_chunks)
        self.kinds = frozenset(int(k) for k in kinds)
        self.multi_kind = len(self.kinds) > 1
        self.any_fixed = bool(np.any(fixed))
        self.viscous = bool(np.any(np.asarray(params)[:, P_ETA] > 0))
        self.flip = float(flip)   # AFLIP blend (gasp_core.mpm.transfer); > 0: grid_mv also sums the APIC momentum
        self.coloured = bool(coloured) and not self.atomic and self.n_chunks == 1
        self.n_walls, self.n_grounds, self.n_regions = len(walls), len(grounds), len(regions)
        self.ground_rubs = any(g[0] > 0 for g in grounds)   # a ground with friction: the touched layer (touch.py)
        # the particle contact (p_contact: (n, 3) per point, contact.py) with the grounds' and walls' planes
        plane_n, plane_row = planes if planes is not None and p_contact is not None else (np.zeros((0, 3)),) * 2
        self.n_planes = len(plane_n)   # (contact_planes' normals and rows); grid_mv's last channel sums the budgets
        self.n_colc = int(n_colc) if p_contact is not None else 0   # colliders in the particle contact; its supports
        n_faces = int(np.sum(plane_row[:, 2] > 0))   # a body: the grounds, each collider, each face of the walls
        self.n_sup, self.nfric = 1 + self.n_colc + n_faces, bool(self.n_colc or n_faces)   # nfric: grid_fnv
        self.pc = bool(self.n_planes or self.n_colc)   # the particle contact
        # channels of grid_mv: momentum, mass (, APIC momentum with flip) (, viscous volume J V eta when viscous)
        # (, friction budget with the particle contact: always the last)
        self.eta_channel = 7 if self.flip > 0 else 4
        self.acc_width = self.eta_channel + (1 if self.viscous else 0) + (1 if self.pc else 0)
        self.n_set_boxes = count_set_boxes(extras)   # their ghost nodes need the node mass (grid.py)
        self.n_bodies = len(kinds)   # bodies (the viscous step's labels, viscosity.py)
        self._allocate_points(len(kinds))
        self._allocate_grid()
        self.allocate_contact()
        self._allocate_boundaries()
        self._allocate_rigid(*(rigid_frames or ([False] * len(kinds), None, None, None, None)))
        self.allocate_balance(contact_reach if self.n_planes or self.n_colc else None, body_mass)
        np_real = np.float32 if real == ti.f32 else np.float64
        self._upload_points(np_real, x=x, v=v, C0=C0, p_mass=p_mass, p_vol=p_vol, body=body, fixed=fixed,
                            jp0=jp0, params=params, kinds=kinds, p_contact=p_contact)
        # dt, dx and 1 / dx (computed in float64), each rounded once to the working precision
        self.dt[None], self.dx[None], self.inv_dx[None] = np.array([dt, dx, 1.0 / dx], np_real)
        self.col_deep = collider_grid_depth("particle" if self.n_colc else "grid", dx)   # colliders' grid rule
        self.allocate_mixed(mixed, dx)   # the contact chosen per body (contact.py); two fields (in_a, mu):
        self.allocate_fields(*(fields or (None, 0.0, 0.0)))
        self.allocate_hold(hold, box_hold)   # the colliders' and boundaries' hold on the grid contact's points
        self._passive_every, self._np_real = int(passive_every), np_real
        self._passive_plan: tuple[int, list] = (0, [])   # (n_substeps, per-substep weight pair or None)
        self.lo[None], self.gravity[None] = [float(a) for a in lo], [float(a) for a in gravity]
        hold = passive_bounds if passive_bounds is not None else (np.full(3, -np.inf), np.full(3, np.inf))
        self.hold_lo[None], self.hold_hi[None] = ([float(a) for a in b] for b in hold[:2])
        self.hold_mu[None] = float(hold[2]) if len(hold) > 2 else 0.0
        self._upload_boundaries(walls, grounds, regions, plane_n, plane_row)
        self.grid_mv.fill(0), self.grid_v.fill(0)
        self._split_chunks(), self._init_box(), self.allocate_passive_span(p_mass, p_vol)   # transfers.py
        self._setup_extras(extras, time_table, np_real, n_substeps)
        self.tiles = bool(tiles) and self.gpu and not self.has_wind and not deterministic   # schedule/tiles.py, CUDA
        self.allocate_fixed(deterministic and self.gpu, p_mass, p_vol, np.asarray(params)[:, P_ETA], dx, dt, lo)
        if self.tiles:
            self.allocate_tiles(sort_every)
        if self.has_passive and not self.atomic:   # the chunks' node box: only the CPU's chunked and coloured P2G read it
            self.passive_box()
        self.visc = ImplicitViscosity(self, self.eta_channel) if self.viscous else None

    def _allocate_points(self, n_bodies: int) -> None:
        """Per-point fields (x, v, C, F, Jp, p_mass, p_vol, body, fixed) and per-body fields (kind, mat).

        Field sizes are rounded up so that Taichi's offline cache (keyed on the kernel IR and the field
        layout) is hit by scenes of similar size; the live count is a field."""
        real = self.real
        cap = max(1024, 1 << (self.n - 1).bit_length())
        self.x = ti.Vector.field(3, real, shape=cap)
        self.v = ti.Vector.field(3, real, shape=cap)
        self.C, self.C_prev = (ti.Matrix.field(3, 3, real, shape=s) for s in (cap, cap if self.trap_stress else 1))
        self.F = ti.Matrix.field(3, 3, real, shape=cap)
        self.Jp = ti.field(real, shape=cap)
        self.p_mass = ti.field(real, shape=cap)
        self.p_vol = ti.field(real, shape=cap)
        self.body = ti.field(ti.i32, shape=cap)
        self.fixed = ti.field(ti.i8, shape=cap)
        self.p_contact = ti.Vector.field(3, real, shape=cap if self.n_planes or self.n_colc else 1)   # (k, c, skin)
        bcap = max(4, 1 << (n_bodies - 1).bit_length())
        self.kind, self.asleep = ti.field(ti.i32, shape=bcap), ti.field(ti.i32, shape=bcap)   # asleep: set_asleep
        self.mat = ti.Vector.field(N_PARAMS, real, shape=bcap)

    def _allocate_grid(self) -> None:
        """Grid copies, grid velocity and mass, touched-node boxes, point chunks and the step scalars."""
        real, ng = self.real, self.n_grid
        self.grid_mv = ti.Vector.field(self.acc_width, real, shape=(self.n_chunks, ng, ng, ng))
        self.grid_v0 = ti.Vector.field(3, real, shape=(ng, ng, ng) if self.flip > 0 else (1, 1, 1))  # AFLIP's v_i^n
        self.grid_v = ti.Vector.field(3, real, shape=(ng, ng, ng))
        # node mass of the last grid update, read by the passive points' G2P (only with passive points)
        # and the held boxes' ghost nodes (grid.py; a fixed region's under grid_tables.FIXED_BY_MASS)
        self.keep_mass = self.has_passive or self.n_set_boxes > 0 or (self.n_regions > 0 and grid_tables.FIXED_BY_MASS)
        self.grid_m = ti.field(real, shape=(ng, ng, ng) if self.keep_mass else (1, 1, 1))
        self.allocate_cut()   # the fixed regions' broken faces (grid.py)
        self.box = ti.Vector.field(3, ti.i32, shape=(self.n_chunks, 2))  # touched node box per chunk
        self.plane_chunks = ti.Vector.field(2, ti.i32, shape=ng)  # first and last chunk whose box reaches I_x
        self.n_out = ti.field(ti.i32, shape=())  # out-of-grid point-substeps since last reset
        self.bad = ti.field(ti.i32, shape=4)     # check_points' counts and first indices
        self.n_points = ti.field(ti.i32, shape=())
        self.chunk_lo, self.chunk_hi = ti.field(ti.i32, shape=self.n_chunks), ti.field(ti.i32, shape=self.n_chunks)
        self.n_total = ti.field(ti.i32, shape=())
        self.pbox = ti.Vector.field(3, ti.i32, shape=(self.n_chunks, 2))  # passive points' node box
        # substep (s), node spacing (m), 1 / dx (1/m)
        self.dt, self.dx, self.inv_dx = (ti.field(real, shape=()) for _ in range(3))
        # substeps of the passive points' full interval [0] and last [1] (mpm.substeps.passive_schedule)
        self.passive_substeps = ti.field(ti.i32, shape=2)
        self.lo, self.gravity = ti.Vector.field(3, real, shape=()), ti.Vector.field(3, real, shape=())
        # the box the boundaries keep passive points in (m; gasp_core.mpm.points.passive_bounds), its floor's mu
        self.hold_lo, self.hold_hi = ti.Vector.field(3, real, shape=()), ti.Vector.field(3, real, shape=())
        self.hold_mu = ti.field(real, shape=())
        if self.coloured:   # the block sort (transfers.sort_blocks): keys, sorted order, counts per (chunk, key)
            from .schedule.coloured import BLOCK, SORT_CHUNKS
            cap = self.x.shape[0]
            self.nbh = ((ng + BLOCK - 1) // BLOCK + 1) // 2   # blocks per axis, halved (rounded up): colour-major keys
            self.n_keys = 8 * self.nbh ** 3
            self.key = ti.field(ti.i32, shape=cap)
            self.order = ti.field(ti.i32, shape=cap)
            self.skey = ti.field(ti.i32, shape=cap)
            self.late = ti.field(ti.i8, shape=cap)
            self.hist = ti.field(ti.i32, shape=(SORT_CHUNKS, self.n_keys))
            self.colour_lo = ti.field(ti.i32, shape=9)
            self.n_late = ti.field(ti.i32, shape=())
        self.late_points = 0   # late points since the engine was built (statistics)

    def _allocate_boundaries(self) -> None:
        """Friction and node ranges of at most 4 boundaries of each kind (walls, ground, fixed_region).

        Raises SceneError with more."""
        real, nb = self.real, 4
        self.wall_fric = ti.field(real, shape=nb)
        self.wall_hi_first = ti.Vector.field(3, ti.i32, shape=nb)
        self.wall_lo_first = ti.Vector.field(3, ti.i32, shape=nb)
        self.plane_n = ti.Vector.field(3, real, shape=max(self.n_planes, 1))     # the particle contact's planes:
        self.plane_row = ti.Vector.field(3, real, shape=max(self.n_planes, 1))   # normal; offset, friction, support
        self.ground_fric = ti.field(real, shape=nb)
        self.ground_kmax = ti.field(ti.i32, shape=nb)
        self.ground_h = ti.field(real, shape=nb)
        self.reg_lo = ti.Vector.field(3, ti.i32, shape=nb)
        self.reg_hi = ti.Vector.field(3, ti.i32, shape=nb)
        self.reg_box = ti.Vector.field(3, real, shape=(nb, 2))   # the regions' boxes, m (GridUpdate.mirror_held)
        if max(self.n_walls, self.n_grounds, self.n_regions) > nb:
            raise SceneError(f"engine 'taichi_mpm': at most {nb} boundaries of each kind (walls, ground, "
                             f"fixed_region); got {self.n_walls}, {self.n_grounds}, {self.n_regions}")

    def _upload_points(self, np_real, *, x, v, C0, p_mass, p_vol, body, fixed, jp0, params, kinds, p_contact) -> None:
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
        if self.trap_stress:   # round 69: the trapezoid's last gradient (mid_stress.py)
            put(self.C_prev, C0, np_real)
        put(self.Jp, jp0, np_real)
        put(self.p_mass, p_mass, np_real)
        put(self.p_vol, p_vol, np_real)
        put(self.body, body, np.int32)
        put(self.fixed, fixed, np.int8)
        put(self.kind, kinds, np.int32)
        put(self.mat, params, np_real)
        if self.n_planes or self.n_colc:
            put(self.p_contact, p_contact, np_real)
        self.n_points[None] = self.n_material
        self.n_total[None] = self.n

    def _upload_boundaries(self, walls, grounds, regions, plane_n, plane_row) -> None:
        """:func:`node_ranges`' walls, grounds and regions, and the particle contact's planes, into their fields."""
        for i, (fr, lo_first, hi_first) in enumerate(walls):
            self.wall_fric[i] = fr
            self.wall_lo_first[i] = lo_first
            self.wall_hi_first[i] = hi_first
        for q in range(self.n_planes):
            self.plane_n[q], self.plane_row[q] = [float(a) for a in plane_n[q]], [float(a) for a in plane_row[q]]
        for i, (fr, kmax, h) in enumerate(grounds):
            self.ground_fric[i] = fr
            self.ground_kmax[i] = kmax
            self.ground_h[i] = h
        for i, (rlo, rhi, blo, bhi) in enumerate(regions):
            self.reg_lo[i], self.reg_hi[i], self.reg_box[i, 0], self.reg_box[i, 1] = rlo, rhi, blo, bhi

    def _split_chunks(self) -> None:
        """Material points split into ``n_chunks`` contiguous chunks (the passive points run one thread a point)."""
        bounds = np.linspace(0, self.n_material, self.n_chunks + 1).round().astype(np.int32)
        self.chunk_lo.from_numpy(bounds[:-1].copy())
        self.chunk_hi.from_numpy(bounds[1:].copy())

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
        points after its grid update (:func:`gasp_core.mpm.substeps.passive_schedule`)."""
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
        ``passive_every``-th and the frame's last: :func:`gasp_core.mpm.substeps.passive_schedule`), by the
        grid velocity that already holds the forces, colliders and boundaries, so they follow the
        material and respect what it respects; they add nothing to the grid. With colliders, forces
        or impulses the frame's time table is loaded first and the substep index set before each P2G."""
        at = self._passive_at(n_substeps)
        if self.has_extras:
            self.ex_tab.from_numpy(self._time_table().astype(self._ex_np))
            self.ex_step[None] = 0
        self.p2g_substep(0, 0)
        for s in range(n_substeps - 1):
            self.grid_update()   # with the balance's fix (grid.py)
            if at[s] is not None:
                self.g2p_passive(at[s])
            if self.has_extras:
                self.ex_step[None] = s + 1
            if self.any_rigid:   # the rigid bodies' G2P and projection; the fused kernel below skips their G2P
                self.g2p_rigid()
                self.rigid_step()
            self.p2g_substep(1, s + 1)
        self.grid_update()
        self.last_g2p(at[-1])   # G2P, the passive points', the rigid projection (rigid_hold.py)

    def p2g_substep(self, with_g2p: int, substep: int) -> None:
        """(G2P and) P2G of one substep (coloured, tiled or atomic), the implicit viscous step; with the particle
        contact the bodies' moments for its balance (balance.py) on the ``x, v, C`` this P2G used (warp_mpm's)."""
        with_g2p = self.cells_before_p2g(with_g2p)   # Grady's cells: G2P apart, the nodes' reference cells (cells.py)
        if self.coloured:
            self.p2g_coloured(with_g2p, substep)
        elif self.tiles:
            self.p2g_tiled(with_g2p, substep)
        else:
            self.g2p_p2g(with_g2p)
        if self.fixed_point:   # deterministic: the fixed-point sums to reals (schedule/fixed.py)
            self.fixed_to_grid()
        if self.visc is not None and self.atomic:
            self.full_box()
        if self.visc is not None:
            self.visc.solve()
        self.contact_fields()   # the two-field contact of a mixed scene (fields.py)
        if self.n_spin:   # the bodies' moments for the balance, on the x, v, C this P2G used (balance.py)
            if self.gpu:
                self.contact_moments_gpu()
            else:
                self.contact_moments()
                self.contact_shift()
