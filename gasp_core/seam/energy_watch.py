"""The energy watchdog: a run that gains energy is stopped as a blow-up (issue 66 item 6, "No energy is gained").

:func:`gasp_core.seam.runner.check_state` stops non-finite values and points out of the domain, the grid engines
points faster than a cell a substep. An engine that gains energy slowly passes both: in round 59 a rigid box under a
snow ball flew off at 44 m/s at 400 substeps a frame (AFLIP's old velocity, ``gasp_core.mpm.fields``) and its points
left the grid slower than a cell a substep, counted as ``left_domain``: a silent wrong answer. The watchdog reads only
what the runner has, so it holds for every engine.

**The energy of a frame** (joules), over the counted points (below), each of mass ``m = rho p_vol`` (its body's
material; passive points weigh 0):

- kinetic: ``sum m |x_k - x_{k-1}|^2 / (2 frame_dt^2)``, the frame's mean velocity. By Jensen's inequality the
  frame's mean kinetic energy is at least this: the watchdog can only under-report.
- potential: ``sum m |g| h`` at the frame's midpoint ``(x_k + x_{k-1}) / 2``, with ``h = -g^ . (x - domain_lo)
  + span`` the height above the domain's lowest corner along gravity (``span = sum |g^_i| (hi_i - lo_i)``;
  ``h >= 0`` in the domain). The midpoint pairs with the mean velocity: a ballistic point's energy then reads
  exactly ``-m |g|^2 frame_dt^2 / 8`` from its start, whatever its speed (the end position would read
  ``+- m |g| v frame_dt / 2``, a thrown body's false gain).

``E0`` is the start's: ``sum m |v|^2 / 2`` from ``setup.v`` plus the potential at ``setup.x``. The scene's energy
scale is ``S = KE0 + sum m |g| span``: all the energy it has and all gravity could ever give it inside the domain.
A frame with ``(E - E0) / S > ALLOWANCE`` raises :class:`~gasp_core.errors.EngineDivergence` with :data:`CAUSE_ENERGY`.

**The allowance**, :data:`ALLOWANCE` = 0.5 of ``S``: a gain of half of all the energy the scene has and could get from
gravity in its domain is not a roundoff or a modelling choice; below it the watchdog's own errors (a kink inside a
frame: at most ``m |g| v frame_dt / 2`` over the ``m v^2 / 2`` Jensen takes off) and what a start can release that
``E0`` does not count (a point set a little inside a support, pushed out by the particle contact's penalty) stay
far below (docs/mpm.md "Round 60: the energy watchdog": the largest ratio measured on a family of scenes). A defect
that makes energy is a feedback that grows from substep to substep (round 59: the box from rest to 44 m/s): a
larger or smaller fraction moves the stop by a frame or two, not whether it comes.

**Points that leave the grid** (engines with the feature ``left_domain``, :func:`gasp_core.seam.runner.left_grid`)
freeze where they are: from the frame they leave, their energy that frame (a lower bound, they froze inside it) is
taken off ``E0`` and they are counted no more. Energies are non-negative, so dropping a point only lowers ``E``.
A resumed run starts from the frame-0 ``E0``, its points out of the grid at the resume dropped with nothing taken
off (``E0`` only larger: only under-reports).

**Scenes not watched** (:func:`unwatched`, said in ``run.json`` ``energy.skipped``): sources of work the runner
cannot account for, impulses (``setup.impulses``), force fields (wind, attractors: ``setup.forces``) and moving
colliders (a prescribed motion pushes without bound), and a scene without gravity nor initial motion (``S`` = 0).
Static colliders, the ground, walls and fixed regions do no work (their points or surfaces are still) and are
watched. A body that starts with stored elastic energy (set up compressed) could release it unnoticed by ``E0``;
every setup GASP builds starts at rest in its rest shape (brittle bodies too: the energy a crack releases was first
put in by the motion ``E0`` counts).
"""
from __future__ import annotations

import numpy as np

from gasp_core.errors import EngineDivergence
from gasp_core.seam.setup import SimSetup

#: The likely cause of a run that gains energy (:class:`EnergyWatch`).
CAUSE_ENERGY = ("energy gained: a contact or transfer defect that makes motion (a contact impulse or a velocity "
                "blend feeding back), or a time step too large for the material")
#: The gain over the start's energy that stops a run, a fraction of the scene's energy scale (module notes).
ALLOWANCE = 0.5


