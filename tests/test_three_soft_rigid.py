"""Round 64 (issue 67 item 4, ``docs/rigid.md`` "Round 64: the rigid collider among three or more bodies"): in scenes
of three or more bodies with a rigid one, every rigid body that meets a soft one is a moving collider of the soft
field (``gasp_core.mpm.rigid_collider``, :data:`~gasp_core.mpm.rigid_collider.MULTI`), and every interface rests.

Scenes (``benchmarks/studies/collider_three.py``'s ``rest_setup``: jelly rho 1000, frames of 1/60 s, a frictionless
ground, at rest at t = 0): ``sandwich`` (rigid 6 x 6 x 3 cm / jelly 28 x 16 x 8 cm / rigid 32 x 20 x 3 cm, top first),
``rjj`` (the same rigid / jelly / jelly) and ``beside`` (a 6 cm jelly cube and a 6 x 6 x 3 cm rigid block side by side
on a 40 x 16 x 3 cm rigid slab). Each interface's gap (the upper body's lowest point less the lower's highest under
it): its drift from 0.3 to 1.0 s and its settle from the start to 0.3 s within ``DRIFT_TOL`` = 0.1 dx either way
(``tests/test_soft_on_rigid_rest.py``'s limit). Before the rule the sandwich's jelly sank into its bottom block,
-0.65 dx in 0.7 s at n_grid 32 (E 1e5).

The thrown top block of the sandwich (``scenes_rigid3.slide_setup`` rigid / jelly / rigid, mu 0.5) takes Coulomb's
friction while it slides: the friction impulse over the normal one within ``SLIDE_TOL`` of ``mu``
(``scenes_rigid3.measure_slide_mu``, round 67: warp_mpm n_grid 32 and 48, taichi_mpm 32), and at n_grid 48 it slides
within ``SLIDE_TOL`` of Coulomb's closed form (``measure_slide`` as ``tests/test_rigid_three.py``; before the rule:
+4.15 % at n_grid 32, +6.25 % at 48). Round 67 dropped the slide's length at n_grid 32 from the check: it reads
-2.7 % there (the jelly rings under the 2-cell block, which loses its load for frames, so the closed form's steady
``N = m g`` does not hold over the 0.1 s slide), and an engine with 5 % less friction slid +2.7 % and passed it; the
ratio reads -0.03 % and that engine -4.8 % (``docs/rigid.md`` "Round 67: the sandwich's slide").

The default tier holds the NumPy reference of the node's owner (:func:`test_the_owner_reference`); the engine runs
are slow (``tests/slow_tier.txt``).
"""
from __future__ import annotations

import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.mpm import rigid_collider as RC
from gasp_core.testing import scenes_rigid3 as S
from gasp_testing import needs_package

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
from collider_three import measure_rest  # noqa: E402

DRIFT_TOL = 0.1   # of dx, each interface's drift 0.3 -> 1.0 s and settle 0 -> 0.3 s
SLIDE_TOL = 0.035   # of Coulomb's slide, two-sided (tests/test_rigid_three.py's)


def _holds(r) -> bool:
    return bool(np.all(np.abs(r["drift"]) < DRIFT_TOL) and np.all(np.abs(r["settle"]) < DRIFT_TOL))


def _say(r) -> str:
    return ", ".join(f"{a}/{b}: drift {d:+.3f} settle {s:+.3f} dx" for (a, b), d, s in
                     zip(r["pairs"], r["drift"], r["settle"]))


def _slide_error(engine: str, n_grid: int) -> float:
    r = S.measure_slide(engine, S.slide_setup(n_grid, 0.5, models=("rigid", "elastic", "rigid")))
    return r["slide"] / r["closed"] - 1.0


def _mu_error(engine: str, n_grid: int) -> float:
    """The sliding block's friction over normal impulse against ``mu``, less 1 (``measure_slide_mu``)."""
    r = S.measure_slide_mu(engine, S.slide_setup(n_grid, 0.5, models=("rigid", "elastic", "rigid")))
    return r["mu"] / r["mu_closed"] - 1.0


@pytest.fixture
def rule(monkeypatch):
    """The rule on (``RIGID_COLLIDER`` and ``MULTI``), whatever the defaults."""
    monkeypatch.setattr(RC, "RIGID_COLLIDER", True)
    monkeypatch.setattr(RC, "MULTI", True)


#: (engine, case, n_grid, E): the family; taichi_mpm at n_grid 32 only (its n_grid 48 not run, docs/rigid.md).
FAMILY = [(e, c, n, E) for e in ("warp_mpm", "taichi_mpm") for c in ("sandwich", "rjj", "beside")
          for n in ((32, 48) if e == "warp_mpm" else (32,)) for E in (1.0e5, 1.0e6)]


@pytest.mark.slow
@pytest.mark.parametrize("engine,case,n_grid,E", FAMILY)
def test_every_interface_rests(engine, case, n_grid, E, rule):
    needs_package(f"gasp_{engine}")
    r = measure_rest(engine, case, n_grid, E)
    assert _holds(r), f"{engine} {case} n_grid {n_grid} E {E:g}: {_say(r)}"


