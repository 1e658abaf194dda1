"""An energy ledger per substep of the MPM engines (issue 66 item 6 "No energy is gained"; docs/fracture.md "Round 46:
where the landing's energy goes").

Read-only: the engine is stepped one substep at a time through its own pieces (taichi_mpm: the solver's P2G, grid
update, the contact's balance fix and G2P, unfused; warp_mpm: its recorded launches in their order) and its fields
are read between them; nothing in an engine changes. Per substep (energies in J; the points are the material ones):

- ``Ep``: the points' kinetic energy with the APIC affine part, ``sum m (|v|^2 + dx^2 / 4 |C|_F^2) / 2`` (the
  quadratic B-spline's inertia ``D = dx^2 / 4 I``): with it P2G and G2P each lose energy, never gain it (the grid
  velocity is a weighted mean of the points' affine fields and the G2P a least-squares projection of the grid's);
- ``K0``: the grid's kinetic energy of the P2G without forces (NumPy, the points' ``m (v + C (x_i - x_p))`` with their
  weights; its node masses are checked against the engine's); the impulses the engine's P2G adds on top: the particle
  contact's (NumPy, ``gasp_core.mpm.contact``'s damped penalty on the ground from the engine's own ``(k, c, skin)``),
  the stress's (the engine's P2G momentum less the two), gravity's ``m g dt`` (the ledger's own ``g``); each does the
  work ``J . (v_a + v_b) / 2`` at the node (``v_a`` the free P2G's velocity, ``v_b`` the engine's before its rule), an
  order-free split whose sum is ``K3 - K0``, ``K3`` the grid's energy before the rule; under the grid contact (round
  56) a node the ground's rule changed takes each impulse's work at its velocity after the rule instead (the points'
  ``F`` advances with that velocity, so the stress's work against the stored energy's rise is at it; the kinetic energy
  the stress gave the node before the rule stopped it is the rule's); ``K4``: the engine's grid velocity after the
  grid update (the ground's and walls' grid rule, the nodes' Coulomb friction); ``K5``: after the contact's balance
  fix. The grid is the engine's: under the grid contact the ground lies on a node layer
  (``gasp_core.mpm.grid_origin.ground_on_node``, round 56);
- ``psi``: the stored elastic energy of the engine's ``F`` (:class:`Stored`, each model's: jelly fixed corotated, ``V0
  (mu sum (s_i - 1)^2 + lam (J - 1)^2 / 2)``; sand Hencky's ``V0 (mu |e|^2 + lam tr(e)^2 / 2)``; snow fixed
  corotated times ``exp(xi (1 - Jp))``; brittle: the carried Hencky energy and the damage's dissipation ``D`` of
  ``benchmarks/brittle_donut_arrest.py``), ``U``: the contact's springs ``sum k depth^2 / 2``, ``PE``: ``m g z``.
  Under ``stress_at = "trapezoid"`` (round 70; ``gasp_core.mpm.stress_at``) ``psi`` is that of ``F`` with the
  increment it still owes booked (:data:`OWED`, :meth:`Ledger.owed_F`): the scheme's P2G of a substep advances ``F``
  by ``dt (C_prev + C) / 2``, the mean of the gradient the point had at the P2G before and the one G2P gave it since,
  while the stress that P2G scatters works on the grid's velocities before and after its kick, whose gradients are
  those two: a substep's stress works for the increment that the NEXT P2G takes. The stored energy of the engine's
  ``F`` alone lags the stress's work by that whole increment (round 69's whole-step offset of the elastic term). With
  the owed increment booked the elastic term of a substep is the stress's work against the rise it pays for (round
  69's "c = 1" pairing, without a shift): the free bar's elastic term ends 0.07 % / 0.31 % of the energy brought at
  cfl 0.4 / 0.8 (2.10 / 5.46 % unbooked, 1.00 / 2.58 % booked by half; ``free_vibration.py --ledger --owed``). On the
  ball's landing the increment owed at the end is small: its closing sum (-3.19 % at n_grid 32, 4.43 m/s) is the
  ``gradient`` term below, not this one (round 70). Only the hyperelastic points (jelly,
  neo-Hookean: the scheme's; the return-mapping models keep the start's increment and stress); the ledger's scenes
  have no held points. Under "start" and "mid" nothing is booked: their stress works half a step ahead of ``F``, a
  bounded offset that the family's half-step pairing takes out (their figures since round 53 are read so).

Sinks of a substep (positive: lost): ``p2g = Ep - K0``; ``contact = -W_contact - dU`` (the penalty's damping and its
discrete steps); ``friction`` (``gasp_core.mpm.contact.node_friction`` on the friction budget the engine scattered,
applied to ``K3``'s velocities); ``rule = K3 - K4 - friction`` (the ground's and walls' grid rule; with the held
nodes' work moved, above); ``balance = K4 - K5``; ``g2p = K5 - Ep'``; ``plastic`` (round 53; round 56 for sand and
snow): the returned stress's work on the return's log strain, over the points whose model returns (brittle points
broken through, every sand point: the Drucker-Prager return; every snow point: the clamp; :meth:`Ledger.plastic`);
``hardening`` (round 56): snow's stored energy's change with ``Jp`` at the returned ``F`` (:meth:`Ledger.hardening`);
``gradient`` (round 70, under ``stress_at = "trapezoid"`` alone, :meth:`Ledger.gradient`): the stress's work on
the part of ``F``'s increment that the grid never carried. The stress's force on the nodes does ``-V tau : C(u)`` of
work on a node velocity field ``u`` (``C(u)`` its APIC gather at the point, :func:`gather_C`), so a substep's stress
works on ``(C~ + C^) / 2``, ``C~`` the gather of the free P2G's velocity (the point's own gradient ``C_0`` through the
transfers' round trip) and ``C^`` that of the grid's velocity after the kick, before the grid's rule and friction;
the trapezoid's increment takes ``(C_0 + C_1) / 2``, the point's own ``C_0`` and the ``C_1`` G2P gives after the rule
and friction, and its stored energy rises by the scattered stress's work on that (the midpoint rule). The difference,
``dt V tau_s : ((C~ - C_0) + (C^ - C_1)) / 2`` (``tau_s`` the engine's scattered stress, the midpoint's ``tau(H F)
H^-T``), is no stress's work on the grid: booked here (positive: lost). Round 70 (``free_vibration.py --ledger``, the
family): 3.37 % of the energy brought lost on the ball at n_grid 32 and 4.43 m/s (the elastic term ends -3.19 %
without it, +0.18 % with it); 0.62 % on the README jelly donut at cfl 0.8 (ground friction 0.5; its ``C^ - C_1`` part
is the friction's; +0.33 % at the end with it, -0.29 % without, and its gain read 0.37 %: 1.76 % with the first part
alone); 0.006 % on the free bar at cfl 0.8, whose elastic term ends 0.32 % with it (the one-pass guess's offset),
0.000 % with 3 passes. The stored energy's difference instead of this work (``psi`` of the two increments)
books 0.99 % on the free bar that it does not lose: its second-order part is no work. Under "start" the increment takes
``C_1`` alone (nothing to book).
The two untraced terms, zero for an integrator that conserves energy: ``elastic = W_stress + dpsi + dD + plastic +
hardening`` (the stress's work on the grid against the stored energy's rise, the damage's dissipation and the
return's) and ``gravity = W_gravity + dPE``. With them the sinks sum to the drop of ``E = Ep + psi + U + PE + D`` (an
identity: the ledger closes when the untraced terms are small). Used by ``benchmarks/energy_ledger_family.py``,
``benchmarks/energy_ledger_plastic.py`` and ``tests/test_energy_ledger.py``, ``tests/test_energy_ledger_plastic.py``.
"""
from __future__ import annotations

