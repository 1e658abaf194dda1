"""Which points the ground's and walls' position-level hold keeps in the box of
:func:`gasp_core.mpm.points.passive_bounds` after their G2P (each grid engine's ``box_hold``; the rule of
:func:`gasp_core.mpm.points.hold_passive`: a point past a face is put on it, its velocity into the face removed, and
one put on the floor loses the floor's ``mu`` times that removed speed from its horizontal speed).

- The grid contact's deformable bodies (issue 66, round 30): every point. The grid rule acts at the nodes, and a point
  between a stopped node layer and a moving one was carried 1.25 mm under the ground by a landing at 50 m/s.
- Round 97 (issue 66 item 6, ``docs/fracture.md`` "Round 97: the extremes' neighbours"): the particle contact's
  deformable bodies too. Its planes push a point by a penalty ``k depth`` within its skin, which a fast point
  overruns: over ``benchmarks/studies/extremes97.py``'s family (a brittle box and ball at 20 and 50 m/s thrown down,
  into a wall and at 45 degrees, n_grid 32 and 48) the frames showed points up to 2.77 mm (0.22 dx) past a wall's
  plane and 1.93 mm under the ground on 12 of 24 particle-contact runs, and none on the grid contact's.
  A point at rest lies within its skin, above the plane, so the hold acts only on one that has passed the plane
  itself. A point that started behind a plane (a negative skin, ``gasp_core.mpm.contact.contact_coefficients``: a
  capture's vertex through its ground, which the penalty holds at its starting depth) is left to the penalty.
- Rigid bodies are held by their own rule (``rigid_hold``), not this one.
"""
from __future__ import annotations

import numpy as np

#: Round 97: True holds the particle contact's deformable bodies too (module notes); False: the grid contact's alone
#: (the rule before: points up to 0.14 dx past a wall's plane at the frames of a 20 m/s throw).
PARTICLE_HOLD = True
#: The codes of :func:`box_hold_codes`: no hold, every point held, held unless it started behind a plane.
NONE, GRID, PARTICLE = 0, 1, 2


def box_hold_codes(setup, contact: str) -> np.ndarray:
    """Per body, shape ``(len(setup.materials),)``, int32: :data:`GRID` for a deformable body of the grid contact
    (``gasp_core.mpm.contact.flowing_bodies``), :data:`PARTICLE` for a deformable body of the particle contact in a
    scene with a ground or walls (with :data:`PARTICLE_HOLD`), else :data:`NONE` (a rigid body; ``contact`` one of
    ``"grid"``, ``"particle"``, ``"mixed"``: the engine's contact model)."""
    from gasp_core.mpm.contact import flowing_bodies
    from gasp_core.mpm.rigid import rigid_mask
    flows = np.asarray(flowing_bodies(setup, contact), bool)
    rigid = np.asarray(rigid_mask(setup.materials), bool)
    codes = np.where(flows & ~rigid, GRID, NONE)
    planes = any(b.kind in ("ground", "walls") for b in setup.boundaries)
    if PARTICLE_HOLD and planes and contact in ("particle", "mixed"):
        codes = np.where(~flows & ~rigid, PARTICLE, codes)
    return codes.astype(np.int32)
