"""Round 87 (issue 67 item 2, ``docs/rigid.md`` "Round 87: the rolling ball's neighbours"): ``tests/test_rolling.py``'s
rigid ball on its 20 degree slope at other radii and grids than the test's own (R 0.1 m at n_grid 24), judged by that
test's two-sided check (``test_rolling.check``: rolling at mu 0.5, ``(5/7) g sin theta`` and ``omega R / v`` within 5 %;
slipping at mu 0.05, Coulomb's ``g (sin - mu cos)`` and the spin-up ``mu g cos t / k`` within 5 %), built as the test
builds it (``benchmarks/studies/roll_sizes87.py``: its Gaussians a Fibonacci shell whose count scales with its area,
3,217 at 0.1 m, over a lattice fill at ``dx / 2``).

Measured (warp_mpm; taichi_mpm the same to the digits shown where run, R 0.05 at n_grid 24 and 48): the slip's
translation is Coulomb's on every case (within 0.02 %), but its spin-up falls short on five of the ten neighbours,
by up to 43.5 %, and the 5 cm ball's roll at n_grid 48 is 6.5 % slow. Those are strict xfails (``MISSES``) with their
figures. The spin-up follows how densely the Gaussians sample the ball, not the grid alone. On the flat ground, a ball
thrown sliding at 0.5 m/s at mu 0.05 spins up at 0.21 of ``mu g / k`` (R 0.05 m, n_grid 48, 804 Gaussians) and at
0.97 with 3,217. The 10 cm ball at n_grid 24 spins up at 0.999 with 3,217 and at 0.625 with 200. The cause (round 87,
found, not fixed): the body rests on its Gaussians, so a ball rolls as the polyhedron they sample, each vertex that
comes down an inelastic impact (rolling resistance ``c_rr`` 0.023 with 804 Gaussians on the 5 cm ball, 0.0023 with
3,217); the next class is the ground contact on the round body's exact shape (``roll_contact``'s sphere).

The checks are ``test_rolling``'s, each shown failing on engines broken on purpose there
(``test_rolling.test_the_checks_catch_broken_engines``); here the family fails the five neighbours above.
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest
from slopes import ENGINES

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
import roll_sizes87 as RS  # noqa: E402

RADII = (0.05, 0.1)
GRIDS = (24, 32, 48)
#: Measured misses (round 87, warp_mpm; both engines where run): (R, n_grid, mu) -> the check's figure.
MISSES = {
    (0.05, 24, 0.05): "spin-up omega R at 0.3 s 0.3083 m/s against 0.3457 (-10.82 %)",
    (0.05, 32, 0.05): "spin-up omega R at 0.3 s 0.2520 m/s against 0.3457 (-27.10 %)",
    (0.05, 48, 0.5): "a = 2.2410 m/s^2 against 2.3966 (-6.49 %)",
    (0.05, 48, 0.05): "spin-up omega R at 0.3 s 0.1953 m/s against 0.3457 (-43.50 %)",
    (0.1, 48, 0.05): "spin-up omega R at 0.3 s 0.3060 m/s against 0.3457 (-11.49 %)",
}


def _cases():
    for radius in RADII:
        for n_grid in GRIDS:
            if (radius, n_grid) == (0.1, 24):
                continue   # test_rolling's own case
            for mu in RS.MUS:
                why = MISSES.get((radius, n_grid, mu))
                marks = [pytest.mark.xfail(strict=True, reason=why)] if why else []
                yield pytest.param(radius, n_grid, mu, marks=marks, id=f"R{radius}-n{n_grid}-mu{mu}")


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("radius,n_grid,mu", list(_cases()))
def test_a_rigid_ball_rolls_or_slips_at_other_sizes_and_grids(engine, radius, n_grid, mu):
    pytest.importorskip(f"gasp_{engine}")
    r = RS.row(engine, radius, n_grid, mu)
    assert r["problem"] is None, f"{engine}, R {radius}, n_grid {n_grid}: {r['problem']}"


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=(
    "round 87: the 5 cm ball on n_grid 48 (R 4 dx, 804 Gaussians) rolls at 2.2410 m/s^2 against 5/7 g sin's "
    "2.3966 (-6.49 %) and slipping spins up to 0.1953 m/s against 0.3457 (-43.50 %); both engines"))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_5_cm_rigid_ball_rolls_and_slips_as_the_10_cm_one(engine):
    """The worst neighbour of ``docs/must_shows.md``'s rolling row, as one test: rolling at mu 0.5 and slipping at
    mu 0.05 both within ``test_rolling``'s check."""
    pytest.importorskip(f"gasp_{engine}")
    problems = [p for mu in RS.MUS if (p := RS.row(engine, 0.05, 48, mu)["problem"])]
    assert not problems, problems