import numpy as np

from gasp_core.mpm.contact import node_friction

SINKS = ("p2g", "contact", "friction", "rule", "balance", "g2p", "plastic", "hardening", "gradient")
UNTRACED = ("elastic", "gravity")


def weights(x: np.ndarray, lo: np.ndarray, inv_dx: float):
    """Quadratic B-spline stencils: ``base`` (n, 3) int, ``fx`` (n, 3) and ``w`` (n, 3, 3) (axis, node 0-2)."""
    X = (x - lo) * inv_dx
    base = np.floor(X - 0.5).astype(np.int64)
    fx = X - base
    w = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2], axis=2)
    return base, fx, w


def stencil(x: np.ndarray, lo: np.ndarray, dx: float, ng: int):
    """The 27 nodes of the points' quadratic stencils, one at a time: ``(wt, flat, dpos)``, the weights (n,), the
    nodes' flat indices (n,) int (clipped to the grid) and ``x_i - x_p`` (n, 3), m."""
    base, fx, w = weights(x, lo, 1.0 / dx)
    for i in range(3):
        for j in range(3):
            for k in range(3):
                off = np.array([i, j, k])
                idx = np.clip(base + off, 0, ng - 1)
                yield (w[:, 0, i] * w[:, 1, j] * w[:, 2, k], (idx[:, 0] * ng + idx[:, 1]) * ng + idx[:, 2],
                       (off - fx) * dx)


