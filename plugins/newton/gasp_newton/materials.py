"""GASP materials as Newton's per-particle implicit-MPM parameters (``model.mpm.*``), NumPy only.

Newton's ``SolverImplicitMPM`` has one constitutive model for every particle (Newton 1.8.0,
``newton/_src/solvers/implicit_mpm``): Hencky (logarithmic) isotropic elasticity with Young's
modulus ``E`` and Poisson ratio ``nu`` (``USE_HENCKY_STRAIN_MEASURE = True`` in
``implicit_mpm_solver_kernels.py``), bounded by a yield surface in stress space
(``rheology_solver_kernels.YieldParamVec``): a pressure range ``[-tensile_yield_ratio * p_max, p_max]``
(``p_max = yield_pressure``), a deviatoric bound ``s = yield_stress + friction * (pressure terms)`` on the
Frobenius norm of the deviatoric stress, ``hardening`` scaling both bounds by
``sinh(-hardening log Jp)``, and a ``viscosity``. A GASP material is a choice of those numbers:

============  ===================================================================================
material      Newton parameters (source of the mapping)
============  ===================================================================================
jelly         E, nu; no yield (``yield_pressure`` 1e15, ``tensile_yield_ratio`` 1, Newton's elastic
              beam example ``example_mpm_beam_twist.py``). Hencky, not fixed-corotated elasticity:
              the two agree to first order in the strain (same E, nu), differ at large strain.
neo_hookean   as jelly (Newton has no neo-Hookean energy; same small-strain response).
sand          E, nu; cohesionless Drucker-Prager: ``tensile_yield_ratio`` 0, ``friction`` =
              ``sqrt(3) a`` with Klar et al. 2016's ``a = sqrt(2/3) 2 sin(phi) / (3 - sin(phi))``
              (docs/mpm.md's sand), i.e. ``2 sqrt(2) sin(phi) / (3 - sin(phi))``: 0.669 at phi = 35 deg
              (Newton's granular example uses 0.68). The factor sqrt(3) takes Klar's
              ``|dev tau| <= a tr(tau)`` to Newton's normal coordinate ``tr(tau) / sqrt(3)``.
metal         E, nu; von Mises: ``yield_stress`` = sqrt(2/3) Y on the deviatoric norm (the radius of
              ``gasp_core.mpm.materials.VON_MISES_RADIUS``), ``friction`` 0, no pressure bound.
plasticine    as metal (Newton has no softening law: ``Material.softening`` is not used).
snow          E, nu; Stomakhin et al. 2013's critical strains as stress bounds: ``yield_pressure`` =
              K theta_c (compressive), ``tensile_yield_ratio`` = theta_s / theta_c, ``yield_stress``
              = 2 mu theta_s, ``hardening`` = xi (Newton hardens the bounds with
              ``sinh(-xi log Jp)``, as the snow example ``example_mpm_snow_ball.py``; Stomakhin
              scales the moduli by ``exp(xi (1 - Jp))`` instead). An approximation of the same
              material, not the same model.
liquid        E, nu as a compressible fluid: ``yield_stress`` 0 and ``friction`` 0 (no shear stress),
              ``tensile_yield_ratio`` 1 (Newton's dam-break example ``example_mpm_water_dam_break.py``).
============  ===================================================================================

``rigid`` is refused by capability.
"""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

#: Materials this module maps (``Capabilities.materials`` of the engine).
MATERIALS = frozenset({"jelly", "neo_hookean", "sand", "metal", "plasticine", "snow", "liquid"})

#: Newton's per-particle arrays set here, in ``model.mpm`` (``SolverImplicitMPM.register_custom_attributes``).
FIELDS = ("young_modulus", "poisson_ratio", "damping", "friction", "yield_pressure", "tensile_yield_ratio",
          "yield_stress", "hardening", "viscosity")

#: A yield pressure no scene reaches, Pa (Newton's own default for "no bound").
NO_BOUND = 1.0e15


def sand_friction(friction_angle_deg: float) -> float:
    """Newton's friction coefficient for a Drucker-Prager sand of friction angle ``phi`` (degrees).

    ``sqrt(3) a`` with Klar et al. 2016's ``a = sqrt(2/3) 2 sin(phi) / (3 - sin(phi))``.
    """
    s = math.sin(math.radians(friction_angle_deg))
    return 2.0 * math.sqrt(2.0) * s / (3.0 - s)


def material_row(m, damping: float = 0.0) -> dict[str, float]:
    """Newton's parameters (``FIELDS``) for one GASP ``Material`` ``m`` (see the module table).

    Parameters
    ----------
    m : gasp_core.seam.Material
        ``name`` in :data:`MATERIALS`; ``E`` (Pa), ``nu``, ``yield_stress`` (Pa), ``friction_angle``
        (deg), ``hardening``, ``theta_c``, ``theta_s`` as the material uses them.
    damping : float
        Newton's elastic damping relaxation time, s (the engine option ``damping``).

    Raises
    ------
    ValueError
        ``m.name`` not in :data:`MATERIALS` (the core refuses it by capability before).
    """
    row = {"young_modulus": m.E, "poisson_ratio": m.nu, "damping": damping, "friction": 0.5,
           "yield_pressure": NO_BOUND, "tensile_yield_ratio": 1.0, "yield_stress": 0.0, "hardening": 0.0,
           "viscosity": 0.0}
    if m.name in ("jelly", "neo_hookean"):
        return row
    if m.name == "sand":
        return {**row, "friction": sand_friction(m.friction_angle), "tensile_yield_ratio": 0.0}
    if m.name in ("metal", "plasticine"):
        return {**row, "friction": 0.0, "yield_stress": math.sqrt(2.0 / 3.0) * m.yield_stress}
    if m.name == "snow":
        return {**row, "friction": 0.0, "yield_pressure": m.K * m.theta_c,
                "tensile_yield_ratio": m.theta_s / m.theta_c, "yield_stress": 2.0 * m.mu * m.theta_s,
                "hardening": m.hardening}
    if m.name == "liquid":
        return {**row, "friction": 0.0}
    raise ValueError(f"material {m.name!r} has no Newton mapping (expected one of {sorted(MATERIALS)})")


def particle_parameters(materials: Sequence, body_id: np.ndarray, damping: float = 0.0) -> dict[str, np.ndarray]:
    """Per-particle arrays of :data:`FIELDS`, shape (n,), float32, from each point's body material."""
    rows = [material_row(m, damping) for m in materials]
    ids = np.asarray(body_id)
    return {f: np.array([r[f] for r in rows], dtype=np.float32)[ids] for f in FIELDS}
