"""The particle contact with the grounds, walls and colliders (engine option ``contact = "particle"``, ``gasp_core.mpm.contact``,
``docs/contact.md``), as Taichi functions; warp_mpm's ``contact.py`` spells the same steps.

- :meth:`Contact.plane_contact` in P2G: a point's normal impulse ``j_n = max(0, dt (k depth - c v . n))`` (a rigid
  body's point: its restitution's law, :meth:`gasp_taichi_mpm.rigid.Rigid.contact_impulse`) from each
  plane (the grounds and the walls' faces, ``gasp_core.mpm.contact.contact_planes``) less than its skin from its
  centre (``depth = offset + skin - n . x``), and its friction budget ``sum mu j_n``, which P2G adds to its nodes
  with its weights (``grid_mv``'s last channel);
- :meth:`Contact.node_friction` in the grid update: the node's tangential (x, y) velocity loses
  ``min(budget / m, |v_t|)`` (the grounds alone; with walls or colliders :meth:`Contact.surface_friction`);
- :meth:`Contact.point_contact` and :meth:`Contact.surface_friction`: the same against the ``[[collider]]``s' signed
  distances (the impulse along the outward normal, friction relative to the collider in the plane normal to the
  nodes' budget-weighted normal);
- the contact's balance (:mod:`gasp_taichi_mpm.balance`, warp_mpm's ``balance.py``);
- the contact chosen per body (``contact = "auto"`` with flowing and other bodies: ``"mixed"``,
  ``gasp_core.mpm.contact.rule_models``): :meth:`Contact.allocate_mixed`, :meth:`Contact.scatter_flow` (the flowing
  bodies' mass per node, in P2G) and :meth:`Contact.rule` (the boundaries' grid rule by the node's flowing-mass fraction
  where only the grid contact's rule reaches);
- :meth:`Contact.hold_passive` after a passive point's update: the point put back in the box the boundaries keep
  it in (``gasp_core.mpm.points.passive_bounds``, ``hold_passive``).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``n_planes``, ...) it reads.
"""
import taichi as ti

from gasp_core.mpm.grid_tables import CM_FRICTION, COL_META