@pytest.mark.slow
@pytest.mark.parametrize("engine,n_grid", [("warp_mpm", 32), ("warp_mpm", 48), ("taichi_mpm", 32)])
def test_the_sandwich_slides_as_coulomb(engine, n_grid, rule):
    """Coulomb's ratio while it slides (every row; measured -0.03 % at n_grid 32, +0.01 % at 48) and the slide's
    length at n_grid 48 (+0.10 %; at 32 it reads -2.7 % and cannot fail a 5 % bias: the module notes)."""
    needs_package(f"gasp_{engine}")
    err = _mu_error(engine, n_grid)
    assert abs(err) < SLIDE_TOL, f"{engine} n_grid {n_grid}: friction over normal impulse {100 * err:+.2f} % of mu"
    if n_grid >= 48:
        err = _slide_error(engine, n_grid)
        assert abs(err) < SLIDE_TOL, f"{engine} n_grid {n_grid}: the slide {100 * err:+.2f} % of Coulomb's"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm"])
def test_the_checks_catch_broken_engines(engine, monkeypatch, rule):
    """The rule off for three or more bodies (``MULTI`` False: the sandwich's jelly sinks into its bottom block, -0.65
    dx), no reaction on the bodies (``REACT`` 0: the top block falls into the jelly, settle -4.8 dx), the collider
    frictionless (``FRICTION`` 0: the thrown block slides +500 %), and its friction 5 % low or high (``FRICTION``
    1/1.05 and 1.05: at n_grid 32 the ratio reads -4.8 % and +5.0 %, where the slide's length read +2.7 % for the
    first and passed; at 48 the length +5.4 % and -4.8 %) each fail a check."""
    needs_package(f"gasp_{engine}")
    mod = importlib.import_module(f"gasp_{engine}.rigid_collider")
    caught = {}
    monkeypatch.setattr(RC, "MULTI", False)
    caught["rule off"] = not _holds(measure_rest(engine, "sandwich", 32, 1.0e5))
    monkeypatch.setattr(RC, "MULTI", True)
    monkeypatch.setattr(mod, "REACT", 0)
    caught["no reaction"] = not _holds(measure_rest(engine, "sandwich", 32, 1.0e5))
    monkeypatch.setattr(mod, "REACT", 1)
    monkeypatch.setattr(mod, "FRICTION", 0.0)
    caught["frictionless"] = abs(_slide_error(engine, 32)) >= SLIDE_TOL
    for name, f in (("friction 5 % low", 1.0 / 1.05), ("friction 5 % high", 1.05)):
        monkeypatch.setattr(mod, "FRICTION", f)
        caught[f"{name}, n_grid 32 (ratio)"] = abs(_mu_error(engine, 32)) >= SLIDE_TOL
        caught[f"{name}, n_grid 48 (length)"] = abs(_slide_error(engine, 48)) >= SLIDE_TOL
    assert all(caught.values()), caught


def test_the_owner_reference():
    """``gasp_core.mpm.rigid_collider.collider_owner``: a node between a rigid body and a soft one is the rigid
    body's slot whichever field holds it; between two rigid bodies of the two fields (a rigid pair) or beyond every
    rigid body's pad, no slot; of two rigid bodies of one field, the nearer's; the body's frame is its own."""
    dx = 0.01
    # bodies: 0 rigid (field A), 1 soft (B), 2 rigid (A), 3 rigid (B); the rigid slots 0, 2, 3
    in_a = np.array([True, False, True, False])
    bodies = [0, 2, 3]
    centre = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.1], [0.5, 0.0, 0.0], [0.5, 0.0, 0.1]])
    rot = np.tile(np.eye(3), (4, 1, 1))
    boxes = np.tile(np.array([[-0.03, -0.03, -0.015], [0.03, 0.03, 0.015]]), (4, 1, 1))
    pad = 1.5 * dx
    own = RC.collider_owner
    assert own([0.0, 0.0, 0.02], in_a, bodies, centre, rot, boxes, pad) == 0     # over body 0: its slot
    assert own([0.5, 0.0, 0.02], in_a, bodies, centre, rot, boxes, pad) == 1     # body 2 (A) alone there
    assert own([0.5, 0.0, 0.08], in_a, bodies, centre, rot, boxes, pad) == 2     # body 3 (B) alone there
    assert own([0.0, 0.0, 0.05], in_a, bodies, centre, rot, boxes, pad) == -1    # beyond every pad: soft on soft
    near = centre.copy()
    near[3] = [0.5, 0.0, 0.04]   # body 3 lowered onto body 2: a rigid pair
    assert own([0.5, 0.0, 0.02], in_a, bodies, near, rot, boxes, pad) == -1
    turned = rot.copy()   # body 0 turned 90 deg about x: its 3 cm half-width now along z
    turned[0] = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
    assert own([0.0, 0.0, 0.04], in_a, bodies, centre, turned, boxes, pad) == 0
    assert own([0.0, 0.0, 0.04], in_a, bodies, centre, rot, boxes, pad) == -1