def unwatched(setup: SimSetup) -> str | None:
    """Why the scene's energy is not watched, in words (sources of work the runner cannot bound, or no energy
    scale), or None when it is (module notes)."""
    why = [name for name, on in (("impulses", bool(setup.impulses)), ("force fields", bool(setup.forces)),
                                 ("moving colliders", any(c.moving for c in setup.colliders))) if on]
    if why:
        return "work from " + ", ".join(why)
    if not (np.any(setup.gravity) or np.any(setup.v[setup.p_mass > 0])):
        return "no gravity and no initial motion"
    return None


class EnergyWatch:
    """One run's energy against its start's (module notes): :meth:`check` after every simulated frame.

    Parameters
    ----------
    setup : SimSetup
    out_at_start : ndarray, shape (n,), bool, optional
        The points already out of the grid before the first frame simulated here (a resumed run's restored state,
        engines with the feature ``left_domain``: :func:`gasp_core.seam.runner.left_grid`); they are not counted.

    Attributes
    ----------
    skipped : str or None
        :func:`unwatched`'s reason; :meth:`check` then does nothing.
    largest : float
        The largest ``(E - E0) / S`` seen (``-inf`` before the first frame).
    """

    def __init__(self, setup: SimSetup, out_at_start: np.ndarray | None = None):
        self.skipped = unwatched(setup)
        self.largest = -np.inf
        self.frame_dt = float(setup.frame_dt)
        self.m = setup.p_mass
        g = np.asarray(setup.gravity, np.float64)
        self.g_abs = float(np.linalg.norm(g))
        self.up = -g / self.g_abs if self.g_abs > 0 else np.zeros(3)
        span = float(np.abs(self.up) @ (setup.domain_hi - setup.domain_lo))
        self.h0 = span - float(self.up @ setup.domain_lo)   # h(x) = up . x + h0 >= 0 in the domain
        ke0 = 0.5 * float(self.m @ np.einsum("ij,ij->i", setup.v, setup.v))
        self.scale = ke0 + float(self.m.sum()) * self.g_abs * span
        self.e0 = ke0 + float(self.potential(setup.x).sum())
        self.counted = np.ones(len(setup.x), bool) if out_at_start is None else ~np.asarray(out_at_start, bool)

    def potential(self, x: np.ndarray) -> np.ndarray:
        """Each point's potential energy ``m |g| h(x)``, J, shape (n,) (module notes)."""
        return self.m * self.g_abs * (x @ self.up + self.h0)

    def energies(self, x_prev: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Each point's energy over the frame from ``x_prev`` to ``x`` (both (n, 3), m), J, shape (n,): the mean
        velocity's kinetic energy plus the midpoint's potential (module notes)."""
        u = (x - x_prev) / self.frame_dt
        return 0.5 * self.m * np.einsum("ij,ij->i", u, u) + self.potential(0.5 * (x + x_prev))

    def check(self, frame: int, x_prev: np.ndarray, x: np.ndarray, out: np.ndarray | None = None) -> None:
        """Compare frame ``frame``'s energy (positions ``x_prev`` before it, ``x`` after, (n, 3), m) with the start's;
        then drop the points out of the grid after it (``out``, shape (n,), bool: :func:`gasp_core.seam.runner.left_grid`
        of ``x``, engines with the feature ``left_domain``; None: none drops out).

        Raises
        ------
        EngineDivergence
            ``(E - E0) / S`` over :data:`ALLOWANCE`, with :data:`CAUSE_ENERGY`.
        """
        if self.skipped is not None:
            return
        e = self.energies(x_prev, x)
        gain = float(e[self.counted].sum()) - self.e0
        ratio = gain / self.scale
        self.largest = max(self.largest, ratio)
        if ratio > ALLOWANCE:
            fast = int(np.argmax(np.where(self.counted, np.einsum("ij,ij->i", x - x_prev, x - x_prev), -1.0)))
            raise EngineDivergence(
                f"the scene gained {gain:.4g} J over its start's energy {self.e0:.4g} J, {ratio:.3g} of its energy "
                f"scale {self.scale:.4g} J (allowance {ALLOWANCE:g}); fastest point {fast} at "
                f"{np.linalg.norm(x[fast] - x_prev[fast]) / self.frame_dt:.3g} m/s", frame, CAUSE_ENERGY)
        if out is not None:
            gone = self.counted & out
            if gone.any():
                self.e0 -= float(e[gone].sum())
                self.counted &= ~gone

    def record(self) -> dict:
        """``run.json``'s ``energy``: ``largest_gain`` (the largest ``(E - E0) / S`` seen, None before a frame or
        when skipped), ``allowance``, ``scale_J`` and ``skipped`` (the reason, or None)."""
        seen = self.skipped is None and np.isfinite(self.largest)
        return {"largest_gain": float(self.largest) if seen else None, "allowance": ALLOWANCE,
                "scale_J": float(self.scale), "skipped": self.skipped}