def p2g(x, vals, lo, dx, ng, C=None, m=None):
    """Scatter ``vals`` (n, k) to the nodes (ng^3, k) with the points' weights; with ``C`` (n, 3, 3) and ``m`` (n,)
    the affine momentum ``m C (x_i - x_p)`` is added to the first three columns."""
    out = np.zeros((ng ** 3, vals.shape[1]))
    for wt, flat, dpos in stencil(x, lo, dx, ng):
        val = vals * wt[:, None]
        if C is not None:
            val[:, :3] += (m * wt)[:, None] * np.einsum("nij,nj->ni", C, dpos)
        for c in range(vals.shape[1]):
            out[:, c] += np.bincount(flat, val[:, c], ng ** 3)
    return out


def gather_C(x: np.ndarray, vn: np.ndarray, lo: np.ndarray, dx: float, ng: int) -> np.ndarray:
    """The APIC gather of the node velocities ``vn`` (ng^3, 3) at the points ``x`` (n, 3): ``C_p = 4 / dx^2 sum w v_i
    (x_i - x_p)^T`` (n, 3, 3), the engines' G2P gradient; MLS-MPM's stress force on the nodes does ``-V tau : C_p`` of
    work on a node velocity field ``vn`` exactly."""
    C = np.zeros((len(x), 3, 3))
    for wt, flat, dpos in stencil(x, lo, dx, ng):
        C += (4.0 / dx ** 2) * wt[:, None, None] * np.einsum("ni,nj->nij", vn[flat], dpos)
    return C


def grid_ke(mom: np.ndarray, mass: np.ndarray) -> float:
    """``sum |p|^2 / (2 m)`` over the nodes with mass (J)."""
    ok = mass > 0
    return 0.5 * float(((mom[ok] ** 2).sum(1) / mass[ok]).sum())


def grid_ke_v(v: np.ndarray, mass: np.ndarray) -> float:
    """``sum m |v|^2 / 2`` (J)."""
    return 0.5 * float(mass @ (v ** 2).sum(1))


HENCKY = ("sand", "metal", "plasticine")   # Hencky's energy in the engines; each returns F every substep

#: The increment of ``F`` the ledger books under ``stress_at = "trapezoid"`` (module notes), as the fraction of the
#: next P2G's ``dt (C_prev + C) / 2``: "whole" (1, the scheme's: the default), "half" (1/2) and "none" (0: round 69's
#: ledger, unbooked) are the catches of ``tests/test_energy_ledger.py`` and ``free_vibration.py --ledger --owed``.
OWED = {"whole": 1.0, "half": 0.5, "none": 0.0}
TRAP_MODELS = ("jelly", "neo_hookean")   # the models the trapezoid advances (gasp_warp_mpm.trapezoid, mid_stress.py)


def stress_at_of(engine) -> str:
    """The engine's ``stress_at`` (``gasp_core.mpm.stress_at``; "start" where it has no config)."""
    return str(getattr(getattr(engine, "config", None), "stress_at", "start"))


