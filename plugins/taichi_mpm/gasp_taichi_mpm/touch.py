"""The ground's contact detected from the points (issue 67, rounds 35-36; docs/contact.md "Round 35: the contact
detected from the points", "Round 36: the touched layer on both engines"): with the grid contact, the node layer just
above a ground's plane takes the ground's Coulomb rule in the columns where a point of the body touches the plane: a
point of a body that does not flow when its lowest extent (its height less half its own spacing) lies within
``touch_margin`` of that half spacing (round 47, docs/contact.md "Round 47: the touch test tied to the point's
extent"), a point of a flowing body (sand, snow, liquid) when its height is under ``touch_delta`` cells (round 36's
rule); warp_mpm's ``gasp_warp_mpm.touch``, the same rule. Round 48 (docs/contact.md "Round 48: a dashpot above the
held layers"): in a column a body that does not flow touches, the node layer above the held ones takes a dashpot on
its normal velocity (:meth:`GroundTouch.dashpot`). Round 49 (docs/contact.md "Round 49: the touched layer shares the
column's Coulomb bound"): in such a column the touched layer takes no normal stop (its normal motion is the body's,
with the dashpot) and only the Coulomb bound its column's held layers left unused (:meth:`GroundTouch.touch_keep`,
:meth:`GroundTouch.share_bound`). Round 50 (docs/contact.md "Round 50: the dashpot's push in the column's Coulomb
bound"): the dashpot's signed push, times ``mu``, a credit of the column kept across substeps that the touched node's
friction may spend (``touch_credit``, :meth:`GroundTouch.share_bound`).

Mixed into :class:`gasp_taichi_mpm.grid.GridUpdate` (and so :class:`gasp_taichi_mpm.solver.MPMSolver`), whose
fields (``ground_kmax``, ``ground_h``, ``x``, ``n_points``, ...) it reads.
"""
import taichi as ti

from gasp_core.mpm.contact import DAMPING, TOUCH_BOUNDS, TOUCH_PULLS
from gasp_core.mpm.materials import MaterialKind

from .body_bound import BodyBound

#: The flowing materials' codes (``gasp_core.mpm.contact.FLOWING``): round 36's touch test.
SAND, SNOW, LIQUID = int(MaterialKind.SAND), int(MaterialKind.SNOW), int(MaterialKind.LIQUID)


