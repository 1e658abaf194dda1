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
"""
from __future__ import annotations

from gasp_core.seam.options import Option

#: Engine option ``flip`` of the MPM engines: the AFLIP blend ``alpha`` (0 = APIC, the default).
FLIP = Option(
    "flip", 0.0, "AFLIP blend alpha (Fei et al. 2021): v_p <- v_PIC(new) + alpha (v_p - v_PIC(old)); 0 = APIC "
    "(most dissipative, smoothest), 0.95-0.99 keeps most of the kinetic energy the transfers lose "
    "(docs/dissipation.md)", kind="number", lo=0.0, hi=1.0)
