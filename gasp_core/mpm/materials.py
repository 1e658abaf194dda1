"""Material codes and the per-body parameter table the kernels of a grid (MPM) engine read, and the initial ``Jp``.

Material parameters are checked once, by :class:`gasp_core.seam.setup.SimSetup` (``E > 0``,
``rho > 0``, ``-1 < nu < 0.5``): every model of ``docs/mpm.md`` is well posed on that whole range
(``lam + 2 mu``, ``3 lam + 2 mu`` and the bulk modulus ``K`` stay positive), so an MPM engine adds
no rule of its own on ``nu``.
"""
from __future__ import annotations

import math
from enum import IntEnum
from typing import Sequence

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.seam.setup import Material


class MaterialKind(IntEnum):
    """Material codes of the kernels (index of the branch in the constitutive update, docs/mpm.md table); the
    lower-case name is the scene's material name."""

    JELLY = 0
    NEO_HOOKEAN = 1
    METAL = 2
    SAND = 3
    SNOW = 4
    PLASTICINE = 5
    LIQUID = 6
    BRITTLE = 7


class Param(IntEnum):
    """Columns of the per-body parameter table (:func:`material_table`)."""

    MU = 0
    LAM = 1
    YIELD = 2
    SOFTENING = 3
    HARDENING = 4
    THETA_C = 5
    THETA_S = 6
    ALPHA = 7
    K = 8
    ETA = 9
    FT = 10
    SF = 11
    DMU = 12
    IK = 13
    CELLS = 14


#: The codes and columns as plain ints, the constants the plugins' kernels compile in.
JELLY, NEO_HOOKEAN, METAL, SAND, SNOW, PLASTICINE, LIQUID, BRITTLE = (int(k) for k in MaterialKind)
MATERIAL_CODES = {k.name.lower(): int(k) for k in MaterialKind}
(P_MU, P_LAM, P_YIELD, P_SOFTENING, P_HARDENING, P_THETA_C, P_THETA_S, P_ALPHA, P_K, P_ETA, P_FT,
 P_SF, P_DMU, P_IK, P_CELLS) = (int(c) for c in Param)
N_PARAMS = len(Param)
#: von Mises yield surface radius per unit yield stress: metal and plasticine return-map the Hencky
#: strain's deviator ``e`` onto ``2 mu ||e|| <= sqrt(2/3) Y``, i.e. ``||dev tau|| <= sqrt(2/3) Y``, so a
#: bar in uniaxial stress yields at ``Y`` (von Mises: ``sigma_vm = sqrt(3/2) ||dev tau||``;
#: de Souza Neto, Peric & Owen, Computational Methods for Plasticity, 2008, Ch. 6). The MLS-MPM reference
#: code (Hu et al. 2018) and PhysGaussian use ``||e|| <= Y / (2 mu)``, which yields at ``sqrt(3/2) Y = 1.22 Y``.
VON_MISES_RADIUS = math.sqrt(2.0 / 3.0)


#: mu(I) rheology's constants (Jop, Forterre & Pouliquen 2006, Nature 441, glass beads): ``I_0`` and the grains'
#: solid fraction (the grain density is ``rho / MU_I_PACKING``).
MU_I_I0, MU_I_PACKING = 0.279, 0.6


def mu_of_I(ratio_2, ik, shear_rate, p):
    """The mu(I) cone's widening, ``mu(I) / mu_s = 1 + (mu_2 / mu_s - 1) / (1 + I_0 / I)``, NumPy (the reference
    of the kernels' ``mu_i_alpha`` in both MPM plugins).

    ``I = gamma_dot d / sqrt(p / rho_s)`` is the inertial number (Jop et al. 2006, Eq. 2-3; GDR MiDi 2004): the
    shear rate ``gamma_dot`` (1/s; the kernels take the plastic one of the substep, ``sqrt(2) dg / dt``, ``dg``
    the Hencky deviator the rate-independent cone removes), the pressure ``p`` (Pa), the grain diameter ``d`` and
    density ``rho_s``. In simple shear the cone's ``sqrt(J2) / p`` is the friction coefficient ``mu = tau / p``, and
    it is proportional to ``alpha``; so ``alpha(I)`` runs from the cone of ``friction_angle`` (``mu_s``) at rest to
    that of ``friction_angle_2`` (``mu_2``) as ``I`` grows: ``ratio_2 = alpha(phi_2) / alpha(phi) - 1``
    (``P_DMU``), ``ik = I_0 / (d sqrt(rho_s))`` (``P_IK``), as :func:`material_table` writes them.
    """
    return 1.0 + ratio_2 / (1.0 + ik * np.sqrt(np.maximum(p, 0.0)) / np.maximum(shear_rate, 1e-30))