class Contact:
    """The particle contact's impulse per point (:meth:`plane_contact`) and friction per node (:meth:`node_friction`);
    the passive points' box (:meth:`hold_passive`)."""

    def allocate_mixed(self, mixed, dx: float) -> None:
        """The contact chosen per body: ``mixed`` is None (one contact for the scene: ``self.mixed`` False, the
        grid rule as the solver's boundaries set it) or ``(flows, walls, grounds)``, which bodies flow (per body,
        bool) and :func:`gasp_taichi_mpm.grid.node_ranges`' walls and grounds of the particle contact, where the rule
        acts fully; the solver's own ranges and ``col_deep`` are then the grid contact's (its reach). Allocates
        ``grid_mf`` (the flowing bodies' mass per node), ``flows``, ``wall_lo_full`` / ``wall_hi_full``,
        ``ground_kfull``, and sets ``col_full`` (m); then the grid contact's touched columns (touch.py)."""
        from gasp_core.mpm.contact import collider_grid_depth
        self.mixed = mixed is not None
        ng = self.n_grid if self.mixed else 1
        self.grid_mf = ti.field(self.real, shape=(ng, ng, ng))
        self.flows = ti.field(ti.i32, shape=max(4, len(mixed[0]) if self.mixed else 1))
        self.wall_lo_full, self.wall_hi_full = (ti.Vector.field(3, ti.i32, shape=4) for _ in "lh")
        self.ground_kfull = ti.field(ti.i32, shape=4)
        self.col_full = self.col_deep
        if self.mixed:
            self.col_deep, self.col_full = collider_grid_depth("grid", dx), collider_grid_depth("particle", dx)
            for b, fl in enumerate(mixed[0]):
                self.flows[b] = int(fl)
            for i, (_fr, lo_full, hi_full) in enumerate(mixed[1]):
                self.wall_lo_full[i], self.wall_hi_full[i] = lo_full, hi_full
            for i, (_fr, kfull, _h) in enumerate(mixed[2]):
                self.ground_kfull[i] = kfull
        self.allocate_touch()

    @ti.func
    def scatter_flow(self, p, base, w, m):
        """With the contact chosen per body, a flowing body's point adds its mass ``m`` to its 27 nodes' ``grid_mf``
        with its weights ``w``."""
        if ti.static(self.mixed):
            if self.flows[self.body[p]] != 0:
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    ti.atomic_add(self.grid_mf[base + ti.Vector([i, j, k])], (w[i][0] * w[j][1] * w[k][2]) * m)

    @ti.func
    def rule(self, v, v_rule, partial, f):
        """A boundary's grid rule ``v_rule`` at a node: whole, or (with the contact chosen per body, at a node
        ``partial``: in the grid contact's reach, outside the particle contact's) ``v + f (v_rule - v)``, ``f`` the
        node's flowing-mass fraction."""
        out = v_rule
        if ti.static(self.mixed):
            if partial:
                out = v + f * (v_rule - v)
        return out

    def allocate_contact(self) -> None:
        """With the walls' or colliders' particle contact (``nfric``): per node the budget-weighted normal and supports'
        velocity (``grid_fnv``, 6 channels, scattered by the pushed points only, read and cleared by the grid
        update)."""
        ng = self.n_grid if self.nfric else 1
        self.grid_fnv = ti.Vector.field(6, self.real, shape=(ng, ng, ng))

    @ti.func
    def scatter_contact(self, base, w, budget, fn, fv):
        """A pushed point's budget-weighted normal ``fn`` and supports' velocity ``fv`` into its 27 nodes'
        ``grid_fnv`` with its weights ``w`` (with the walls' or colliders' particle contact)."""
        if ti.static(self.nfric):
            if budget > 0.0:
                val = ti.Vector([fn[0], fn[1], fn[2], fv[0], fv[1], fv[2]], self.real)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    ti.atomic_add(self.grid_fnv[base + ti.Vector([i, j, k])], (w[i][0] * w[j][1] * w[k][2]) * val)

    @ti.func
    def plane_contact(self, p, q: ti.template()):
        """``j_n`` of point p (kg m/s, along the plane's normal ``plane_n[q]``) from plane q (``plane_n[q] . x =
        plane_row[q][0]``, ``gasp_core.mpm.contact.contact_planes``), ``p_contact[p] = (k, c, skin)``."""
        n = self.plane_n[q]
        jq = ti.cast(0.0, self.real)
        xq, vq, kcs, own = self.plane_point(p, n)   # round 88: a rigid sphere at its contact point (rigid_lift.py)
        depth = self.plane_row[q][0] + kcs[2] - n.dot(xq)
        if depth > 0.0 and (kcs[0] > 0.0 or own == 0):   # a sphere: its points with mass
            jq = self.contact_impulse(p, self.plane_e[q], n.dot(vq), n, depth, kcs, xq, own)
        return jq, xq

    @ti.func
    def point_contact(self, p):
        """``(impulse, budget, budget n, budget v_c, support)`` of point p: the planes' (grounds and walls' faces,
        :meth:`plane_contact`) and (with ``n_colc``) the colliders' normal impulses summed (collider c: ``max(0, dt
        (k depth - c (v - v_c) . n))``, ``depth = skin - phi``, along its outward normal, :meth:`collider_at`), the
        friction budget, the budget-weighted normal and supports' velocity, and the support (row of the balance:
        ``body n_sup + s``, s 0 the grounds, 1 + c a collider, then the walls' faces; -1 none) that pushes it most;
        with the balance each support's impulse also goes to its sums (:meth:`add_contact`)."""
        imp = ti.Vector.zero(self.real, 3)
        budget = ti.cast(0.0, self.real)
        fn = ti.Vector.zero(self.real, 3)
        fv = ti.Vector.zero(self.real, 3)
        sup = -1
        jbest = ti.cast(0.0, self.real)
        for q in ti.static(range(self.n_planes)):
            jq, xq = self.plane_contact(p, q)
            if jq > 0.0:
                mu = self.plane_row[q][1]
                n = self.plane_n[q]
                imp += jq * n
                budget += mu * jq
                self.add_twist(p, xq, mu, jq, n, ti.Vector.zero(self.real, 3))
                fn += (mu * jq) * n
                sq = ti.cast(self.plane_row[q][2], ti.i32)
                self.add_contact(p, xq, sq, jq, n, fv)
                if jq > jbest:
                    sup = sq
                    jbest = jq
        if ti.static(self.n_colc > 0):
            base = self.ex_step[None] * self.ex_width
            for c in range(self.n_colc):   # round 89: a rigid sphere or cylinder on its shape (rigid_lift.py)
                depth, n, vc, xq, vq, kcs, own = self.collider_point(p, c, base)
                if depth > 0.0 and (kcs[0] > 0.0 or own == 0):
                    jq = self.contact_impulse(p, 1.0, (vq - vc).dot(n), n, depth, kcs, xq, own)
                    if jq > 0.0:
                        mu = self.ex_meta[c * COL_META + CM_FRICTION]
                        imp += jq * n
                        budget += mu * jq
                        self.add_twist(p, xq, mu, jq, n, vc)
                        fn += (mu * jq) * n
                        fv += (mu * jq) * vc
                        self.add_contact(p, xq, 1 + c, jq, n, vc)
                        if jq > jbest:
                            sup = 1 + c
                            jbest = jq
        if sup >= 0:
            sup += self.body[p] * self.n_sup
        return imp, self.node_budget(p, budget), fn, fv, sup

    @ti.func
    def surface_friction(self, v, m, fb, fn, fv):
        """A node's Coulomb friction with the colliders' particle contact: the budget ``fb`` on its velocity relative
        to the supports' (``fv / fb``) in the plane normal to its budget-weighted normal ``fn``."""
        out = v
        ln = fn.norm()
        if fb > 0.0 and ln > 0.0:
            n = fn / ln
            u = v - fv / fb
            ut = u - u.dot(n) * n
            lt = ut.norm()
            if lt > 0.0:
                out = v - (ti.min(fb / m, lt) / lt) * ut
        return out

    @ti.func
    def node_friction(self, v, m, fb):
        """Coulomb friction of the budget ``fb`` (kg m/s) on a node of mass ``m``: stops, never reverses, ``v_t``."""
        vt = ti.Vector([v[0], v[1], 0.0], self.real)
        lt = vt.norm()
        out = v
        if fb > 0.0 and lt > 0.0:
            out = v - (ti.min(fb / m, lt) / lt) * vt
        return out

    @ti.func
    def hold_passive(self, x, v, stranded):
        """``(x, v)`` of a passive point after its update, held in ``[hold_lo, hold_hi]``: on each axis a point below
        ``hold_lo[d]`` is put there with ``v[d] = max(v[d], 0)``, above ``hold_hi[d]`` likewise with ``min``; a
        ``stranded`` one (no node with mass in its stencil) held on the floor loses ``hold_mu`` times the speed into
        it removed from its horizontal speed, Coulomb friction (``gasp_core.mpm.points.hold_passive``: a massless
        surface marker cannot be inside the ground or the walls, nor slide on the ground for ever)."""
        xo = x
        vo = v
        for d in ti.static(range(3)):
            if xo[d] < self.hold_lo[None][d]:
                xo[d] = self.hold_lo[None][d]
                vo[d] = ti.max(vo[d], 0.0)
            if xo[d] > self.hold_hi[None][d]:
                xo[d] = self.hold_hi[None][d]
                vo[d] = ti.min(vo[d], 0.0)
        vt = ti.sqrt(vo[0] * vo[0] + vo[1] * vo[1])
        if stranded and x[2] < self.hold_lo[None][2] and vt > 0.0:
            keep = 1.0 - ti.min(vt, self.hold_mu[None] * (vo[2] - v[2])) / vt
            vo[0] *= keep
            vo[1] *= keep
        return xo, vo

