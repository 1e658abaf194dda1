"""The material schema, declared once: every material parameter's default, range, unit and meaning
(:data:`MATERIAL_PARAMS`), and the keys each material uses (:data:`MATERIAL_KINDS`, a tagged union keyed on
the material's ``name``).

The scene reader (:func:`gasp_core.scene.tables.read_material`) refuses a key that the chosen material does
not use, and checks every value against its :class:`Param`; :class:`gasp_core.seam.setup.Material` takes its
defaults from here and :meth:`~gasp_core.seam.setup.Material.check` applies the same ranges, so a value is
refused in the same words by the scene and by ``SimSetup``. ``docs/scene_keys.md`` is generated from these
tables (:func:`gasp_core.scene.keys_doc.scene_keys_markdown`). An engine with a narrower range declares its
own limit (:mod:`gasp_core.seam.limits`).

Every model of ``docs/mpm.md`` is well posed on all of ``-1 < nu < 0.5`` (``lam + 2 mu``, ``3 lam + 2 mu``
and ``K`` stay positive).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def range_text(lo: float | None, hi: float | None, lo_open: bool = False, hi_open: bool = False) -> str:
    """``"a finite number > 0"``, ``"a finite number in (-1, 0.5)"``, ...: a range in words."""
    if lo is None and hi is None:
        rng = ""
    elif hi is None:
        rng = f" {'>' if lo_open else '>='} {lo:g}"
    elif lo is None:
        rng = f" {'<' if hi_open else '<='} {hi:g}"
    else:
        rng = f" in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"
    return "a finite number" + rng


def in_range(value, lo: float | None, hi: float | None, lo_open: bool = False, hi_open: bool = False) -> bool:
    """True when ``value`` is a finite int or float (never a bool) within the range."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)):
        return False
    if not math.isfinite(value):
        return False
    if lo is not None and not (value > lo if lo_open else value >= lo):
        return False
    return hi is None or (value < hi if hi_open else value <= hi)


@dataclass(frozen=True)
class Param:
    """One numeric material parameter.

    Attributes
    ----------
    default : float
        The value a scene that leaves the key out gets, in ``unit``.
    lo, hi : float or None
        Bounds, in ``unit``; None = unbounded.
    lo_open, hi_open : bool
        Make the bound exclusive.
    unit : str
        SI unit (``"Pa"``, ``"kg/m^3"``, ``"deg"``, ``"Pa s"``), ``""`` when dimensionless.
    doc : str
        The meaning, one line.
    """

    default: float
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""
    doc: str = ""

    @property
    def range(self) -> str:
        """The range in words, e.g. ``"a finite number in (-1, 0.5)"``."""
        return range_text(self.lo, self.hi, self.lo_open, self.hi_open)

    def expected(self, value) -> str | None:
        """None when ``value`` is valid, else what is expected, in words (:attr:`range`)."""
        return None if in_range(value, self.lo, self.hi, self.lo_open, self.hi_open) else self.range


#: Every material parameter, by its scene key (and :class:`~gasp_core.seam.setup.Material` field).
MATERIAL_PARAMS: dict[str, Param] = {
    "E": Param(1e5, 0.0, lo_open=True, unit="Pa", doc="Young's modulus"),
    "nu": Param(0.3, -1.0, 0.5, lo_open=True, hi_open=True, doc="Poisson's ratio"),
    "rho": Param(1000.0, 0.0, lo_open=True, unit="kg/m^3", doc="density"),
    "yield_stress": Param(1e4, 0.0, lo_open=True, unit="Pa",
                          doc="von Mises yield stress: the uniaxial stress at which a bar yields"),
    "friction_angle": Param(30.0, 0.0, 90.0, hi_open=True, unit="deg", doc="Drucker-Prager friction angle (Klar et al. 2016's cone; "
                            "its layers flow at a steeper angle: 30 deg flows at 34.7, docs/mpm.md)"),
    "grain_diameter": Param(0.0, 0.0, unit="m",
                            doc="grain diameter d of the mu(I) rheology (Jop et al. 2006): the cone widens from "
                                "friction_angle's at rest towards friction_angle_2's at a high inertial number; "
                                "0 = rate-independent Drucker-Prager (docs/contact.md)"),
    "friction_angle_2": Param(0.0, 0.0, 90.0, hi_open=True, unit="deg",
                              doc="the angle of mu_2, the mu(I) rheology's limiting friction, above "
                                  "friction_angle (used when grain_diameter > 0)"),
    "softening": Param(0.1, 0.0, doc="yield stress drop per unit accumulated plastic strain"),
    "hardening": Param(10.0, 0.0, lo_open=True, doc="hardening coefficient xi (Stomakhin et al. 2013)"),
    "theta_c": Param(2.5e-2, 0.0, 1.0, lo_open=True, hi_open=True,
                     doc="critical compression (Stomakhin et al. 2013): singular values clamped at 1 - theta_c"),
    "theta_s": Param(4.5e-3, 0.0, lo_open=True, doc="critical stretch (Stomakhin et al. 2013)"),
    "viscosity": Param(0.0, 0.0, unit="Pa s",
                       doc="Kelvin-Voigt shear viscosity eta, 0 = no physical damping (engine feature "
                           "'viscosity'; docs/dissipation.md)"),
    "tensile_strength": Param(1e4, 0.0, lo_open=True, unit="Pa",
                              doc="Rankine tensile strength f_t: the largest principal stress an undamaged point "
                                  "carries (docs/fracture.md)"),
    "fracture_energy": Param(50.0, 0.0, lo_open=True, unit="J/m^2",
                             doc="fracture energy G_f: the work to open a unit area of crack; at least "
                                 "tensile_strength^2 h / (2 E), the snap-back limit at the crack band width "
                                 "h = dx, the grid cell (docs/fracture.md)"),
}