def snap_back_limit(m: Material, h: float) -> float:
    """The least fracture energy a crack band of width ``h`` (m) takes, J/m^2: ``f_t^2 h / (2 E)``
    (:meth:`Material.snap_back_limit`; ``h`` from ``gasp_core.seam.setup.crack_band``).

    With linear softening the band's stress falls from ``f_t`` to 0 over the strain ``2 G_f / (f_t h)``; below
    this limit that strain is smaller than the elastic ``f_t / E`` and the band would snap back (Bazant & Oh
    1983, "Crack band theory for fracture of concrete", Materiaux et Constructions 16; Jirasek & Bazant,
    "Inelastic Analysis of Structures", Wiley 2002, on the crack band model).
    """
    return m.snap_back_limit(h)


def softening_stress(m: Material, h: float) -> float:
    """``s_f = 2 E G_f / (f_t h)``, Pa: the undamaged (effective) principal stress at which a brittle point is
    fully damaged (linear softening in a crack band of width ``h``, m, Bazant & Oh 1983): the band then dissipates
    ``f_t s_f / (2 E) h = G_f`` per unit crack area, whatever ``h``. ``h`` is the width the crack localises in,
    ``dx``, the cell (``gasp_core.seam.setup.crack_band``, docs/fracture.md "The crack band").

    Raises
    ------
    SceneError
        ``G_f`` at or below :func:`snap_back_limit`, naming the limit and the band width ``h``
        (:meth:`Material.check_band`; ``SimSetup`` refuses it first).
    """
    m.check_band(h, "material 'brittle'")
    return 2.0 * m.E * m.fracture_energy / (m.tensile_strength * h)


def brittle_damage(s, ft, sf):
    """Damage ``d`` in [0, 1] that the largest undamaged principal stress ``s`` (Pa) gives, NumPy (the kernels'
    ``brittle_tau`` in both MPM plugins, and the reference of their tests).

    Linear softening of the crack band (Bazant & Oh 1983): the stress ``(1 - d) s`` carried at an effective
    stress ``s`` is ``s`` up to ``f_t``, then ``f_t (s_f - s) / (s_f - f_t)`` down to 0 at ``s_f``
    (:func:`softening_stress`), so ``d = 1 - f_t (s_f - s) / (s (s_f - f_t))`` on ``(f_t, s_f)``, 0 below and 1
    above. A point keeps the largest ``d`` it has had (damage never heals).
    """
    s = np.asarray(s, dtype=np.float64)
    safe = np.maximum(s, ft)
    d = 1.0 - ft * (sf - safe) / (safe * (sf - ft))
    return np.where(s <= ft, 0.0, np.where(s >= sf, 1.0, d))


def band_weight(fx, n):
    """The crack band weight ``W`` of a point, in [0.5, 1] (NumPy; the kernels' ``band_weight`` in both MPM plugins).

    Parameters
    ----------
    fx : array_like, shape (..., 3), float
        The point's offset from its stencil's first node, in cells, ``(x - lo) / dx - floor((x - lo) / dx - 0.5)``,
        each in [0.5, 1.5) (the quadratic B-spline stencil's ``fx``).
    n : array_like, shape (..., 3), float
        The unit normal of its crack: the direction of its largest principal stress.

    Returns
    -------
    W : ndarray, shape (...), float64
        ``sum_a n_a^2 max(w_a, 1 - w_a)``, ``w_a = 2 fx_a (1.5 - fx_a)^2``.

    Notes
    -----
    In MLS-MPM the velocity gradient of a point is ``sum_k c_k v_k`` with ``c_k = 4 w_k (k - fx) / dx`` (Hu et al.
    2018, quadratic B-splines): along an axis it is ``w_a (v_1 - v_0) / dx + (1 - w_a) (v_2 - v_1) / dx``, so a crack
    opening ``J`` between two nodes strains a point of that cell by ``W J / dx``, ``W`` its weight on its own cell
    (1 at the cell's middle, 1/2 on a node), and a point of the next cell by the rest, ``1 - W``. Every point of the
    cracked cell reaches the end of its softening at the same opening when its softening range is scaled by ``W``
    (:func:`band_softening_stress`), whatever the point lattice's offset from the nodes; with one ``s_f`` the points
    on nodes (``W`` 1/2) kept softening after the cell's middle had broken through and three point layers broke where
    the band ``h = dx`` counts two: +32 % of ``G_f`` dissipated at n_grid 24 (docs/fracture.md "Shifted lattices
    (round 33)").
    """
    fx = np.asarray(fx, np.float64)
    n = np.asarray(n, np.float64)
    w = 2.0 * fx * (1.5 - fx) ** 2
    return np.sum(n * n * np.maximum(w, 1.0 - w), axis=-1)


