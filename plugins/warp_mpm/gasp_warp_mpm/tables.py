"""The colliders', forces' and impulses' tables of a :class:`~gasp_warp_mpm.engine.WarpMPMEngine`
(``gasp_core.mpm.grid_tables``): built once, and their time-dependent rows loaded each frame."""
from __future__ import annotations

import numpy as np
import warp as wp

from gasp_core.seam import SimSetup
from gasp_core.mpm.contact import collider_grid_depth, contact_model, rule_models
from gasp_core.mpm.rigid import step_view


class ExtraTables:
    """Mixed into the engine, whose ``k``, ``device``, ``n_substeps``, ``dt``, ``frame``, ``setup`` and
    ``_np_dtype`` it reads."""

    def _extras(self, setup: SimSetup, arr, Ft):
        """``(has_extras, Extras struct)`` from ``gasp_core.mpm.grid_tables.grid_tables`` (empty arrays when none)."""
        from gasp_core.mpm.grid_tables import grid_tables
        tables = grid_tables(setup)
        ex = self.k.Extras()
        self._ex_tables = tables if tables.any else None
        np_t = self._np_dtype
        ex.sdf, ex.grad, ex.meta = arr(tables.sdf.astype(np_t), Ft), arr(tables.sdf_grad.astype(np_t), Ft), \
            arr(tables.col_meta.astype(np_t), Ft)
        ex.forces, ex.modes, ex.imps = arr(tables.forces.astype(np_t), Ft), arr(tables.modes.astype(np_t), Ft), \
            arr(tables.impulses.astype(np_t), Ft)
        ex.tab = wp.zeros(max(1, self.n_substeps * tables.width), dtype=Ft, device=self.device)
        ex.step = wp.zeros(1, dtype=wp.int32, device=self.device)
        ex.n_col, ex.n_force, ex.n_imp, ex.width = (tables.n_colliders, tables.n_forces, tables.n_impulses,
                                                     tables.width)
        # the colliders' grid rule two cells inside them with the particle contact (its points meet the surface)
        # (the contact chosen per body: from the surface, fully from there; gasp_core.mpm.contact.rule_models)
        reach, full = rule_models(contact_model(step_view(setup)))
        ex.col_deep, ex.col_full = Ft(collider_grid_depth(reach, self.dx)), Ft(collider_grid_depth(full, self.dx))
        # the rigid bodies' restitution (per body and per plane of contact_planes) and the rest speed
        from gasp_core.mpm.contact import contact_planes
        from gasp_core.mpm.restitution import body_table, plane_table, rest_speed
        n_planes = len(contact_planes(step_view(setup), contact_model(step_view(setup)))[0])
        ex.rb_e = arr(body_table(setup).astype(np_t), Ft)
        ex.rb_vin, ex.rb_vin_next = (wp.zeros(len(setup.materials), dtype=Ft, device=self.device) for _ in "ab")
        ex.rb_touch = wp.zeros(len(setup.materials), dtype=wp.int32, device=self.device)
        ex.rb_jn = wp.zeros(len(setup.materials), dtype=self.k.vec3, device=self.device)
        ex.rb_je, ex.rb_j = (wp.zeros(len(setup.materials), dtype=Ft, device=self.device) for _ in "ab")
        from gasp_core.mpm.rigid import face_counts
        ex.rb_nface = arr(face_counts(setup).astype(np_t), Ft)
        ex.rb_count, ex.rb_nlast, ex.rb_ndepth = (wp.zeros(len(setup.materials), dtype=wp.int32, device=self.device)
                                                  for _ in "abc")
        vec3d = wp.types.vector(3, wp.float64)
        ex.rb_cx = self.rb_c if getattr(self, "any_rigid", False) else wp.zeros(1, dtype=vec3d, device=self.device)
        ex.rb_twist = wp.zeros(len(setup.materials), dtype=wp.float64, device=self.device)
        ex.rb_fx = wp.zeros(len(setup.materials), dtype=wp.vec4d, device=self.device)
        ex.rb_fv = wp.zeros(len(setup.materials), dtype=vec3d, device=self.device)
        ex.rb_jx = wp.zeros(10 * len(setup.materials), dtype=wp.float64, device=self.device)
        ex.rb_deep = wp.zeros(len(setup.materials), dtype=wp.float64, device=self.device)
        ex.rb_flat = wp.array(np.ones(len(setup.materials)), dtype=wp.float64, device=self.device)
        ex.rb_xf = wp.zeros(len(setup.materials), dtype=vec3d, device=self.device)
        ex.rb_wx = self.rb_w if getattr(self, "any_rigid", False) else wp.zeros(1, dtype=vec3d, device=self.device)
        from gasp_core.mpm.round_ground import ROUND_COLLIDER, ground_shapes, level_band   # round 88: the rigid spheres' exact contact
        from gasp_core.mpm.rigid import RIGID_OMEGA_DT, RIGID_SLOP
        shapes = ground_shapes(setup)
        ex.rb_rad = wp.array(shapes[:, 0], dtype=wp.float64, device=self.device)
        ex.rb_ax = wp.array(shapes[:, 2:], dtype=vec3d, device=self.device)
        ex.rb_band = wp.array(level_band(shapes, RIGID_SLOP * float(self.dx)), dtype=wp.float64, device=self.device)
        ex.rb_rot = self.rb_R if getattr(self, "any_rigid", False) else wp.zeros(1, dtype=wp.types.matrix((3, 3), wp.float64),
                                                                                  device=self.device)
        ex.rb_w2 = Ft((RIGID_OMEGA_DT / float(self.dt)) ** 2)
        ex.rb_col = int(ROUND_COLLIDER)   # round 89: and the colliders (round_collider.py)
        ex.plane_e = arr(plane_table(setup, n_planes).astype(np_t) if n_planes else np.ones(1, np_t), Ft)
        ex.v_rest = Ft(rest_speed(setup))
        self._ex = ex
        return int(tables.any), ex

    def _load_frame_table(self) -> None:
        """The time-dependent inputs of this frame's substeps (collider poses, impulse weights)."""
        from gasp_core.mpm.grid_tables import frame_table
        tab = frame_table(self.setup, (self.frame - 1) * self.setup.frame_dt, self.n_substeps, self.dt).astype(self._np_dtype)
        self._ex.tab.assign(tab)
        self._ex.step.zero_()
