"""The ``taichi_mpm`` engine: a :class:`gasp_core.seam.engine.PointEngine` over :class:`MPMSolver`.

Taichi has one runtime per process and ``ti.init`` resets it: **one taichi_mpm engine is live per process at a
time**. Building a new engine invalidates every earlier one; calling an invalidated engine raises
:class:`gasp_core.seam.engine.EngineError`.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from gasp_core.mpm.contact import (balance_mass, contact_coefficients, contact_model, contact_planes, contact_reach,
                                   flowing_bodies, rule_models, touch_dashpot_speed)
from gasp_core.mpm.box_hold import box_hold_codes
from gasp_core.mpm.fields import field_setup
from gasp_core.mpm.rigid_pairs import pair_data, support_data
from gasp_core.mpm.shared_fields import shared_field_warning
from gasp_core.mpm.grid_engine import choose_dt, GridEngineBase, transfer_alpha
from gasp_core.mpm.materials import JELLY, initial_Jp, material_table
from gasp_core.mpm.rigid_hold import hold_setup
from gasp_core.mpm.rigid import body_frames, face_counts, ground_shapes, rigid_contact, rigid_mask, step_view, zero_stress
from gasp_core.seam.memory import check_memory, estimate_bytes
from gasp_core.mpm.restitution import body_table, plane_table, rest_speed
from gasp_core.mpm.points import blow_up_rows, held_codes, passive_bounds, passive_floor_friction
from gasp_core.seam import CAUSE_UNSTABLE, EngineDivergence, EngineError, SimSetup

from . import ENGINE, TaichiMPMConfig
from .affinity import allowed_cores, pin_workers, spin_all_threads, thread_ids
from .frontend import lighten_frontend
from .schedule.fixed import refuse_uncovered
from .state_step import StateClock

#: ``p2g = "auto"`` tiles the GPU schedule's P2G on CUDA from this many material points (docs/performance.md).
TILES_MIN_POINTS = 1 << 18


def use_tiles(p2g: str, n_material: int) -> bool:
    """Whether CUDA's GPU schedule tiles its P2G (:mod:`gasp_taichi_mpm.schedule.tiles`) for option ``p2g``."""
    return p2g == "tiles" or (p2g == "auto" and n_material >= TILES_MIN_POINTS)


#: On CPU the coloured block P2G is used while the grid takes at most this many bytes (beyond, the atomic one).
MAX_PRIVATE_GRID_BYTES = 1 << 30
#: Taichi's offline kernel cache may hold this many bytes (its default, 100 MiB, is less than the kernels of
#: GASP's test run; over it Taichi drops a quarter of the cached kernels at each exit, which then compile again:
#: 12 s for the README donut's P2G alone). ``TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES`` in the environment wins.
CACHE_MAX_BYTES = 1 << 30

#: On the CPU, Taichi's ``advanced_optimization`` passes are off: with them a cold README run spent 35.2 s on frame 1
#: (kernels compiling), without them 16.7 s, and the 36 frames with the kernels cached took the same time (110.8 s
#: against 110.0 s, one farm-bench pair, 1.007x; ``docs/performance.md`` "First run"). ``TI_ADVANCED_OPTIMIZATION``
#: in the environment wins. CUDA keeps Taichi's default (not measured: no GPU here).
CPU_ADVANCED_OPTIMIZATION = False

_generation = 0  # bumped by every engine built; an engine is live while its generation is current


def _quiet_init(ti, **kw) -> None:
    """``ti.init(**kw)`` without its unconditional "[Taichi] Starting on arch=..." line on stdout
    (GASP's stdout carries results, e.g. ``gasp engines --json``); anything else it prints goes to stderr. The
    offline cache may grow to :data:`CACHE_MAX_BYTES`."""
    import contextlib, io, sys  # noqa: E401
    if "TI_OFFLINE_CACHE_MAX_SIZE_OF_FILES" not in os.environ:
        kw.setdefault("offline_cache_max_size_of_files", CACHE_MAX_BYTES)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        ti.init(**kw)
    for line in buf.getvalue().splitlines():
        if not line.startswith("[Taichi] Starting on arch="):
            print(line, file=sys.stderr)