def band_projection(n):
    """The cell's projection on a crack's normal, in cells: ``g = sum_a |n_a|`` (NumPy; the kernels' ``band_sf`` in
    both MPM plugins), 1 along a grid axis, sqrt(2) at 45 deg about an axis, sqrt(3) along a cube's diagonal.

    Parameters
    ----------
    n : array_like, shape (..., 3), float
        Unit normals (the direction of the largest principal stress).

    Returns
    -------
    g : ndarray, shape (...), float64

    Notes
    -----
    A crack across the grid at an angle opens between the nodes either side of it; the points whose quadratic
    B-spline stencils (1.5 cells each way along every axis) read both sides lie within ``1.5 dx g`` of it, a band
    ``g`` times the aligned one's: the points of a 45 deg crack broke through over 2.6 to 3 lattice layers of ``dx /
    2`` where an aligned one breaks 2 (``benchmarks/tension_oblique.py``, docs/fracture.md "Oblique specimens (round
    34)"). So the band is ``h = g dx``, ``s_f`` its :func:`softening_stress` (``s_f(dx) / g``) where that stays above
    ``f_t``; as the width of a finite element's band grows by the element's projection on the crack's normal (J. Oliver,
    "A consistent characteristic length for smeared cracking models", IJNME 28, 1989, 461-474).
    """
    return np.sum(np.abs(np.asarray(n, np.float64)), axis=-1)


def band_softening_stress(ft, sf, W):
    """A point's own end of softening, Pa: ``f_t + W (s_f - f_t)`` (``W`` from :func:`band_weight`; ``s_f`` of the
    band ``dx``, :func:`softening_stress`). Its strain past the strength is ``W`` times its cell's, so it breaks
    through with the cell; always above ``f_t`` where ``s_f`` is (no new snap-back limit)."""
    return ft + np.asarray(W, np.float64) * (sf - ft)


