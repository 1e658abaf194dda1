"""The midpoint stress (round 68, the engine option ``stress_at = "mid"``; ``gasp_core.mpm.stress_at``'s notes,
docs/fracture.md "Round 68"): P2G scatters the work-conjugate stress of the increment's midpoint ``F_mid = (I + dt/2 C)
F``, ``tau(F_mid) (I + dt/2 C)^-T``, for the hyperelastic models (jelly, neo-Hookean); warp_mpm's ``mid_stress.py``.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``kinds``, ...) it reads.
"""
import taichi as ti

from gasp_core.mpm.materials import JELLY, NEO_HOOKEAN, P_LAM, P_MU


def mid_flag(stress_at) -> bool:
    """The solver's ``mid_stress`` from the option ``stress_at`` (or a bool): "trapezoid" (round 69, warp_mpm's
    ``trapezoid.py`` only) is refused (``EngineError``) rather than run another stress under its name."""
    if isinstance(stress_at, bool):
        return stress_at
    if stress_at == "trapezoid":
        from gasp_core.seam import EngineError
        raise EngineError('engine \'taichi_mpm\': stress_at = "trapezoid" is built on warp_mpm only (round 69, '
                          'docs/fracture.md); use "start" or "mid"')
    return stress_at == "mid"


class MidStress:
    """:meth:`mid_tau`, read by :meth:`gasp_taichi_mpm.transfers.Transfers.p2g_prep` where ``mid_stress`` is set."""

    #: The option ``stress_at = "mid"`` (set per solver by its ``mid_stress`` argument; read when the kernels compile).
    mid_stress = False
    #: The midpoint's place in the increment (1/2; read when the kernels compile): the catch of
    #: ``tests/test_stress_at.py`` sets -1/2 (the stress extrapolated back, which gains).
    mid_fraction = 0.5

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
            out = self.elastic_tau(kind, H @ F, prm[P_MU], prm[P_LAM]) @ H.inverse().transpose()
        return out
