"""``deterministic = true`` on the GPU schedule: the P2G scatter in fixed point (issue 65).

Float atomics add in whatever order the threads arrive, so two runs of the atomic P2G differ in the last bits
(measured on an H100: 1.8e-5 dx after 3 frames of the README donut, docs/performance.md). Integer addition is
associative, so here each point's share of a node is rounded to a multiple of a per-channel atom
``bound / 2**62``, added as a 64-bit integer atomic (exact, modulo 2**64), and the node's sum converted back to
floats in one pass over the grid (:meth:`FixedPointP2G.fixed_to_grid`): the same inputs give the same grid on
any thread count and device. Partial sums may wrap around; only the node's final sum has to lie within
``+-bound``, which holds for every stable substep (below). The bound of each channel (SI units):

- momentum, the APIC momentum, the friction budget (kg m/s): ``M * 64 dx / dt`` (``M`` the material points'
  mass): a node past it moves its points 64 cells a substep, a divergence the frame's checks stop;
- mass (kg): ``2 M``; the viscous volume ``J V eta`` (m^3 Pa s): ``64 V eta_max`` (``V`` the points' volume).

The atom is then about 1e-16 of ``M`` times the speed ``64 dx / dt``: on the README donut 1.3e-16 kg m/s against
a point's momentum at 1 mm/s of 8.5e-9 kg m/s (below f32's rounding). Covered: ``grid_mv`` (the points' P2G).
Not covered (the engine refuses ``deterministic`` with them, :func:`not_covered`): wind, the particle contact
against colliders or walls' faces (``grid_fnv``), the contact chosen per body (``grid_mf``), the two-field contact
and rigid bodies (float atomics of their own). Source of the technique: fixed-point atomics for reproducible
reductions (e.g. Demmel & Nguyen 2013, reproducible summation; PhysX/Warp's deterministic modes).
"""
import numpy as np
import taichi as ti

from gasp_core.mpm.contact import JSUMS

#: Scale of a channel's bound: its sums are kept in ``[-2**62, 2**62]`` units of ``bound / 2**62``.
FIXED_BITS = 62
#: Headroom on the speed ``dx / dt`` and on ``J`` in the bounds (module notes).
HEADROOM = 64.0


def channel_bounds(acc_width: int, eta_channel: int, *, mass: float, volume: float, eta_max: float, dx: float,
                   dt: float, viscous: bool, pc: bool) -> np.ndarray:
    """Per channel of ``grid_mv`` (shape ``(acc_width,)``, float64, SI units) the largest node sum a stable substep
    reaches (module notes): ``[momentum x3, mass, (APIC momentum x3), (J V eta), (friction budget)]``."""
    mom = max(mass, 1e-30) * HEADROOM * dx / dt
    out = np.full(acc_width, mom)
    out[3] = 2.0 * max(mass, 1e-30)
    if viscous:
        out[eta_channel] = HEADROOM * max(volume, 1e-30) * max(eta_max, 1e-30)
    if pc:
        out[acc_width - 1] = mom
    return out


def support_bounds(mass: float, dx: float, dt: float, lo, n_grid: int) -> np.ndarray:
    """Per column of the contact's support sums ``c_jsums`` (``gasp_core.mpm.contact.JSUMS``: j, j x, j n,
    x cross j n, j v_c, the pushed points' mass m, the box, j x x^T, j^2; float64, SI units) the largest sum a stable
    substep reaches: the impulse ``J = M 64 dx / dt`` (kg m/s), times the farthest coordinate of the grid ``L`` (m)
    for the first moments, ``2 L`` for the moments, ``L^2`` for the second moments, and times the speed
    ``64 dx / dt`` for the supports' velocities; the mass ``2 M``; ``J^2``; 1 for the box's six columns (min and
    max, never summed in fixed point)."""
    lo = np.abs(np.asarray(lo, np.float64))
    far = float(np.max(np.maximum(lo, np.abs(np.asarray(lo) + n_grid * dx)))) if lo.size else 1.0
    speed = HEADROOM * dx / dt
    jb = max(mass, 1e-30) * speed
    return np.array([jb] + [jb * far] * 3 + [jb] * 3 + [2 * jb * far] * 3 + [jb * speed] * 3
                    + [2.0 * max(mass, 1e-30)] + [1.0] * 6 + [jb * far * far] * 6 + [jb * jb])


def not_covered(solver) -> list[str]:
    """What in ``solver``'s scene the fixed-point P2G does not make deterministic (module notes); empty when all."""
    out = []
    for flag, what in (("has_wind", "wind"), ("nfric", "the particle contact against colliders or walls"),
                       ("mixed", "the contact chosen per body"), ("fields", "the two-field contact"),
                       ("any_rigid", "rigid bodies")):
        if getattr(solver, flag, False):
            out.append(what)
    return out