class Stored:
    """Stored energy (and the damage's dissipation) of the engine's ``F``: ``(psi, D)`` in J (module notes), per
    each material's model in both engines (``constitutive.py`` of taichi_mpm and warp_mpm): fixed corotated (jelly);
    Hencky's ``mu |eps|^2 + lam tr(eps)^2 / 2`` of the log strain ``eps`` (sand, Klar et al. 2016; metal,
    plasticine); fixed corotated scaled by the hardening ``h = exp(xi (1 - Jp))`` (snow, Stomakhin et al. 2013);
    the brittle Hencky energy and damage. ``plastic`` False: the ledger before round 56 (fixed corotated for every
    material but brittle, and no point of sand or snow returns), the catch of
    ``tests/test_energy_ledger_plastic.py``."""

    def __init__(self, material, setup, plastic: bool = True):
        self.mat, self.plastic = material, plastic
        self.E, self.nu = material.E, material.nu
        self.lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        self.mu = self.E / (2 * (1 + self.nu))
        self.setup = setup
        self.kind = material.name if plastic or material.name == "brittle" else "jelly"

    def __call__(self, F, Jp, v0, x) -> tuple[float, float]:
        psi, D = self.points(F, Jp, v0, x)
        return float(psi.sum()), float(D.sum())

    def hardening(self, Jp) -> np.ndarray:
        """Snow's hardening ``exp(xi (1 - Jp))`` of ``Jp`` (n,); 1 for every other model."""
        if self.kind != "snow":
            return np.ones(len(Jp))
        return np.exp(self.mat.hardening * (1.0 - np.asarray(Jp, float)))

    def points(self, F, Jp, v0, x) -> tuple[np.ndarray, np.ndarray]:
        """Each point's stored energy and the damage's dissipation (J, (n,) each); ``F`` (n, 3, 3), ``Jp`` (n,) the
        engine's (brittle: the damage, clipped to 1 here; snow: the plastic volume ratio), ``v0`` (n,) m^3."""
        sv = np.linalg.svd(F, compute_uv=False)
        if self.kind in HENCKY:
            eps = np.log(np.maximum(sv, 1e-4))
            return v0 * (self.mu * (eps ** 2).sum(1) + 0.5 * self.lam * eps.sum(1) ** 2), np.zeros(len(v0))
        if self.kind != "brittle":
            psi = self.mu * ((sv - 1) ** 2).sum(1) + 0.5 * self.lam * (sv.prod(1) - 1) ** 2
            return v0 * self.hardening(Jp) * psi, np.zeros(len(v0))
        from brittle_donut_arrest import stresses
        d = np.minimum(Jp, 1.0)
        st, ft, E = self.setup, self.mat.tensile_strength, self.E
        eps, s, sc, _n, W = stresses(F, d, x, self.mat, st.dx, np.asarray(st.domain_lo))
        sf = 2 * E * self.mat.fracture_energy / (ft * float(st.crack_band[0]))
        sfp = ft + W * (sf - ft)
        sd = ft * sfp / ((1 - np.minimum(d, 1)) * (sfp - ft) + ft)
        return 0.5 * v0 * (sc * eps).sum(1), v0 * ft * sd * d / (2 * E)

    def tau(self, F) -> np.ndarray:
        """The Kirchhoff stress (Pa, (n, 3, 3)) of the hyperelastic models the trapezoid advances, the engines'
        (``constitutive.py``): fixed corotated ``2 mu (F - R) F^T + lam J (J - 1) I`` (jelly), neo-Hookean ``mu (F
        F^T - I) + lam log(J) I``."""
        J = np.linalg.det(F)
        if self.kind == "neo_hookean":
            return self.mu * (np.einsum("nij,nkj->nik", F, F) - np.eye(3)) + (self.lam * np.log(J))[:, None, None] \
                * np.eye(3)
        U, _s, Vt = np.linalg.svd(F)
        return 2 * self.mu * np.einsum("nij,nkj->nik", F - U @ Vt, F) + (self.lam * J * (J - 1))[:, None, None] \
            * np.eye(3)

    def returns(self, Jp) -> np.ndarray:
        """The points whose model returns ``F`` this substep (bool, (n,)), from their ``Jp`` before it: brittle
        points broken through (``d >= 1``: the cohesionless sand's Drucker-Prager return); every sand, metal and
        plasticine point (their Hencky return runs each substep, a no-op inside the cone or yield surface); every
        snow point (the singular values' clamp); none for jelly."""
        if self.kind == "brittle":
            return np.asarray(Jp) >= 1.0
        return np.full(len(Jp), self.kind in HENCKY + ("snow",))

    def principal(self, sr, Jp) -> np.ndarray:
        """The principal Kirchhoff stresses (Pa, (n, 3)) of the returned principal stretches ``sr`` (n, 3), the
        engines' stress of the model: Hencky's ``2 mu e + lam tr(e)``, ``e = log sr``; snow's fixed corotated
        ``h (2 mu (s - 1) s + lam J (J - 1))`` with the hardening ``h`` of ``Jp`` (n,) before the return (the
        engines take ``h`` of the ``Jp`` they read, before they update it)."""
        if self.kind == "snow":
            J = sr.prod(1, keepdims=True)
            return self.hardening(Jp)[:, None] * (2 * self.mu * (sr - 1) * sr + self.lam * J * (J - 1))
        er = np.log(np.maximum(sr, 1e-4))
        return 2 * self.mu * er + self.lam * er.sum(1, keepdims=True)