@dataclass(frozen=True)
class MaterialKind:
    """One material model: what it is and the parameter keys it uses (besides ``name``).

    Attributes
    ----------
    doc : str
        The model, one line, with its source.
    keys : tuple of str
        Keys of :data:`MATERIAL_PARAMS` the model reads; a scene giving another one is refused.
    """

    doc: str
    keys: tuple[str, ...]


_ELASTIC = ("E", "nu", "rho", "viscosity")

#: Material models an engine may offer (capability names), keyed on the scene's ``material.name``.
MATERIAL_KINDS: dict[str, MaterialKind] = {
    "jelly": MaterialKind("elastic, fixed corotated (Stomakhin et al. 2012)", _ELASTIC),
    "neo_hookean": MaterialKind("elastic, compressible neo-Hookean", _ELASTIC),
    "metal": MaterialKind("von Mises plasticity on Hencky strain (StVK Hencky elasticity)",
                          _ELASTIC + ("yield_stress",)),
    "sand": MaterialKind("Drucker-Prager plasticity on Hencky strain (Klar et al. 2016), optionally mu(I) "
                         "(Jop et al. 2006)", _ELASTIC + ("friction_angle", "grain_diameter", "friction_angle_2")),
    "snow": MaterialKind("hardening plasticity (Stomakhin et al. 2013)",
                         _ELASTIC + ("hardening", "theta_c", "theta_s")),
    "plasticine": MaterialKind("von Mises with softening", _ELASTIC + ("yield_stress", "softening")),
    "brittle": MaterialKind("Rankine damage on Hencky elasticity, crack band of width dx, the grid cell "
                            "(Bazant & Oh 1983)",
                            _ELASTIC + ("tensile_strength", "fracture_energy")),
    "liquid": MaterialKind("weakly compressible fluid (pressure from the bulk modulus K of E and nu)", _ELASTIC),
    "rigid": MaterialKind("rigid body (engines with rigid bodies)", ("rho",)),
}

#: Values of a material's ``model`` key (issue 40): the full elastic model, the rigid limit, or chosen from the
#: body's estimated strain (``gasp_core.prepare.route``).
BODY_MODELS = ("auto", "elastic", "rigid")
#: What each value of ``model`` does (``docs/scene_keys.md``, ``docs/rigid.md``).
BODY_MODEL_DOCS = {
    "auto": "the default: the core estimates the body's deformation under its weight, at its drop's impact and "
            "from its spin, and takes `rigid` when it is below a quarter of a grid cell (metal: also below its "
            "yield), else `elastic`; `gasp simulate` says the choice in one line and run.json records it "
            "(docs/rigid.md)",
    "elastic": "the material's full model, whatever its stiffness costs in substeps",
    "rigid": "the rigid limit: one rigid motion, no stress, its step set by the motion (engine feature "
             "'rigid_limit'; an engine without it refuses the scene)",
}
#: Materials that take the ``model`` key: elastic up to a yield (a rigid body never yields, so ``metal`` is
#: rigid only while its estimated stress stays below its yield stress), or up to fracture (``brittle``: a rigid
#: brittle body breaks on impact into rigid fragments, ``docs/fracture.md`` "Stiff brittle bodies: fragments").
RIGID_KINDS = ("jelly", "neo_hookean", "metal", "brittle")
#: Materials that take the ``friction`` key (issue 67 item 4): the grid engines' bodies that do not flow. A flowing body's friction on
#: another body is its own (sand: ``tan(friction_angle)``; snow, liquid: 0), ``gasp_core.mpm.fields.field_friction``.
FRICTION_KINDS = ("jelly", "neo_hookean", "metal", "plasticine", "brittle")
#: The largest ``friction`` a scene may give (Bullet clamps a pair's combined coefficient to 10).
MAX_FRICTION = 10.0


def body_keys(name: str) -> tuple[str, ...]:
    """The keys material ``name`` takes besides its :data:`MATERIAL_KINDS` parameters: ``model`` and ``restitution``
    (:data:`RIGID_KINDS`), ``friction`` (:data:`FRICTION_KINDS`)."""
    return (("model", "restitution") if name in RIGID_KINDS else ()) + (("friction",) if name in FRICTION_KINDS else ())


#: ``auto`` considers the rigid limit for a ``brittle`` body only from this Young's modulus (Pa): at handbook
#: stiffness (wood across the grain 0.9 GPa and up) an explicit step is out of reach; the soft brittle bodies of the
#: crack-band model (1e4-1e7 Pa) keep their own model.
STIFF_BRITTLE_E = 1.0e8

#: The material of a scene object whose ``material`` table gives no ``name``.
DEFAULT_MATERIAL = "jelly"
