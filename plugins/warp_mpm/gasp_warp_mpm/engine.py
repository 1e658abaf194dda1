"""The Warp MLS-MPM engine: :class:`WarpMPMEngine`, built from a :class:`~gasp_core.seam.engine.SimSetup`.

Implements ``docs/mpm.md`` (3D MLS-MPM, quadratic B-splines, APIC; Hu et al. 2018) with :mod:`gasp_warp_mpm.kernels`.
Per substep three launches: P2G (return mapping, stress once per point, scatter), grid update over nodes (which also
clears the accumulation grid), and G2P fused with the position update; with a viscous material the implicit viscous step
(:mod:`gasp_warp_mpm.viscosity`) runs between P2G and the grid update, then the two-field contact of a mixed scene or of
two soft bodies (:mod:`gasp_warp_mpm.fields`). On CUDA the substeps of a frame are captured once in a CUDA graph; on CPU
pre-recorded ``wp.Launch`` objects. The host syncs once per frame, for the blow-up check.

Notes
-----
Choices where docs/mpm.md leaves room (the Taichi plugin agrees to ~1e-5 m on all seven materials):

- ``jelly`` takes ``R = U V^T`` from a Newton polar iteration (Higham 1986) when ``det F > 0``, the same matrix as the
  SVD's ``U V^T``; the plastic materials take the SVD from that rotation and a Jacobi eigen-decomposition of ``R^T F``
  (the Taichi plugin's algorithm, docs/mpm.md "Constitutive models"); ``wp.svd3`` (U, V proper rotations, the sign of a
  reflection on ``sig[2]``, checked in the tests) is used when ``det F <= 0`` or the iteration does not converge.
- ``metal`` / ``plasticine`` rebuild ``F = U diag(exp(eps)) V^T`` only when ``dg > 0``; ``sand`` always rebuilds it.
- Wall friction axis by axis, x then y then z, the low face before the high face.
- A point out of the grid neither scatters nor gathers, keeps its ``x, v, C`` for the frame, which raises
  :class:`EngineDivergence`. ``p_mass v + affine dpos`` and APIC's ``C`` in a factored form: rounding only.
- On CPU the points are kept sorted by grid cell (re-sorted after every frame, stable, so runs repeat bit for bit;
  every per-point array moves with them, the contact coefficients and cells included); outputs in ``setup.x``'s order.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import warp as wp

from gasp_core.mpm.grid_engine import choose_dt, GridEngineBase, transfer_alpha
from gasp_core.mpm.grid_tables import passive_span_mass
from gasp_core.mpm.materials import JELLY, P_ETA, initial_Jp, material_table
from gasp_core.mpm.rigid import rigid_contact, step_view, zero_stress
from gasp_core.seam.memory import check_memory, estimate_bytes
from gasp_core.mpm.contact import (contact_coefficients, contact_model, contact_planes, ground_node_layer,
                                      rule_models, wall_floor, wall_grid_cells)
from gasp_core.mpm.points import blow_up_rows, cell_order, held_codes, passive_bounds, passive_floor_friction
from gasp_core.mpm.substeps import passive_schedule
from gasp_core.seam import CAUSE_UNSTABLE, EngineDivergence, EngineError, SimSetup

from . import ENGINE, WarpMPMConfig, kernels as K
from .balance_alloc import allocate_balance
from .cells import cell_arrays, cell_launches, follow_order
from .colliders import hold_launches
from .fields import allocate_fields, field_launches, grid_sweep   # grid_sweep: round 64's grid_box.py
from .pair_push import with_push
from .collider_launch import collider_launches, with_mark
from .held import HeldRule, held_boxes, mirror_launches   # HeldRule: held_rule.py
from .rigid import RigidBodies
from .sleeping import Sleeping
from .tables import ExtraTables
from .touch import GroundTouch
from .startup import start_warp
from .state_step import StateClock
from .warmup import compile_all
from .schedule import balance_for, resolve as resolve_schedule, viscosity_for


class WarpMPMEngine(GridEngineBase, RigidBodies, ExtraTables, Sleeping, HeldRule, GroundTouch, StateClock):
    """MLS-MPM in Warp (docs/mpm.md), one instance per simulation (the non-kernel part: GridEngineBase).

    Parameters
    ----------
    setup : SimSetup
        Points, materials (``jelly, neo_hookean, metal, sand, snow, plasticine, liquid``),
        boundaries (``ground, walls, fixed_region``), domain and ``n_grid``. ``setup.options``
        (checked and completed by the core) hold ``device`` ("cpu" | "cuda" | "cuda:N"), ``precision`` ("f32" | "f64"), ``dt`` (s) or
        ``n_substeps``, ``cfl`` (0.4) and ``threads`` (accepted and ignored: Warp runs CPU
        kernels on one thread, so CPU runs repeat bit for bit). Options, materials and boundaries
        are checked by the core (``gasp_core.seam.build.build_engine``), the
        material parameters and ``n_grid`` by :class:`SimSetup`.

    Raises
    ------
    SceneError
        More substeps per frame than ``max_substeps``.
    EngineError
        ``device="cuda"`` (or ``"cuda:N"``) without that CUDA device.
    """

    ENGINE = ENGINE

    def __init__(self, setup: SimSetup):
        setup = self.grid_setup(setup)   # the ground on a node; rigid bodies put inside a ground lifted out
        self.setup = setup
        self.options = opts = setup.options  # checked and completed by the core (build_engine)
        cfg = self.config = WarpMPMConfig(**opts)   # the same settings, typed
        kinds, par = zero_stress(*material_table(setup.materials, setup.crack_band, setup.cells is not None), setup.materials, JELLY)   # rigid bodies: no stress
        steps = choose_dt(step_view(setup), opts, ENGINE, implicit_viscosity=True)  # refuses a scene past max_substeps before any build work
        check_memory(estimate_bytes(len(setup.x), setup.n_grid, cfg.precision), ENGINE,
                     f"{len(setup.x)} points, n_grid {setup.n_grid}, {cfg.precision}")
        self.device = start_warp(cfg.device)
        self.schedule = resolve_schedule(cfg.schedule, self.device.is_cuda)   # "cpu" or "gpu" (schedule/__init__.py)
        self.precision = cfg.precision
        Ft = wp.float32 if self.precision == "f32" else wp.float64
        compile_all(Ft, self.device)   # once per install: a later scene compiles nothing (warmup.py)
        self._np_dtype = np.float32 if self.precision == "f32" else np.float64
        self.k = K.build_kernels(Ft)

        self.n_points, self.n_grid = len(setup.x), int(setup.n_grid)
        self.dx, self.inv_dx = setup.dx, 1.0 / setup.dx
        self.n_substeps, self.dt = steps   # chosen once: a step shortened for the contact warns once
        self.frame, self.sim_time = 0, 0.0
        # Sort points by grid cell (cache locality of scatter and gather); order[i] is the setup index of internal
        # point i. Material points first, then the passive ones (SimSetup.passive: G2P only, no P2G).
        self.order_points(setup, self.dx)
        self._upload_points(kinds, par, Ft)
        self._upload_rigid()
        self._allocate_grid(Ft)
        self._upload_boundaries(Ft)
        has_extras, ex = self._extras(setup, self._array, Ft)
        self._launches, self._passive_at, self._tick = [], [None] * self.n_substeps, None
        self._recorded = (Ft, has_extras, ex)   # what the launches are recorded with (again: state_step.py)
        if self.n_points:
            self._record_launches(Ft, has_extras, ex)
        self._graph, self._closed = None, False
        self.clock = self.state_clock(Ft)   # snow's step from its state (state_step.py; off: the setup's)

    def _array(self, a, dtype) -> wp.array:
        """``a`` (contiguous) as a Warp array of ``dtype`` on the engine's device."""
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=self.device)

    def _upload_points(self, kinds, par, Ft) -> None:
        """The points' arrays in internal order (``self._order``) and the per-body material table.

        Points that start inside a fixed region are held (docs/mpm.md G2P)."""
        setup, order, dt_np, k, arr = self.setup, self._order, self._np_dtype, self.k, self._array
        fixed = held_codes(setup.x, setup.boundaries, self.dx, sampled=True).astype(np.int32)   # 2+: strained
        jp0 = initial_Jp(setup.materials, setup.body_id, setup.cells)
        self.x = arr(setup.x[order].astype(dt_np), k.vec3)
        self.v = arr(setup.v[order].astype(dt_np), k.vec3)
        self.F = arr(np.broadcast_to(np.eye(3, dtype=dt_np), (self.n_points, 3, 3)), k.mat33)
        self.C = (wp.zeros(self.n_points, dtype=k.mat33, device=self.device) if setup.C is None
                  else arr(setup.C[order].astype(dt_np), k.mat33))
        self.Jp = arr(jp0[order].astype(dt_np), Ft)
        self.p_mass = arr(setup.p_mass[order].astype(dt_np), Ft)
        self.p_vol = arr(setup.p_vol[order].astype(dt_np), Ft)
        self.body = arr(setup.body_id[order], wp.int32)
        self.fixed = arr(fixed[order], wp.int32)
        self.mat_kind = arr(kinds, wp.int32)
        self.mat_par = arr(par.astype(dt_np), Ft)

    def _allocate_grid(self, Ft) -> None:
        """Grid arrays (momentum and mass, velocity, node mass for passive points, wind surface) and flags."""
        d, k = self.device, self.k
        n_nodes = self.n_grid ** 3
        self.grid_mv = wp.zeros(n_nodes, dtype=k.vec4, device=d)
        self.grid_v = wp.zeros(n_nodes, dtype=k.vec3, device=d)
        n_passive = self.n_points - self.n_material
        self.grid_m = wp.zeros(n_nodes if n_passive or held_boxes(self.setup) else 1, dtype=Ft, device=d)   # node mass
        # with wind: sum_p p_vol grad N_ip per node (m^2), the windward area the drag acts on
        self.has_wind = int(any(f.kind == "wind" for f in (getattr(self.setup, "forces", None) or [])))
        self.grid_g = wp.zeros(n_nodes if self.has_wind else 1, dtype=k.vec3, device=d)
        self.flags = wp.zeros(2, dtype=wp.int32, device=d)  # [out-of-grid count, non-finite count]
        self.flip = transfer_alpha(step_view(self.setup), self.options, self.n_substeps, True)   # AFLIP's (transfer.py)
        self.grid_mv0 = wp.zeros(n_nodes if self.flip else 1, dtype=k.vec4, device=d)
        self.grid_v0 = wp.zeros(n_nodes if self.flip else 1, dtype=k.vec3, device=d)
        # with a viscous material: the viscous volume sum_p w J V eta per node and the implicit step (viscosity.py)
        viscous = bool(np.any(self.mat_par.numpy()[:, P_ETA] > 0))
        self.grid_eta = wp.zeros(n_nodes if viscous else 1, dtype=Ft, device=d)
        self.visc = viscosity_for(self, Ft) if viscous else None   # the run's schedule's (schedule/__init__.py)

    def _upload_boundaries(self, Ft) -> None:
        """Walls' friction, grounds' and fixed regions' boxes as arrays; the particle contact's planes and budgets."""
        fixed_lo, fixed_hi, ground, wall_mu = [], [], [], []
        contact = self._contact = contact_model(step_view(self.setup))
        reach, full = rule_models(contact)   # the grid rule's reach, and where it acts fully (contact.rule_models)
        for bd in self.setup.boundaries:
            if bd.kind == "fixed_region":
                fixed_lo.append(np.asarray(bd.lo, float))
                fixed_hi.append(np.asarray(bd.hi, float))
            elif bd.kind == "ground":
                # the ground's node layers, decided in float64 (gasp_core.mpm.contact.ground_node_layer: its top
                # layer with contact = "grid", two cells lower with the particle contact, which meets the plane)
                lo_z = self.setup.domain_lo[2]
                ground.append((float(ground_node_layer(reach, bd.height, lo_z, self.dx)), bd.friction,
                               float(ground_node_layer(full, bd.height, lo_z, self.dx))))
            else:
                wall_mu.append(bd.friction)
        dt_np, k, arr = self._np_dtype, self.k, self._array
        self.wall_mu = arr(np.array(wall_mu, dtype=dt_np), Ft)
        self.wall_in, self.wall_full = wall_grid_cells(reach), wall_grid_cells(full)   # 3.5 cells in, 1.5 with particle
        self.wall_floor = int(wall_floor(self.setup, reach))   # no floor face where a ground is the floor
        self.ground = arr(np.array(ground, dtype=dt_np).reshape(-1, 3), k.vec3)
        allocate_fields(self, Ft, contact)   # the contact chosen per body: flows, grid_mf; the two fields (fields.py)
        self.fixed_lo = arr(np.array(fixed_lo, dtype=dt_np).reshape(-1, 3), k.vec3)
        # the particle contact: the planes (offset, friction, support) and normals, each point's (k, c, skin) and the
        # nodes' friction budgets; colc: the colliders too; nfric: normals other than +z (walls or colliders), whose
        # nodes keep their budget's normal and the supports' velocity (gasp_warp_mpm.contact)
        plane_n, planes = contact_planes(step_view(self.setup), contact)
        self.planes, self.plane_n = arr(planes.astype(dt_np), k.vec3), arr(plane_n.astype(dt_np), k.vec3)
        self.colc = int(contact in ("particle", "mixed") and bool(self.setup.colliders))
        self.nfric = int(self.colc or bool(np.any(plane_n[:, 2] < 1.0)))
        n = self.n_grid ** 3 if len(planes) or self.colc else 1
        kcs = self._contact_coefficients()[self._order] if n > 1 else np.zeros((1, 3))
        self.p_contact = arr(kcs.astype(dt_np), k.vec3)
        self.grid_fb = wp.zeros(n, dtype=Ft, device=self.device)
        self.grid_fn, self.grid_fv = (wp.zeros(n if self.nfric else 1, dtype=k.vec3, device=self.device) for _ in "nv")
        # the contact's balance (gasp_warp_mpm.balance), per body and support (the grounds, each collider, each wall face)
        allocate_balance(self, list(planes), Ft, 1 + len(self.setup.colliders) * self.colc + int(np.sum(planes[:, 2] > 0)))
        self.fixed_hi = arr(np.array(fixed_hi, dtype=dt_np).reshape(-1, 3), k.vec3)

    def _contact_coefficients(self) -> np.ndarray:
        """The particle contact's coefficients, setup order; a rigid body's follow the step (``rigid_contact``)."""
        return rigid_contact(self.setup, self.dt, contact_coefficients(step_view(self.setup)))

    def _record_launches(self, Ft, has_extras: int, ex) -> None:
        """The recorded launches: a substep's (P2G, grid update, G2P), the passive points' G2P, the tick, the check."""
        setup, d, k = self.setup, self.device, self.k
        lo_v = k.vec3(*[float(c) for c in setup.domain_lo])
        hi_v = k.vec3(*[float(c) for c in setup.domain_hi])
        g_v = k.vec3(*[float(c) for c in setup.gravity])
        inv_dx, dx, dt_f, ng, rule = Ft(self.inv_dx), Ft(self.dx), Ft(self.dt), self.n_grid, self.held_rule_flag()
        self._launches = [
            wp.launch(k.p2g, dim=self.n_material, device=d, record_cmd=True, inputs=[
                self.x, self.v, self.F, self.C, self.Jp, self.p_mass, self.p_vol, self.body,
                self.mat_kind, self.mat_par, self.grid_mv, self.flags, lo_v, inv_dx, dx, dt_f, ng,
                self.grid_g, self.has_wind, self.grid_mv0, int(self.flip > 0), self.p_contact, self.planes, self.plane_n,
                self.grid_fb, self.grid_eta, self.c_shift, self.grid_fbody, ex, self.colc, self.n_sup, self.grid_fn,
                self.grid_fv, self.grid_mf, self.mf_bodies, self.grid_sv, self.grid_vf, self.in_a, self.fixed, rule,
                self.p_pic, self.body_mu, *self.trap_arrays(), *cell_arrays(self, "p2g")]),
            wp.launch(k.grid_update, dim=grid_sweep(self)[1], device=d, record_cmd=True, inputs=[
                self.grid_mv, self.grid_v, self.grid_m, g_v, lo_v, hi_v, dx, dt_f, ng, Ft(self.wall_in), self.wall_mu,
                self.ground, self.fixed_lo, self.fixed_hi, self.touch_slots, has_extras, ex, self.grid_g, self.has_wind,
                self.grid_mv0, self.grid_v0, int(self.flip > 0), self.grid_fb, self.grid_fbody, self.fr_sums,
                self.fr_nodes, self.nfric, self.grid_fn, self.grid_fv, Ft(self.wall_full), self.grid_mf, self.fr_dv,
                self.fr_fb, self.wall_floor, self.ground_touch, self.dv_friction, self.field_rule,
                Ft(0.0 if self.column_dashpot() else self.touch_speed), self.bound_mode(), *grid_sweep(self)]),
            wp.launch(k.g2p, dim=self.n_material, device=d, record_cmd=True, inputs=[
                self.x, self.v, self.C, self.fixed, self.grid_v, lo_v, inv_dx, dt_f, ng, self.grid_v0, Ft(self.flip),
                self.grid_dv, self.body, self.in_a, ex, self.mat_kind, self.fixed_lo, self.fixed_hi, dx, rule,
                self.grid_m, *cell_arrays(self, "g2p")]),
        ] + hold_launches(self, Ft, has_extras, ex) + self._rigid_launches(Ft)
        self._pre, fixes = balance_for(self, k, lo_v, dx, dt_f, ex)   # the balance's; then round 49's, held.py's
        self._pre[:0] = cell_launches(self, Ft)[0]   # Grady's cells: the nodes' reference cells first (cells.py)
        self._launches[2:3] = (self.share_launches(Ft) + fixes + mirror_launches(self, Ft, has_extras, ex)
                               + collider_launches(self, Ft, self._launches[2]))   # round 63; G2P, round 66's points
        # after P2G: touch.py, fields.py (round 62's push before the fields' clear: pair_push.py; round 63's mark)
        self._launches[1:1] = self.touch_launches(Ft) + with_push(self, Ft, with_mark(self, Ft, field_launches(self, Ft)))
        # passive points after the grid update (forces, colliders, boundaries in the grid velocity): one launch per
        # interval of passive_schedule, at its substeps; then held in the box of gasp_core.mpm.points.passive_bounds
        self._passive_at = [None] * self.n_substeps
        n_passive = self.n_points - self.n_material
        if n_passive:
            by_interval, span_mass = {}, Ft(passive_span_mass(setup.p_mass, setup.p_vol))   # transfers.py
            schedule = passive_schedule(self.n_substeps, self.config.passive_every, self.dt)
            hold_lo, hold_hi = (k.vec3(*[float(c) for c in b]) for b in passive_bounds(setup, self._contact))
            for substep, weight_prev, weight_now in schedule:
                m = int(round((weight_prev + weight_now) / self.dt))   # substeps since the last gather
                if m not in by_interval:
                    by_interval[m] = wp.launch(
                        k.g2p_passive, dim=n_passive, device=d, record_cmd=True, inputs=[
                            self.x, self.v, self.C, self.fixed, self.grid_v, self.grid_m, self.flags, lo_v,
                            inv_dx, dt_f, m, ng, self.n_material, hold_lo, hold_hi, g_v, self.grid_dv, self.body,
                            self.in_a, Ft(passive_floor_friction(setup, self._contact)), span_mass])
                self._passive_at[substep] = self.then_pose(by_interval[m])   # a rigid body's back on its pose
        self._tick = (wp.launch(k.tick, dim=1, device=d, record_cmd=True, inputs=[ex.step])
                      if has_extras else None)
        self._check_launch = wp.launch(k.check, dim=self.n_points, device=d, record_cmd=True,
                                       inputs=[self.x, self.v, self.flags])

    def _cell_order(self, x: np.ndarray) -> np.ndarray:
        """Stable order of points by flat cell index (``gasp_core.mpm.points.cell_order``)."""
        return cell_order(x, self.setup.domain_lo, self.dx, self.n_grid)

    def _resort(self) -> None:
        """Re-sort the points by cell (CPU only: the arrays are host memory, numpy views)."""
        x = self.x.numpy()
        m = self.n_material
        perm = np.concatenate([self.material_order(x[:m]), m + self._cell_order(x[m:])])   # sleeping.py
        if np.array_equal(perm, np.arange(self.n_points)):
            return
        per_point = [self.p_contact] if self.p_contact.shape[0] == self.n_points else []  # (1, 3) without planes
        per_point += ([self.X0] if self.any_rigid else []) + self.trap_sorted() + [self.p_cell][:int(self.cells_on)]
        for a in (self.x, self.v, self.F, self.C, self.Jp, self.p_mass, self.p_vol, self.body, self.fixed, *per_point):
            view = a.numpy()
            view[...] = view[perm]
        self.permute_marks(perm[:m])   # sleeping.py
        self._order = self._order[perm]

    def _substeps(self, capturing: bool = False) -> None:
        for s in range(self.n_substeps):
            self._substep(s, capturing)

    def _substep(self, s: int, capturing: bool = False) -> None:
        """The recorded launches of substep ``s`` (its passive points' gather where they move at it)."""
        self.trial_passes(capturing)   # stress_at "trapezoid": its trial substeps first (trapezoid.py)
        for cmd in self._pre:
            cmd.launch()
        for i, cmd in enumerate(self._launches):
            cmd.launch()
            if i == 0 and self.visc is not None:   # after P2G: the implicit viscous step
                self.visc.solve(capturing)
        if self._passive_at[s] is not None:
            self._passive_at[s].launch()
        if self._tick is not None:
            self._tick.launch()

    # ------------------------------------------------------------------ PointEngine
    def step_frame(self) -> None:
        """Advance by ``setup.frame_dt`` seconds (``n_substeps`` substeps of ``dt``; with snow, as many as its state asks,
        :mod:`gasp_warp_mpm.state_step`).

        Raises
        ------
        EngineDivergence
            A point's ``x`` or ``v`` not finite, or out of the grid at over a cell a substep (docs/mpm.md "Blow-up
            detection"; slower, it drops out: feature ``left_domain``); ``frame`` is the 1-based frame number."""
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': step_frame() after close()")
        self.frame += 1
        if self.n_points == 0:
            self.sim_time += self.setup.frame_dt
            return
        self.flags.zero_()
        self.recolour_fields(self.in_a.assign)   # round 61: the coloured bodies' fields from the last frame's points
        if self._ex_tables is not None and not self.clock.on:   # the clock loads each substep's row (state_step.py)
            self._load_frame_table()
        if self.clock.on:
            self.clock_frame()
        elif self.device.is_cuda:
            if self._graph is None:
                with wp.ScopedCapture(device=self.device) as capture:
                    self._substeps(capturing=True)
                self._graph = capture.graph
            wp.capture_launch(self._graph)
        else:
            self._substeps()
        self._check_launch.launch()
        n_out, n_bad = (int(c) for c in self.flags.numpy())
        self.sim_time += self.setup.frame_dt
        if n_bad:
            raise EngineDivergence(
                f"{n_bad} of {self.n_points} points have non-finite position or velocity "
                f"(dt = {self.dt:.3g} s, {self.n_substeps} substeps/frame)", self.frame, CAUSE_UNSTABLE)
        # out of the grid with a material point faster than a cell a substep: a blow-up; slower: drifted out (feature
        # left_domain); passive points' speed is no sign of an unstable step (gasp_core.mpm.points.blow_up_rows)
        if n_out and float(np.max(np.linalg.norm(blow_up_rows(self.velocities(), self.setup.passive), axis=1),
                                   initial=0.0)) * self.dt > self.setup.dx:
            raise EngineDivergence(f"{n_out} point-substeps were out of the grid (n_grid {self.n_grid}), moving "
                                   "faster than a cell a substep", self.frame, CAUSE_UNSTABLE)
        if not self.device.is_cuda:
            self._resort()

    def check_open(self) -> None:
        if self._closed:
            raise EngineError(f"engine '{ENGINE}': engine was closed")

    def positions(self) -> np.ndarray:
        """Current positions, shape (n, 3), float32 (f32) or float64 (f64), metres, setup order."""
        self.check_open()
        return self.to_setup_order(self.x.numpy())

    def velocities(self) -> np.ndarray:
        """Current velocities, shape (n, 3), float32 or float64, m/s, setup order."""
        self.check_open()
        return self.to_setup_order(self.v.numpy())

    # get_state / set_state (GridEngineBase): these arrays in internal (cell-sorted) order, that order, frame, sim_time
    STATE = ("x", "v", "F", "C", "Jp", "p_mass", "p_vol", "body", "fixed")

    def read_array(self, name: str) -> np.ndarray:
        return getattr(self, name).numpy().copy()

    def write_array(self, name: str, value: np.ndarray) -> None:
        getattr(self, name).assign(value)

    def state_extras(self) -> dict[str, np.ndarray]:
        return {"order": self._order.copy(), "frame": np.array(self.frame), "sim_time": np.array(self.sim_time),
                **self.rigid_state()}

    def restore_extras(self, state: dict[str, np.ndarray]) -> None:
        self._order = np.asarray(state["order"]).astype(np.int64)
        if self.p_contact.shape[0] == self.n_points:   # the contact coefficients follow the restored order
            self.p_contact.assign(self._contact_coefficients()[self._order].astype(self._np_dtype))
        follow_order(self)   # so do Grady's cells (cells.py)
        self.set_rigid_state(state)
        self.frame = int(state["frame"])
        self.sim_time = float(state["sim_time"])

    def stats(self) -> dict[str, Any]:
        """:meth:`GridEngineBase.grid_stats` (mass and passive statistics from the engine's arrays, not after
        close) and ``sim_time`` (s)."""
        live = not self._closed
        grid_m = self.grid_m.numpy().reshape((self.n_grid,) * 3) if live and self.n_material < self.n_points else None
        out = self.grid_stats(str(self.device), self.precision, self.x.numpy() if live else None,
                              self.p_mass.numpy() if live else None, grid_m)
        out["sim_time"] = self.sim_time
        return out

    def close(self) -> None:
        """Release the Warp arrays and the CUDA graph."""
        self._graph, self._check_launch = None, None
        self._launches, self._passive_at, self._tick = [], [], None
        for name in ("x", "v", "F", "C", "Jp", "p_mass", "p_vol", "body", "fixed", "grid_mv", "grid_v", "grid_m"):
            if hasattr(self, name):
                setattr(self, name, None)
        self._closed = True
