"""The tension family at an angle to the grid (issue 66, "Tension, over a family", round 34;
``benchmarks/tension_oblique.py``, docs/fracture.md "Oblique specimens (round 34)"): the family's flat dog-bones with
their axis at 30 and 45 deg to the grid's x axis (about z, their width along z), held by the half-space ``x <= c`` (a
``fixed_region``) and pulled by a set impulse over ``x >= c'``, the boxes a user can write; the must-show of
``tests/test_tension_family.py`` (peak within 5 % of f_t, the break in the gauge, the work to separate within 20 % of
G_f at N and 2N and within 15 % between them), measured along the specimen's axis.

What misses is a strict xfail with its figures (``KNOWN``): the peak is 4.5 to 8 % under f_t at every oblique case
(the stress of the oblique lattice's points in the gauge spreads 0.91 to 1.09 of its mean, 5th to 95th percentile,
where the aligned lattice's is within 0.96 to 1.07, so its weakest points soften early), and at 45 deg the work to
separate is +31 % at N and +3 % at 2N (the crack's band 2.6 to 3 lattice layers wide where an aligned crack's is 2).

The default tier: the 2:1 dog-bone at 30 deg at n_grid 24 on warp_mpm (every line of the must-show at N), and its
catch: one ``s_f`` for every point (the engine's ``weighted_band`` off, before round 33) takes +25 % of G_f. Slow: a
straight bar (no grips) at 30 deg breaks at the clamp's corner (the limit of axis-aligned holds: docs/fracture.md).
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

#: the oblique cases that miss the must-show, with the measured figures (both engines alike,
#: benchmarks/results/tension_oblique.md)
KNOWN: dict = {
    ("dogbone_2to1", "30"): "peak 0.948 f_t at n_grid 48 (-5.2 %; 0.955 at 24): the oblique lattice's stress spread",
    ("dogbone_2to1", "45"): "peak 0.935 / 0.942 f_t (n_grid 24 / 48); work to separate 26.26 J/m^2 (+31 %) at 24, "
                            "20.58 at 48 (-21.6 % between): the band dx across a 45 deg crack is 1.4 cells wide",
    ("dogbone_1.5to1", "45"): "peak 0.922 / 0.946 f_t; at n_grid 48 it breaks 0.6187 m along, within 1.5 cells of "
                              "the pulled face's corner (held edge); work 25.84 J/m^2 (+29 %) at 24, 22.86 at 48",
}


def oblique_failures(sp, angle: str, name: str, grids=(N, 2 * N)) -> list[str]:
    """Every line of the must-show (``test_tension_family.failures``, along the axis) on ``sp`` at ``angle``, at
    ``grids``, and the work within ``GRID_TOL`` between N and 2N where both run."""
    rs = [to.run_case(sp, n, name, angle) for n in grids]
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
def test_oblique_dog_bones_carry_f_t_break_in_the_gauge_and_take_G_f(sp, angle, name):
    """The two dog-bones at 30 and 45 deg at n_grid 24 and 48 (measured: benchmarks/results/tension_oblique.md)."""
    bad = oblique_failures(sp, angle, name)
    assert bad == [], bad


@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_a_dog_bone_at_30_deg_meets_the_must_show():
    """The default tier's oblique case: the 2:1 dog-bone at 30 deg at n_grid 24 (peak 0.955 f_t, -4.5 %; at the
    gauge's end; work 23.19 J/m^2, +16 %)."""
    assert oblique_failures(BONES[0], "30", "warp_mpm", (N,)) == []


@pytest.mark.skipif("warp_mpm" not in _names(), reason="warp_mpm is not available")
def test_the_oblique_work_check_catches_one_s_f(monkeypatch):
    """The catch: one ``s_f`` for every point (``weighted_band`` off, before round 33) takes 25.1 J/m^2 (+25.5 %) on
    the default tier's dog-bone: the work check fails it."""
    one_sf(monkeypatch, "warp_mpm")
    bad = oblique_failures(BONES[0], "30", "warp_mpm", (N,))
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
    catch) 26.51 (+32.6 %). The must-show's work to separate with it on reads 14.43 (-28 %): docs/fracture.md."""
    _projection(monkeypatch, name, True)
    r = to.run_case(BONES[0], N, name, "45")
    assert abs(r["dissipated"] / to.tf.GF - 1) <= 0.10 and r["where"] == "gauge", (r["dissipated"], r["where"])
    _projection(monkeypatch, name, False)
    r = to.run_case(BONES[0], N, name, "45")
    assert not abs(r["dissipated"] / to.tf.GF - 1) <= 0.10, r["dissipated"]
