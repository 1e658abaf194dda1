"""The rigid limit (``material.model = "rigid"``, ``gasp_core.mpm.rigid``, ``docs/rigid.md``) as Taichi kernels;
warp_mpm's ``rigid.py`` would spell the same steps.

After each G2P (:meth:`Rigid.rigid_step`; within a frame the rigid points' G2P runs alone, :meth:`Rigid.g2p_rigid`,
and the fused G2P + P2G kernel skips it, :meth:`Rigid.fused_g2p`): ``rigid_reduce`` sums each rigid body's momentum
and angular momentum about the origin (APIC's affine part included) over its points, serially in the point order (a
fixed order: the same numbers on any thread count; the CPU schedule's kernel, in
:mod:`gasp_taichi_mpm.schedule.ordered`; the GPU schedule's :meth:`Rigid.rigid_reduce_gpu` sums slices by a fixed
tree); :meth:`Rigid.rigid_update` turns them into the body's velocity and spin and advances its centre and rotation;
:meth:`Rigid.rigid_apply` puts every point of the body (its passive points too) on the rigid pose ``c + R X0`` with
the rigid velocity, ``C`` the spin's skew matrix times its body's carried share (``gasp_core.mpm.spin_booking.spin_shares``:
1 for a body alone in its field since round 76, ``rigid_update`` taking P2G's booking of it back; else ``APIC_SPIN``) and ``F = R``; with the particle contact's planes ``rigid_depth``
and :meth:`Rigid.rigid_lift` then move a resting body deeper than the slop out without speed
(``gasp_core.mpm.rigid_friction.settle_projection``, Bullet's split impulse; issue 53) and :meth:`Rigid.rigid_apply`
runs again.
The body's state is kept in float64 whatever the working precision.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields (``x``, ``v``, ``C``, ``F``, ``body``, ...) it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.contact import DAMPING
from gasp_core.mpm.restitution import lift_off_rule
from gasp_core.mpm import rigid as core_rigid
from gasp_core.mpm.rigid import RIGID_LEVER

from .rigid_friction import RigidFriction
from .rigid_lift import RigidLift
from .rigid_pairs import RigidPairs


class Rigid(RigidLift, RigidFriction, RigidPairs):
    """Per-body rigid state and the three kernels of :meth:`rigid_step`."""

    def _allocate_rigid(self, rigid, centre, X0, inertia0, mass) -> None:
        """Fields of the rigid bodies (``gasp_core.mpm.rigid.body_frames``' arrays, solver order)."""
        nb = len(rigid)
        self.any_rigid = bool(np.any(rigid))
        cap = self.x.shape[0] if self.any_rigid else 1
        self.rb_rigid = ti.field(ti.i32, shape=max(nb, 1))
        self.rb_M = ti.field(ti.f64, shape=max(nb, 1))
        self.rb_c = ti.Vector.field(3, ti.f64, shape=max(nb, 1))
        self.rb_V = ti.Vector.field(3, ti.f64, shape=max(nb, 1))
        self.rb_w = ti.Vector.field(3, ti.f64, shape=max(nb, 1))
        self.rb_acc = ti.Vector.field(6, ti.f64, shape=max(nb, 1))
        self.rb_R = ti.Matrix.field(3, 3, ti.f64, shape=max(nb, 1))
        self.rb_I0 = ti.Matrix.field(3, 3, ti.f64, shape=max(nb, 1))
        self.X0 = ti.Vector.field(3, ti.f64, shape=cap)
        # the share of the spin the points carry in C, and so of M dx^2 / 2 in the inertia (APIC_SPIN: 0 since
        # round 67, the body's own inertia)
        self.rb_aff = ti.field(ti.f64, shape=())
        # round 76: per body the share of the spin carried in C and of its booking taken back (spin_booking.py)
        self.rb_carry = ti.field(ti.f64, shape=max(nb, 1))
        self.rb_book = ti.field(ti.f64, shape=max(nb, 1))
        self.rb_passes = ti.field(ti.i32, shape=())   # the rotation's midpoint passes (ROTATION_PASSES)
        self.n_bodies = nb
        # the restitution's hysteresis (set_restitution): per body its e (-1: none), the approach speed of its
        # ongoing contact, this substep's (atomic max) and whether a point touched; per plane its e; the rest speed
        self.rb_e, self.rb_vin, self.rb_vin_next = (ti.field(self.real, shape=max(nb, 1)) for _ in range(3))
        self.rb_touch, self.rb_was = (ti.field(ti.i32, shape=max(nb, 1)) for _ in range(2))
        self.rb_jn = ti.Vector.field(3, self.real, shape=max(nb, 1))   # the contact's sum j n and sum j e_sup, sum j
        self.rb_je, self.rb_j = (ti.field(self.real, shape=max(nb, 1)) for _ in range(2))
        self.rb_c0 = ti.Vector.field(3, ti.f64, shape=max(nb, 1))   # the centre where the contact began
        self.rb_steps = ti.field(ti.i32, shape=max(nb, 1))   # the contact's substeps so far
        # the points of the largest flat face (gasp_core.mpm.rigid.face_counts), those touching now and last
        self.rb_nface, self.rb_rad, self.rb_band, self.rb_ax = (*(ti.field(t, shape=max(nb, 1)) for t in (self.real, ti.f64, ti.f64)), ti.Vector.field(3, ti.f64, shape=max(nb, 1)))   # round 88: rigid_lift.set_round
        self.rb_count, self.rb_nlast = (ti.field(ti.i32, shape=max(nb, 1)) for _ in range(2))
        # the points in a plane at the pose the next P2G takes (rigid_depth)
        self.rb_ndepth = ti.field(ti.i32, shape=max(nb, 1))
        self.rest_zeta = float(DAMPING)
        self.rb_twist = ti.field(ti.f64, shape=max(nb, 1))   # this substep's sum mu j |r_perp| (kg m^2/s)
        self.rb_fx = ti.Vector.field(4, ti.f64, shape=max(nb, 1))   # this substep's sum mu j x (kg m^2/s), sum mu j
        self.rb_fv = ti.Vector.field(3, ti.f64, shape=max(nb, 1))   # this substep's sum mu j v_sup (kg m^2/s^2)
        # this substep's normal impulses: sum j, sum j x, sum j x x^T (xx, xy, xz, yy, yz, zz): the patch's spread
        self.rb_jx = ti.Vector.field(10, ti.f64, shape=max(nb, 1))
        self.rb_deep = ti.field(ti.f64, shape=max(nb, 1))   # this substep's deepest point (m): the patch's curvature
        # the last substep's patch: its flatness (1 before any) and centre (the settling damping's, contact_impulse)
        self.rb_flat = ti.field(ti.f64, shape=max(nb, 1))
        self.rb_xf = ti.Vector.field(3, ti.f64, shape=max(nb, 1))
        self.plane_e = ti.field(self.real, shape=max(self.n_planes, 1))
        self.v_rest = ti.field(self.real, shape=())
        self.lift_rule = ti.field(ti.i32, shape=())   # restitution.LIFT_OFF's integer
        self.rb_V0 = ti.Vector.field(3, ti.f64, shape=max(nb, 1))   # the velocity before the contact began
        self.rb_jsup = ti.field(ti.f64, shape=max(nb, 1))   # the supports' normal impulse over the contact (kg m/s)
        # the resting bodies' non-penetration (rigid_depth, rigid_lift): per body and plane the deepest penetration
        # and the penetration-weighted sum of the touching points
        self.rb_dmax = ti.field(ti.f64, shape=max(nb * self.n_planes, 1))
        self.rb_dsum = ti.Vector.field(4, ti.f64, shape=max(nb * self.n_planes, 1))
        self.rb_e.fill(-1.0)
        self.rb_aff[None] = float(core_rigid.APIC_SPIN)   # read when built (a test sets it)
        self.rb_carry.fill(float(core_rigid.APIC_SPIN))   # until set_spin_shares (the engine's, per body)
        self.rb_book.fill(0.0)
        self.rb_passes[None] = int(core_rigid.ROTATION_PASSES)
        self.rb_flat.fill(1.0)
        self.plane_e.fill(1.0)
        if self.any_rigid and self.gpu:   # the GPU schedule's slice sums of the momenta and the depths
            from .schedule.primitives import SliceSums, slice_points
            self.rb_slice = slice_points(cap, nb * max(6, 4 * self.n_planes))
            self.rb_sums = SliceSums(-(-cap // self.rb_slice), nb * 6)
            self.rb_dsums = SliceSums(-(-cap // self.rb_slice), max(nb * self.n_planes * 4, 1))
        if not self.any_rigid:
            return
        self.rb_rigid.from_numpy(np.asarray(rigid, np.int32))
        self.rb_M.from_numpy(np.asarray(mass, np.float64))
        self.rb_c.from_numpy(np.asarray(centre, np.float64))
        self.rb_R.from_numpy(np.broadcast_to(np.eye(3), (nb, 3, 3)).copy())
        self.rb_I0.from_numpy(np.asarray(inertia0, np.float64))
        buf = np.zeros((cap, 3))
        buf[:len(X0)] = X0
        self.X0.from_numpy(buf)

    def set_spin_shares(self, setup) -> None:
        """Per body the share of its spin its points carry in ``C`` and of its booking the projection takes back
        (``gasp_core.mpm.spin_booking.spin_shares``, round 76)."""
        from gasp_core.mpm.spin_booking import spin_shares
        for f, a in zip((self.rb_carry, self.rb_book), spin_shares(setup)):
            f.from_numpy(np.resize(np.asarray(a, np.float64), f.shape[0]))

    def set_restitution(self, body_e, plane_e, v_rest: float, n_face, sphere) -> None:
        """The rigid bodies' restitution (``gasp_core.mpm.restitution``): ``body_e`` per body (shape (n_bodies,), -1 for a
        body without it), ``plane_e`` per contact plane (shape (n_planes,)), ``v_rest`` (m/s) the rebound speed below which a
        contact is inelastic, ``n_face`` per body (``gasp_core.mpm.rigid.face_counts``), ``sphere`` per body its exact round shape (round 88, ``gasp_core.mpm.round_ground.ground_shapes``)."""
        if self.any_rigid:
            self.rb_e.from_numpy(np.asarray(body_e, self._np_real))
            self.rb_nface.from_numpy(np.asarray(n_face, self._np_real))
            self.set_round(sphere)   # round 88: rigid_lift.py
            if self.n_planes:
                self.plane_e.from_numpy(np.asarray(plane_e, self._np_real))
            self.v_rest[None] = float(v_rest)
            self.lift_rule[None] = lift_off_rule()

    @ti.func
    def add_twist(self, p, xp, mu, jq, n, vc):
        """Point p's normal impulse ``jq`` (kg m/s) from a support of friction ``mu`` and normal ``n`` moving at ``vc``
        (m/s), for Coulomb's friction on its body as one (a rigid body with restitution): its budget ``mu jq`` times
        its lever about the axis along ``n`` through the body's centre into ``rb_twist`` (the most angular momentum
        about the normal the friction can take this substep, :meth:`twist_brake`); the budget's moments into
        ``rb_fx`` and ``rb_fv``, the impulse's into ``rb_jx`` (:meth:`slide_brake`)."""
        if ti.static(self.any_rigid):
            b = self.body[p]
            if self.rb_e[b] >= 0.0:
                x = ti.cast(xp, ti.f64)
                r = x - self.rb_c[b]
                nd = ti.cast(n, ti.f64)
                j = ti.cast(jq, ti.f64)
                f = ti.cast(mu, ti.f64) * j
                ti.atomic_add(self.rb_twist[b], f * (r - r.dot(nd) * nd).norm())
                ti.atomic_add(self.rb_fx[b], ti.Vector([f * x[0], f * x[1], f * x[2], f], ti.f64))
                ti.atomic_add(self.rb_fv[b], f * ti.cast(vc, ti.f64))
                ti.atomic_add(self.rb_jx[b], j * ti.Vector([1.0, x[0], x[1], x[2], x[0] * x[0], x[0] * x[1],
                                                            x[0] * x[2], x[1] * x[1], x[1] * x[2], x[2] * x[2]],
                                                           ti.f64))

    @ti.func
    def node_budget(self, p, budget):
        """The friction budget point p gives its nodes (kg m/s): none for a rigid body with restitution, whose
        Coulomb friction acts on the body as one (:meth:`slide_brake`, :meth:`twist_brake`; issue 67: the nodes'
        friction, made Coulomb's on the body by the contact's balance, and the slide brake after it took the budget
        twice, and a wooden block on a 30 degree slope at mu 0.3 stuck), else ``budget``."""
        out = budget
        if ti.static(self.any_rigid):
            if self.rb_e[self.body[p]] >= 0.0:
                out = ti.cast(0.0, self.real)
        return out

    @ti.func
    def contact_impulse(self, p, e_sup, vn, n, depth, kcs, x, own):
        """Point p's normal impulse (kg m/s) at ``depth`` (m, > 0) in a support of restitution ``e_sup``, ``vn`` its
        normal velocity relative to it (m/s), ``n`` its normal, ``kcs = (k, c, skin)``: ``max(0, dt (k depth - c
        vn))``; a rigid body's point with restitution (``gasp_core.mpm.restitution``) while its body bounces:
        ``dt k depth`` while it approaches (``vn`` < 0), ``e^2 dt k depth`` while it recedes (the hysteresis of Walton
        & Braun 1986), ``e`` its body's times ``e_sup``; once ``e`` times the approach speed of the body's ongoing
        contact is below ``v_rest`` a damped law set by the body, not the point (``c = 2 DAMPING dt k``: a substep
        takes ``2 DAMPING n / N`` of the body's normal speed on ``n`` points); its ``k`` times ``N / max(N,
        N_touch)`` (``gasp_core.mpm.rigid.face_counts``, ``N_touch`` the points that touched in the last
        substep). Records the touch, the approach speed
        and ``dt k depth`` along ``n`` and times ``e_sup`` for :meth:`lift_off`."""
        dt = self.dt[None]
        jq = ti.max(dt * (kcs[0] * depth - kcs[1] * vn), 0.0)
        if ti.static(self.any_rigid):
            b = self.body[p]
            if self.rb_e[b] >= 0.0:
                n_t = ti.max(ti.cast(ti.max(self.rb_nlast[b], self.rb_ndepth[b]), self.real), 1.0)
                sk = self.rb_nface[b] / ti.max(self.rb_nface[b], n_t)
                if own != 0:   # round 88: a rigid sphere's share of its body's stiffness on a plane, not scaled
                    sk = 1.0
                elif self.rb_ndepth[b] > 0:
                    # the points this P2G finds in the planes counted (rigid_depth): N / max(n_t, min(N, LEVER n_t)),
                    # Omega dt 1 on more than N points, at most 1 on a few (gasp_core.mpm.rigid.support_scale)
                    sk = self.rb_nface[b] / ti.max(n_t, ti.min(self.rb_nface[b], RIGID_LEVER * n_t))
                jk = dt * kcs[0] * sk * depth
                # settling: per point c = 2 zeta dt k' (M = k N dt^2 at Omega dt = 1): a substep takes 2 zeta n / N of the body's normal speed on n
                # points, at most 2 zeta = 1; sqrt(N / n_t) more overshot (a ladder ball gained 633 % of its fall energy)
                c = 2.0 * self.rest_zeta * dt * kcs[0] * sk
                jq = ti.max(jk - dt * c * self.rolling_vn(x, b, vn, n), 0.0)
                ti.atomic_add(self.rb_count[b], 1)
                self.rb_touch[b] = 1
                ti.atomic_add(self.rb_jn[b], jk * n)
                ti.atomic_add(self.rb_je[b], jk * e_sup)
                ti.atomic_add(self.rb_j[b], jk)
                ti.atomic_max(self.rb_deep[b], ti.cast(depth, ti.f64))
                if vn < 0.0:
                    ti.atomic_max(self.rb_vin_next[b], -vn)
                e = self.rb_e[b] * e_sup
                if e * self.rb_vin[b] >= self.v_rest[None]:
                    jq = jk
                    if vn >= 0.0:
                        jq = e * e * jk
        return jq

    @ti.func
    def rolling_vn(self, x, b, vn, n):
        """The normal velocity (m/s) the settling damping of point p of rigid body b takes: its own ``vn`` on a
        face, the patch centre's on a rounded body (``rb_flat`` 0: a ball's points entering its rolling cap move down
        at ``omega s``, and damping each on its own braked the rolling by 2.8 %; issue 67), blended by the last
        substep's flatness (``gasp_core.mpm.rigid_friction.contact_flatness``)."""
        f = self.rb_flat[b]
        d = ti.cast(n, ti.f64).dot(self.rb_w[b].cross(self.rb_xf[b] - ti.cast(x, ti.f64)))
        return vn + ti.cast((1.0 - f) * d, self.real)

    def _contact_fields(self) -> dict:
        """The rigid bodies' ongoing contact (the restitution's state, :meth:`contact_impulse`), by state key."""
        return {"rigid_vin": self.rb_vin, "rigid_was": self.rb_was, "rigid_steps": self.rb_steps,
                "rigid_c0": self.rb_c0, "rigid_jn": self.rb_jn, "rigid_je": self.rb_je, "rigid_j": self.rb_j,
                "rigid_nlast": self.rb_nlast, "rigid_ndepth": self.rb_ndepth, "rigid_w": self.rb_w,
                "rigid_flat": self.rb_flat, "rigid_xf": self.rb_xf, "rigid_V0": self.rb_V0, "rigid_jsup": self.rb_jsup}

    def rigid_state(self) -> dict:
        """``rigid_c`` (n_bodies, 3) and ``rigid_R`` (n_bodies, 3, 3), and the ongoing contact's state
        (``rigid_vin``, ...): what a saved state adds for the rigid bodies."""
        return {"rigid_c": self.rb_c.to_numpy(), "rigid_R": self.rb_R.to_numpy(),
                **{k: f.to_numpy() for k, f in self._contact_fields().items()}}

    def set_rigid_state(self, state: dict) -> None:
        """Restore :meth:`rigid_state` (a state saved before issue 53 has no contact state: a body free then)."""
        self.rb_c.from_numpy(np.asarray(state["rigid_c"], np.float64))
        self.rb_R.from_numpy(np.asarray(state["rigid_R"], np.float64))
        for k, f in self._contact_fields().items():
            if k in state:
                f.from_numpy(np.asarray(state[k], f.to_numpy().dtype))

    @ti.func
    def fused_g2p(self, p):
        """G2P of point p in the fused G2P + P2G kernels (``transfers.py``), skipped for a rigid body's point: it had
        its G2P and its projection before (:meth:`g2p_rigid`, :meth:`rigid_step`). The other bodies so run the same
        kernel on the same numbers with or without a rigid body in the scene (bit for bit:
        ``tests/test_rigid_engines.py``); a branch on the data, not a ``ti.static`` one, so the kernel compiled is
        the same in both."""
        if self.rb_rigid[self.body[p]] == 0:
            self.g2p_point(p)

    @ti.kernel
    def g2p_rigid(self):
        """G2P of the rigid bodies' points only (before their projection; the fused kernel skips them)."""
        for p in range(self.n_points[None]):
            if self.rb_rigid[self.body[p]] != 0:
                self.g2p_point(p)

    def rigid_step(self) -> None:
        """Project the rigid bodies' points after a G2P (:mod:`gasp_taichi_mpm.rigid`); with the particle contact's
        planes, a resting body deeper than the slop is then moved out (:meth:`rigid_lift`) and its points put on the
        pose again."""
        if self.gpu:
            self.rigid_reduce_gpu()
        else:
            self.rigid_reduce()
        self.rigid_update()
        if self.field_pair and not self.pair_many:   # two rigid bodies: their contact as one (rigid_friction.py)
            self.rigid_pair()
        elif self.pair_many:   # round 62: rigid bodies among three or more, their pairs solved together
            self.rigid_pairs_gpu() if self.gpu and self.pair_islands else self.rigid_pairs()   # round 81: islands
        self.rigid_apply()
        if self.n_planes and self.pc:
            if self.gpu:
                self.rigid_depth_gpu()
            else:
                self.rigid_depth()
            self.rigid_lift()
            self.rigid_apply()

    @ti.func
    def rigid_terms(self, p, quarter):
        """Point p's momentum and angular momentum about the origin (APIC's spin with ``quarter = dx^2 / 4``)."""
        m = ti.cast(self.p_mass[p], ti.f64)
        x = ti.cast(self.x[p], ti.f64)
        v = ti.cast(self.v[p], ti.f64)
        C = ti.cast(self.C[p], ti.f64)
        aff = ti.Vector([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]])
        L = m * x.cross(v) + (m * quarter) * aff
        return ti.Vector([m * v[0], m * v[1], m * v[2], L[0], L[1], L[2]])

    @ti.kernel
    def rigid_reduce_gpu(self):
        """:meth:`rigid_reduce` on the GPU schedule: slices of ``rb_slice`` points, one thread a slice, summed per
        body by a fixed tree (:class:`gasp_taichi_mpm.schedule.primitives.SliceSums`)."""
        n = self.n_points[None]
        quarter = 0.25 * ti.cast(self.dx[None], ti.f64) ** 2
        nt = (n + self.rb_slice - 1) // self.rb_slice
        self.rb_sums.clear(nt)
        for t in range(nt):
            for p in range(t * self.rb_slice, ti.min(t * self.rb_slice + self.rb_slice, n)):
                b = self.body[p]
                if self.rb_rigid[b] != 0:
                    a = self.rigid_terms(p, quarter)
                    for q in ti.static(range(6)):
                        self.rb_sums.part[t, b * 6 + q] += a[q]
        self.rb_sums.reduce(nt)
        for b in range(self.n_bodies):
            acc = self.held(b)
            for q in ti.static(range(6)):
                acc[q] += self.rb_sums.out[b * 6 + q]
            self.rb_acc[b] = acc

    @ti.func
    def rotation_of(self, a):
        """``exp(skew(a))`` (Rodrigues), ``a`` a rotation vector, rad."""
        th = a.norm()
        K = ti.Matrix([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]], dt=ti.f64)
        s = 1.0 - th * th / 6.0
        c = 0.5 - th * th / 24.0
        if th > 1e-4:
            s = ti.sin(th) / th
            c = (1.0 - ti.cos(th)) / (th * th)
        return ti.Matrix.identity(ti.f64, 3) + s * K + c * (K @ K)

    @ti.kernel
    def rigid_update(self):
        dt = ti.cast(self.dt[None], ti.f64)
        half = 0.5 * self.rb_aff[None] * ti.cast(self.dx[None], ti.f64) ** 2
        dx2 = 0.5 * ti.cast(self.dx[None], ti.f64) ** 2
        # each body its own (writes only its own rows): parallel on both schedules, the same bits
        for b in range(self.n_bodies):
            if self.rb_rigid[b] != 0 and self.rb_M[b] > 0.0:
                M = self.rb_M[b]
                acc = self.rb_acc[b]
                P = ti.Vector([acc[0], acc[1], acc[2]])
                c = self.rb_c[b]
                # the body's own angular momentum: the grid's less the booking of the spin its points carried
                # (round 76, gasp_core.mpm.spin_booking.SPIN_BOOKED)
                Lc = ti.Vector([acc[3], acc[4], acc[5]]) - c.cross(P) - dx2 * self.rb_book[b] * M * self.rb_w[b]
                R = self.rb_R[b]
                Id = ti.Matrix.identity(ti.f64, 3)
                w_pred = (R @ self.rb_I0[b] @ R.transpose() + half * M * Id).inverse() @ Lc
                for _q in range(4):   # round 67: the implicit midpoint, at most 4 passes (warp_mpm's rigid_update)
                    if _q < self.rb_passes[None]:
                        R_h = self.rotation_of(0.5 * dt * w_pred) @ R
                        w_pred = (R_h @ self.rb_I0[b] @ R_h.transpose() + half * M * Id).inverse() @ Lc
                R_new = self.rotation_of(dt * w_pred) @ R
                inertia = R_new @ self.rb_I0[b] @ R_new.transpose() + half * M * Id
                w = inertia.inverse() @ Lc
                V = P / M
                jsup = self.rb_jx[b][0]   # this substep's supports' normal impulse (slide_brake clears it)
                if self.rb_e[b] >= 0.0:
                    w = self.twist_brake(b, w, inertia)
                    V, w = self.slide_brake(b, V, w, inertia, M, c)
                if self.rb_touch[b] != 0 and self.rb_was[b] == 0:
                    self.rb_c0[b] = c
                    self.rb_steps[b] = 0
                    self.rb_V0[b] = self.rb_V[b]
                    self.rb_jsup[b] = 0.0
                self.rb_jsup[b] += jsup
                V = self.lift_off(b, V, c, dt * self.rb_steps[b])
                self.rb_steps[b] += self.rb_touch[b]
                self.rb_V[b] = V
                self.rb_w[b] = w
                self.rb_c[b] = c + dt * V
                self.rb_R[b] = R_new
            # the contact's approach speed: its first substep's, kept while a point touches; 0 once free (the
            # largest of its substeps took the speed gravity adds in the contact's first substeps: a steel ball's
            # bounces of 0.5 m/s grew instead of dying out)
            if self.rb_touch[b] != 0:
                if self.rb_was[b] == 0:
                    self.rb_vin[b] = self.rb_vin_next[b]
            else:
                self.rb_vin[b] = 0.0
                self.rb_jn[b] = ti.Vector.zero(self.real, 3)
                self.rb_je[b] = 0.0
                self.rb_j[b] = 0.0
            self.rb_was[b] = self.rb_touch[b]
            self.rb_nlast[b] = self.rb_count[b]
            self.rb_count[b] = 0
            self.rb_ndepth[b] = 0
            self.rb_vin_next[b] = 0.0
            self.rb_touch[b] = 0

    @ti.kernel
    def rigid_apply(self):
        for p in range(self.n_total[None]):
            b = self.body[p]
            if self.rb_rigid[b] != 0:
                R = self.rb_R[b]
                w = self.rb_w[b]
                wc = self.rb_carry[b] * w   # the spin the affine parts carry (round 76: spin_shares)
                r = R @ self.X0[p]
                self.x[p] = ti.cast(self.rb_c[b] + r, self.real)
                self.v[p] = ti.cast(self.rb_V[b] + w.cross(r), self.real)
                self.C[p] = ti.cast(ti.Matrix([[0.0, -wc[2], wc[1]], [wc[2], 0.0, -wc[0]], [-wc[1], wc[0], 0.0]],
                                              dt=ti.f64), self.real)
                self.F[p] = ti.cast(R, self.real)
