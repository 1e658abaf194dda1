"""Sand in a closed box of ``walls`` (issue 67 item 5: granular material stays outside what it meets): a block of sand
filling the walls' planes on all four sides, its floor the domain's lower wall, settling under its own weight.

Known answer: laterally confined by frictionless walls, the block is in uniaxial strain; under its weight, switched on
at once, its top rings about the settlement ``u = rho g H^2 / (2 M)`` between 0 and ``2 u`` (``M = E (1 - nu) / ((1 +
nu)(1 - 2 nu))``, the constrained modulus): its largest sink is ``2 u``, ``2 u / H = rho g H / M``, 0.50 % of ``H``
for the columns, 0.25 % for the slab. The check: the top layer's largest mean sink over the frames within
:data:`PEAK_TOL` (4 %) of ``2 u`` either way (the sand neither creeps into the walls nor swells), and no point's centre
past a wall's plane (``gasp_core.mpm.points.WALL_NODES`` cells inside the domain's faces) by more than :data:`PAST_TOL`
cells. Before round 32 the walls' grid rule left the node layer on each plane free: the column sank 11 % of ``H``
(22 times ``2 u``).

Used by ``tests/test_sand_box.py``.
"""
from __future__ import annotations

import numpy as np

from gasp_core.mpm.points import WALL_NODES
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, make_setup

E, NU, RHO, PHI = 3.5e5, 0.3, 1600.0, 32.0
#: The boxes (cells along x, y, z of sand) and the block's height H (m): a column and a slab, at two grids.
BOXES = {"column": ((6, 6, 12), 0.15), "column_fine": ((12, 12, 24), 0.15), "slab": ((24, 6, 6), 0.075)}
FRAME_DT = 0.01
N_FRAMES = 30
#: The largest sink against ``2 u``, either way (module notes).
PEAK_TOL = 0.04
#: Cells a point's centre may pass a wall's plane.
PAST_TOL = 0.02


def box_setup(name: str, contact: str = "grid") -> SimSetup:
    """The sand block ``name`` of :data:`BOXES` in its closed box (module notes)."""
    (nx, ny, nz), H = BOXES[name]
    dx = H / nz
    w = WALL_NODES * dx
    cells = np.array([nx, ny, nz]) + 2 * WALL_NODES + np.array([0, 0, 4])
    n_grid = int(cells.max())
    lo = np.array([w, w, w])
    x, p_vol = box_points(lo, lo + dx * np.array([nx, ny, nz]), dx / 2)
    return make_setup(x, p_vol, Material("sand", E=E, nu=NU, rho=RHO, friction_angle=PHI), lo=np.zeros(3),
                      hi=cells * dx, n_grid=n_grid, frame_dt=FRAME_DT, boundaries=[Boundary("walls", friction=0.0)],
                      options={"contact": contact})


def measure(xs: list[np.ndarray], setup: SimSetup) -> dict:
    """From the frames ``xs`` (list of (n, 3) positions, m, frame 0 first): ``sink`` (the top layer's largest mean sink
    over ``H``, signed: negative where it rose most) and ``past`` (cells: the furthest any point's centre passed a
    wall's plane, 0 if none)."""
    x0 = xs[0]
    top = x0[:, 2] > x0[:, 2].max() - 1e-9
    H = x0[:, 2].max() - x0[:, 2].min() + setup.dx / 2
    sinks = np.array([(x0[top, 2] - x[top, 2]).mean() for x in xs[1:]]) / H
    dx = setup.dx
    lo, hi = setup.domain_lo + WALL_NODES * dx, setup.domain_hi - WALL_NODES * dx
    past = max(float(np.max(np.maximum(lo[:2] - x[:, :2], x[:, :2] - hi[:2]))) for x in xs) / dx
    return {"sink": float(sinks[np.argmax(np.abs(sinks))]), "past": max(past, 0.0)}


def peak(setup: SimSetup) -> float:
    """The known answer: the largest sink ``2 u / H = rho g H / M`` of the block of ``setup`` (module notes)."""
    H = float(np.ptp(setup.x[:, 2])) + setup.dx / 2
    return RHO * 9.81 * H * (1 + NU) * (1 - 2 * NU) / (E * (1 - NU))


def problems(r: dict, setup: SimSetup) -> list[str]:
    """What a :func:`measure` row of ``setup``'s block breaks (module notes); empty when it meets the known answer."""
    out, known = [], peak(setup)
    if not abs(r["sink"] / known - 1.0) <= PEAK_TOL:
        out.append(f"the top sank at most {r['sink']:+.3%} of H, against {known:.3%} (within {PEAK_TOL:.0%})")
    if not r["past"] <= PAST_TOL:
        out.append(f"a point passed a wall's plane by {r['past']:.3f} cells (at most {PAST_TOL})")
    return out
