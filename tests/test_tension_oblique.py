"""The tension family at an angle to the grid (issue 66, "Tension, over a family", round 34;
``benchmarks/tension_oblique.py``, docs/fracture.md "Oblique specimens (round 34)" and "Round 40"): the family's flat
dog-bones with their axis at 30 and 45 deg to the grid's x axis (about z, their width along z), held over x
half-spaces, the boxes a user can write; the must-show of ``tests/test_tension_family.py`` (peak within 5 % of f_t,
the break in the gauge, the work to separate within 20 % of G_f at N and 2N and within 15 % between them), measured
along the specimen's axis.

**The holds bend the gauge (round 40).** Held by a ``fixed_region`` and pulled along the axis by a set box (round
34's holds, ``grip="along"``), the faces cross the section obliquely: the gauge carries a transverse force and a
bending moment, in the elastic continuum too (``benchmarks/oblique_grip.py``: its largest principal strain 0.899 to
1.104 of its median at 45 deg, 5th to 95th percentile; MPM 0.878-1.115), so its surface reaches f_t when its mean is
at 0.92-0.955 f_t. The slow tier runs the family on ``grip="free"``: both ends set boxes, the pulled one drifting
across the axis so that it carries no transverse force (the gauge's spread 0.992-1.006 on taichi_mpm at 45 deg); what
misses there is a strict xfail with its figures (``KNOWN``).

The default tier: the continuum's bending under each grip (no engine); the 2:1 dog-bone at 45 deg at n_grid 24 on
warp_mpm on free grips (every line of the must-show at N) and its two catches: the grips along the axis (the peak
0.934 f_t) and one ``s_f`` for every point (the engine's ``weighted_band`` off, before round 33: +29 % of G_f). Slow:
the 2:1 at 30 deg on the grips along the axis at N (it passes), a straight bar (no grips) at 30 deg breaking at the
clamp's corner (the limit of axis-aligned holds: docs/fracture.md).
"""
from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import tension_oblique as to   # noqa: E402
from test_tension_family import GRID_TOL, N, _names, band_switch, failures, one_sf   # noqa: E402

BONES = [to.SPECIMENS["dogbone_2to1"], to.SPECIMENS["dogbone_1.5to1"]]
ANGLES = ["30", "45"]

#: the oblique cases on free grips that miss the must-show, with the measured figures (both engines alike to every
#: printed digit; benchmarks/results/tension_oblique.md, grip free)
KNOWN: dict = {
    ("dogbone_1.5to1", "45"): "work to separate 24.35 J/m^2 at n_grid 24 (+21.8 %; 22.12 at 48, -9.2 % between; "
                              "round 48): the band dx across a 45 deg crack; peaks 0.987 / 0.987 f_t, in the gauge",
}


def oblique_failures(sp, angle: str, name: str, grids=(N, 2 * N), grip: str = "along") -> list[str]:
    """Every line of the must-show (``test_tension_family.failures``, along the axis) on ``sp`` at ``angle`` held by
    ``grip`` (``tension_oblique.build``'s), at ``grids``, and the work within ``GRID_TOL`` between N and 2N where both
    run."""
    rs = [to.run_case(sp, n, name, angle, grip=grip) for n in grids]
    bad = [f"{angle} deg: {b}" for r in rs for b in failures(_as_family(r))]
    if len(rs) == 2 and not abs(rs[1]["work"] / rs[0]["work"] - 1) <= GRID_TOL:
        bad.append(f"{sp.name} at {angle} deg: work to separate {rs[0]['work']:.2f} J/m^2 at n_grid {grids[0]}, "
                   f"{rs[1]['work']:.2f} at {grids[1]}")
    return bad


def _as_family(r: dict) -> dict:
    """An oblique case's figures under ``test_tension_family.failures``' names (its axial ``crack_s`` as
    ``crack_x``)."""
    return {**r, "crack_x": r["crack_s"], "peak_vs_ft": r["peak_vs_ft"]}


def _cases():
    return [pytest.param(sp, ang, n, id=f"{n}-{ang}-{sp.name}",
                         marks=[pytest.mark.xfail(strict=True, reason=KNOWN[sp.name, ang])]
                         if (sp.name, ang) in KNOWN else [])
            for sp in BONES for ang in ANGLES for n in _names()]


@pytest.mark.slow
@pytest.mark.parametrize("sp, angle, name", _cases())
def test_oblique_dog_bones_on_free_grips_carry_f_t_break_in_the_gauge_and_take_G_f(sp, angle, name):
    """The two dog-bones at 30 and 45 deg at n_grid 24 and 48 on free grips (measured on both engines: peaks 0.954 to
    0.987 f_t in round 40, 0.974 to 0.987 in round 48, every break in the gauge;
    benchmarks/results/tension_oblique.md)."""
    bad = oblique_failures(sp, angle, name, grip="free")
    assert bad == [], bad


def bending(sp, angle: str, beta: float) -> list[str]:
    """What the continuum (``oblique_grip.elastic_field``) finds bent in ``sp``'s gauge at ``angle`` with the pulled
    grip drifting by ``beta``: its largest principal strain more than 1 % off its median anywhere."""
    import oblique_grip as og
    least, largest = og.spread(og.elastic_field(sp, angle, N, beta))[2:]
    return [] if 0.99 <= least and largest <= 1.01 else [f"{sp.name} at {angle} deg, beta {beta:.3f}: gauge strain "
                                                         f"{least:.3f}-{largest:.3f} of its median"]


