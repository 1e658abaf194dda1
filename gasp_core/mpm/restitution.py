"""Coefficients of restitution of the rigid route's contact (issue 53, ``docs/rigid.md`` "Restitution").

A contact's coefficient of restitution ``e`` is the ratio of the normal separation speed to the normal approach
speed of the two surfaces. Each body's material gives one (:func:`body_restitution`: the material's
``restitution`` key, else the value of the substance its ``E`` and ``rho`` match in :data:`SUBSTANCES`, else
:data:`DEFAULT_RESTITUTION`), each ``[[boundary]]`` one (its ``restitution`` key, default 1: a hard floor), and a
pair takes their product (:func:`combine`), the rule of Bullet (``btManifoldResult::calculateCombinedRestitution``).
The product is chosen because the substances' values below are measured against a hard, nearly elastic floor: a
steel ball on the default floor bounces with the steel figure, and a softer floor (``restitution`` < 1 on the
boundary) lowers every body's bounce in proportion. (PhysX averages by default; an average would not keep a table
value on a hard floor unchanged; ``docs/rigid.md`` compares the rules.)

The engines apply ``e`` to a rigid body's points by a hysteretic contact law (Walton & Braun 1986, "Viscosity,
granular-temperature, and stress calculations for shearing assemblies of inelastic, frictional disks", J. Rheol.
30: a loading and an unloading branch): a point's normal impulse is ``dt k depth`` while its normal velocity
approaches the support and ``e^2 dt k depth`` while it recedes, so the energy the contact gives back is ``e^2`` of
what it stored whatever the stiffness, the number of points touching and how it grows with the depth: the body
leaves with ``e`` of its approach speed (less ``(1 - e^2) M g d`` of kinetic energy, ``d`` the deepest
penetration: below 0.01 in ``e`` at the steps the rigid route takes). A contact whose approach speed ``v_in`` gives
a rebound ``e v_in`` below :func:`rest_speed` is perfectly inelastic (``e`` = 0: the body comes to rest, as a
rigid-body engine's bounce threshold does).
"""
from __future__ import annotations

import math

import numpy as np

#: Restitution on a hard floor, and the Young's modulus (Pa) and density (kg/m^3) ranges a material must fall in to
#: take it without a ``restitution`` key. Values: a ball of the substance dropped on a hard (steel, stone) floor,
#: at speeds of about 1-5 m/s (Goldsmith 1960, "Impact", Table 21 and ch. 8; Cross 1999, "The bounce of a ball",
#: Am. J. Phys. 67, 222: a superball 0.8-0.9, a steel ball 0.9 and more; hardwood 0.5-0.6, Kharaz & Gorham 2000
#: for glass on steel and glass, 0.9-0.97 at low speed).
SUBSTANCES: dict[str, tuple[float, tuple[float, float], tuple[float, float]]] = {
    "steel": (0.93, (1.8e11, 2.2e11), (7600.0, 8100.0)),
    "hardwood": (0.55, (7.0e9, 2.0e10), (500.0, 1000.0)),
    "glass": (0.9, (5.0e10, 9.0e10), (2200.0, 2800.0)),
    "rubber": (0.8, (1.0e6, 1.0e8), (900.0, 1300.0)),
}
#: A rigid body whose material matches no substance and sets no ``restitution``.
DEFAULT_RESTITUTION = 0.5
#: A boundary (ground, walls) without a ``restitution`` key: a hard floor, the one the substances' values are for.
BOUNDARY_RESTITUTION = 1.0
#: A rebound that would lift the body less than this share of a grid cell is none: the contact is inelastic
#: (:func:`rest_speed`). A rise below a quarter of a cell is what the rigid route's choice already calls unseen
#: (``gasp_core.prepare.route.RIGID_SHARE``).
REST_RISE_CELLS = 0.25
#: What the engines' ``lift_off`` (the substep a rigid body's contact ends) does with :func:`lift_off_speed`'s
#: figure ``u_out`` (round 60, ``docs/contact.md`` "Round 60: the rebound under a load"). ``"poisson"`` (the
#: default): the rebound is an impulse on top of every other impulse the body took over the contact: the normal
#: speed ``u`` is lowered to ``u_out`` when above it, and raised at most to ``u_out + J_o / M``, ``J_o`` the normal
#: impulse over the contact of everything but gravity and the supports (another body pressing it down: < 0), never
#: lowered by the raise (:func:`lift_off_normal`): a free body's bounce is ``"set"``'s, a box under landing sand is
#: not launched at ``e v_in``. ``"set"`` (before round 60): ``u`` set to ``u_out`` (a box under a landing sand ball
#: bounced and flew at 2x and 4x the default substeps). ``"cap"`` (measured, not for use): lowered only (the
#: hysteresis alone gives back too little: steel 0.62-0.70). Read when a solver is built.
LIFT_OFF = "poisson"
#: The kernels' integer for each rule.
LIFT_OFF_RULES = {"set": 0, "poisson": 1, "cap": 2}


def substance_of(material) -> str | None:
    """The name in :data:`SUBSTANCES` whose ``E`` and ``rho`` ranges hold the material's, or None."""
    for name, (_e, (e_lo, e_hi), (r_lo, r_hi)) in SUBSTANCES.items():
        if e_lo <= material.E <= e_hi and r_lo <= material.rho <= r_hi:
            return name
    return None