class TaichiSteps:
    """taichi_mpm's substep in pieces (``MPMSolver.substeps(1)``'s order, G2P and P2G unfused; the grid update's
    pieces: ``v4`` after the nodes' update and the touched layer, ``v5`` after the balance's fix and the holds, as
    :class:`WarpSteps` reads them)."""

    def __init__(self, engine):
        self.s = engine.solver
        self.mat = self.s.p_mass.to_numpy() > 0

    def points(self) -> dict:
        s, k = self.s, self.mat
        return {"x": s.x.to_numpy()[k].astype(np.float64), "v": s.v.to_numpy()[k].astype(np.float64),
                "C": s.C.to_numpy()[k].astype(np.float64), "F": s.F.to_numpy()[k].astype(np.float64),
                "Jp": s.Jp.to_numpy()[k].astype(np.float64), "m": s.p_mass.to_numpy()[k].astype(np.float64),
                "v0": s.p_vol.to_numpy()[k].astype(np.float64),
                **({"C_prev": s.C_prev.to_numpy()[k].astype(np.float64)} if s.trap_stress else {})}

    def coefficients(self) -> np.ndarray:
        """The particle contact's ``(k, c, skin)`` of the material points (n, 3; zeros without it: the grid
        contact)."""
        kc = self.s.p_contact.to_numpy().astype(np.float64)
        return kc[self.mat] if len(kc) == len(self.mat) else np.zeros((int(self.mat.sum()), 3))

    def substep(self) -> dict:
        s = self.s
        s.p2g_substep(0, 0)
        acc = s.grid_mv.to_numpy().astype(np.float64).sum(0)
        ng = acc.shape[0]
        acc = acc.reshape(ng ** 3, -1)
        s.grid_nodes()   # MPMSolver.grid_update's pieces (round 68: since b5d3d626 it runs the balance's fix and the
        s.touch_after()  # holds itself, which this ledger then booked in `rule` and ran a second time), as warp_mpm's
        v4 = s.grid_v.to_numpy().astype(np.float64).reshape(-1, 3)
        s.fix_contact()   # nothing without a balance
        s.hold_nodes()
        v5 = s.grid_v.to_numpy().astype(np.float64).reshape(-1, 3)
        s.last_g2p(None)
        fb = acc[:, -1] if s.pc else np.zeros(len(acc))   # the particle contact's friction budget (last channel)
        return {"mom": acc[:, :3], "mass": acc[:, 3], "v4": v4, "v5": v5, "budget": fb}


class WarpSteps:
    """warp_mpm's substep: its recorded launches in ``_substeps``' order, the grid read after P2G, after the grid
    update and before G2P."""

    def __init__(self, engine):
        self.e = engine
        keys = [getattr(getattr(c, "kernel", None), "key", "") for c in engine._launches]
        self.i_update = next(i for i, k in enumerate(keys) if k.endswith("__grid_update"))
        self.i_g2p = next(i for i, k in enumerate(keys) if k.endswith("__g2p"))
        self.mat = engine.p_mass.numpy() > 0

    def points(self) -> dict:
        e, k = self.e, self.mat
        return {"x": e.x.numpy()[k].astype(np.float64), "v": e.v.numpy()[k].astype(np.float64),
                "C": e.C.numpy()[k].astype(np.float64), "F": e.F.numpy()[k].astype(np.float64),
                "Jp": e.Jp.numpy()[k].astype(np.float64), "m": e.p_mass.numpy()[k].astype(np.float64),
                "v0": e.p_vol.numpy()[k].astype(np.float64),
                **({"C_prev": e.trap_arrays()[0].numpy()[k].astype(np.float64)} if e.trap_on() else {})}

    def coefficients(self) -> np.ndarray:
        """The particle contact's ``(k, c, skin)`` of the material points (n, 3; zeros without planes)."""
        kc = self.e.p_contact.numpy().astype(np.float64)
        return kc[self.mat] if len(kc) == len(self.mat) else np.zeros((int(self.mat.sum()), 3))

    def substep(self) -> dict:
        e, out = self.e, {}
        assert e.visc is None and e._tick is None
        e.trial_passes()   # stress_at "trapezoid": its trial substeps, not booked (gasp_warp_mpm.trapezoid)
        for cmd in e._pre:
            cmd.launch()
        for i, cmd in enumerate(e._launches):
            if i == self.i_g2p:
                out["v5"] = e.grid_v.numpy().astype(np.float64).copy()
            cmd.launch()
            if i == 0:
                acc = e.grid_mv.numpy().astype(np.float64).copy()
                out["mom"], out["mass"] = acc[:, :3], acc[:, 3]
                fb = e.grid_fb.numpy().astype(np.float64)
                out["budget"] = fb.copy() if len(fb) == len(acc) else np.zeros(len(acc))
            if i == self.i_update:
                out["v4"] = e.grid_v.numpy().astype(np.float64).copy()
        return out