def _init_cpu(ti, real, threads: int, pin: bool) -> tuple[list[int], str]:
    """``ti.init`` on the CPU with ``threads`` workers (the advanced passes as :data:`CPU_ADVANCED_OPTIMIZATION`
    unless ``TI_ADVANCED_OPTIMIZATION`` is set), then, if ``pin``, each worker pinned to its own core
    (:func:`gasp_taichi_mpm.affinity.pin_workers`: the cores pinned, or why none)."""
    cpu = {} if "TI_ADVANCED_OPTIMIZATION" in os.environ else {"advanced_optimization": CPU_ADVANCED_OPTIMIZATION}
    before = thread_ids()
    _quiet_init(ti, arch=ti.cpu, default_fp=real, offline_cache=True, cpu_max_num_threads=threads,
                fast_math=False, log_level=ti.WARN, **cpu)
    if not pin:
        return [], "not asked (pin_threads = false)"
    return pin_workers(thread_ids() - before, spin_all_threads, threads)


class TaichiMPMEngine(GridEngineBase, StateClock):
    """MLS-MPM engine on Taichi (``docs/mpm.md``).

    Parameters
    ----------
    setup : SimSetup
        World frame, SI units. ``setup.options`` (checked and completed by the core) hold ``device`` ("cpu" | "cuda"),
        ``precision`` ("f32" | "f64"), ``dt`` (s) or ``n_substeps`` (per frame), ``cfl`` (0.4) and
        ``threads`` (CPU threads, Taichi's ``cpu_max_num_threads``; default the cores this process may use),
        ``schedule`` (:mod:`gasp_taichi_mpm.schedule`: "cpu", "gpu" or "auto", gpu on CUDA), ``p2g`` ("tiles", "atomic" or
        "auto": tiles from :data:`TILES_MIN_POINTS` points, on CUDA's GPU schedule only) and
        ``pin_threads`` (each worker on its own core: :mod:`gasp_taichi_mpm.affinity`; ``stats()["pinned_cores"]``).

    Raises
    ------
    SceneError
        More substeps per frame than ``max_substeps``; ``deterministic`` with what it does not cover
        (:func:`gasp_taichi_mpm.schedule.fixed.refuse_uncovered`). Options, materials and boundaries are
        checked by the core (``gasp_core.seam.build.build_engine``) before.
    EngineError
        ``device="cuda"`` where Taichi has no CUDA.

    Notes
    -----
    Calls ``ti.init`` (``offline_cache=True``, ``fast_math=False``: IEEE semantics, closer to the
    Warp engine, and measured ~10 % faster here than Taichi's fast math): this resets Taichi, so any earlier engine of this
    plugin in the process stops working. On CPU with ``threads=1`` a run repeats bit for bit (the capability
    ``deterministic={"cpu"}`` is promised for ``threads=1``). On more threads the grid, the viscous step and the
    contact's moments and friction sums are summed in a fixed order (the coloured block P2G,
    ``gasp_taichi_mpm.solver``; :mod:`gasp_taichi_mpm.balance`), but the particle contact's balance adds each
    support's normal impulses in P2G with float64 atomics, whose order follows the threads: with the balance on
    and a body touching a support, runs may differ in the last bits (measured: 1 of 4 runs of the bench block on 2
    threads, 15 frames; with ``contact_balance = false`` 4 of 4 alike). Viscosity is
    integrated implicitly (:mod:`gasp_taichi_mpm.viscosity`), so it does not lower the substep.
    """

    ENGINE = ENGINE

    def __init__(self, setup: SimSetup):
        global _generation
        setup = self.grid_setup(setup)   # the ground on a node; rigid bodies put inside a ground lifted out
        opt = setup.options  # checked and completed by the core (build_engine)
        cfg = self.config = TaichiMPMConfig(**opt)   # the same settings, typed
        # viscosity implicit (backward Euler): no viscous step cap; a rigid body sets no elastic or contact step (step_view)
        view = step_view(setup)
        self.n_substeps, self.dt = choose_dt(view, opt, ENGINE, implicit_viscosity=True)
        shared_field_warning(view, ENGINE)   # solids glued where they touch (fields.py)
        check_memory(estimate_bytes(len(setup.x), setup.n_grid, cfg.precision),
                     ENGINE, f"{len(setup.x)} points, n_grid {setup.n_grid}, {cfg.precision}")
        import taichi as ti
        lighten_frontend()   # frame 1's kernel load: the lighter note, each source read once (frontend.py)

        self.setup = setup
        self.options = opt
        real = ti.f32 if cfg.precision == "f32" else ti.f64
        threads = self._start_taichi(ti, cfg, real)
        _generation += 1
        self._gen = _generation
        self._ti, self.threads = ti, threads
        from .grid import node_ranges
        from .solver import MPMSolver

        dx = setup.dx
        n = len(setup.x)
        # Points sorted by grid cell for memory locality (material points first, then the passive
        # ones: G2P only); outputs go back to the setup order.
        self.order_points(setup, dx)
        o = self._order

        contact = contact_model(view)
        reach, full = rule_models(contact)   # chosen per body: the rule reaches the grid contact's nodes
        walls, grounds, regions = node_ranges(setup, dx, reach)
        mixed = ((flowing_bodies(view, contact),) + node_ranges(setup, dx, full)[:2]) if contact == "mixed" else None
        fixed = held_codes(setup.x, setup.boundaries, dx, sampled=True)   # 1 held, 2+ held and strained (near a face)
        kinds, params = zero_stress(*material_table(setup.materials, setup.crack_band, setup.cells is not None), setup.materials, JELLY)
        rigid = rigid_mask(setup.materials)
        frames = body_frames(setup.x[o], setup.p_mass[o], setup.body_id[o], rigid) if rigid.any() else None
        jp0 = initial_Jp(setup.materials, setup.body_id, setup.cells)
        bytes_per = 4 if real == ti.f32 else 8
        grid_bytes = 4 * bytes_per * setup.n_grid ** 3
        from .schedule import resolve
        self.schedule = resolve(cfg.schedule, self.device)   # "cpu" or "gpu" (gasp_taichi_mpm.schedule)
        atomic = self.device == "cuda" or self.schedule == "gpu" or grid_bytes > MAX_PRIVATE_GRID_BYTES
        C0 = np.zeros((n, 3, 3)) if setup.C is None else setup.C[o]
        self.solver = MPMSolver(x=setup.x[o], v=setup.v[o], C0=C0, p_mass=setup.p_mass[o], p_vol=setup.p_vol[o],
            body=setup.body_id[o], fixed=fixed[o], jp0=jp0[o], params=params, kinds=kinds,
            n_grid=setup.n_grid, lo=setup.domain_lo, dx=dx, dt=self.dt, gravity=setup.gravity,
            walls=walls, grounds=grounds, regions=regions, real=real,
            n_chunks=1, atomic=atomic, coloured=not atomic, n_material=self.n_material,
            passive_every=cfg.passive_every, flip=transfer_alpha(view, opt, self.n_substeps, implicit_viscosity=True),
            p_contact=(rigid_contact(setup, self.dt, contact_coefficients(view))[o]
                       if contact in ("particle", "mixed") and (grounds or walls or setup.colliders) else None),
            n_colc=len(setup.colliders) if contact in ("particle", "mixed") else 0,
            planes=contact_planes(view, contact),
            mixed=mixed, fields=(*field_setup(view), view), hold=flowing_bodies(view, contact) if setup.colliders else None,
            box_hold=box_hold_codes(view, contact),   # the ground and walls' hold (colliders.py)
            passive_bounds=(*passive_bounds(setup, contact), passive_floor_friction(setup, contact)), rigid_frames=None if frames is None else (rigid, *frames),
            contact_reach=contact_reach(setup), gpu=self.schedule == "gpu",
            tiles=self.schedule == "gpu" and self.device == "cuda" and use_tiles(cfg.p2g, self.n_material),
            deterministic=cfg.deterministic, sort_every=cfg.tile_sort_every, mid_stress=cfg,
            body_mass=balance_mass(setup),   # round 59: 0 for a flowing body, which the balance leaves alone
            touch_speed=touch_dashpot_speed(setup, MPMSolver.touch_damping), **self._extras(setup))
        self._rigid_extras(setup, flowing_bodies(view, contact), rigid.any())
        self._p2g_mode = ("tiles" if self.solver.tiles else "atomic" if atomic else "coloured blocks") + \
            (" in fixed point" if self.solver.fixed_point else "")
        refuse_uncovered(self.solver, cfg.deterministic)   # deterministic: what it covers (schedule/fixed.py)
        self.frame, self._closed = 0, False
        self._x = setup.x.astype(np.float32 if real == ti.f32 else np.float64)
        self._v = setup.v.astype(self._x.dtype)
        self.clock = self.state_clock()   # snow's step from its state (state_step.py; off: the setup's)

    def _start_taichi(self, ti, cfg: TaichiMPMConfig, real) -> int | None:
        """``ti.init`` on ``cfg.device`` ("auto": CUDA where Taichi starts one, measured faster there,
        docs/performance.md; else the CPU); sets ``device``, ``pinned`` and ``unpinned_why``; returns the CPU threads
        (None on CUDA).

        Raises
        ------
        EngineError
            ``device = "cuda"`` where Taichi has no CUDA or cannot start it.
        """
        self.device = cfg.device
        if cfg.device == "auto":   # CUDA where it starts (measured faster there, docs/performance.md), else the CPU
            self.device = "cpu"
            import ctypes.util
            if ti.lang.misc.is_arch_supported(ti.cuda) and ctypes.util.find_library("cuda"):   # a driver to start
                _quiet_init(ti, arch=ti.cuda, default_fp=real, offline_cache=True, fast_math=False, log_level=ti.ERROR)
                self.device = "cuda" if ti.lang.impl.current_cfg().arch == ti.cuda else "cpu"
        if self.device == "cuda":
            if not ti.lang.misc.is_arch_supported(ti.cuda):
                raise EngineError(f"engine '{ENGINE}': device 'cuda' requested but this Taichi build "
                                  "or machine has no CUDA; use device='cpu'")
            _quiet_init(ti, arch=ti.cuda, default_fp=real, offline_cache=True, fast_math=False, log_level=ti.WARN)
            if ti.lang.impl.current_cfg().arch != ti.cuda:
                raise EngineError(f"engine '{ENGINE}': device 'cuda' requested but Taichi could not "
                                  "start CUDA (no GPU or driver); use device='cpu'")
            threads = None
            self.pinned, self.unpinned_why = [], "device cuda"
        else:
            threads = int(cfg.threads) if cfg.threads is not None else len(allowed_cores())
            self.pinned, self.unpinned_why = _init_cpu(ti, real, threads, cfg.pin_threads)
        return threads

    def _rigid_extras(self, setup: SimSetup, flows: np.ndarray, any_rigid: bool) -> None:
        """Rigid bodies' restitution, hold of the flowing points (``flows``: per body), pairs (round 62); the cells."""
        self.solver.allocate_cells(setup.cells, self._order)   # Grady's cells, or none (cells.py)
        self.solver.set_spin_shares(setup)   # round 76: the spin the points carry, booked (spin_booking.py)
        self.solver.set_restitution(body_table(setup), plane_table(setup, self.solver.n_planes), rest_speed(setup),
                                    face_counts(setup), ground_shapes(setup))
        self.solver.allocate_rigid_hold(*hold_setup(setup, setup.dx, flows, any_rigid), flows)
        self.solver.set_pairs(*pair_data(setup), support=support_data(setup), setup=setup)   # round 92: setup

    def _extras(self, setup: SimSetup) -> dict[str, Any]:
        """Colliders, forces and impulses for the solver (``gasp_core.colliders.model``); none: nothing."""
        from gasp_core.mpm.grid_tables import frame_table, grid_tables
        ex = grid_tables(setup)
        if not ex.any:
            return {}

        def next_table():
            return frame_table(setup, self.frame * setup.frame_dt, self.n_substeps, self.dt)
        return {"extras": ex, "time_table": next_table, "n_substeps": self.n_substeps}

    # ------------------------------------------------------------------ interface
    def _check_live(self) -> None:
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': this engine was closed")
        if self._gen != _generation:
            raise EngineError(f"engine '{ENGINE}': this engine was invalidated because a newer "
                              f"taichi_mpm engine was built in the process (ti.init is global: "
                              f"one engine per process at a time)")

    def step_frame(self) -> None:
        """Advance ``frame_dt`` seconds in ``n_substeps`` substeps of ``dt``.

        Raises
        ------
        EngineDivergence
            Non-finite position or velocity, or a point out of the grid during the frame (the
            message gives the count and the first point index in setup order).
        EngineError
            The engine was closed or invalidated by a newer one.

        After an EngineDivergence, :meth:`positions` and :meth:`velocities` still return the last
        frame that passed the checks.
        """
        self._check_live()
        s = self.solver
        s.reset_out()
        self.recolour_fields(s.set_in_a)   # round 61: the coloured bodies' fields from the last frame's points
        self.clock_frame() if self.clock.on else s.substeps(self.n_substeps)
        self.frame += 1
        if s.gpu:
            self._checked_on_device()
            return
        x = self.to_setup_order(s.get(s.x))
        v = self.to_setup_order(s.get(s.v))
        n_out = int(s.n_out[None])
        finite = np.isfinite(x).all(axis=1) & np.isfinite(v).all(axis=1)
        if not finite.all():
            bad = np.flatnonzero(~finite)
            raise EngineDivergence(f"{len(bad)} point(s) with non-finite position or velocity "
                                   f"(first index {bad[0]})", self.frame, CAUSE_UNSTABLE)
        base = np.floor((x - self.setup.domain_lo) / self.setup.dx - 0.5)
        out = ((base < 0) | (base > self.setup.n_grid - 3)).any(axis=1)
        out &= ~np.asarray(self.setup.passive, dtype=bool)   # the material points' (None: all; blow_up_rows)
        if (out.any() or n_out > 0) and self._fast(v):
            bad = np.flatnonzero(out)
            where = f" (first index {bad[0]} at {x[bad[0]].tolist()})" if len(bad) else ""
            raise EngineDivergence(
                f"{max(len(bad), 1)} point(s) left the grid{where} faster than a cell a substep; {n_out} "
                f"out-of-grid point-substeps in this frame", self.frame, CAUSE_UNSTABLE)
        self._x, self._v = x, v     # points that left slower stay where they left, out of the transfers

    def _fast(self, v: np.ndarray) -> bool:
        """Whether some material point moves more than a cell a substep (``v``: (n, 3) m/s, setup order): points out
        of the grid are then a blow-up; slower ones have drifted out and drop out of the simulation (feature
        ``left_domain``). Passive points add nothing to the grid: their speed is no sign of an unstable step
        (``gasp_core.mpm.points.blow_up_rows``, issue 66's brittle README donut at 20 m/s)."""
        v = blow_up_rows(v, self.setup.passive)
        return float(np.max(np.linalg.norm(v, axis=1), initial=0.0)) * self.dt > self.setup.dx

    def _checked_on_device(self) -> None:
        """:meth:`step_frame`'s checks on the GPU schedule: counted on the device (``MPMSolver.check_points``), then
        only the positions read back; the velocities when asked (:meth:`velocities`) or when a check fails."""
        s = self.solver
        s.check_points()
        bad = s.bad.to_numpy()
        n_out = int(s.n_out[None])
        if bad[0]:
            raise EngineDivergence(f"{bad[0]} point(s) with non-finite position or velocity "
                                   f"(first index {int(self._order[bad[1]])})", self.frame, CAUSE_UNSTABLE)
        x = s.positions_setup_order(self._order)   # permuted on the device
        if bad[2] or n_out > 0:
            v = self.to_setup_order(s.get(s.v))
            if self._fast(v):
                where = f" (first index {int(self._order[bad[3]])} at {x[self._order[bad[3]]].tolist()})" \
                    if bad[2] else ""
                raise EngineDivergence(
                    f"{max(int(bad[2]), 1)} point(s) left the grid{where} faster than a cell a substep; {n_out} "
                    f"out-of-grid point-substeps in this frame", self.frame, CAUSE_UNSTABLE)
        self._x, self._v = x, None

    def set_asleep(self, asleep: np.ndarray) -> None:
        """Freeze the flagged bodies from the next frame (feature ``sleep``, :mod:`gasp_core.seam.body_sleep`).

        ``asleep``: ndarray, shape (n_bodies,), bool. Their points are left out of the block sort (so the colour
        passes never see them), of the atomic and chunked transfers, of the last G2P and of the contact's moments;
        their ``x, v, C, F, Jp`` stay. Rigid bodies and passive points are not frozen here (the core never asks)."""
        self._check_live()
        a = np.asarray(asleep, dtype=bool).ravel()
        buf = np.zeros(self.solver.asleep.shape, np.int32)
        buf[:len(a)] = a
        self.solver.asleep.from_numpy(buf)

    def positions(self) -> np.ndarray:
        """Current positions, shape (n, 3), float32 (f32) or float64 (f64), metres, setup order."""
        return self._x.copy()

    def velocities(self) -> np.ndarray:
        """Current velocities, shape (n, 3), m/s, setup order (on the GPU schedule read from the device when asked)."""
        if self._v is None:
            self._v = self.to_setup_order(self.solver.get(self.solver.v))
        return self._v.copy()

    # get_state / set_state (GridEngineBase): these fields in solver order, and frame
    STATE = ("x", "v", "C", "F", "Jp")

    def check_open(self) -> None:
        self._check_live()

    def read_array(self, name: str) -> np.ndarray:
        return self.solver.get(getattr(self.solver, name))

    def write_array(self, name: str, value: np.ndarray) -> None:
        self.solver.set(getattr(self.solver, name), value)

    def state_extras(self) -> dict[str, np.ndarray]:
        """``frame`` and, with rigid bodies, their centres and rotations (:mod:`gasp_taichi_mpm.rigid`)."""
        out = super().state_extras()
        if self.solver.any_rigid:
            out.update(self.solver.rigid_state())
        return out

    def restore_extras(self, state: dict[str, np.ndarray]) -> None:
        self.frame = int(state["frame"])
        if self.solver.any_rigid:
            self.solver.set_rigid_state(state)
        self._x = self.to_setup_order(self.solver.get(self.solver.x))
        self._v = self.to_setup_order(self.solver.get(self.solver.v))

    def stats(self) -> dict[str, Any]:
        """:meth:`GridEngineBase.grid_stats` (mass and passive statistics from the solver's fields while the
        engine is live), ``threads``, ``p2g`` (coloured blocks, atomic or tiles) and, while live, ``late_points``
        (coloured P2G: points scattered serially after the colour passes, since the build) and ``viscous_cg_iterations``
        (with a viscous material: mean CG iterations per viscous solve)."""
        live = not self._closed and self._gen == _generation
        s = self.solver
        out = self.grid_stats(self.device, self.config.precision, s.get(s.x) if live else None,
                              s.get(s.p_mass) if live else None, s.grid_m.to_numpy() if live else None)
        out.update(threads=self.threads, p2g=self._p2g_mode, schedule=self.schedule, pinned_cores=list(self.pinned))
        if not self.pinned:
            out["unpinned_why"] = self.unpinned_why
        if live and s.coloured:
            out["late_points"] = int(s.late_points)
        if live and s.visc is not None:
            out["viscous_cg_iterations"] = s.visc.mean_iterations()
        return out

    def close(self) -> None:
        """Drop the fields (Taichi memory is reclaimed at the next ``ti.init``/``ti.reset``)."""
        self._closed = True
        self.solver = None
