"""Brittle substances at their handbook stiffness, strength and fracture energy (issue 66 item 5, ``docs/fracture.md``
"Stiff brittle bodies: fragments"), beside the restitution table (:data:`gasp_core.mpm.restitution.SUBSTANCES`).

A ``brittle`` material may name one (``[object.material] name = "brittle"``, ``substance = "porcelain"``): its ``E``,
``nu``, ``rho``, ``tensile_strength`` and ``fracture_energy`` are taken from :data:`BRITTLE_SUBSTANCES` unless the
scene gives them (:func:`substance_values`).

The figures are *typical values* of each class, not one measured specimen: a handbook gives ranges (quoted in each
row's ``source``), and a cup, a pane or a beam of the same name may sit anywhere in them. Where a source gives the
fracture toughness ``K_Ic`` rather than the fracture energy, ``G_f = K_Ic^2 / E`` (Irwin's relation, plane stress;
the energy to open a unit area of crack, J/m^2).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BrittleSubstance:
    """One row of :data:`BRITTLE_SUBSTANCES`.

    Attributes
    ----------
    E : float
        Young's modulus, Pa.
    nu : float
        Poisson's ratio.
    rho : float
        Density, kg/m^3.
    tensile_strength : float
        ``f_t``, Pa.
    fracture_energy : float
        ``G_f``, J/m^2.
    source : str
        Where the figures come from, with the ranges quoted there.
    """

    E: float
    nu: float
    rho: float
    tensile_strength: float
    fracture_energy: float
    source: str


#: Handbook figures (module notes). Keys are the names a scene's ``substance`` takes.
BRITTLE_SUBSTANCES: dict[str, BrittleSubstance] = {
    # K_Ic 1.2 MPa m^1/2 -> G_f = 1.44e12 / 7e10 = 20.6 J/m^2
    "porcelain": BrittleSubstance(
        7.0e10, 0.22, 2400.0, 4.0e7, 20.6,
        "Ashby & Jones, Engineering Materials 2 (2nd ed. 1998), ch. 15-17: porcelain E 70 GPa, rho 2300-2500, "
        "modulus of rupture 50-100 MPa (tension about 40 MPa taken), K_Ic about 1 (0.8-1.5) MPa m^1/2; "
        "G_f = K_Ic^2 / E at K_Ic 1.2"),
    # K_Ic 0.75 MPa m^1/2 -> G_f = 5.6e11 / 7e10 = 8.0 J/m^2
    "soda_lime_glass": BrittleSubstance(
        7.0e10, 0.22, 2500.0, 5.0e7, 8.0,
        "Ashby & Jones, Engineering Materials 2, Table 15.7: soda glass E 74 GPa, rho 2480, tensile strength "
        "about 50 MPa (annealed panes 30-70 MPa), K_Ic 0.7-0.8 MPa m^1/2 (Wiederhorn 1969, J. Am. Ceram. Soc. 52); "
        "G_f = K_Ic^2 / E at K_Ic 0.75"),
    # K_Ic 1.5 MPa m^1/2 -> G_f = 2.25e12 / 5e10 = 45 J/m^2
    "granite": BrittleSubstance(
        5.0e10, 0.25, 2650.0, 1.0e7, 45.0,
        "Whittaker, Singh & Sun, Rock Fracture Mechanics (1992), Table A: granites K_Ic 1.0-2.5 MPa m^1/2; "
        "Jaeger, Cook & Zimmerman, Fundamentals of Rock Mechanics (4th ed. 2007): E 40-70 GPa, rho 2600-2700, "
        "tensile (Brazilian) 7-25 MPa; G_f = K_Ic^2 / E at K_Ic 1.5 (work-of-fracture tests give more, up to "
        "about 100 J/m^2: Bazant & Planas 1998)"),
    # C30/37: f_ctm = 0.30 f_ck^(2/3) = 2.9 MPa; G_F = G_F0 (f_cm / 10)^0.7 = 0.030 N/mm * 3.8^0.7 = 77 J/m^2
    "concrete": BrittleSubstance(
        3.0e10, 0.2, 2400.0, 2.9e6, 77.0,
        "CEB-FIP Model Code 1990, 2.1.3: a C30 concrete, f_ctm 2.9 MPa, E_c about 30 GPa (E_ci 33.6 GPa), "
        "G_F = G_F0 (f_cm / 10 MPa)^0.7 with G_F0 = 0.030 N/mm (aggregate 16 mm), f_cm 38 MPa; "
        "Bazant & Planas, Fracture and Size Effect in Concrete and Other Quasibrittle Materials (1998): "
        "G_F 50-150 J/m^2"),
    "wood_across_grain": BrittleSubstance(
        9.0e8, 0.35, 480.0, 2.3e6, 250.0,
        "USDA Forest Products Laboratory, Wood Handbook (FPL-GTR-190, 2010), Tables 5-1, 5-3a: Douglas-fir E_L "
        "13.4 GPa, E_R / E_L 0.068 (E across the grain about 0.9 GPa), tension perpendicular to grain 2.3 MPa, "
        "rho about 480 at 12 % moisture; G_f across the grain (TL/RL crack systems) 200-400 J/m^2 for softwoods "
        "(Stanzl-Tschegg, Tan & Tschegg 1995, Wood Sci. Technol. 29)"),
}

#: The material keys a substance fills.
SUBSTANCE_KEYS = ("E", "nu", "rho", "tensile_strength", "fracture_energy")


def substance_values(name: str, given: dict) -> dict:
    """The keys :data:`SUBSTANCE_KEYS` of substance ``name`` that ``given`` (a material table) does not set.

    Parameters
    ----------
    name : str
        A key of :data:`BRITTLE_SUBSTANCES`.
    given : dict
        The scene's material table (its own values win).

    Returns
    -------
    dict
        ``{key: float}`` for the keys ``given`` lacks.

    Raises
    ------
    KeyError
        ``name`` is not in the table (the scene reader names the choices before calling).
    """
    row = BRITTLE_SUBSTANCES[name]
    return {k: float(getattr(row, k)) for k in SUBSTANCE_KEYS if k not in given}
