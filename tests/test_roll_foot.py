"""Round 94 (issue 67 items 2 and 4, a solid cylinder on a curved rigid body; ``docs/rigid.md`` "Round 94: a
cylinder's foot"): where a cylinder's side bears on a fitted surface, its foot and normal (NumPy,
``gasp_core.mpm.rigid_fit.hollow_contact``). The engines' runs are in ``tests/test_roll_dome.py``.

A cylinder lying on a sphere touches it at the foot of the perpendicular from the sphere's centre to its axis; once
its axis tilts, the foot moves along the axis (by the sphere's radius per radian, a board on a log), and the push
there rights it. Round 93 pushed through the centres with the plane fit's normal, which leans along the axis as the
patch is cut off at the cylinder's ends: a scan-like cylinder across a 1 m mound tipped sideways and arrived 15 %
slow.

**The reference:** the rule (``rigid_fit.side_foot``: the mean of the axial coordinate weighted by ``max(band - (gap -
least gap), 0)``) applied to the exact surface's gap, ``|c + t e| - R_s`` (a sphere of radius ``R_s`` about the
origin) or ``t sin(tilt)`` (a plane). The fit must give it from the body's points: even ones on spheres of 0.2, 1 and
5 m (random, on the surface) within :data:`FOOT_EVEN`; the outer points the engines read of ``roll_dome93``'s dome
and mound (their fill and their Gaussians, Fibonacci or scan-like, n_grid 32 and 48) within :data:`FOOT_EVEN` and
:data:`FOOT_SCAN`. The normal within :data:`NORMAL_DEG` of the exact one. The catch: round 93's fit (``CYL_SIDE`` 0)
puts the foot at the middle.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.mpm import rigid_fit

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))

#: The cylinder (``roll_family88``'s: R 5 cm, 15 cm long) and the other body's point spacing (n_grid 32's fill, m).
R, HALF, SPACING = 0.05, 0.075, 0.6 / 32 / 2
#: Tolerances (m, degrees): the foot from even points, the normal (measured worst 0.74 mm and 0.69 degrees over the
#: family); the foot from the scan-like dome's and mound's (measured 3.4 and 2.6 mm; the mound's was 8.7 mm until
#: round 95, when the study's block top cut its outward-jittered Gaussians within 5.6 cm of its top).
FOOT_EVEN, NORMAL_DEG, FOOT_SCAN = 0.001, 1.0, 0.004


def cap(radius: float, jitter: bool, seed: int = 3) -> np.ndarray:
    """Points (m) on the cap of the sphere of ``radius`` about the origin within 0.5 m of its top (at most 0.5 rad), at
    random at the spacing's areal density; ``jitter``: each moved along its normal by up to a quarter spacing."""
    rng = np.random.default_rng(seed)
    half_angle = min(0.5, 0.5 / radius)
    n = int(2 * math.pi * radius ** 2 * (1 - math.cos(half_angle)) / SPACING ** 2)
    z = rng.uniform(math.cos(half_angle), 1.0, n)
    phi = rng.uniform(0.0, 2 * math.pi, n)
    u = np.c_[np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z]
    return u * (radius + (rng.uniform(-SPACING / 4, SPACING / 4, n) if jitter else np.zeros(n)))[:, None]


def rule(gap, spacing: float = SPACING) -> float:
    """``side_foot``'s weighting on an exact gap ``gap(t)`` (m, ``t`` m along the axis from the centre), its band of
    the other body's ``spacing``."""
    tk = -1.0 + (np.arange(rigid_fit.FOOT_SAMPLES) + 0.5) * 2.0 / rigid_fit.FOOT_SAMPLES
    g = gap(tk * HALF)
    p = np.clip(rigid_fit.FOOT_BAND * spacing - (g - g.min()), 0.0, None)
    return float(HALF * (p * tk).sum() / p.sum())


def sphere_cases(X, radius: float, spacing: float, tilts=(0.0, 1.0, 3.0), feet=(0.0, 0.01, 0.02, -0.04)):
    """``(tilt deg, foot m, found foot, wanted foot, normal off deg)`` for a cylinder lying on the sphere of ``radius``
    about the origin, sampled by the points ``X`` of ``spacing``, its axis tilted about the path's direction and its
    foot off its middle."""
    D = radius + R
    for tilt in tilts:
        p = math.radians(tilt)
        e, n_exact = np.array([0.0, math.cos(p), math.sin(p)]), np.array([0.0, -math.sin(p), math.cos(p)])
        for tf in feet:
            c = D * n_exact - tf * e   # the axis touches the sphere of radius D at tf along it from the centre
            n, foot = rigid_fit.hollow_contact(X, spacing, np.eye(3), np.zeros(3), c, np.array([0.0, 0.0, 1.0]),
                                               axis=e, half=HALF, radius=R)
            want = rule(lambda t: np.sqrt(D * D + (t - tf) ** 2) - radius, spacing)
            yield tilt, tf, 0.0 if foot is None else foot, want, math.degrees(math.acos(min(1.0, float(n @ n_exact))))


