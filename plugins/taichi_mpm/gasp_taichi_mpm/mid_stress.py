"""The midpoint stress (round 68, the engine option ``stress_at = "mid"``; ``gasp_core.mpm.stress_at``'s notes,
docs/fracture.md "Round 68"): P2G scatters the work-conjugate stress of the increment's midpoint ``F_mid = (I + dt/2 C)
F``, ``tau(F_mid) (I + dt/2 C)^-T``, for the hyperelastic models (jelly, neo-Hookean); warp_mpm's ``mid_stress.py``.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``kinds``, ...) it reads.
"""
import taichi as ti

from gasp_core.mpm.materials import JELLY, NEO_HOOKEAN, P_LAM, P_MU


def stress_flags(cfg) -> tuple[bool, bool]:
    """The solver's ``(mid_stress, trap_stress)`` from the engine's config (its ``stress_at``, ``stress_passes``), or
    from a bool (``mid_stress`` alone). "trapezoid" is built here with one pass alone (round 69: no trial substep;
    warp_mpm's ``trapezoid.py`` has more): ``stress_passes`` > 1 is refused (``EngineError``) rather than run another
    stress under its name."""
    if isinstance(cfg, bool):
        return cfg, False
    if cfg.stress_at == "trapezoid" and cfg.stress_passes > 1:
        from gasp_core.seam import EngineError
        raise EngineError(f"engine 'taichi_mpm': stress_at = \"trapezoid\" is built with stress_passes = 1 only "
                          f"(round 69, docs/fracture.md; {cfg.stress_passes} asked)")
    return cfg.stress_at == "mid", cfg.stress_at == "trapezoid"


class MidStress:
    """:meth:`mid_tau`, read by :meth:`gasp_taichi_mpm.transfers.Transfers.p2g_prep` where ``mid_stress`` is set."""

    #: The option ``stress_at = "mid"`` (set per solver by its ``mid_stress`` argument; read when the kernels compile).
    mid_stress = False
    #: The option ``stress_at = "trapezoid"`` (one pass; set per solver from its ``mid_stress`` argument): ``F``
    #: advanced by the mean of the point's last two gradients (``C_prev``, :meth:`trap_gradient`), the stress at
    #: :meth:`mid_tau`'s midpoint; warp_mpm's ``trapezoid.py`` with ``stress_passes = 1``.
    trap_stress = False
    #: The end gradient's weight in the trapezoid's increment (1/2; read when the kernels compile): the catch of
    #: ``tests/test_stress_trapezoid.py`` sets 1 (the end gradient alone: round 68's "mid"). warp_mpm's ``TRAP_WEIGHT``.
    trap_weight = 0.5
    #: The midpoint's place in the increment (1/2; read when the kernels compile): the catch of
    #: ``tests/test_stress_at.py`` sets -1/2 (the stress extrapolated back, which gains).
    mid_fraction = 0.5
    #: Scatter the symmetric part of the midpoint stress (round 71: its antisymmetric part, of order ``dt tau C``, is
    #: a torque: a free spun jelly ball lost 8.4e-4 of its angular momentum in 4 frames; tests/test_stress_spin.py).
    #: False, the broken variant (rounds 68-70); read when the kernels compile. warp_mpm's ``SYMMETRIC``.
    symmetric = True

    @ti.func
    def trap_gradient(self, p, a, C, Cf):
        """Point ``p``'s gradient for its ``F`` increment under the trapezoid: ``(C_prev + C) / 2`` for a free
        hyperelastic point (``a < 0``), else ``Cf``; ``C_prev`` set to ``C``."""
        b = self.body[p]
        kind = self.kind[b]
        if ti.static(not self.multi_kind):
            kind = ti.static(next(iter(self.kinds)))
        out = Cf
        if a < 0 and (kind == JELLY or kind == NEO_HOOKEAN):
            out = (1.0 - ti.static(self.trap_weight)) * self.C_prev[p] + ti.static(self.trap_weight) * C
        self.C_prev[p] = C
        return out

    @ti.func
    def mid_tau(self, p, C, F, tau):
        """Point ``p``'s midpoint stress (module notes) from its gradient ``C`` and new ``F``; ``tau`` (its return
        mapping's) unchanged for every other model."""
        b = self.body[p]
        kind = self.kind[b]
        if ti.static(not self.multi_kind):
            kind = ti.static(next(iter(self.kinds)))
        out = tau
        if kind == JELLY or kind == NEO_HOOKEAN:
            prm = self.mat[b]
            H = ti.Matrix.identity(self.real, 3) + (ti.static(self.mid_fraction) * self.dt[None]) * C
            S = self.elastic_tau(kind, H @ F, prm[P_MU], prm[P_LAM]) @ H.inverse().transpose()
            out = S
            if ti.static(self.symmetric):
                out = 0.5 * (S + S.transpose())   # its symmetric part: no torque (round 71)
        return out
