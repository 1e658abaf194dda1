"""Round 52 (issue 67; docs/contact.md "Round 52: one balance carried with the body"): ``touch_bound = "body"``
(``gasp_core.mpm.contact.TOUCH_BOUNDS`` 4), round 51's debt (:meth:`GroundTouch.column_bound`) kept per body and
ground instead of per column. A column marked 2 belongs to the largest body id of the points of a body that does not
flow that mark it (``touch_body``, :meth:`GroundTouch.mark_touch`, atomic max). Three kernels after the grid update,
in place of :meth:`GroundTouch.share_bound`: :meth:`BodyBound.body_gather` (a row of columns a thread: the two dashpots,
and the column's ``mu`` times their signed push, its held layers' stops, the friction its held nodes want, each at
most its own stop's, and its touched node's ``m |v_xy|``, summed in column order into the row's partial of its ground
and body, ``row_pool``), :meth:`BodyBound.body_settle` (a pool a thread: the rows' partials summed in row order, so
the sums are the same bits on any number of threads and on CUDA, unlike float atomics (lead, round 52); round 51's
bound on the pool, the held nodes first; the balance
carried ``min(max(r, 0), avail - give)``, a debt kept until the body's stops pay it wherever on its footprint) and
:meth:`BodyBound.body_apply` (a column a thread: each node's cut, the slots cleared). warp_mpm's
``gasp_warp_mpm.body_bound``, the same rule.

Round 53 (docs/contact.md "Round 53: a pull's debt refunded at once"; ``touch_pull``, ``pull_mode``): ``"refund"``
(the default) returns a debt :meth:`BodyBound.body_settle` leaves at once, at most the friction given since the body's
contact began (slot 8) and the wants, as negative fractions that :meth:`BodyBound.body_apply` turns into a scale-up of
the nodes' tangential velocity along their slip; ``"contact"`` a column's dashpots pull at most their net push since
its contact began (``touch_credits``); ``"none"`` no pull; ``"both"`` round 52's. warp_mpm's the same rule.

Mixed into :class:`gasp_taichi_mpm.touch.GroundTouch`, whose fields (``ground_touch``, ``touch_slots``,
``ground_kmax``, ``ground_fric``, ``grid_v``, ...) it reads.
"""
import taichi as ti

#: A pool's slots (``body_pool[b, body]``): 0 the balance carried (kept across substeps), 1 ``mu`` times the
#: dashpots' push, 2 the held layers' stops, 3 the held nodes' want, 4 the touched nodes', 5 the columns counted, 6
#: the held fraction given, 7 the touched fraction given; round 53: 8 the friction given since the body's contact began
#: less what was refunded (warp_mpm's ``body_bound.POOL``).
POOL = 9


