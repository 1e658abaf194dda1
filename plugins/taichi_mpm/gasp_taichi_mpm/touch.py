"""The ground's contact detected from the points (issue 67, rounds 35-36; docs/contact.md "Round 35: the contact
detected from the points", "Round 36: the touched layer on both engines"): with the grid contact, the node layer just
above a ground's plane takes the ground's Coulomb rule in the columns where a point of the body touches the plane: a
point of a body that does not flow when its lowest extent (its height less half its own spacing) lies within
``touch_margin`` of that half spacing (round 47, docs/contact.md "Round 47: the touch test tied to the point's
extent"), a point of a flowing body (sand, snow, liquid) when its height is under ``touch_delta`` cells (round 36's
rule); warp_mpm's ``gasp_warp_mpm.touch``, the same rule. Round 48 (docs/contact.md "Round 48: a dashpot above the
held layers"): in a column a body that does not flow touches, the node layer above the held ones takes a dashpot on
its normal velocity (:meth:`GroundTouch.dashpot`).

Mixed into :class:`gasp_taichi_mpm.grid.GridUpdate` (and so :class:`gasp_taichi_mpm.solver.MPMSolver`), whose
fields (``ground_kmax``, ``ground_h``, ``x``, ``n_points``, ...) it reads.
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.contact import DAMPING
from gasp_core.mpm.materials import P_LAM, P_MU, MaterialKind

#: The flowing materials' codes (``gasp_core.mpm.contact.FLOWING``): round 36's touch test.
SAND, SNOW, LIQUID = int(MaterialKind.SAND), int(MaterialKind.SNOW), int(MaterialKind.LIQUID)


class GroundTouch:
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

    def allocate_touch(self) -> None:
        """``touch_on`` (the switch, a ground with friction, ``ground_rubs``, and the grid contact's rule: no particle contact, or the contact chosen
        per body) and ``ground_touch`` (i32, ``(4, n_grid, n_grid)``: ground, column; else one entry). Called by
        :meth:`~gasp_taichi_mpm.contact.Contact.allocate_mixed` (``mixed`` known); ``ground_touch`` holds 2 where a
        point of a body that does not flow touches, 1 where only flowing ones do; ``touch_speed`` (m/s, float:
        :meth:`dashpot_speed`, 0.0 when off)."""
        self.touch_on = bool(self.touch_contact and self.ground_rubs and (not self.pc or self.mixed))
        ng = self.n_grid
        self.ground_touch = ti.field(ti.i32, shape=(4, ng, ng) if self.touch_on else (1, 1, 1))
        self.touch_speed = self.dashpot_speed() if self.touch_on else 0.0

    def dashpot_speed(self) -> float:
        """The dashpot's speed (m/s, float; ``gasp_core.mpm.contact.touch_dashpot_speed``, the same rule): ``2
        touch_damping c``, ``c`` the largest P-wave speed ``sqrt((lam + 2 mu) / rho)`` of the bodies that do not flow
        (their Lame parameters from ``mat``, ``rho`` their points' mass over volume); 0.0 without one."""
        n = self.n_material
        body, kind, mat = self.body.to_numpy()[:n], self.kind.to_numpy(), self.mat.to_numpy().astype(np.float64)
        mass = np.bincount(body, self.p_mass.to_numpy()[:n].astype(np.float64), minlength=len(kind))
        vol = np.bincount(body, self.p_vol.to_numpy()[:n].astype(np.float64), minlength=len(kind))
        speeds = [np.sqrt((mat[b, P_LAM] + 2.0 * mat[b, P_MU]) * vol[b] / mass[b]) for b in range(len(kind))
                  if mass[b] > 0.0 and int(kind[b]) not in (SAND, SNOW, LIQUID)]
        return 2.0 * float(self.touch_damping) * float(max(speeds, default=0.0))

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
                    if not flowing:
                        h = 0.5 * ti.pow(self.p_vol[p], 1.0 / 3.0)   # only the extent test reads it
                        mark = 2   # round 48: the dashpot above the held layers acts there (dashpot)
                    for b in ti.static(range(self.n_grounds)):
                        z = self.x[p][2] - self.ground_h[b]
                        if (flowing and z < reach) or (not flowing and z - h < margin * h):
                            for i, j in ti.static(ti.ndrange(3, 3)):
                                ti.atomic_max(self.ground_touch[b, base[0] + i, base[1] + j], mark)

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
        """Round 48: at node ``I`` in the layer just above ground ``b``'s held ones (``ground_kmax + 2``) of a column
        marked 2 (a point of a body that does not flow touches the plane, :meth:`mark_touch`), on a ground with
        friction, ``v``'s normal (+z) part divided by ``1 + touch_speed dt / dx``, both ways; ``v`` elsewhere. No
        friction is taken from it (warp_mpm's ``touch.build_dashpot``)."""
        out = v
        if ti.static(self.touch_on and self.touch_speed > 0.0):
            if I[2] == self.ground_kmax[b] + 2 and self.ground_fric[b] > 0 and self.ground_touch[b, I[0], I[1]] == 2:
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

    def touch_update(self) -> None:
        """:meth:`mark_touch` where ``touch_on`` (after each P2G, before the two-field contact and the grid update, on
        the points' positions P2G used; warp_mpm's order)."""
        if self.touch_on:
            self.mark_touch()
