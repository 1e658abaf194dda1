"""The walls' floor under a ground (round 58; issue 67 item 1, "the same law on the ground, on walls"; docs/contact.md
"Round 58: the walls' floor under a ground").

With the particle contact a ``walls`` boundary's faces are planes ``WALL_NODES`` (3) cells inside the domain's faces
(``gasp_core.mpm.contact.contact_planes``). Before round 58 its floor face stayed a plane in a scene with a ``ground``:
on a ground at ``lo_z + 3 dx`` (the conformance grounds' height) a resting point pressed both planes alike, so the
ground's friction acted on half its weight (the sand column's runout: docs/contact.md "Round 58: the column's step
dependence traced"); on a ground below it the bodies rested on the frictionless floor above the ground. Now a ground is
the floor (``wall_faces``).

The check: the ``slide_to_rest`` conformance slab (4 x 4 x 2 dx jelly launched at 0.5 m/s, ground friction 0.3,
``gasp_core.testing.scenes_support``) inside frictionless walls, its ground at the walls' floor plane, 0.4 cell above
it and 0.7 cell below it (``examples/donut_shatter.toml``'s ground lies 0.9 cell under it): it stops after Coulomb's
``v0^2 / (2 mu g)`` within the scene's tolerance (4 %), as without walls, on both engines. The catch: the floor face
put back (``wall_faces`` returning all six) fails it where the floor plane lies within a skin of the ground or above
it (:data:`CAUGHT`; figures in docs/contact.md); 0.4 cell under the ground (beyond the slab's skin, a quarter cell)
the floor face never acts and the slide is the same either way.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.seam.plugins import get_engine
from gasp_core.seam.setup import Boundary
from gasp_core.testing.helpers import GRAVITY, box_points, make_setup
from gasp_core.testing.kit import run_trace
from gasp_core.testing.scenes_contact import BALL
from gasp_core.testing.scenes_rest import DX, LO, N_GRID, SIDE
from gasp_core.testing.scenes_support import SLIDE_MU, SLIDE_T, SLIDE_TOL, SLIDE_V0, SPACING

ENGINES = ("taichi_mpm", "warp_mpm")
#: The ground's height over the walls' floor plane (``lo_z + 3 dx``), in cells.
OFFSETS = (0.0, 0.4, -0.7)
#: The offsets where the floor face, kept, reaches the slab (on the ground's plane, above it).
CAUGHT = (0.0, -0.7)


def slab_in_walls(offset: float):
    """The ``slide_to_rest`` slab on a ground ``offset`` cells over the walls' floor plane, in frictionless walls."""
    ground = float(LO[2]) + (3.0 + offset) * DX
    lo = np.array([-4.3 * DX, -1.8 * DX, ground])
    x, p_vol = box_points(lo, lo + np.array([4 * DX, 4 * DX, 2 * DX]), SPACING)
    x[:, 2] += ground - (x[:, 2].min() - SPACING / 2)   # the volumes' bottom on the plane
    return make_setup(x, p_vol, BALL, v=np.array([SLIDE_V0, 0.0, 0.0]), lo=LO, hi=LO + SIDE, n_grid=N_GRID,
                      boundaries=[Boundary("ground", height=ground, friction=SLIDE_MU),
                                  Boundary("walls", friction=0.0)])


def slide_error(engine: str, offset: float) -> float:
    """The slab's slide over ``SLIDE_T`` against Coulomb's ``v0^2 / (2 mu g)``, less 1."""
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    tr = run_trace(get_engine(engine), slab_in_walls(offset), round(SLIDE_T * 30))
    c = tr.centroid()
    return float(np.linalg.norm(c[-1, :2] - c[0, :2])) / (SLIDE_V0 ** 2 / (2.0 * SLIDE_MU * GRAVITY)) - 1.0


@pytest.mark.parametrize("offset", OFFSETS)
@pytest.mark.parametrize("engine", ENGINES)
def test_a_slab_in_walls_slides_as_coulomb_says_on_its_ground(engine, offset):
    err = slide_error(engine, offset)
    assert abs(err) <= SLIDE_TOL, err


@pytest.mark.slow
@pytest.mark.parametrize("offset", CAUGHT)
@pytest.mark.parametrize("engine", ENGINES)
def test_catch_the_walls_floor_kept_under_the_ground(engine, offset, monkeypatch):
    import gasp_core.mpm.contact as contact
    monkeypatch.setattr(contact, "wall_faces", lambda setup: [(d, s) for d in range(3) for s in (1.0, -1.0)])
    err = slide_error(engine, offset)
    assert abs(err) > SLIDE_TOL, err