def body_restitution(material) -> float:
    """A body's coefficient of restitution on a hard floor, in [0, 1]: its material's ``restitution`` (a number
    or a substance name, ``gasp_core.seam.setup.Material``), else its substance's (:func:`substance_of`), else
    :data:`DEFAULT_RESTITUTION`."""
    e = getattr(material, "restitution", None)
    if e is not None:
        return float(e)
    s = substance_of(material)
    return SUBSTANCES[s][0] if s else DEFAULT_RESTITUTION


def restitution_why(material) -> str:
    """Where :func:`body_restitution`'s figure comes from, in words (for the route line and ``run.json``)."""
    if getattr(material, "restitution", None) is not None:
        return "material.restitution"
    s = substance_of(material)
    return (f"{s} (its E and rho)" if s else f"the default {DEFAULT_RESTITUTION:g} (no substance matches its E "
            f"and rho; set material.restitution)")


def combine(e_body: float, e_support: float) -> float:
    """A pair's coefficient: the product (Bullet's rule; module docstring)."""
    return float(e_body) * float(e_support)


def rest_speed(setup) -> float:
    """The rebound speed below which a rigid body's contact is inelastic, m/s: ``sqrt(2 |g| REST_RISE_CELLS dx)``,
    the speed that lifts a body :data:`REST_RISE_CELLS` of a cell (0 without gravity)."""
    g = float(np.linalg.norm(np.asarray(setup.gravity, np.float64)))
    return math.sqrt(2.0 * g * REST_RISE_CELLS * float(setup.dx))


def body_table(setup) -> np.ndarray:
    """Per body its coefficient (:func:`body_restitution`) for a rigid body, -1 for the others (their contact keeps
    its damping): shape (n_bodies,), float64."""
    from gasp_core.mpm.rigid import rigid_mask
    rigid = rigid_mask(setup.materials)
    return np.array([body_restitution(m) if r else -1.0 for m, r in zip(setup.materials, rigid)], np.float64)


def plane_table(setup, n_planes: int) -> np.ndarray:
    """Per plane of ``gasp_core.mpm.contact.contact_planes`` (the grounds, then each walls boundary's faces,
    ``contact.wall_faces``) its boundary's ``restitution``: shape (n_planes,), float64 (the same order; empty when
    there are none)."""
    from gasp_core.mpm.contact import wall_faces
    grounds = [float(getattr(b, "restitution", BOUNDARY_RESTITUTION)) for b in setup.boundaries if b.kind == "ground"]
    walls = [float(getattr(b, "restitution", BOUNDARY_RESTITUTION)) for b in setup.boundaries if b.kind == "walls"]
    out = np.array(grounds + [e for e in walls for _ in wall_faces(setup)], np.float64)
    return out[:n_planes] if len(out) >= n_planes else np.ones(n_planes)


def lift_off_rule() -> int:
    """:data:`LIFT_OFF`'s integer (:data:`LIFT_OFF_RULES`), the engines' kernels' argument."""
    if LIFT_OFF not in LIFT_OFF_RULES:
        raise ValueError(f"restitution.LIFT_OFF must be one of {sorted(LIFT_OFF_RULES)}, not {LIFT_OFF!r}")
    return LIFT_OFF_RULES[LIFT_OFF]


def lift_off_normal(u: float, u_out: float, j_other: float, mass: float, rule: int) -> float:
    """The normal speed (m/s) a rigid body leaves its contact with, by rule (:data:`LIFT_OFF_RULES`): ``u`` its
    normal speed now (m/s, > 0), ``u_out`` :func:`lift_off_speed`'s (free flights), ``j_other`` (kg m/s) the normal
    impulse over the contact of all but gravity and the supports, ``mass`` (kg). ``"poisson"``: ``min(u_out, max(u,
    u_out + j_other / mass))`` (Poisson's hypothesis, Stronge 2000 "Impact Mechanics" ch. 2: the restitution as the
    support's impulse, superposed on the others'); ``"set"``: ``u_out``; ``"cap"``: ``min(u, u_out)``. The engines
    spell it in their rigid kernels (``lift_off``)."""
    u_out = max(u_out, 0.0)
    if rule == 0:
        return u_out
    if rule == 2:
        return min(u, u_out)
    return min(u_out, max(u, u_out + j_other / mass))


def lift_off_speed(e: float, v_in: float, T: float, dz: float, g_n: float) -> float:
    """The normal speed (m/s) a body leaves its contact with, so that its free flights before and after cross as an
    instantaneous bounce of restitution ``e``: the figure a filmed drop reads (``gasp_studies.accuracy.
    ballistic_restitution``), whatever the contact's duration.

    The flight in meets the contact at ``t_0`` with the normal speed ``-v_in``; the body leaves ``T`` (s) later,
    ``dz`` (m) further along the normal, with ``u``; ``g_n`` (m/s^2) is gravity's pull against the normal. The two
    parabolas cross at ``tau`` after ``t_0`` with ``u - g_n (tau - T) = e (v_in + g_n tau)``, which gives, for
    ``A = u + g_n T``, ``A^2 + B A - C = 0`` with ``B = v_in (1 - e) - (1 + e) g_n T`` and ``C = e v_in^2 - (1 + e)
    g_n (dz + g_n T^2 / 2)``; ``u`` is the larger root less ``g_n T`` (``e v_in`` for an instantaneous contact,
    ``T = dz = 0``), at least 0. The engines spell it in their rigid kernels (``lift_off``).
    """
    B = v_in * (1.0 - e) - (1.0 + e) * g_n * T
    C = e * v_in * v_in - (1.0 + e) * g_n * (dz + 0.5 * g_n * T * T)
    return max(0.5 * (-B + math.sqrt(max(B * B + 4.0 * C, 0.0))) - g_n * T, 0.0)
