"""Conformance scene ``mass_agreement``: every engine simulates the setup's mass and centre of mass.

A torus (a donut: its hole must stay empty) of material points at ``dx / 2`` spacing, with a
surface layer of half-volume points on one side (so the volumes vary and the centre of mass is
off the torus centre), and passive surface points (``SimSetup.passive``, ``p_vol = 0``) on the
tube's surface. Right after the build (nothing has moved) the engine's ``stats()`` must report
``mass`` (kg) within :data:`MASS_TOL` of ``sum rho p_vol`` and ``centre_of_mass`` (m) within
:data:`COM_TOL` of the object's size (the diagonal of its bounding box, as in
``docs/speed_accuracy.md``) of the setup's. Both residuals are reported as the checks' ``value``.
An engine that gave every material point the same mass (the mean) would put the centre of mass
1.4 % of the size off, and one that gave the passive points
the mean volume too would be 23 % off in mass: both fail. An engine without the feature
``passive_points`` runs through the core's embedding (:mod:`gasp_core.seam.passive`).
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.build import build_engine
from gasp_core.seam.engine import call_engine, EngineInfo
from gasp_core.seam.passive import setup_mass_properties
from gasp_core.seam.setup import Material, SimSetup
from gasp_core.testing.helpers import box_points, Check
from gasp_core.testing.kit import Requires, Scene

#: Relative tolerance on the total mass.
MASS_TOL = 0.02
#: Tolerance on the centre of mass, as a share of the object's size (bounding-box diagonal).
COM_TOL = 0.01

R_MAJOR, R_MINOR = 0.2, 0.08
CENTRE = np.array([0.5, 0.5, 0.5])
N_GRID = 24


def torus_setup() -> SimSetup:
    """The ``mass_agreement`` setup (domain ``[0, 1]^3``, ``n_grid`` 24, jelly, no gravity)."""
    dx = 1.0 / N_GRID
    h = dx / 2
    lo = CENTRE - (R_MAJOR + R_MINOR)
    x, _ = box_points(lo, CENTRE + (R_MAJOR + R_MINOR), h)
    r = x - CENTRE
    tube = np.hypot(np.hypot(r[:, 0], r[:, 1]) - R_MAJOR, r[:, 2])
    fill = x[tube <= R_MINOR]
    vol = np.full(len(fill), h ** 3)
    # one side (x > centre) carries a denser skin: half-volume points beside the outer cells
    skin = fill[(tube[tube <= R_MINOR] > R_MINOR - h) & (fill[:, 0] > CENTRE[0])]
    skin = skin + np.array([0.25 * h, 0.0, 0.0])
    # passive points on the tube's surface
    u, w = np.meshgrid(np.linspace(0, 2 * math.pi, 48, endpoint=False),
                       np.linspace(0, 2 * math.pi, 16, endpoint=False), indexing="ij")
    u, w = u.ravel(), w.ravel()
    surf = CENTRE + np.stack([(R_MAJOR + R_MINOR * np.cos(w)) * np.cos(u),
                              (R_MAJOR + R_MINOR * np.cos(w)) * np.sin(u), R_MINOR * np.sin(w)], axis=1)
    x = np.concatenate([surf, fill, skin])
    p_vol = np.concatenate([np.zeros(len(surf)), vol, np.full(len(skin), 0.5 * h ** 3)])
    passive = np.zeros(len(x), bool)
    passive[:len(surf)] = True
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=0, materials=[Material("jelly", E=1e5, nu=0.3, rho=500.0)],
                    gravity=np.zeros(3), domain_lo=np.zeros(3), domain_hi=np.ones(3), n_grid=N_GRID,
                    frame_dt=1.0 / 30.0, n_render=len(surf), passive=passive)


def _run_mass(info: EngineInfo) -> list[Check]:
    setup = torus_setup()
    want = setup_mass_properties(setup)
    size = float(np.linalg.norm(np.ptp(setup.x, axis=0)))
    engine = build_engine(info, setup)
    try:
        st = dict(call_engine(info, "stats", engine.stats))
    finally:
        call_engine(info, "close", engine.close)
    if "mass" not in st or "centre_of_mass" not in st:
        return [Check("mass_reported", False, f"stats() lacks 'mass' or 'centre_of_mass' (keys: {sorted(st)})")]
    rel = abs(float(st["mass"]) / want["mass"] - 1.0)
    dc = float(np.linalg.norm(np.subtract(st["centre_of_mass"], want["centre_of_mass"]))) / size
    checks = [
        Check("total_mass", rel <= MASS_TOL,
              f"|M_engine / M_setup - 1| = {rel:.4g} (limit {MASS_TOL:g}; engine {float(st['mass']):.6g} kg, "
              f"setup {want['mass']:.6g} kg)", {"value": rel, "limit": MASS_TOL, "mass": float(st["mass"]),
                                               "mass_setup": want["mass"]}),
        Check("centre_of_mass", dc <= COM_TOL,
              f"|c_engine - c_setup| / size = {dc:.4g} (limit {COM_TOL:g}; size {size:.3g} m)",
              {"value": dc, "limit": COM_TOL}),
    ]
    return checks


SCENES_MASS: list[Scene] = [
    Scene("mass_agreement", f"torus with a denser skin on one side and passive surface points: stats() mass "
          f"within {MASS_TOL:.0%} and centre of mass within {COM_TOL:.0%} of the size of sum rho p_vol's",
          Requires(materials=frozenset({"jelly"})), run=_run_mass),
]
