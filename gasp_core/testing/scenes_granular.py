"""Conformance scene of granular flow against experiment: quasi-2D column collapse (Lube et al. 2005).

A sand column of initial length ``L_i`` (along x) and height ``H_i = a L_i`` stands against a
frictionless wall at the low-x face of a narrow channel (frictionless side walls in y) and is
released at ``t = 0``. Once the pile has stopped, its runout ``L_inf`` (the deposit's front) and
final height ``H_inf`` (at the wall) are compared with the experimental fits of

    Lube, Huppert, Sparks & Freundt, "Collapses of two-dimensional granular columns",
    Phys. Rev. E 72, 041301 (2005): a rectangular channel, the column released on one side and
    standing against the channel's end wall (the symmetry plane of a symmetric collapse); sand,
    rice, sugar (as the secondary sources below describe it):

        (L_inf - L_i) / L_i = 1.2 a           for a < 2.3,   1.9 a^(2/3)  for a > 2.3
        H_inf / L_i          = a               for a < 1.15,  a^(2/5)      for a > 1.15

Where the fits were found (the original is paywalled and was not read here): the runout fit
with its 2.3 crossover is quoted for the quasi-2D collapse in a rectangular channel in K. Kumar's
PhD thesis (University of Cambridge, 2015; github.com/kks32/phd-thesis, Chapter2/chapter2.tex), in
a paragraph that cites Lajeunesse et al. 2005 beside Lube et al. 2005, so the attribution there is
ambiguous; the compilation of Lagree, Staron & Popinet (2011), J. Fluid Mech. 686:378,
Eqs. (3.1)-(3.2) (as reproduced in an SPH code's validation notes found with the search tool)
attributes lambda_1 = 1.2, lambda_2 = 1.9, exponent 2/3, crossover 1.8-2.8 to Lube et al. (sand,
rice, sugar), against lambda_1 = 1.8, lambda_2 = 2.3, crossover ~3 for the glass beads of
Lajeunesse, Monnier & Homsy, Phys. Fluids 17, 103302 (2005): at a = 2 that is 3.6, 50 % above
Lube et al., so the two experiments do not agree within the tolerance; Lube et al. is the one
used. The height fit a^(2/5) above a ~ 1.15 is confirmed less well: the same compilation gives Lube et al.'s height
branch as lambda_4 ~ 1, exponent ~ 0.4, without the crossover value; Kumar's thesis quotes
a^(1/3) above a ~ 0.7 for the 2D collapse in Lajeunesse et al. At a = 2 the two height fits give
1.32 (Lube) and 1.26 (a^(1/3)): 5 % apart, well inside the tolerance.

The scene uses a = 2 (the linear runout regime, below the 2.3 crossover; the power-law height
regime): runout ``(L_inf - L_i) / L_i = 2.40`` and ``H_inf / L_i = 1.32``, each checked within
``COLUMN_TOL = 25 %`` (issue 17), and the pile must have stopped (max speed below 0.05 m/s).
Lube et al. found the scaling independent of the grains (as Kumar's thesis reports it); the sand here is a
cohesionless quartz sand of friction angle ``COLUMN_PHI = 32`` deg (a typical value, within the 30-35 deg the brief
of issue 17 names; Lube et al.'s own angles were not read here) on a base with Coulomb friction ``tan(32 deg)``. The
engines' ``friction_angle`` is a Drucker-Prager cone through Mohr-Coulomb's triaxial-compression corners (Klar et al.
2016), much stronger than 32 deg would be in the channel's plane strain, so the scene passes :func:`flow_dp_angle`
(27.29 deg): the cone whose layers flow at 32 deg, ``sqrt(J2) / p = tan(32 deg)``, the base's own friction in the same
measure (the mu(I) rheology's convention, Jop et al. 2006). Until round 33 it passed :func:`plane_strain_dp_angle`
(23.45 deg, ``sqrt(J2) / p = sin(32 deg)``: Mohr-Coulomb's failure at 32 deg on its own critical plane, a material
whose layers flow at 27.9 deg, weaker than the base it lies on); that sand ran out 20-25 % past Lube's fit on the tall
columns at n_grid 96-192 and stood 11-19 % low (docs/contact.md, "The column's cone"). Passing 32 deg itself gives a
runout of 1.40 instead of 2.40 at n_grid 32 (-42 %): the pile stops at the static slope.

Resolution and cost: n_grid 48 on a 1 m domain (dx 2.08 cm; the column is 7.2 cells long and
14.4 high, 2 points per cell, 2436 points in a 3-cell-wide channel), 35 frames of 0.02 s (the pile
stops by t = 0.6 s, ~2.4 sqrt(2 H_i / g), as in Staron & Hinch 2005). Measured on the two MLS-MPM
engines (identical to 3 digits, round 33): runout 1.917 (-20.1 %), H_inf / L_i 1.219 (-7.6 %); since round 36 (the
ground's touched layer, docs/contact.md) 1.917 and 1.237 (-6.2 %), both engines. The runout is short
at this grid (7.2 cells along ``L_i``) and grows with it: 2.073 at n_grid 64, 2.438 (+1.6 %) at 96, 2.993 (+24.7 %) at
192, where this rate-independent cone does not converge; with the mu(I) rheology it does, 2.785 (+16.0 %) at 192 and
2.802 (+16.8 %) at 384, the height 1.287 (-2.5 %) there (``benchmarks/lube_family.py``; docs/contact.md). The 25 % tolerance of issue 17 therefore fails a further 5 % low bias
of the runout and a 17 % low bias of the height; a 10-degree stronger sand (the catch) runs out -46 %.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, Check, check as _check, make_setup as _setup, wall_margin
from gasp_core.testing.kit import Requires, Scene, Trace

#: Aspect ratio H_i / L_i of the column.
COLUMN_A = 2.0
#: Initial length of the column along x, m.
COLUMN_L = 0.15
#: Mohr-Coulomb friction angle of the sand, degrees (quartz sand: about 30-35).
COLUMN_PHI = 32.0
#: Relative tolerance on runout and final height (issue 17: +-25 %).
COLUMN_TOL = 0.25
#: Grid resolution and domain (x length 1 m: dx = 1/32 m, the column is 4.8 cells long).
COLUMN_N_GRID = 48
COLUMN_DOMAIN = (1.0, 0.5)  # x length, z height, m
COLUMN_DEPTH = 0.0625  # channel width in y, m (3 cells)
#: A point counts towards the front when the deposit there is thicker than this many point layers.
COLUMN_FRONT_LAYERS = 1.0
#: The pile counts as stopped when no point moves faster than this, m/s.
COLUMN_STOP_SPEED = 0.05


def lube_runout(a: float) -> float:
    """Normalised runout ``(L_inf - L_i) / L_i`` of a quasi-2D granular column, Lube et al. (2005).

    ``1.2 a`` for ``a < 2.3``, ``1.9 a^(2/3)`` above (Phys. Rev. E 72, 041301; see the module
    docstring for where the fit was found).
    """
    return 1.2 * a if a < 2.3 else 1.9 * a ** (2.0 / 3.0)


def lube_height(a: float) -> float:
    """Normalised final height ``H_inf / L_i`` of a quasi-2D granular column, Lube et al. (2005).

    ``a`` for ``a < 1.15`` (the top is untouched), ``a^(2/5)`` above.
    """
    return a if a < 1.15 else a ** 0.4


def plane_strain_dp_angle(phi_mc: float) -> float:
    """The ``Material.friction_angle`` (deg) whose Drucker-Prager cone yields, in plane strain, where
    Mohr-Coulomb at ``phi_mc`` (deg) does.

    ``Material.friction_angle`` sets the cone ``sqrt(J2) = eta p`` with
    ``eta = 6 sin(phi) / (sqrt(3) (3 - sin(phi)))`` (docs/mpm.md, Klar et al. 2016: the cone through
    Mohr-Coulomb's triaxial-compression corners). The channel holds the sand in plane strain
    (``eps_yy = 0``), and the return mapping's plastic flow is deviatoric (no dilatancy), so at
    yield the out-of-plane deviatoric stress vanishes, ``s_yy = 0``: then ``sqrt(J2)`` is the
    largest shear stress ``(sigma_1 - sigma_3) / 2`` and ``p = (sigma_1 + sigma_3) / 2``, and
    Mohr-Coulomb ``(sigma_1 - sigma_3) / 2 = p sin(phi_mc)`` is the cone with ``eta = sin(phi_mc)``.
    Solving ``6 sin(phi) / (sqrt(3) (3 - sin(phi))) = sin(phi_mc)`` gives
    ``sin(phi) = 3 sqrt(3) sin(phi_mc) / (6 + sqrt(3) sin(phi_mc))``: 23.45 deg for 32 deg.
    (With associated flow the plane-strain match is ``eta = 3 tan(phi) / sqrt(9 + 12 tan^2 phi)``,
    de Souza Neto, Peric & Owen 2008, Sec. 6.4: 22.5 deg for 32 deg.)
    """
    s = math.sin(math.radians(phi_mc))
    return math.degrees(math.asin(3 * math.sqrt(3) * s / (6 + math.sqrt(3) * s)))


def flow_dp_angle(phi: float) -> float:
    """The ``Material.friction_angle`` (deg) whose Drucker-Prager cone flows in simple shear at the Coulomb angle
    ``phi`` (deg): ``sqrt(J2) / p = tan(phi)``.

    In a steady simple shear the return mapping's flow is deviatoric and coaxial with the stress, so on the shearing
    plane the shear stress is ``sqrt(J2)`` and the normal stress is ``p``: a layer flows down an incline steeper than
    ``atan(eta)``. A granular material's angle of repose (the angle its layers stop flowing at) is then
    ``atan(eta)``; this is the convention of the mu(I) rheology (Jop, Forterre & Pouliquen 2006, Nature 441:
    ``mu = |tau| / P``, ``mu_s = tan(theta_1)``). :func:`plane_strain_dp_angle` instead puts Mohr-Coulomb's failure
    at ``phi`` on its own critical plane, which in a coaxial continuum flows at ``atan(sin(phi))`` on the shearing
    plane (Davis 1968: ``tan(phi_ds) = sin(phi_ps)`` without dilatancy): 27.9 deg for 32 deg.
    """
    return cone_angle(math.tan(math.radians(phi)))


def cone_angle(eta: float) -> float:
    """The ``Material.friction_angle`` (deg) whose cone has ``sqrt(J2) / p = eta`` (the inverse of
    ``eta = 2 sqrt(3) sin(phi) / (3 - sin(phi))``, docs/mpm.md "The angle a sand flows at")."""
    return math.degrees(math.asin(3.0 * eta / (2.0 * math.sqrt(3.0) + eta)))


def _build_column(info: EngineInfo) -> SimSetup:
    dx = COLUMN_DOMAIN[0] / COLUMN_N_GRID
    m = wall_margin(info, dx)
    z0 = 3 * dx
    H = COLUMN_A * COLUMN_L
    x, p_vol = box_points((m, m, z0), (m + COLUMN_L, m + COLUMN_DEPTH, z0 + H), dx / 2)
    # E only sets the elastic wave speed (c = sqrt(E / rho) ~ 15 m/s, ten times the front speed
    # sqrt(2 g H_i)); the yield is the Drucker-Prager cone whose layers flow at COLUMN_PHI, without
    # cohesion; the base has Coulomb friction tan(COLUMN_PHI).
    return _setup(x, p_vol, Material("sand", E=3.5e5, nu=0.3, rho=1600.0,
                                          friction_angle=flow_dp_angle(COLUMN_PHI)),
                  hi=(COLUMN_DOMAIN[0], 2 * m + COLUMN_DEPTH, COLUMN_DOMAIN[1]), n_grid=COLUMN_N_GRID,
                  frame_dt=0.02,
                  boundaries=[Boundary("ground", height=z0, friction=math.tan(math.radians(COLUMN_PHI))),
                              Boundary("walls", friction=0.0)])


def column_deposit(x: np.ndarray, x_wall: float, z0: float, spacing: float) -> tuple[float, float]:
    """Runout and final height of a quasi-2D deposit, m.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Point positions, m.
    x_wall : float
        The wall (symmetry plane) the column stood against, m.
    z0 : float
        Ground height, m.
    spacing : float
        The initial point spacing, m.

    Returns
    -------
    L_inf : float
        Distance from the wall to the front: the far edge of the farthest column of width
        ``spacing`` (in x) in which the deposit is thicker than ``COLUMN_FRONT_LAYERS`` point layers,
        counted as points per column over the column's number of points in y. A few stray points
        beyond it do not move the front.
    H_inf : float
        Height of the deposit's top above the ground: over columns of width ``2 spacing`` (one
        cell at two points per cell) holding at least one full y row of points, the largest
        ``z`` of the row-th highest point (so a single stray point does not count), plus half a
        spacing for the top layer's own thickness. Lube et al. measure the pile's maximum height
        (at the wall); grid engines make the nodes within 3 dx of a face wall nodes, which
        drags the points touching the wall down by about a cell, so the maximum is taken over
        the whole deposit, not at the wall alone.
    """
    n_y = max(1, int(round(COLUMN_DEPTH / spacing)))
    r = x[:, 0] - x_wall
    bins = np.floor(r / spacing).astype(int)
    counts = np.bincount(bins[bins >= 0])
    thick = np.nonzero(counts > COLUMN_FRONT_LAYERS * n_y)[0]
    L_inf = float((thick.max() + 1) * spacing) if len(thick) else 0.0
    wide = np.floor(r / (2 * spacing)).astype(int)
    tops = [np.sort(x[wide == k, 2])[-n_y] for k in np.unique(wide) if (wide == k).sum() >= n_y]
    H_inf = float(max(tops) - z0 + 0.5 * spacing) if tops else 0.0
    return L_inf, H_inf


def _eval_column(info: EngineInfo, tr: Trace) -> list[Check]:
    dx = tr.setup.dx
    spacing = dx / 2
    x_wall = wall_margin(info, dx)
    z0 = 3 * dx
    L_inf, H_inf = column_deposit(tr.x[-1], x_wall, z0, spacing)
    runout = (L_inf - COLUMN_L) / COLUMN_L
    height = H_inf / COLUMN_L
    r_ref, h_ref = lube_runout(COLUMN_A), lube_height(COLUMN_A)
    r_rel = (runout - r_ref) / r_ref
    h_rel = (height - h_ref) / h_ref
    speed = float(np.sqrt((tr.v[-1] ** 2).sum(axis=1)).max())
    return [_check("runout_vs_lube", abs(r_rel), COLUMN_TOL,
                   f"|(L_inf - L_i)/L_i - 1.2 a| / (1.2 a) at a = {COLUMN_A:g} (measured {runout:.3f}, "
                   f"L_inf {L_inf * 100:.1f} cm; Lube et al. 2005 {r_ref:.3f}; signed {r_rel:+.3f})",
                   measured=runout, expected=r_ref, signed=r_rel),
            _check("height_vs_lube", abs(h_rel), COLUMN_TOL,
                   f"|H_inf/L_i - a^(2/5)| / a^(2/5) at a = {COLUMN_A:g} (measured {height:.3f}, "
                   f"H_inf {H_inf * 100:.1f} cm; Lube et al. 2005 {h_ref:.3f}; signed {h_rel:+.3f})",
                   measured=height, expected=h_ref, signed=h_rel),
            _check("stopped", speed, COLUMN_STOP_SPEED, "max point speed at the end", " m/s")]


SCENES_GRANULAR: list[Scene] = [
    Scene("sand_column_collapse", f"quasi-2D sand column (a = {COLUMN_A:g}, phi {COLUMN_PHI:g} deg) against a "
          f"wall: runout and final height within {COLUMN_TOL:.0%} of Lube et al. (2005), once stopped",
          Requires(frozenset({"sand"}), frozenset({"ground", "walls"})), _build_column, 35, _eval_column),
]
