"""The particle-grid transfer option of the grid (MPM) engines: the APIC/FLIP blend (``docs/mpm.md``, "Transfers").

APIC (Jiang et al. 2015) sets a point's velocity to the grid velocity gathered at it, ``v_p <- v_PIC^{n+1}``,
which filters the velocity every substep and loses kinetic energy (``docs/dissipation.md`` measures how much).
AFLIP (Fei, Guo, Wu, Huang & Gao 2021, "Revisiting integration in the material point method: a scheme for
easier separation and less dissipation", ACM TOG 40(4) 109, Sec. 4) keeps the point's own velocity and adds
the grid's velocity change, blended with APIC by ``alpha`` (the option :data:`FLIP`):

    ``v_p^{n+1} = v_PIC^{n+1} + alpha (v_p^n - v_PIC^n)``,  ``C_p^{n+1}`` APIC's,  ``x_p^{n+1} = x_p^n + dt v_PIC^{n+1}``

with ``v_PIC^{n+1} = sum_i w_ip v_i^{n+1}`` (the grid velocity after forces and boundaries) and
``v_PIC^n = sum_i w_ip v_i^n``, ``v_i^n`` the grid velocity of the APIC momentum alone,
``sum_p w_ip m_p (v_p + C_p (x_i - x_p)) / m_i`` (no stress, no gravity). ``alpha = 0`` is APIC exactly;
positions move with the grid velocity (AFLIP's position update; ASFLIP's separation term is not used).
Not the default: it keeps more energy but gives up APIC's exact angular momentum (``docs/dissipation.md``).

**The transfer's damping as a rate** (the option :data:`TRANSFER_DAMPING`, round 56, ``docs/dissipation.md``): an
APIC round trip removes a point's non-affine velocity every substep, so its damping per second grows as ``1 / dt``
and a run does not converge as the step shrinks (the conformance ``bounce_hertz`` ball's restitution 0.874, 0.840,
0.795, 0.747, 0.690 at 7, 14, 28, 56, 112 substeps a frame). Under ``"rate"`` (the default) a substep shorter than the
reference step (the step at ``cfl`` :data:`gasp_core.mpm.substeps.CFL` with the run's other settings, ``n_ref``
substeps a frame) keeps ``alpha = 1 - n_ref / n`` of the non-affine part, so ``(1 - dt / dt_ref)^(t / dt)``
tends to ``exp(-t / dt_ref)``: the damping per second of the reference step at every shorter step (0.874, 0.867,
0.862, 0.861, 0.860). At the reference step or a longer one ``alpha = 0``: APIC exactly, as before. ``"step"``:
APIC's damping per substep, whatever the step (before round 56).
"""
from __future__ import annotations

from gasp_core.seam.options import Option

#: Engine option ``flip`` of the MPM engines: the AFLIP blend ``alpha`` (0 = APIC, the default).
FLIP = Option(
    "flip", 0.0, "AFLIP blend alpha (Fei et al. 2021): v_p <- v_PIC(new) + alpha (v_p - v_PIC(old)); 0 = APIC "
    "(most dissipative, smoothest), 0.95-0.99 keeps most of the kinetic energy the transfers lose "
    "(docs/dissipation.md)", kind="number", lo=0.0, hi=1.0)

#: The transfer's damping: ``"rate"`` (per second, that of the step at cfl 0.4) or ``"step"`` (APIC's, per substep).
TRANSFER_DAMPINGS = ("rate", "step")

#: Engine option ``transfer_damping`` of the MPM engines (module notes).
TRANSFER_DAMPING = Option(
    "transfer_damping", "rate", "the transfers' damping: 'rate' keeps APIC's damping per second at the step of cfl "
    "0.4 when the substep is shorter (AFLIP alpha = 1 - n_ref / n), so a shorter step converges instead of damping "
    "more; 'step': APIC's damping every substep, whatever its length (docs/dissipation.md)", kind="str",
    choices=TRANSFER_DAMPINGS)


def blend_alpha(flip: float, damping: str, n_substeps: int, n_ref: int | None) -> float:
    """The AFLIP blend a run takes (module notes): ``max(flip, 1 - n_ref / n_substeps)`` under ``"rate"``, ``flip``
    under ``"step"`` or where there is no reference step (``n_ref`` None).

    Parameters: ``flip`` the option's blend in [0, 1]; ``damping`` one of :data:`TRANSFER_DAMPINGS`;
    ``n_substeps`` the run's substeps a frame (>= 1); ``n_ref`` the reference step's substeps a frame.
    Returns a float in [0, 1]. Raises ``ValueError`` for an unknown ``damping``."""
    if damping not in TRANSFER_DAMPINGS:
        raise ValueError(f"transfer_damping: expected one of {TRANSFER_DAMPINGS}, got {damping!r}")
    if damping == "step" or n_ref is None or n_substeps <= n_ref:
        return float(flip)
    return max(float(flip), 1.0 - n_ref / n_substeps)