def misses(X, radius: float, spacing: float, tol: float) -> list[str]:
    return [f"R_s {radius} tilt {tilt} foot {1e3 * tf:+.0f} mm: found {1e3 * f:+.2f} mm, want {1e3 * w:+.2f}, "
            f"normal {off:.2f} deg off" for tilt, tf, f, w, off in sphere_cases(X, radius, spacing)
            if not (abs(f - w) <= tol and off <= NORMAL_DEG)]


def study_points(shape: str, n_grid: int, sampling: str):
    """``roll_dome93``'s dome or mound as the engines read it: its outer points about its sphere's centre, their
    spacing, and the sphere's radius."""
    import roll_dome93 as RD
    from gasp_core.mpm.hollow import outer_points
    RD.use(shape)
    X, s = outer_points(RD.dome_points(RD.BOX / n_grid / 2, sampling) - RD.DOME_C)
    return X, RD.DOME_R, s


@pytest.mark.parametrize("radius", (0.2, 1.0, 5.0))
def test_a_cylinders_foot_on_an_evenly_sampled_sphere_is_where_its_side_meets_it(radius):
    bad = misses(cap(radius, False), radius, SPACING, FOOT_EVEN)
    assert not bad, "; ".join(bad)


@pytest.mark.parametrize("sampling", ("fibonacci", "scan"))
@pytest.mark.parametrize("n_grid", (32, pytest.param(48, marks=pytest.mark.slow)))
@pytest.mark.parametrize("shape", ("dome", "mound"))
def test_a_cylinders_foot_on_the_studys_dome_and_mound_is_where_its_side_meets_it(shape, n_grid, sampling):
    X, radius, s = study_points(shape, n_grid, sampling)
    bad = misses(X, radius, s, FOOT_EVEN if sampling == "fibonacci" else FOOT_SCAN)
    assert not bad, "; ".join(bad)


#: Round 95: the reach (m, across) about the study's sphere's top in which its scan's jitter is read.
TOP = 0.03


def top_share_out(shape: str, clip_top: bool = False) -> float:
    """The share of the study's scan-like Gaussians within :data:`TOP` of its sphere's top that lie outside the sphere
    (jittered outwards); ``clip_top``: with round 94's clip at its block's top (the broken scene)."""
    import roll_dome93 as RD
    RD.use(shape)
    X = RD.dome_points(RD.BOX / 32 / 2, "scan")
    if clip_top:
        X = X[X[:, 2] < RD.BLOCK_HI[2]]
    Y = X - RD.DOME_C
    r = np.linalg.norm(Y, axis=1)
    top = (np.hypot(Y[:, 0], Y[:, 1]) < TOP) & (r > RD.DOME_R - RD.BOX / 32 / 4)   # the shell, not the fill
    return float((r[top] > RD.DOME_R).mean())


@pytest.mark.parametrize("shape", ("dome", "mound"))
def test_the_studys_scan_like_surface_is_jittered_both_ways_at_its_top(shape):
    """Round 95: the closed forms take the sphere, so a scan's jitter about it must be two-sided where the bodies touch
    (about half out; measured 0.53 and 0.58 of about 70). Until round 95 the mound's block top, level with its cap's top,
    cut the Gaussians jittered outwards more than the cap's drop within 5.6 cm of it: a flat where the rocking
    cylinder sits (it rocked 9 % fast) and the ball starts (it arrived 10-18 % late). The catch: that clip leaves
    0.09 out."""
    assert 0.4 <= top_share_out(shape) <= 0.6
    if shape == "mound":
        assert top_share_out(shape, clip_top=True) < 0.2


def test_a_cylinder_level_on_a_plane_bears_at_its_middle_and_tilted_at_its_lower_end():
    """A line contact: level (within the band) it bears at its middle; tilted 1 degree along its axis (its ends 2.6 mm
    apart against the band's 0.94) near its lower end, where the rule on the exact plane puts it."""
    rng = np.random.default_rng(5)
    X = np.c_[rng.uniform(-0.3, 0.3, 4000), rng.uniform(-0.3, 0.3, 4000), np.zeros(4000)]
    for tilt in (0.0, 1.0):
        p = math.radians(tilt)
        e = np.array([0.0, math.cos(p), math.sin(p)])
        c = np.array([0.0, 0.0, R / math.cos(p)])   # its side touches the plane at its lower end (or all along)
        n, foot = rigid_fit.hollow_contact(X, SPACING, np.eye(3), np.zeros(3), c, np.array([0.0, 0.0, 1.0]), axis=e,
                                           half=HALF, radius=R)
        want = rule(lambda t: t * math.sin(p))
        assert abs(foot - want) <= FOOT_EVEN, (tilt, foot, want)
        assert (want < -0.7 * HALF) if tilt else (abs(want) < 1e-12)   # tilted: 55 mm towards its lower end