class BodyBound:
    """The per-body pool of round 52's ``"body"`` bound (module docstring)."""

    def allocate_body_bound(self, on: bool) -> None:
        """``pool_on`` (``on``: the share on with ``bound_mode`` 4), ``touch_body`` (i32, ``(4, n_grid, n_grid)``, the
        column's body; one entry when off) and ``body_pool`` (``real``, ``(4, n_bodies, POOL)``, kg m/s and
        fractions)."""
        self.pool_on = bool(on)
        ng = self.n_grid
        self.touch_body = ti.field(ti.i32, shape=(4, ng, ng) if on else (1, 1, 1))
        self.body_pool = ti.field(self.real, shape=(4, max(1, self.n_bodies), POOL) if on else (1, 1, 1))
        # each row of columns' partial sums (slots 1-5 of a pool), summed in a fixed order by body_settle
        self.row_pool = ti.field(self.real, shape=(4, ng, max(1, self.n_bodies), 5) if on else (1, 1, 1, 1))

    @ti.kernel
    def body_gather(self):
        """The columns' sums into their pools (module docstring)."""
        ng = self.n_grid
        for b, i in ti.ndrange(self.n_grounds, ng):   # a row a thread: its columns in order (no float atomics)
            for o, c in ti.ndrange(self.row_pool.shape[2], 5):
                self.row_pool[b, i, o, c] = 0.0
            for j in range(ng):
                self.gather_column(b, i, j)

    @ti.func
    def gather_column(self, b, i, j):
        """One column's sums into its row's partial (:meth:`body_gather`)."""
        ng = self.n_grid
        kt = self.ground_kmax[b] + 1
        if self.ground_touch[b, i, j] == 2 and self.ground_fric[b] > 0 and 0 <= kt and kt < ng:
            mu = self.ground_fric[b]
            m = self.touch_slots[b, i, j, 3]
            push = ti.cast(0.0, self.real)
            if ti.static(self.credit_on):   # round 50's two dashpots; round 53 (pull): a pull at most the net push
                d = ti.cast(self.touch_speed, self.real) * self.dt[None] / self.dx[None]
                room = ti.cast(1e30, self.real)
                if ti.static(self.pull_mode == 2):
                    room = 0.0
                if ti.static(self.pull_mode == 1):
                    room = self.touch_credits[b, i, j]
                jn = self.damp_node(ti.Vector([i, j, kt]), m, d, room)
                if kt + 1 < ng:
                    jn += self.damp_node(ti.Vector([i, j, kt + 1]), self.touch_slots[b, i, j, 4], d, room + jn)
                if ti.static(self.pull_mode == 1):
                    self.touch_credits[b, i, j] += jn
                push = mu * jn
            stops, want = self.held_sums(b, i, j, kt, ti.cast(0.0, self.real))
            v = self.grid_v[i, j, kt]
            o = self.touch_body[b, i, j]
            self.row_pool[b, i, o, 0] += push
            self.row_pool[b, i, o, 1] += stops
            self.row_pool[b, i, o, 2] += want
            self.row_pool[b, i, o, 3] += m * ti.sqrt(v[0] * v[0] + v[1] * v[1])
            self.row_pool[b, i, o, 4] += 1.0
        elif ti.static(self.credit_on and self.pull_mode == 1):
            self.touch_credits[b, i, j] = 0.0   # round 53: the contact ended, its push is not carried

    @ti.kernel
    def body_settle(self):
        """Round 51's bound on each pool (module docstring)."""
        for b, o in ti.ndrange(self.n_grounds, self.body_pool.shape[1]):
            for i in range(self.n_grid):   # the rows' partials, in row order
                for c in ti.static(range(5)):
                    self.body_pool[b, o, 1 + c] += self.row_pool[b, i, o, c]
            if self.body_pool[b, o, 5] > 0:
                r = self.body_pool[b, o, 0] + self.body_pool[b, o, 1]
                avail = r + self.body_pool[b, o, 2]
                wh, wt = self.body_pool[b, o, 3], self.body_pool[b, o, 4]
                give = ti.min(wh + wt, ti.max(avail, 0.0))
                fh = ti.cast(1.0, self.real)
                if give < wh:
                    fh = give / wh
                ft = ti.cast(0.0, self.real)
                if wt > 0 and give > wh:
                    ft = (give - wh) / wt
                bal = ti.min(ti.max(r, 0.0), avail - give)   # a debt kept until paid
                self.body_pool[b, o, 8] += give
                if ti.static(self.pull_mode == 3):   # round 53: the debt refunded at once, along the slip
                    if bal < 0 and wh + wt > 0:
                        back = ti.min(ti.min(-bal, self.body_pool[b, o, 8]), wh + wt)
                        fh = -back / (wh + wt)
                        ft = fh
                        bal += back
                        self.body_pool[b, o, 8] -= back
                self.body_pool[b, o, 0] = bal
                self.body_pool[b, o, 6] = fh
                self.body_pool[b, o, 7] = ft
            else:
                self.body_pool[b, o, 0] = 0.0   # the body touches no column: its balance is not carried
                self.body_pool[b, o, 8] = 0.0
            for c in ti.static(range(1, 6)):
                self.body_pool[b, o, c] = 0.0

    @ti.kernel
    def body_apply(self):
        """Each node's cut by its pool's fractions; the slots cleared (module docstring)."""
        ng = self.n_grid
        for b, i, j in ti.ndrange(self.n_grounds, ng, ng):
            kt = self.ground_kmax[b] + 1
            if self.ground_touch[b, i, j] == 2 and self.ground_fric[b] > 0 and 0 <= kt and kt < ng:
                o = self.touch_body[b, i, j]
                self.cut_held(b, i, j, kt, self.body_pool[b, o, 6])
                if self.touch_slots[b, i, j, 3] > 0:
                    v = self.grid_v[i, j, kt]
                    s = ti.max(0.0, 1.0 - self.body_pool[b, o, 7])
                    self.grid_v[i, j, kt] = ti.Vector([v[0] * s, v[1] * s, v[2]])
            for c in ti.static(range(8)):
                self.touch_slots[b, i, j, c] = 0.0

    def body_bound(self) -> None:
        """The three kernels, in order (after the grid update, in place of ``share_bound``)."""
        self.body_gather()
        self.body_settle()
        self.body_apply()
