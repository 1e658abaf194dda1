"""The sand's slump against the step (round 55, docs/contact.md "Round 55: the sand's slump against the step").

A block of cohesionless sand (``Material("sand", E=2e4, nu=0.3, friction_angle=30)``, 2 x 2 x 2 points a cell) on the
ground at z = 0.15 m (friction 0.5), frictionless walls, released at rest in the unit box under gravity; after 0.5 s
the drop of its top (the 95th percentile of z, m). Drucker-Prager sand is rate independent and the scene has no rate
in it but gravity's, so the drop must converge as the step shrinks: the check (:func:`step_problems`) runs each block
of :data:`FAMILY` at ``N`` and ``2 N`` substeps a frame (``N = 13 n_grid / 16``, the same Courant number on each
grid) and asks the two drops to agree within :data:`STEP_TOL` either way (a 5 % bias per halving fails it).

Measured (round 55, both engines the same to the digits printed): with the grid contact (the default for sand) the
drop shrinks 19.4 % (n_grid 16) and 5.9 % (32) for the 20 cm cube, 20.8 % and 7.0 % for the 30 x 30 x 15 cm block;
with ``contact = "particle"`` +0.15 %, -2.76 %, +0.63 %, -2.70 %, but at n_grid 16 that sand rests on the walls'
frictionless floor, above the ground (on the ground it moves -11.7 / -19.5 % a halving). The cause named first, the grid
contact's touched layer (the ground's rule on a node inside the sand every substep), is part of it: a rule that sets a
node's velocity at a frictional base loses to the transfer's round trip each substep, on both contacts (docs/contact.md
"Round 55: the touched layer as a rate").

Used by ``tests/test_sand_slump_step.py`` and ``benchmarks/sand_slump_step.py``.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam.setup import Boundary, Material, SimSetup

G = 9.81
#: The blocks (m along x, y, z) and the grids of the check.
FAMILY = {"cube": (0.2, 0.2, 0.2), "wide": (0.3, 0.3, 0.15)}
GRIDS = (16, 32)
#: Substeps a frame at n_grid 16 (the default ``cfl`` gives 13 there); scaled by ``n_grid / 16``.
BASE_SUBSTEPS = 13
#: The largest relative change of the drop from ``N`` to ``2 N`` substeps, either way.
STEP_TOL = 0.03
N_FRAMES = 15
GROUND = 0.15


def block(size=(0.2, 0.2, 0.2), n_grid: int = 16, n_substeps: int | None = None, mu: float = 0.5,
          ppc_axis: int = 2, **options) -> SimSetup:
    """The block of ``size`` (m) on the ground at :data:`GROUND`, centred at x = y = 0.5 in the unit box, ground
    friction ``mu``, frictionless walls; ``n_substeps`` (None: the engine's ``cfl``) and ``options`` as engine
    options."""
    dx = 1.0 / n_grid
    h = dx / ppc_axis
    lo = (0.5 - size[0] / 2, 0.5 - size[1] / 2, GROUND)
    axes = [np.arange(int(round(s / h))) * h + h / 2 + o for s, o in zip(size, lo)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    if n_substeps:
        options["n_substeps"] = int(n_substeps)
    return SimSetup(x=x, v=np.zeros(3), p_vol=h ** 3, body_id=0,
                    materials=[Material("sand", E=2e4, nu=0.3, friction_angle=30.0)],
                    gravity=np.array([0.0, 0.0, -G]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=n_grid, boundaries=[Boundary("ground", height=GROUND, friction=mu),
                                               Boundary("walls", friction=0.0)], options=options)


def drop_and_spread(x0: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """``(drop, spread)`` (m): the fall of the 95th percentile of z and the growth of the ptp of x, from the
    positions ``x0`` to ``x`` (shape (n, 3), m)."""
    drop = np.percentile(x0[:, 2], 95) - np.percentile(x[:, 2], 95)
    return float(drop), float(np.ptp(x[:, 0]) - np.ptp(x0[:, 0]))


def step_problems(drops: dict, tol: float = STEP_TOL) -> list[str]:
    """The check: ``drops`` maps ``(name, n_grid)`` to ``(drop at N, drop at 2 N)`` (m); returns one line per case
    whose relative change ``d(2N) / d(N) - 1`` is beyond ``tol`` either way (empty: it passes). Raises
    ``ValueError`` on a drop at ``N`` that is not positive (the block did not settle down at all)."""
    out = []
    for key, (d1, d2) in drops.items():
        if not d1 > 0.0:
            raise ValueError(f"{key}: drop {d1!r} m at N substeps; expected > 0")
        r = d2 / d1 - 1.0
        if abs(r) > tol:
            out.append(f"{key}: drop {100 * d1:.3f} cm at N, {100 * d2:.3f} cm at 2N ({100 * r:+.2f} %, tolerance "
                       f"{100 * tol:.0f} %)")
    return out
