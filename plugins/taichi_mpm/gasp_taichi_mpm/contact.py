"""The particle contact with the grounds (engine option ``contact = "particle"``, ``gasp_core.toolkit.contact``,
``docs/contact.md``), as Taichi functions; warp_mpm's ``contact.py`` spells the same steps.

- :meth:`Contact.plane_contact` in P2G: a point's normal impulse ``j_n = max(0, dt (k depth - c v_z))`` summed
  over the planes less than its skin below its centre (``depth = height + skin - z``), and its friction budget
  ``sum mu j_n``, which P2G adds to its nodes with its weights (``grid_mv``'s last channel);
- :meth:`Contact.node_friction` in the grid update: the node's tangential (x, y) velocity loses
  ``min(budget / m, |v_t|)``;
- :meth:`Contact.point_contact` and :meth:`Contact.surface_friction`: the same against the ``[[collider]]``s' signed
  distances (the impulse along the outward normal, friction relative to the collider in the plane normal to the
  nodes' budget-weighted normal);
- the contact's balance (:mod:`gasp_taichi_mpm.balance`, warp_mpm's ``balance.py``);
- :meth:`Contact.hold_passive` after a passive point's update: the point put back in the box the boundaries keep
  it in (``gasp_core.toolkit.points.passive_bounds``, ``hold_passive``).

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``n_planes``, ...) it reads.
"""
import taichi as ti

from gasp_core.toolkit.grid_tables import CM_FRICTION, COL_META


class Contact:
    """The particle contact's impulse per point (:meth:`plane_contact`) and friction per node (:meth:`node_friction`);
    the passive points' box (:meth:`hold_passive`)."""

    def allocate_contact(self) -> None:
        """With the colliders' particle contact (``n_colc``): per node the budget-weighted normal and supports'
        velocity (``grid_fnv``, 6 channels, scattered by the pushed points only, read and cleared by the grid
        update)."""
        ng = self.n_grid if self.n_colc else 1
        self.grid_fnv = ti.Vector.field(6, self.real, shape=(ng, ng, ng))

    @ti.func
    def scatter_contact(self, base, w, budget, fn, fv):
        """A pushed point's budget-weighted normal ``fn`` and supports' velocity ``fv`` into its 27 nodes'
        ``grid_fnv`` with its weights ``w`` (with the colliders' particle contact)."""
        if ti.static(self.n_colc > 0):
            if budget > 0.0:
                val = ti.Vector([fn[0], fn[1], fn[2], fv[0], fv[1], fv[2]], self.real)
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    ti.atomic_add(self.grid_fnv[base + ti.Vector([i, j, k])], (w[i][0] * w[j][1] * w[k][2]) * val)

    @ti.func
    def plane_contact(self, p):
        """``(j_n, budget)`` of point p (kg m/s) over the grounds' planes (``ground_h``, ``ground_fric``),
        ``p_contact[p] = (k, c, skin)``; zeros without the particle contact."""
        jn = ti.cast(0.0, self.real)
        budget = ti.cast(0.0, self.real)
        if ti.static(self.n_planes > 0):
            kcs = self.p_contact[p]
            for b in ti.static(range(self.n_planes)):
                depth = self.ground_h[b] + kcs[2] - self.x[p][2]
                if depth > 0.0:
                    jq = ti.max(self.dt[None] * (kcs[0] * depth - kcs[1] * self.v[p][2]), 0.0)
                    jn += jq
                    budget += self.ground_fric[b] * jq
        return jn, budget

    @ti.func
    def point_contact(self, p):
        """``(impulse, budget, budget n, budget v_c, support)`` of point p: the planes' and (with ``n_colc``) the
        colliders' normal impulses summed (collider c: ``max(0, dt (k depth - c (v - v_c) . n))``, ``depth = skin -
        phi``, along its outward normal, :meth:`collider_at`), the friction budget, the budget-weighted normal and
        supports' velocity, and the support (row of the balance: ``body n_sup + s``, s 0 the grounds, 1 + c a
        collider; -1 none) that pushes it most; with the balance each support's impulse also goes to its sums
        (:meth:`add_contact`)."""
        jn, budget = self.plane_contact(p)
        imp = ti.Vector([0.0, 0.0, jn], self.real)
        fn = ti.Vector([0.0, 0.0, budget], self.real)
        fv = ti.Vector.zero(self.real, 3)
        sup = -1
        jbest = ti.cast(0.0, self.real)
        if jn > 0.0:
            sup = 0
            jbest = jn
            self.add_contact(p, 0, jn, ti.Vector([0.0, 0.0, 1.0], self.real), fv)
        if ti.static(self.n_colc > 0):
            base = self.ex_step[None] * self.ex_width
            kcs = self.p_contact[p]
            for c in range(self.n_colc):
                phi, n, vc = self.collider_at(self.x[p], c, base, kcs[2])
                depth = kcs[2] - phi
                if depth > 0.0:
                    jq = ti.max(self.dt[None] * (kcs[0] * depth - kcs[1] * (self.v[p] - vc).dot(n)), 0.0)
                    if jq > 0.0:
                        mu = self.ex_meta[c * COL_META + CM_FRICTION]
                        imp += jq * n
                        budget += mu * jq
                        fn += (mu * jq) * n
                        fv += (mu * jq) * vc
                        self.add_contact(p, 1 + c, jq, n, vc)
                        if jq > jbest:
                            sup = 1 + c
                            jbest = jq
        if sup >= 0:
            sup += self.body[p] * self.n_sup
        return imp, budget, fn, fv, sup

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
    def hold_passive(self, x, v):
        """``(x, v)`` of a passive point after its update, held in ``[hold_lo, hold_hi]``: on each axis a point below
        ``hold_lo[d]`` is put there with ``v[d] = max(v[d], 0)``, above ``hold_hi[d]`` likewise with ``min``
        (``gasp_core.toolkit.points.hold_passive``: a massless surface marker cannot be inside the ground or the walls)."""
        xo = x
        vo = v
        for d in ti.static(range(3)):
            if xo[d] < self.hold_lo[None][d]:
                xo[d] = self.hold_lo[None][d]
                vo[d] = ti.max(vo[d], 0.0)
            if xo[d] > self.hold_hi[None][d]:
                xo[d] = self.hold_hi[None][d]
                vo[d] = ti.min(vo[d], 0.0)
        return xo, vo