@pytest.mark.parametrize("angle", ANGLES)
def test_free_grips_leave_the_gauge_straight_in_the_continuum(angle):
    """Plane-stress finite elements of the 2:1 dog-bone under ``tension_oblique.build``'s faces: with the pulled grip
    at its free drift (beta 0.332 / 0.518 at 30 / 45 deg) the gauge's strain is within 0.993-1.008 of its median."""
    import oblique_grip as og
    assert bending(BONES[0], angle, og.free_drift(BONES[0], angle, N)) == []


@pytest.mark.parametrize("angle", ANGLES)
def test_the_straightness_check_catches_the_grips_along_the_axis(angle):
    """The catch: pulled along the axis (beta 0, round 34's holds) the gauge bends, its strain 0.920-1.080 (30 deg)
    and 0.835-1.174 (45 deg) of its median, as MPM's 0.878-1.115 at 45 deg (docs/fracture.md, "Round 40")."""
    assert bending(BONES[0], angle, 0.0) != []


@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_a_dog_bone_at_45_deg_on_free_grips_meets_the_must_show():
    """The 2:1 dog-bone at 45 deg at n_grid 24 on free grips (peak 0.987 f_t, in the gauge, work 21.55 J/m^2,
    +7.8 %, round 48; 21.80 in round 40)."""
    assert oblique_failures(BONES[0], "45", "warp_mpm", (N,), grip="free") == []


@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_the_oblique_peak_check_catches_the_grips_along_the_axis():
    """The catch: the same dog-bone pulled along the axis with its clamp a ``fixed_region`` (round 34's holds, which
    bend its gauge) peaks at 0.934 f_t (-6.6 %; 0.935 in round 34): the peak check fails it."""
    bad = oblique_failures(BONES[0], "45", "warp_mpm", (N,))
    assert any("peak nominal stress" in b for b in bad), bad


@pytest.mark.slow
@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_a_dog_bone_at_30_deg_on_the_grips_along_the_axis_meets_the_must_show_at_N():
    """Round 34's holds at 30 deg, n_grid 24 (round 48: peak 0.953 f_t, -4.7 %; at the gauge's end; work 22.21
    J/m^2, +11 %); slow since round 40 (the default tier's oblique case is on free grips at 45 deg)."""
    assert oblique_failures(BONES[0], "30", "warp_mpm", (N,)) == []


@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_the_oblique_work_check_catches_one_s_f(monkeypatch):
    """The catch: one ``s_f`` for every point (``weighted_band`` off, before round 33) takes 25.79 J/m^2 (+29.0 %) on
    the default tier's dog-bone (45 deg, free grips; 21.55 with the weight, round 48): the work check fails it.
    (Round 34's: 25.1 J/m^2 at 30 deg on the grips along the axis.)"""
    one_sf(monkeypatch, "warp_mpm")
    bad = oblique_failures(BONES[0], "45", "warp_mpm", (N,), grip="free")
    assert any("work to separate" in b for b in bad), bad


@pytest.mark.slow
@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_a_bar_at_30_deg_breaks_at_the_clamps_corner():
    """A straight bar (L0.9, a0.15) at 30 deg, held by the half-space ``x <= c``: the clamp's face crosses it at 60 deg
    to its axis, its corner concentrates stress and the bar breaks there, under 0.85 f_t in the gauge (the limit of
    axis-aligned holds; the dog-bones' grips carry it)."""
    r = to.run_case(to.SPECIMENS["bar_L0.9_a0.15"], N, "warp_mpm", "30")
    assert r["where"] == "held edge" and r["peak_vs_ft"] < -0.15, (r["where"], r["peak_vs_ft"])


def test_the_band_projection_is_the_cells_width_along_the_normal():
    """``band_projection``: 1 along an axis, sqrt(2) at 45 deg about one, sqrt(3) along a cube's diagonal, 1.366 at 30
    deg; the support of a point's stencil along ``n`` (1.5 cells each way along every axis) is ``1.5 g`` cells."""
    import numpy as np

    from gasp_core.mpm.materials import band_projection
    t = np.radians(30)
    n = np.array([[1, 0, 0], [0, -1, 0], [1, 1, 0] / np.sqrt(2), [1, 1, 1] / np.sqrt(3), [np.cos(t), np.sin(t), 0]])
    assert np.allclose(band_projection(n), [1, 1, np.sqrt(2), np.sqrt(3), 1.3660254]), band_projection(n)
    corners = np.array([[i, j, k] for i in (-1.5, 1.5) for j in (-1.5, 1.5) for k in (-1.5, 1.5)])
    assert np.allclose(np.abs(corners @ n.T).max(axis=0), 1.5 * band_projection(n))


def _projection(monkeypatch, name: str, on: bool) -> None:
    """The engine ``name`` with its band projection (``oblique_band``, round 34) ``on``."""
    band_switch(monkeypatch, name, "oblique_band", on)


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_the_projected_band_dissipates_G_f_at_45_deg_and_the_band_dx_does_not(name, monkeypatch):
    """The damage's own account in the crack's zone (``dissipated``) of the 2:1 dog-bone at 45 deg, n_grid 24: with the
    band projected (``oblique_band`` on) 18.87 J/m^2 (-5.7 %), within 10 % of G_f; the band ``dx`` (the default, the
    catch) 26.73 (+33.6 %; 26.51 in round 34). The must-show's work to separate with it on reads 14.43 (-28 %):
    docs/fracture.md."""
    _projection(monkeypatch, name, True)
    r = to.run_case(BONES[0], N, name, "45")
    assert abs(r["dissipated"] / to.tf.GF - 1) <= 0.10 and r["where"] == "gauge", (r["dissipated"], r["where"])
    _projection(monkeypatch, name, False)
    r = to.run_case(BONES[0], N, name, "45")
    assert not abs(r["dissipated"] / to.tf.GF - 1) <= 0.10, r["dissipated"]