class FixedPointP2G:
    """The fixed-point scatter (module notes), a mixin of :class:`gasp_taichi_mpm.solver.MPMSolver`."""

    def allocate_fixed(self, on: bool, p_mass, p_vol, eta, dx: float, dt: float, lo) -> None:
        """The integer grid (``n_grid^3`` x ``acc_width`` int64), the support sums' integers and the per-channel
        scales (:func:`channel_bounds`, :func:`support_bounds` of the material points' ``p_mass`` (kg) and ``p_vol``
        (m^3), the bodies' viscosities ``eta`` (Pa s), ``dx`` (m), ``dt`` (s), the grid's origin ``lo`` (m)) when
        ``on``. Sets ``fixed_point``."""
        self.fixed_point = bool(on)
        ng = self.n_grid if on else 1
        self.grid_q = ti.Vector.field(self.acc_width, ti.i64, shape=(ng, ng, ng))
        self.q_scale = ti.Vector.field(self.acc_width, ti.f64, shape=())
        self.jq_rows = self.c_jsums.shape[0] if on and hasattr(self, "c_jsums") else 1
        self.c_jq = ti.field(ti.i64, shape=(self.jq_rows, len(JSUMS)))
        self.jq_scale = ti.field(ti.f64, shape=len(JSUMS))
        if on:
            self.jq_scale.from_numpy(2.0 ** FIXED_BITS / support_bounds(float(np.sum(p_mass[:self.n_material])), dx,
                                                                        dt, lo, self.n_grid))
            m = self.n_material
            bounds = channel_bounds(self.acc_width, self.eta_channel, mass=float(np.sum(p_mass[:m])),
                                    volume=float(np.sum(p_vol[:m])), eta_max=float(np.max(eta)), dx=dx, dt=dt,
                                    viscous=self.viscous, pc=self.pc)
            self.q_scale[None] = (2.0 ** FIXED_BITS / bounds).tolist()

    @ti.func
    def add_fixed(self, node, val):
        """Node ``node``'s share ``val`` (``acc_width`` reals) added to ``grid_q`` in fixed point."""
        lim = ti.static(2.0 ** FIXED_BITS)
        for c in ti.static(range(self.acc_width)):
            q = ti.min(ti.max(ti.round(ti.cast(val[c], ti.f64) * self.q_scale[None][c]), -lim), lim)
            ti.atomic_add(self.grid_q[node][c], ti.cast(q, ti.i64))

    @ti.func
    def add_support_fixed(self, s, q: ti.template(), val):
        """Column ``q`` of support row ``s`` of the contact's sums: ``val`` (float64) added in fixed point."""
        lim = ti.static(2.0 ** FIXED_BITS)
        ti.atomic_add(self.c_jq[s, q], ti.cast(ti.min(ti.max(ti.round(val * self.jq_scale[q]), -lim), lim), ti.i64))

    @ti.kernel
    def fixed_to_grid(self):
        """Every node's fixed-point sums into ``grid_mv[0]`` as reals, and ``grid_q`` cleared (one thread a node);
        the support sums' likewise into ``c_jsums``."""
        for s, q in self.c_jq:
            if self.c_jq[s, q] != 0:
                self.c_jsums[s, q] = ti.cast(self.c_jq[s, q], ti.f64) / self.jq_scale[q]
                self.c_jq[s, q] = 0
        for I in ti.grouped(self.grid_q):
            q = self.grid_q[I]
            if q[3] != 0:   # the mass channel: a node no point reached has every channel 0
                val = ti.Vector.zero(self.real, self.acc_width)
                for c in ti.static(range(self.acc_width)):
                    val[c] = ti.cast(ti.cast(q[c], ti.f64) / self.q_scale[None][c], self.real)
                self.grid_mv[0, I] = val
                self.grid_q[I] = ti.Vector.zero(ti.i64, self.acc_width)


def refuse_uncovered(solver, deterministic: bool) -> None:
    """Raise when ``deterministic`` was asked on the GPU schedule of a scene it does not cover (:func:`not_covered`).

    Raises
    ------
    gasp_core.seam.SceneError
        Naming the option and what in the scene has float atomics of its own.
    """
    left = not_covered(solver) if deterministic and solver.gpu else []
    if left:
        from gasp_core.seam import SceneError
        raise SceneError(f"engine 'taichi_mpm': option 'deterministic' covers the points' P2G, not {', '.join(left)} "
                         "in this scene (their float atomics add in any order); set deterministic = false, or "
                         "schedule = 'cpu' with threads = 1 (bit for bit on the CPU)")