@pytest.mark.parametrize("sampling", ("fibonacci", "scan"))
def test_the_foot_check_catches_a_push_through_the_middle(sampling, monkeypatch):
    monkeypatch.setattr(rigid_fit, "CYL_SIDE", 0)
    X, radius, s = study_points("mound", 32, sampling)
    bad = misses(X, radius, s, FOOT_EVEN if sampling == "fibonacci" else FOOT_SCAN)
    assert len(bad) >= 6, bad   # every case 2 cm or more off the middle, at three tilts


def test_the_push_at_the_foot_stops_the_foots_approach_and_turns_the_cylinder():
    """``rigid_friction.pair_contact`` with ``arms``: after the push the foot's approach along ``n`` is 0 (a centre's
    would not be: the cylinder also turns), and the cylinder's spin changes by ``-P I^-1 (arm x n)``; through the
    centres (``arms`` None) the centres' approach is 0 and the foot still closes."""
    from gasp_core.mpm.rigid_fit import foot_approach
    from gasp_core.mpm.rigid_friction import pair_contact
    n = np.array([0.0, 0.0, -1.0])   # from A (the cylinder, above) into B (the mound, below)
    IA = np.diag([0.0025, 0.0012, 0.0025])   # kg m^2 for 1 kg (the cylinder's; its axis along y)
    A = (np.array([0.0, 0.0, -0.3]), np.array([0.4, 0.0, 0.0]), IA, 1.0, np.zeros(3))
    B = (np.zeros(3), np.zeros(3), np.eye(3) * 50.0, 800.0, np.array([0.0, 0.0, -1.05]))
    arms = (np.array([0.0, 0.03, 0.0]), np.zeros(3))   # the foot 3 cm along the axis
    (VA, wA), (VB, wB), P = pair_contact(A, B, np.array([0.0, 0.0, -0.05]), n, 0.0, arms=arms)
    assert P > 0.0
    assert abs(foot_approach(VA, wA, VB, wB, arms, n)[0]) < 1e-12
    np.testing.assert_allclose(wA - A[1], -P * np.linalg.solve(IA, np.cross(arms[0], n)), atol=1e-12)
    (VA, wA), (VB, wB), P = pair_contact(A, B, np.array([0.0, 0.0, -0.05]), n, 0.0)
    assert abs(float(np.dot(VA - VB, n))) < 1e-12 and abs(foot_approach(VA, wA, VB, wB, arms, n)[0]) > 0.01


# --------------------------------------------------------------------------- engines (slow)
ENGINES = ("warp_mpm", "taichi_mpm")


def rock_problem(r: dict) -> str | None:
    """The row's ``problem`` (``rock_foot94.row``'s or ``seeded_row``'s: two-sided), named, or None."""
    if not r["problem"]:
        return None
    return (f"{r['engine']} {r['shape']} n_grid {r['n_grid']} {r['sampling']}{' (three bodies)' if r['third'] else ''}:"
            f" period {r['period']:.4f} s against {r['want']:.4f} ({r['problem']})")


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_cylinder_rocks_on_a_dome_or_mound_with_the_boards_period(engine):
    """Board on a log: ``2 pi sqrt((I_x + m R^2) / (m g (R_s - R)))``, 0.145 s on the mound and 0.366 s on the dome,
    within ``rock_foot94.TOL`` (5 %), two-sided; the dome's with a third rigid body too (the many-body law); the
    scan-like cases' (round 95) the mean over ``rock_foot94.SEEDS`` of the scan, each seed within ``SEED_TOL``."""
    pytest.importorskip(f"gasp_{engine}")
    import rock_foot94 as RK
    bad = [p for p in (rock_problem(RK.judged_row(engine, *case)) for case in RK.family()) if p]
    assert not bad, "; ".join(bad)


@pytest.mark.slow
@pytest.mark.parametrize("rule", ("CYL_SIDE", "FOOT_POINT"))
@pytest.mark.parametrize("engine", ENGINES)
def test_the_rocking_check_catches_a_push_through_the_centres_and_a_held_moment(engine, rule, monkeypatch):
    """Round 93's push through the centres (``CYL_SIDE`` 0: no righting moment) and the foot with a face's hold on the
    friction's moment (``FOOT_POINT`` 0: it swung 30 % fast, as if it slid freely along its axis) on the mound."""
    pytest.importorskip(f"gasp_{engine}")
    import rock_foot94 as RK
    monkeypatch.setattr(rigid_fit, rule, 0)
    r = RK.row(engine, "mound", 32, "fibonacci")
    assert rock_problem(r) is not None, f"{engine} {rule} 0 passed ({100 * r['err']:+.2f} %)"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_seeded_mound_check_catches_a_held_moment(engine, monkeypatch):
    """Round 95: the scan-like mound's mean over its seeds (n_grid 32) fails with ``FOOT_POINT`` 0."""
    pytest.importorskip(f"gasp_{engine}")
    import rock_foot94 as RK
    monkeypatch.setattr(rigid_fit, "FOOT_POINT", 0)
    r = RK.seeded_row(engine, "mound", 32)
    assert rock_problem(r) is not None, f"{engine} FOOT_POINT 0 passed ({100 * r['err']:+.2f} %)"