def material_table(materials: Sequence[Material], band=None, cells=None) -> tuple[np.ndarray, np.ndarray]:
    """Material code and parameter row of each body, as the kernels read them.

    Parameters
    ----------
    materials : sequence of Material
        One per body; names in :data:`MATERIAL_CODES`.
    band : float, sequence of float (one per body) or None
        Crack band width of each body, m (``SimSetup.crack_band``: ``dx``); needed when a
        ``brittle`` body is present.
    cells : bool, sequence of bool (one per body) or None
        Whether each body is laid out in Grady's cells (``gasp_core.run.grady_cells``, which lays them in scenes of
        one body: the engines give ``SimSetup.cells is not None``); None: none.

    Returns
    -------
    kinds : ndarray, shape (n_bodies,), int32
        :data:`MATERIAL_CODES` value of each body.
    params : ndarray, shape (n_bodies, N_PARAMS), float64
        Columns ``P_MU`` (Lame mu, Pa), ``P_LAM`` (Lame lam, Pa), ``P_YIELD`` (von Mises yield
        stress, Pa), ``P_SOFTENING``, ``P_HARDENING`` (snow xi), ``P_THETA_C``, ``P_THETA_S``,
        ``P_ALPHA`` (Drucker-Prager ``alpha = sqrt(2/3) 2 sin(phi) / (3 - sin(phi))`` of the
        friction angle phi, Klar et al. 2016 Eq. 27), ``P_K`` (bulk modulus
        :attr:`Material.K`, Pa, of the liquid's equation of state) and ``P_ETA`` (Kelvin-Voigt
        viscosity :attr:`Material.viscosity`, Pa s: the kernels add the Kirchhoff stress
        ``J eta (C + C^T)``, APIC's ``C`` standing for ``grad v``; ``docs/dissipation.md``), and for a
        ``brittle`` body ``P_FT`` (tensile strength ``f_t``, Pa) and ``P_SF`` (:func:`softening_stress`, Pa), and for
        a ``sand`` body with a ``grain_diameter`` ``P_DMU`` and ``P_IK`` (:func:`mu_of_I`; 0 without), and
        ``P_CELLS`` 1 for a body laid out in Grady's cells: its broken points keep their tension-free elastic stress
        (the cells' two fields part them) instead of flowing as cohesionless sand.

    Raises
    ------
    SceneError
        A material without an MPM model here (``rigid``); the engine's capabilities normally
        refuse it before. A ``sand`` body with a ``grain_diameter`` whose ``friction_angle_2`` is not above its
        ``friction_angle``. A ``brittle`` body without ``band``, or below its snap-back limit
        (:func:`softening_stress`).
    """
    kinds = np.zeros(len(materials), dtype=np.int32)
    params = np.zeros((len(materials), N_PARAMS), dtype=np.float64)
    for b, m in enumerate(materials):
        if m.name not in MATERIAL_CODES:
            raise SceneError(f"material '{m.name}' (body {b}) has no MPM model; MPM materials: "
                             f"{sorted(MATERIAL_CODES)}")
        kinds[b] = MATERIAL_CODES[m.name]
        s = math.sin(math.radians(m.friction_angle))
        params[b, P_MU] = m.mu
        params[b, P_LAM] = m.lam
        params[b, P_YIELD] = m.yield_stress
        params[b, P_SOFTENING] = m.softening
        params[b, P_HARDENING] = m.hardening
        params[b, P_THETA_C] = m.theta_c
        params[b, P_THETA_S] = m.theta_s
        params[b, P_ALPHA] = math.sqrt(2.0 / 3.0) * 2.0 * s / (3.0 - s)
        params[b, P_K] = m.K
        params[b, P_ETA] = m.viscosity
        if m.name == "sand" and m.grain_diameter > 0.0:   # mu(I) (mu_of_I)
            if not m.friction_angle < m.friction_angle_2 < 90.0:
                raise SceneError(f"material 'sand' (body {b}): friction_angle_2 = {m.friction_angle_2!r}; expected "
                                 f"an angle in (friction_angle = {m.friction_angle!r}, 90) deg with grain_diameter")
            s2 = math.sin(math.radians(m.friction_angle_2))
            params[b, P_DMU] = s2 * (3.0 - s) / (s * (3.0 - s2)) - 1.0   # alpha(phi_2) / alpha(phi) - 1
            params[b, P_IK] = MU_I_I0 / (m.grain_diameter * math.sqrt(m.rho / MU_I_PACKING))
        if m.name == "brittle":
            if band is None:
                raise SceneError(f"material 'brittle' (body {b}) needs its crack band width h (SimSetup.crack_band)")
            params[b, P_FT] = m.tensile_strength
            params[b, P_SF] = softening_stress(m, float(np.broadcast_to(band, (len(materials),))[b]))
            params[b, P_CELLS] = float(bool(np.broadcast_to(bool(cells) if np.ndim(cells) == 0 else cells,
                                                            (len(materials),))[b]))
    return kinds, params


def initial_Jp(materials: Sequence[Material], body_id: np.ndarray, cells=None) -> np.ndarray:
    """Initial ``Jp`` of each point, shape (n,), float64.

    ``Jp`` is the plastic volume ratio for ``snow`` (1 at rest; Stomakhin et al. 2013) and the
    accumulated plastic strain for ``plasticine`` (0 at rest) and the damage ``d`` for ``brittle`` (0 at rest,
    ``docs/fracture.md``); no other model reads it (1). ``cells`` (``SimSetup.cells``, (n,) int, or None): a Grady
    cell's inside (<= -2, ``gasp_core.run.grady_cells``) starts at -1, which the brittle return reads as "never
    damages" (the engines' damage reads 0 there).
    """
    start = np.array([0.0 if m.name in ("plasticine", "brittle") else 1.0 for m in materials])
    out = start[np.asarray(body_id)]
    if cells is not None:
        out = np.where(np.asarray(cells) <= -2, -1.0, out)
    return out