class GroundTouch(BodyBound):
    """The touched columns (:meth:`mark_touch`) and the ground's node reach (:meth:`ground_reach`)."""

    #: The switch (on by default since round 36; warp_mpm's ``WarpMPMEngine.touch_contact``, the same rule): False
    #: leaves the node layers ``I_z <= ground_kmax`` as the ground's (the rule before); True adds the layer
    #: ``ground_kmax + 1`` in the touched columns (the grid contact's rule only: ``"grid"`` and the grid contact's
    #: reach of ``"mixed"``).
    touch_contact = True
    #: Cells: a point of a flowing body (sand, snow, liquid) touches the plane when its height above it is under
    #: ``touch_delta dx`` (round 36's rule, kept for them: docs/contact.md "Round 47").
    touch_delta = 0.25
    #: Round 47: a point of a body that does not flow touches the plane when its lowest extent (its height less
    #: ``h``, half its own spacing, ``p_vol^(1/3) / 2``) lies under ``touch_margin h`` above it (or below it). At 1
    #: the test sits halfway between a fill's lowest row (its extent on the plane) and its next row (``2 h`` up), as
    #: far from both as it can be, so no rounding of the fill decides it (round 46: the fixed 0.25 dx was the lowest
    #: row's own height, a knife-edge).
    touch_margin = 1.0
    #: Round 48 (docs/contact.md "Round 48: a dashpot above the held layers"): the damping ratio of the dashpot on
    #: the normal velocity of the node layer just above the held ones (``ground_kmax + 2``) in the columns a point of
    #: a body that does not flow touches (:meth:`dashpot`; the particle contact's ``DAMPING``); 0 turns it off (the
    #: rule before, the catch of ``tests/test_grid_hold.py``). warp_mpm's ``GroundTouch.touch_damping``.
    touch_damping = DAMPING
    #: Round 49 (docs/contact.md "Round 49: the touched layer shares the column's Coulomb bound"): True: in a column
    #: marked 2 the touched layer's normal motion is the body's (no stop), and its tangential motion takes what the
    #: held layers' Coulomb bound left unused (:meth:`touch_keep`, :meth:`share_bound`); False: round 47-48's full
    #: Coulomb rule there. warp_mpm's ``GroundTouch.touch_share``.
    touch_share = True
    #: Round 50 (docs/contact.md "Round 50: the dashpot's push in the column's Coulomb bound"): True, with
    #: ``touch_share``: the dashpot's signed normal impulse on the touched node and the one above, times ``mu``, is a
    #: credit of the column kept across substeps, which the touched node's friction may spend where positive
    #: (:meth:`share_bound`); False: round 49's rule (the dashpot's push gives no friction). warp_mpm's
    #: ``GroundTouch.touch_credit``.
    touch_credit = True
    #: Round 51 (docs/contact.md "Round 51: the landing's friction"): the column's Coulomb bound
    #: (``gasp_core.mpm.contact.TOUCH_BOUNDS``): ``"debt"``, ``"credit"`` round 50's rule (``touch_credit`` is read
    #: only there); round 52 ``"body"`` (the default since round 52) the debt's balance per body (:class:`BodyBound`).
    #: warp_mpm's ``touch_bound``.
    touch_bound = "body"
    #: Round 53 (docs/contact.md "Round 53: a pull's debt refunded at once"): under ``"body"``, the answer to the two
    #: dashpots' pull (``TOUCH_PULLS``): ``"refund"`` (the default) the pool's debt returned at once along the slip
    #: (:class:`BodyBound`); ``"both"`` round 52's; ``"contact"`` a column's pull at most its net push since its
    #: contact began (``touch_credits``); ``"none"`` no pull. warp_mpm's ``touch_pull``.
    touch_pull = "refund"
    #: Round 58 (docs/contact.md "Round 58: the sand's base slips at Coulomb's bound"): True: a column a flowing
    #: body's point touches is marked 2 as a column of a body that does not flow (its touched layer takes no normal
    #: stop and the Coulomb bound of its column's held layers, round 49-53's rule); False: round 36's full Coulomb
    #: rule on the touched layer's own velocity (the rule before). warp_mpm's ``touch_flow_share``.
    flow_share = False

    def allocate_touch(self) -> None:
        """``touch_on`` (the switch, a ground with friction, ``ground_rubs``, and the grid contact's rule: no particle contact, or the contact chosen
        per body) and ``ground_touch`` (i32, ``(4, n_grid, n_grid)``: ground, column; else one entry). Called by
        :meth:`~gasp_taichi_mpm.contact.Contact.allocate_mixed` (``mixed`` known); ``ground_touch`` holds 2 where a
        point of a body that does not flow touches, 1 where only flowing ones do; ``touch_speed`` (m/s, float:
        ``gasp_core.mpm.contact.touch_dashpot_speed`` of the scene, given by the engine as ``touch_speed_in``; 0.0 when
        off)."""
        self.touch_on = bool(self.touch_contact and self.ground_rubs and (not self.pc or self.mixed))
        ng = self.n_grid
        self.ground_touch = ti.field(ti.i32, shape=(4, ng, ng) if self.touch_on else (1, 1, 1))
        self.touch_speed = self.touch_speed_in if self.touch_on else 0.0   # the engine's touch_dashpot_speed
        self.share_on = bool(self.touch_on and self.touch_share)   # round 49: touch_slots, 8 a column (touch_keep)
        self.touch_slots = ti.field(self.real, shape=(4, ng, ng, 8) if self.share_on else (1, 1, 1, 1))
        self.bound_mode = TOUCH_BOUNDS[self.touch_bound] if self.share_on else 0   # round 51 (column_bound)
        # round 50: each column's credit, mu times the dashpot's net push less the friction it gave (kg m/s)
        self.credit_on = bool(self.share_on and (self.touch_credit or self.bound_mode > 0) and self.touch_speed > 0.0)
        self.touch_credits = ti.field(self.real, shape=(4, ng, ng) if self.credit_on else (1, 1, 1))
        self.allocate_body_bound(self.share_on and self.bound_mode == TOUCH_BOUNDS["body"])   # round 52
        self.pull_mode = TOUCH_PULLS[self.touch_pull]   # round 53 (body_gather)

    @ti.kernel
    def mark_touch(self):
        """Clear ``ground_touch``, then mark ground ``b``'s column ``(i, j)`` for the 3 x 3 stencil columns of every
        material point (with the contact chosen per body, of a flowing body) that touches ``b``'s plane: a point of a
        flowing material (``kind`` sand, snow or liquid) whose height above it is under ``touch_delta dx`` (m; below
        the plane too), a point of any other body whose lowest extent (its height less ``h``, half its spacing
        ``p_vol^(1/3) / 2``) lies under ``touch_margin h`` above it. A parallel loop over the points with atomic max."""
        ng = self.n_grid
        for b, i, j in ti.ndrange(self.n_grounds, ng, ng):
            self.ground_touch[b, i, j] = 0
            if ti.static(self.pool_on):   # round 52: the column's body (body_bound.py)
                self.touch_body[b, i, j] = 0
        reach = ti.cast(self.touch_delta, self.real) * self.dx[None]
        margin = ti.cast(self.touch_margin, self.real)
        for p in range(self.n_points[None]):
            mine = True
            if ti.static(self.mixed):
                mine = self.flows[self.body[p]] != 0
            if mine:
                base, fx, ok = self.base_fx(self.x[p])
                if ok:
                    k = self.kind[self.body[p]]
                    flowing = k == SAND or k == SNOW or k == LIQUID
                    h = ti.cast(0.0, self.real)
                    mark = 1
                    if ti.static(self.flow_share):   # round 58: a flowing body's column shares the bound too
                        mark = 2
                    if not flowing:
                        h = 0.5 * ti.pow(self.p_vol[p], 1.0 / 3.0)   # only the extent test reads it
                        mark = 2   # round 48: the dashpot above the held layers acts there (dashpot)
                    for b in ti.static(range(self.n_grounds)):
                        z = self.x[p][2] - self.ground_h[b]
                        if (flowing and z < reach) or (not flowing and z - h < margin * h):
                            for i, j in ti.static(ti.ndrange(3, 3)):
                                ti.atomic_max(self.ground_touch[b, base[0] + i, base[1] + j], mark)
                                if ti.static(self.pool_on):   # round 52: the column's body, the largest id
                                    if not flowing or ti.static(self.flow_share):
                                        ti.atomic_max(self.touch_body[b, base[0] + i, base[1] + j], self.body[p])

    @ti.func
    def ground_reach(self, b: ti.template(), I):
        """Whether ground ``b``'s grid rule acts at node ``I``: ``I_z <= ground_kmax[b]``, or (``touch_on``) the layer
        above in a column :meth:`mark_touch` marked."""
        on = I[2] <= self.ground_kmax[b]
        if ti.static(self.touch_on):
            # the touched layer gives the base's shear its friction: none on a frictionless ground, where it would
            # only raise the floor a layer (a liquid's dam break ran 39 % slow with it)
            if I[2] == self.ground_kmax[b] + 1 and self.ground_fric[b] > 0 and self.ground_touch[b, I[0], I[1]] != 0:
                on = True
        return on

    @ti.func
    def dashpot(self, b: ti.template(), I, v):
        """Round 48: at node ``I`` in the layer just above ground ``b``'s held ones (``ground_kmax + 2``; round 49, with
        ``share_on``, the touched layer ``ground_kmax + 1`` too: its normal motion is the body's there) of a column
        marked 2 (a point of a body that does not flow touches the plane, :meth:`mark_touch`), on a ground with
        friction, ``v``'s normal (+z) part divided by ``1 + touch_speed dt / dx``, both ways; ``v`` elsewhere. No
        friction is taken from it (warp_mpm's ``touch.build_dashpot``)."""
        out = v
        if ti.static(self.touch_on and self.touch_speed > 0.0 and not self.credit_on):   # round 50: share_bound's
            k = I[2] - self.ground_kmax[b]   # round 49: the touched layer too (k 1) where it shares the bound
            if (k == 2 or (ti.static(self.share_on) and k == 1)) and self.ground_fric[b] > 0 \
                    and self.ground_touch[b, I[0], I[1]] == 2:
                d = ti.cast(self.touch_speed, self.real) * self.dt[None] / self.dx[None]
                out = ti.Vector([v[0], v[1], v[2] / (1.0 + d)])
        return out

    @ti.func
    def field_reach(self, b: ti.template(), I):
        """:meth:`ground_reach` for the two-field contact (both fields move with the mean where it holds), except
        (``field_rule`` bit 1, ``gasp_core.mpm.fields.TOP_FREE``) the ground's top node layer in a column no flowing
        point touches: the fields keep their offsets there (warp_mpm's ``touch.build_field_reach``)."""
        on = self.ground_reach(b, I)
        if ti.static(self.touch_on and self.field_rule % 2 != 0):
            if I[2] == self.ground_kmax[b] and self.ground_touch[b, I[0], I[1]] == 0:
                on = False
        return on

    @ti.func
    def ground_mu(self, b: ti.template(), I):
        """Round 51: ground ``b``'s friction at node ``I`` in its grid rule: 0 at the held layers ``ground_kmax - 2 ..
        ground_kmax`` of a column marked 2 under a round 51 bound (``bound_mode`` > 0; :meth:`column_bound` gives
        their friction), else ``ground_fric[b]``."""
        mu = self.ground_fric[b]
        if ti.static(self.share_on and self.bound_mode > 0):
            k = I[2] - self.ground_kmax[b]
            if -2 <= k and k <= 0 and self.ground_touch[b, I[0], I[1]] == 2:
                mu = 0.0
        return mu

    @ti.func
    def shares(self, b: ti.template(), I):
        """Round 49: whether node ``I`` is the touched layer (``ground_kmax + 1``) of a column marked 2 on ground ``b``
        (with friction) while ``share_on``: the grid rule leaves it alone there (:meth:`share_bound`)."""
        out = False
        if ti.static(self.share_on):
            if I[2] == self.ground_kmax[b] + 1 and self.ground_fric[b] > 0 and self.ground_touch[b, I[0], I[1]] == 2:
                out = True
        return out

    @ti.func
    def touch_keep(self, I, v, m):
        """Round 49 (``share_on``), in the grid update before the rule, ``v`` node ``I``'s velocity (m/s), ``m`` its
        mass (kg): at ground ``b``'s held layers ``ground_kmax - 2 .. ground_kmax`` the Coulomb bound the stop gives
        that the node does not spend, ``m max(0, mu max(0, -v_z) - |v_xy|)`` (kg m/s), at slot ``I_z - ground_kmax + 2``
        of ``touch_slots[b, I_x, I_y]``; at the touched layer the node's mass at slot 3, round 50 the node above's at
        slot 4 (warp_mpm's ``touch_keep``)."""
        if ti.static(self.share_on):
            for b in ti.static(range(self.n_grounds)):
                d = I[2] - self.ground_kmax[b]
                if -2 <= d and d <= 2:
                    val = m   # the touched node's mass (d 1), round 50: the node above's (d 2)
                    if d < 1:
                        lt = ti.sqrt(v[0] * v[0] + v[1] * v[1])
                        val = m * ti.max(0.0, self.ground_fric[b] * ti.max(0.0, -v[2]) - lt)
                        if ti.static(self.bound_mode > 0):   # round 51: the stop's whole bound, and the mass
                            val = m * self.ground_fric[b] * ti.max(0.0, -v[2])
                            self.touch_slots[b, I[0], I[1], d + 7] = m
                    self.touch_slots[b, I[0], I[1], d + 2] = val

    @ti.func
    def damp_node(self, I, m, d, room):
        """Round 50: node ``I``'s normal velocity divided by ``1 + d``; returns the dashpot's normal impulse (kg m/s, +
        up; 0 at no mass ``m``); round 53: its pull (a negative impulse) at most ``room`` (kg m/s; 1e30 for none)."""
        jn = ti.cast(0.0, self.real)
        if m > 0:
            v = self.grid_v[I]
            jn = ti.max(m * (v[2] / (1.0 + d) - v[2]), -ti.max(room, 0.0))
            self.grid_v[I] = ti.Vector([v[0], v[1], v[2] + jn / m])
        return jn

    @ti.kernel
    def share_bound(self):
        """Round 49, after the grid update: the touched node of a column marked 2 (:meth:`shares`) has its tangential
        velocity cut by the column's unused bound (slots 0-2) over its mass (slot 3), to 0 at most; its normal
        velocity is the body's. Round 50 (``credit_on``): first the dashpot on the touched node and the one above (mass
        slot 4), both ways, its signed normal impulse times ``mu`` added to the column's credit (``touch_credits``,
        kept across substeps, 0 in an unmarked column); the cut may spend the credit where positive, and what it
        spends beyond the held layers' bound is taken from it. The slots are cleared for the next substep (warp_mpm's
        ``touch_share``)."""
        ng = self.n_grid
        for b, i, j in ti.ndrange(self.n_grounds, ng, ng):
            kt = self.ground_kmax[b] + 1
            m = self.touch_slots[b, i, j, 3]
            if self.ground_touch[b, i, j] == 2 and self.ground_fric[b] > 0 and 0 <= kt and kt < ng:
                r = ti.cast(0.0, self.real)
                mu = self.ground_fric[b]
                if ti.static(self.credit_on):
                    d = ti.cast(self.touch_speed, self.real) * self.dt[None] / self.dx[None]
                    if ti.static(self.bound_mode != 2):   # round 51 "substep": no balance carried
                        r = self.touch_credits[b, i, j]
                    r += mu * self.damp_node(ti.Vector([i, j, kt]), m, d, 1e30)
                    if kt + 1 < ng:
                        r += mu * self.damp_node(ti.Vector([i, j, kt + 1]), self.touch_slots[b, i, j, 4], d, 1e30)
                if ti.static(self.bound_mode > 0):
                    r = self.column_bound(b, i, j, kt, r)
                else:
                    v = self.grid_v[i, j, kt]
                    lt = ti.sqrt(v[0] * v[0] + v[1] * v[1])
                    if m > 0 and lt > 1e-30:
                        held = (self.touch_slots[b, i, j, 0] + self.touch_slots[b, i, j, 1]
                                + self.touch_slots[b, i, j, 2])
                        s = ti.max(0.0, 1.0 - (held + ti.max(r, 0.0)) / (m * lt))
                        self.grid_v[i, j, kt] = ti.Vector([v[0] * s, v[1] * s, v[2]])
                        r -= ti.max(0.0, m * lt * (1.0 - s) - held)   # what it spent beyond the held layers'
                if ti.static(self.credit_on):
                    self.touch_credits[b, i, j] = r
            elif ti.static(self.credit_on):
                self.touch_credits[b, i, j] = 0.0
            for c in ti.static(range(8)):
                self.touch_slots[b, i, j, c] = 0.0

    @ti.func
    def held_sums(self, b, i, j, kt, start):
        """A touched column's held layers (slots 0-2 their stops ``mu m max(0, -v_z)``, 5-7 their masses; kg m/s):
        ``(start`` plus the stops summed in layer order, the friction the held nodes want, each at most its own
        stop's``)``. Round 51's :meth:`column_bound` and round 52's ``BodyBound.gather_column``."""
        total = start
        want = ti.cast(0.0, self.real)
        for c in ti.static(range(3)):
            total += self.touch_slots[b, i, j, c]
            mc = self.touch_slots[b, i, j, 5 + c]
            if mc > 0 and kt - 3 + c >= 0:
                u = self.grid_v[i, j, kt - 3 + c]
                want += ti.min(mc * ti.sqrt(u[0] * u[0] + u[1] * u[1]), self.touch_slots[b, i, j, c])
        return total, want

    @ti.func
    def cut_held(self, b, i, j, kt, fh):
        """Each held node's tangential velocity cut by ``fh`` (the fraction given) of its own want (:meth:`held_sums`).
        Round 51's :meth:`column_bound` and round 52's ``BodyBound.body_apply``."""
        for c in ti.static(range(3)):
            mc = self.touch_slots[b, i, j, 5 + c]
            if mc > 0 and kt - 3 + c >= 0:
                u = self.grid_v[i, j, kt - 3 + c]
                lu = ti.sqrt(u[0] * u[0] + u[1] * u[1])
                if lu > 1e-30:
                    s = ti.max(0.0, 1.0 - fh * ti.min(mc * lu, self.touch_slots[b, i, j, c]) / (mc * lu))
                    self.grid_v[i, j, kt - 3 + c] = ti.Vector([u[0] * s, u[1] * s, u[2]])

    @ti.func
    def column_bound(self, b: ti.template(), i, j, kt, r):
        """Round 51 (``bound_mode`` > 0; docs/contact.md "Round 51: the landing's friction"): the column's friction in
        the substep at most ``avail``, the held layers' stops (slots 0-2, ``mu m max(0, -v_z)``, kg m/s) plus ``r``
        (``mu`` times the two dashpots' signed push; "debt" / "episode": the carried balance too); given to the held
        nodes first (each at most its own stop's), the rest to the touched node (mass slot 3, held masses 5-7).
        Returns the balance to carry: "debt" ``min(max(r, 0), avail - given)``, "episode" ``avail - given``, else 0
        (warp_mpm's ``column_bound``)."""
        m = self.touch_slots[b, i, j, 3]
        avail, want = self.held_sums(b, i, j, kt, r)
        v = self.grid_v[i, j, kt]
        lt = ti.sqrt(v[0] * v[0] + v[1] * v[1])
        give = ti.min(want + m * lt, ti.max(avail, 0.0))
        fh = ti.cast(1.0, self.real)
        if give < want:
            fh = give / want
        self.cut_held(b, i, j, kt, fh)
        if m > 0 and lt > 1e-30 and give > want:
            s = ti.max(0.0, 1.0 - (give - want) / (m * lt))
            self.grid_v[i, j, kt] = ti.Vector([v[0] * s, v[1] * s, v[2]])
        out = ti.cast(0.0, self.real)
        if ti.static(self.bound_mode == 1):
            out = ti.min(ti.max(r, 0.0), avail - give)   # a debt kept until paid, a credit not beyond the push
        if ti.static(self.bound_mode == 3):
            out = avail - give
        return out

    def touch_update(self) -> None:
        """:meth:`mark_touch` where ``touch_on`` (after each P2G, before the two-field contact and the grid update, on
        the points' positions P2G used; warp_mpm's order)."""
        if self.touch_on:
            self.mark_touch()

    def touch_after(self) -> None:
        """Round 49: :meth:`share_bound` where ``share_on`` (after the grid update, before the held boxes' ghosts)."""
        if self.pool_on:   # round 52: the body's pool (body_bound.py)
            self.body_bound()
        elif self.share_on:
            self.share_bound()