def steps_of(engine):
    """The engine's stepper (:class:`TaichiSteps` or :class:`WarpSteps`)."""
    return TaichiSteps(engine) if hasattr(engine, "solver") else WarpSteps(engine)


class Ledger:
    """The per-substep ledger of one engine run (module notes). ``setup``: the run's (nominal) scene, whose gravity and
    material the ledger uses (a broken engine may differ; the contact's ``(k, c, skin)`` are the engine's own);
    ``engine``: built from it or a variant; ``ground``: ``(height, friction)`` of its ground plane or None. Only the
    ground's particle contact is booked: a scene with walls' or colliders' particle contact would put their impulses
    in the stress's term (the family's scenes have a ground alone). ``plastic``: :class:`Stored`'s (False: the
    ledger before round 56); ``held_end``: the held nodes' work at their end velocity (module notes; None: under the
    grid contact). ``owed``: the share of ``F``'s owed increment booked in ``psi`` (a key of :data:`OWED`; None: the
    engine's scheme's, "whole" under ``stress_at = "trapezoid"``, else nothing; module notes); ``gradient``: the
    trapezoid's ``gradient`` sink booked (:meth:`gradient`; False: the catch, round 69's ledger). Raises
    ``AssertionError`` on a warp_mpm engine with a viscous material or a time table (their steps are not split
    here)."""

    def __init__(self, setup, engine, material, ground=(0.0, 0.0), plastic: bool = True, held_end=None,
                 owed: str | None = None, gradient: bool = True):
        from gasp_core.mpm.contact import contact_model
        from gasp_core.mpm.grid_origin import ground_on_node
        setup = ground_on_node(setup)   # the engines' grid: a ground on a node layer under the grid contact (round 56)
        self.setup, self.steps = setup, steps_of(engine)
        self.dt = float(engine.dt)
        self.lo, self.dx, self.ng = np.asarray(setup.domain_lo, float), float(setup.dx), int(setup.n_grid)
        self.g = np.asarray(setup.gravity, float)
        self.stored = Stored(material, setup, plastic)
        trap = stress_at_of(engine) == "trapezoid" and material.name in TRAP_MODELS
        self.owed = (owed or "whole") if trap else "none"
        assert self.owed in OWED, self.owed
        self.trap_gradient = trap and gradient
        self.passes = int(getattr(getattr(engine, "config", None), "stress_passes", 1))
        self.ground = ground if contact_model(setup) == "particle" else None
        self.held_end = contact_model(setup) != "particle" if held_end is None else held_end
        self.kc = self.steps.coefficients()   # the engine's own (k, c, skin) per point, its order
        self.rows, self.mass_err = [], 0.0
        self.E = self.energy(self.steps.points())

    def contact(self, p) -> tuple[np.ndarray, float]:
        """The points' contact impulses (n, 3) and the springs' energy ``sum k depth^2 / 2`` (J)."""
        imp = np.zeros_like(p["v"])
        if self.ground is None:
            return imp, 0.0
        k, c, s = self.kc.T
        depth = self.ground[0] + s - p["x"][:, 2]
        on = depth > 0
        imp[:, 2] = np.where(on, np.maximum(0.0, self.dt * (k * depth - c * p["v"][:, 2])), 0.0)
        return imp, 0.5 * float((k * np.where(on, depth, 0.0) ** 2).sum())

    def owed_F(self, p) -> np.ndarray:
        """The points' ``F`` (n, 3, 3) with the increment the scheme still owes booked (module notes): ``(I + w dt
        (C_prev + C) / 2) F``, ``w`` :data:`OWED`'s share (1 under the trapezoid: the next P2G's ``F``); ``F`` itself
        where nothing is owed."""
        F = p["F"].reshape(-1, 3, 3)
        w = OWED[self.owed]
        if w == 0.0:
            return F
        Ca = 0.5 * (p["C_prev"].reshape(-1, 3, 3) + p["C"].reshape(-1, 3, 3))
        return np.einsum("nij,njk->nik", np.eye(3) + (w * self.dt) * Ca, F)

    def energy(self, p) -> dict:
        """The state's energies (J): ``Ep``, ``kinetic`` (no affine part), ``psi`` (of :meth:`owed_F`), ``D``, ``U``,
        ``PE``."""
        m = p["m"]
        kin = 0.5 * float(m @ (p["v"] ** 2).sum(1))
        aff = 0.5 * float(m @ (p["C"] ** 2).sum((1, 2))) * self.dx ** 2 / 4
        psi, D = self.stored(self.owed_F(p), p["Jp"], p["v0"], p["x"])
        return {"Ep": kin + aff, "kinetic": kin, "psi": psi, "D": D, "U": self.contact(p)[1],
                "PE": -float(m @ (p["x"] @ self.g))}

    def plastic(self, p0: dict, p1: dict, trial: bool = False) -> float:
        """The plastic work of a substep (J), over the points whose model returns (:meth:`Stored.returns`, from
        ``p0``'s ``Jp``): the returned Kirchhoff stress's work on the return's log strain, ``V0 sum_i s_i (e_t,i -
        e_i)`` (``e_t`` the trial ``F = (I + dt C) F``'s principal log strains, ``p0``'s and the engines' P2G; ``e`` the
        returned ``F``'s, ``p1``'s, in the trial's principal frame; ``s`` the model's stress of the returned ``F``,
        :meth:`Stored.principal`), the dissipation of the backward-Euler return. The same form for the Hencky
        return (sand's Drucker-Prager, metal's von Mises) and snow's clamp of the singular values (its stress with
        the hardening of ``p0``'s ``Jp``, the engines'): the explicit step's stress of the substep is the returned
        one, so the kinetic energy the stress takes for a strain ``dE`` is ``s : dE``, and a point held on its yield
        surface (or clamp) loses ``s : (e_t - e)`` to the return; the stored energy of the trial less the returned
        one would add ``(e_t - e) : A : (e_t - e) / 2``, a part of the trial the stress never paid for.
        ``trial``: that difference instead (at the same ``Jp``, ``p0``'s), which also counts it (a point broken
        through at the apex, ``s = 0``, stretched by its ``dt C``: 9.0 J on the brittle donut, round 53). Snow's
        hardening, the stored energy's change with ``Jp`` at the returned ``F``, is :meth:`hardening`'s. Zero for
        jelly."""
        on = self.stored.returns(p0["Jp"])
        if not on.any():
            return 0.0
        F0, C0 = p0["F"].reshape(-1, 3, 3)[on], p0["C"].reshape(-1, 3, 3)[on]
        Ft, Fr = np.einsum("nij,njk->nik", np.eye(3) + self.dt * C0, F0), p1["F"].reshape(-1, 3, 3)[on]
        jp, v0, x = p0["Jp"][on], p1["v0"][on], p1["x"][on]
        if trial:
            return float(self.stored.points(Ft, jp, v0, x)[0].sum() - self.stored.points(Fr, jp, v0, x)[0].sum())
        U, sv, Vt = np.linalg.svd(Ft)
        et = np.log(np.maximum(sv, 1e-4))
        sr = np.einsum("nji,njk,nik->ni", U, Fr, Vt)   # diag(U^T F_r V): the returned stretches, the trial's frame
        er = np.log(np.maximum(sr, 1e-4))
        return float(v0 @ (self.stored.principal(sr, jp) * (et - er)).sum(1))

    def hardening(self, p0: dict, p1: dict) -> float:
        """Snow's hardening term of a substep (J): its stored energy at the returned ``F`` (``p1``'s) with the
        hardening of ``p0``'s ``Jp`` less that with ``p1``'s, ``V0 (h(Jp_0) - h(Jp_1)) psi_c(F)`` (``psi_c`` the
        fixed corotated energy, :class:`Stored`). No force does work for it: a point compressed past ``theta_c``
        (``Jp`` falls, ``h`` rises) stores energy no stress paid for, a gain (negative); one stretched past
        ``theta_s`` loses it. Stomakhin et al. 2013's hardening is not derived from a potential in ``Jp``, so the
        ledger books it as its own term. Zero for every other model."""
        st = self.stored
        if st.kind != "snow":
            return 0.0
        F1, v0, x = p1["F"].reshape(-1, 3, 3), p1["v0"], p1["x"]
        return float(st.points(F1, p0["Jp"], v0, x)[0].sum() - st.points(F1, p1["Jp"], v0, x)[0].sum())

    def gradient(self, Ct: np.ndarray, Cb: np.ndarray, p1: dict) -> float:
        """The trapezoid's ``gradient`` sink of a substep (J; module notes): ``dt sum V tau_s : ((C~ - C_prev) + (C^ -
        C)) / 2``, ``C~`` and ``C^`` (n, 3, 3) the gathers at the points of this substep's free P2G velocity and of
        the grid's velocity after the P2G's impulses (before the grid's rule and friction), ``C_prev`` (``p1``'s) the
        ``C`` this substep's P2G read and ``C`` the one G2P gave, ``tau_s`` the stress it scattered, ``tau(H F) H^-T`` of ``p1``'s ``F`` with ``H = I +
        dt/2 C_prev`` (one pass; with more, ``C_prev`` and ``C`` averaged: the converged guess). Zero but under the
        trapezoid."""
        if not self.trap_gradient:
            return 0.0
        F, C0, C1 = (p1[k].reshape(-1, 3, 3) for k in ("F", "C_prev", "C"))
        H = np.eye(3) + 0.5 * self.dt * (C0 if self.passes == 1 else 0.5 * (C0 + C1))
        tau = self.stored.tau(np.einsum("nij,njk->nik", H, F))
        ts = np.einsum("nij,nkj->nik", tau, np.linalg.inv(H))   # tau H^-T
        return 0.5 * self.dt * float(np.einsum("n,nij,nij->", p1["v0"], ts, (Ct - C0) + (Cb - C1)))

    def step(self) -> dict:
        """One substep; appends and returns its row (module notes; ``E`` the total after it, ``mass_err`` the
        NumPy P2G's largest node-mass error over the engine's total mass)."""
        p0, E0 = self.steps.points(), self.E
        m = p0["m"]
        imp, _u = self.contact(p0)
        free = p2g(p0["x"], np.c_[m[:, None] * p0["v"], m], self.lo, self.dx, self.ng, C=p0["C"], m=m)
        cont = p2g(p0["x"], imp, self.lo, self.dx, self.ng) if imp.any() else np.zeros((self.ng ** 3, 3))
        g = self.steps.substep()
        mass = g["mass"]
        self.mass_err = max(self.mass_err, float(np.abs(free[:, 3] - mass).max() / mass.sum()))
        ok = mass > 0
        inv = np.where(ok, 1.0 / np.where(ok, mass, 1.0), 0.0)[:, None]
        va = free[:, :3] * inv                                      # the free P2G's velocity
        Ct = gather_C(p0["x"], va, self.lo, self.dx, self.ng) if self.trap_gradient else None   # its round trip
        stress = g["mom"] - free[:, :3] - cont                      # the engine's momentum less the free and contact
        vg = g["mom"] * inv + np.where(ok[:, None], self.dt * self.g, 0.0)
        mid = 0.5 * (va + vg)                                       # each impulse's work at the node's mean velocity
        K0, K3 = grid_ke(free[:, :3], mass), grid_ke_v(vg, mass)
        Wc, Ws = float((cont * mid).sum()), float((stress * mid).sum())
        Wg = float((mass[:, None] * self.dt * self.g * mid).sum())
        moved = 0.0   # the grid contact's held nodes: each impulse's work at the node's end velocity (round 56)
        if self.held_end:
            h = ok & (np.abs(g["v4"] - vg).max(1) > 1e-5 + 1e-4 * np.abs(vg).max(1))
            end = g["v4"][h] - mid[h]
            dW = [float((cont[h] * end).sum()), float((stress[h] * end).sum()),
                  float((mass[h, None] * self.dt * self.g * end).sum())]
            Wc, Ws, Wg, moved = Wc + dW[0], Ws + dW[1], Wg + dW[2], sum(dW)
        K4, K5 = grid_ke_v(g["v4"], mass), grid_ke_v(g["v5"], mass)
        fric = K3 - grid_ke_v(node_friction(vg, np.where(ok, mass, 1.0), g["budget"]), mass)
        p1 = self.steps.points()
        E1 = self.energy(p1)
        d = {k: E1[k] - E0[k] for k in ("psi", "D", "U", "PE")}
        Cb = gather_C(p0["x"], vg, self.lo, self.dx, self.ng) if self.trap_gradient else None   # after the kick
        plastic, hard, grad = self.plastic(p0, p1), self.hardening(p0, p1), self.gradient(Ct, Cb, p1)
        row = {"p2g": E0["Ep"] - K0, "contact": -Wc - d["U"], "rule": K3 - K4 - fric + moved, "friction": fric,
               "balance": K4 - K5,
               "g2p": K5 - E1["Ep"], "plastic": plastic, "hardening": hard, "gradient": grad,
               "elastic": Ws + d["psi"] + d["D"] + plastic + hard + grad,
               "gravity": Wg + d["PE"],
               "mid_err": K3 - K0 - Wc - Ws - Wg + moved,
               "total": sum(E1[k] for k in ("Ep", "psi", "D", "U", "PE")), **E1}
        self.E = E1
        self.rows.append(row)
        return row


def total(e: dict) -> float:
    """``Ep + psi + D + U + PE`` of :meth:`Ledger.energy`'s dict (J)."""
    return sum(e[k] for k in ("Ep", "psi", "D", "U", "PE"))
