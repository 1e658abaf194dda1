"""Round 93 (issue 67 items 2 and 4, a round body on a curved convex rigid body; ``docs/rigid.md`` "Round 93: a ball
over a dome"): a rigid ball released at rest 20 degrees from the top of a rigid dome rolls (or slides) down it and
leaves it where Newton says, on both MPM engines.

Round 91 took a round body's normal with a body that is not round from that body's support table, the nearest of rows
about 12 degrees apart: on a curved face up to 7.5 degrees off. The ball ran over the rows' facets, reached 40 degrees
2.4 % early and left the dome 11.6 % early. Where the table reads the face curved (``rigid_support.curved_rows``), the
normal is now round 92's plane fit to the body's outer points nearest the ball.

- **The family** (``benchmarks/studies/roll_dome93.py``): n_grid 32 and 48, the ball's and the dome's Gaussians on
  their spheres or scan-like, mu 0.5 (rolls, then slips near the edge) and 0 (slides): the time to 40 degrees and
  the time to be 5 mm clear of the dome each within :data:`TOL` of the closed form (``roll_dome93.reference``),
  two-sided; and on a mound (a low cap of a 1 m sphere, its slope 5-21 % along the path) the time from 3 to 12
  degrees.
- **The default tier** runs the dome at n_grid 24 on warp_mpm.
- **The catch**: the table's rows (``rigid_support.CURVED`` 0) fail both, on both engines.
- **Round 94, a solid cylinder** across the path, over the same family on both shapes; its catch is round 93's push
  through the centres (``rigid_fit.CYL_SIDE`` 0), under which the scan-like one tipped over the mound.
- **NumPy**: the dome's and the mound's rows and a scanned face read curved, a lattice's faces flat; the normal along
  the ball's path is radial within 0.2 degrees with the rule and 3 degrees or more off without it; the gap is not
  known on a curved row.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

import roll_dome93 as RD  # noqa: E402

from gasp_core.mpm import rigid_support  # noqa: E402

ENGINES = ("warp_mpm", "taichi_mpm")
#: Two-sided, relative, on each time (a 5 % bias fails; the rows miss by 2.4 and 11.6 %).
TOL = RD.TOL


def problem(r: dict) -> str | None:
    bad = [f"{q} {r[q]:.4f} s against {r['want'][q]:.4f} ({100 * e:+.2f} %)" for q, e in r["err"].items()
           if not abs(e) <= TOL]
    return None if not bad else f"n_grid {r['n_grid']} {r['sampling']} mu {r['mu']}: " + "; ".join(bad)


def test_the_reference_leaves_where_the_closed_forms_say():
    """Rolling throughout (mu large) it leaves at ``cos = 2 cos theta_0 / (3 + k)`` (56.4 degrees for k 0.4; it slips
    only as ``N`` vanishes), sliding (k 0) at ``2 cos theta_0 / 3`` (51.2)."""
    c0 = math.cos(math.radians(RD.THETA0))
    assert RD.reference(0.0, 0.0)["leave_deg"] == pytest.approx(math.degrees(math.acos(2 * c0 / 3)), abs=0.02)
    assert RD.reference(0.4, 100.0)["leave_deg"] == pytest.approx(math.degrees(math.acos(2 * c0 / 3.4)), abs=0.1)
    assert RD.reference(0.4, 0.5)["t1"] > RD.reference(0.0, 0.0)["t1"]   # rolling is slower


@pytest.mark.parametrize("engine", [pytest.param("warp_mpm"), pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_a_ball_leaves_a_rigid_dome_where_newton_says(engine):
    """n_grid 24 (warp_mpm about 10 s, the default tier): -0.72 % to 40 degrees, +0.28 % to leave (the rows: -2.56
    and -10.88 %)."""
    pytest.importorskip(f"gasp_{engine}")
    r = RD.row(engine, 24, "fibonacci", 0.5)
    assert problem(r) is None, f"{engine}: {problem(r)}"


@pytest.mark.slow
@pytest.mark.parametrize("shape", ("dome", "mound"))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_ball_rolls_over_a_rigid_dome_or_mound_across_the_family(engine, shape):
    pytest.importorskip(f"gasp_{engine}")
    bad = [p for p in (problem(RD.row(engine, *case, shape=shape)) for case in RD.family()) if p]
    assert not bad, f"{engine} {shape}: " + "; ".join(bad)


@pytest.mark.slow
@pytest.mark.parametrize("shape", ("dome", "mound"))
@pytest.mark.parametrize("engine", ENGINES)
def test_a_cylinder_rolls_over_a_rigid_dome_or_mound_across_the_family(engine, shape):
    """A solid cylinder lying across the path touches the sphere at its middle: the same closed form with its ``k``
    (0.5); its normal is the fit to the points nearest its axis's segment, and (round 94) the pair pushes at its foot
    (``rigid_fit.side_foot``). On the rows it left the dome 14.1 % early and stuck on a facet of the mound (warp_mpm,
    n_grid 32); pushed through its centre the scan-like one tipped over the mound and arrived 15.0 % slow."""
    pytest.importorskip(f"gasp_{engine}")
    bad = [p for p in (problem(RD.row(engine, *case, shape=shape, body="cylinder")) for case in RD.family()) if p]
    assert not bad, f"{engine} {shape}: " + "; ".join(bad)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_cylinder_check_catches_a_push_through_the_centres(engine, monkeypatch):
    """Round 93's law (``rigid_fit.CYL_SIDE`` 0): the scan-like cylinder rolling over the mound at n_grid 32 tips
    sideways (its axis 20 degrees down by 12 degrees of travel) and arrives 15.0 % slow."""
    pytest.importorskip(f"gasp_{engine}")
    from gasp_core.mpm import rigid_fit
    monkeypatch.setattr(rigid_fit, "CYL_SIDE", 0)
    r = RD.row(engine, 32, "scan", 0.5, shape="mound", body="cylinder")
    assert problem(r) is not None, f"{engine}: round 93's law passed ({r['err']})"


@pytest.mark.slow
@pytest.mark.parametrize("shape", ("dome", "mound"))
@pytest.mark.parametrize("engine", ENGINES)
def test_the_dome_check_catches_the_tables_rows(engine, shape, monkeypatch):
    pytest.importorskip(f"gasp_{engine}")
    monkeypatch.setattr(rigid_support, "CURVED", 0)
    r = RD.row(engine, 32, "fibonacci", 0.5, shape=shape)
    assert problem(r) is not None, f"{engine} {shape}: the rows passed ({r['err']})"


# --------------------------------------------------------------------------- NumPy
def _dome(n_grid: int = 32, sampling: str = "fibonacci", shape: str = "dome"):
    from gasp_core.mpm.hollow import outer_points
    from gasp_core.mpm.rigid_support import round_table, support_table
    RD.use(shape)
    s = RD.BOX / n_grid / 2
    X = RD.dome_points(s, sampling)
    cm = X.mean(0)
    table = support_table(X - cm, s)
    ball = (table[0], *round_table(table[0], np.array([RD.BALL_R, 0.0, 0.0, 0.0, 0.0])), table[3])
    Xo, so = outer_points(X - cm)
    return table, ball, cm, (Xo, so, np.zeros(3), 0.0, RD.BALL_R)


def _path():
    for th in np.radians(np.linspace(0.0, 55.0 if RD.OFF else RD.THETA1, 56)):
        radial = np.array([math.sin(th), 0.0, math.cos(th)])
        yield radial, RD.DOME_C + (RD.DOME_R + RD.BALL_R) * radial


def test_a_dome_a_mound_and_a_scanned_face_read_curved_and_a_lattices_faces_flat():
    import roll_pair90
    from gasp_core.mpm.rigid_support import support_table
    from gasp_core.testing.helpers import box_points
    for shape in ("dome", "mound"):
        table, _, _, _ = _dome(shape=shape)
        assert rigid_support.curved_rows(table[1], table[2]).mean() > 0.9, shape
    X, _ = box_points((-0.12, -0.12, 0.0), (0.20, 0.12, 0.03), 0.01)
    box = support_table(X - X.mean(0), 0.01)
    faces = np.flatnonzero(np.isclose(np.abs(box[0]), 1.0).any(axis=1))   # the rest frame's axes
    assert len(faces) >= 6 and not rigid_support.curved_rows(box[1], box[2])[faces].any()
    Y = np.concatenate([roll_pair90.scan_top(0.02), X])   # the same slab scanned: its top is not an exact plane
    scan = support_table(Y - Y.mean(0), 0.01)
    top = int(np.argmax(scan[0] @ np.array([0.0, 0.0, 1.0])))
    assert rigid_support.curved_rows(scan[1], scan[2])[top] == 1.0


@pytest.mark.parametrize("shape", ("dome", "mound"))
@pytest.mark.parametrize("curved, worst", ((1, (0.0, 0.2)), (0, (3.0, 90.0))))
def test_the_normal_over_a_dome_is_radial_only_from_its_outer_points(curved, worst, shape, monkeypatch):
    monkeypatch.setattr(rigid_support, "CURVED", curved)
    table, ball, cm, outer = _dome(shape=shape)
    cone, I = math.cos(math.radians(20.0)), np.eye(3)
    off = []
    for radial, c in _path():
        n = rigid_support.round_normal(table, I, cm, ball, I, c, radial, cone, outer=outer)
        off.append(math.degrees(math.acos(min(1.0, float(n @ radial)))))
        gap = rigid_support.pair_gap(table, I, cm, 0.0, ball, I, c, 1.0, n, cone)
        assert (gap < -1e29) == bool(curved), gap   # no gap known on a curved row
    assert worst[0] <= max(off) < worst[1], max(off)
