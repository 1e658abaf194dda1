"""Round 49 (issue 67; docs/contact.md "Round 49: the touched layer shares the column's Coulomb bound"): soft bodies
resting on the grid contact sag as the static estimates say, both MPM engines, two grids
(:func:`gasp_core.testing.sag.sag_ratio`: the centre of mass's mean drop over 0.6 s undamped, less the same body's at
``10 E``, over the estimate's).

Round 47's touch test made the touched node layer (one cell over the plane) stop the normal motion of a soft body's
lowest cell, so the body could not flatten there: ``plugins/taichi_mpm/tests/test_sag.py``'s donut read 0.472 of its
estimate. Round 49's touched layer leaves the normal motion to the body (the dashpot on it, as on the layer above) and
takes only the Coulomb bound its column's held layers left unused.

Family: the README donut (Hertz's line contact plus its fibres' shortening; ``SAG_TOL`` 35 % either way, the reasons
in ``test_sag.py``'s docstring) and a 15 x 15 x 10 cm block with nu 0 (``rho g H^2 / (3 E)``, exact in small strain;
``BLOCK_TOL`` 15 %: its base strain is 10 %, so finite strain and the mean over 5 periods are a few per cent each) on
n_grid 32 and 48; the catch: round 48's rule (``touch_share`` False) must fail the block (it reads 0.607 on n_grid
32, both engines). The ball (Hertz's sphere plus fibres) is measured and not met, by any touch rule: a strict xfail
(``BALL_MISSES``). The runs take 3-25 s each (slow).
"""
from __future__ import annotations

import pytest

from gasp_core.testing.sag import sag_ratio

ENGINES = ["warp_mpm", "taichi_mpm"]
SAG_TOL, BLOCK_TOL = 0.35, 0.15
FAMILY = [("block", 32), ("block", 48), ("donut", 32), ("donut", 48)]
#: The soft ball's sag against Hertz's sphere plus fibres, not met with any touch rule (docs/contact.md "Round 49").
BALL_MISSES = "ratio about 0.47 on n_grid 32 with round 49's rule and with the touched layer off (0.37 round 48's)"


def _tol(shape: str) -> float:
    return BLOCK_TOL if shape == "block" else SAG_TOL


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("shape,n_grid", FAMILY)
def test_a_soft_body_sags_by_the_static_estimate(engine, shape, n_grid):
    r, m, e = sag_ratio(engine, shape, n_grid)
    tol = _tol(shape)
    assert 1.0 - tol <= r <= 1.0 + tol, f"{engine} {shape} n_grid {n_grid}: sag {m * 1e3:.3f} mm against " \
                                        f"{e * 1e3:.3f} mm (ratio {r:.3f})"


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason=BALL_MISSES)
@pytest.mark.parametrize("engine", ENGINES)
def test_a_soft_ball_sags_by_hertz(engine):
    r, m, e = sag_ratio(engine, "ball", 32)
    assert 1.0 - SAG_TOL <= r <= 1.0 + SAG_TOL, f"{engine} ball: ratio {r:.3f}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_sag_check_catches_round_48s_touched_layer(engine, monkeypatch):
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate as cls
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine as cls
    monkeypatch.setattr(cls, "touch_share", False)
    r, m, e = sag_ratio(engine, "block", 32)
    assert not 1.0 - BLOCK_TOL <= r <= 1.0 + BLOCK_TOL, f"{engine}: round 48's rule met the block's sag ({r:.3f})"
