"""Tension over a family (issue 66, "Tension, over a family"; ``benchmarks/tension_family.py``, docs/fracture.md "The
held region" and "The dog-bones' shoulders"): a straight bar and a dog-bone of the family, held by a
``fixed_region`` at one end and pulled by a set impulse at the other, on both MPM engines:

- the peak nominal stress in the gauge is f_t within 5 % (two-sided);
- the break is in the gauge, not at the held edge (a dog-bone's gauge: where its section is within 2 % of the
  narrowest, ``tension_family.SECTION_TOL``);
- the work to separate over the section (``int sigma_c dw``) is G_f within 20 % (two-sided) at n_grid N and 2N, and
  within 15 % between them (the crack band ``h = dx``, round 31).

The slow tier runs the family's six specimens (bars of three lengths and two sections, dog-bones of two proportions)
on both engines; the default tier the bar L0.7. The bar L0.7 with its lattice and faces off the grid's nodes runs
at five shifts (slow), and at two in the default tier with their catches: the set box before round 32's brittle held
rule (the engines' ``held_rule`` False) breaks the (1/4, 1/4) bar at the pulled box's face; one ``s_f`` for every point
(before round 33's crack band weight, the engines' ``weighted_band`` False) takes +68 % of G_f on the (1/4, 0) bar, a
point layer on each node (``gasp_core.mpm.materials.band_weight``, docs/fracture.md "Shifted lattices (round 33)").

The catches: the crack band of before (``dx + p_vol^(1/3)``) fails the work (31 % short at 2N); the engines with the
held region before issue 66 (the fixed region's nodes at 0, its points rigid, no ghost nodes) fail the bar: it breaks
at its clamp's edge at a peak under 0.9 f_t. The dog-bone before round 30 (a square section, cosine shoulders as
long as the gauge is wide: elastic Kt 1.5, benchmarks/shoulder_kt.py; a staircase fill) fails the dog-bone's check:
it breaks in its shoulder at 0.92 f_t. The shoulders' continuum Kt
(``benchmarks/shoulder_kt.py``) is checked apart, against the old cosine shoulders'.
"""
from __future__ import annotations

import functools
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import tension_family as tf   # noqa: E402

from gasp_core.seam.plugins import engines   # noqa: E402

STRENGTH_TOL, GF_TOL, GRID_TOL = 0.05, 0.20, 0.15
N = 24
BAR = tf.FAMILY[1]    # bar_L0.7_a0.15


def _names():
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in ("taichi_mpm", "warp_mpm")]


def failures(r: dict) -> list[str]:
    """What the must-show finds wrong with one case of :func:`tension_family.run_case`."""
    bad = []
    if abs(r["peak"] / tf.FT - 1) > STRENGTH_TOL:
        bad.append(f"{r['specimen']} n_grid {r['n_grid']}: peak nominal stress {r['peak']:.0f} Pa against f_t "
                   f"{tf.FT:.0f} ({100 * r['peak_vs_ft']:+.1f} %)")
    if r["where"] != "gauge":
        bad.append(f"{r['specimen']} n_grid {r['n_grid']}: breaks at x = {r['crack_x']:.3f} m ({r['where']}; clamp "
                   f"face {r['clamp_face']:.3f}, gauge {r['gauge'][0]:.3f}-{r['gauge'][1]:.3f})")
    if not abs(r["work"] / tf.GF - 1) <= GF_TOL:
        bad.append(f"{r['specimen']} n_grid {r['n_grid']}: work to separate {r['work']:.2f} J/m^2 against G_f "
                   f"{tf.GF:g}")
    return bad


def old_clamp(monkeypatch, name: str) -> None:
    """The engine ``name`` with the held region before issue 66: no ghost nodes, every held point rigid."""
    from gasp_core.mpm.points import fixed_mask

    def rigid(x, boundaries, dx, sampled=False):
        return fixed_mask(x, boundaries).astype(np.int8)
    if name == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate
        monkeypatch.setattr(GridUpdate, "grid_update", lambda self: self.grid_nodes())
        monkeypatch.setattr("gasp_taichi_mpm.engine.held_codes", rigid)
    else:
        monkeypatch.setattr("gasp_warp_mpm.engine.mirror_launches", lambda *a: [])
        monkeypatch.setattr("gasp_warp_mpm.engine.held_codes", rigid)


def strength_failures(r: dict) -> list[str]:
    """:func:`failures` without the work to separate."""
    return [b for b in failures(r) if "work to separate" not in b]


#: the family's cases that miss the must-show, with the measured figures (benchmarks/results/tension_family.md)
KNOWN: dict = {}   # none since round 32's brittle held rule on both engines (the bar L0.9 at 2N: gauge, +1.9 %)


def family_failures(sp, name: str) -> list[str]:
    """Every line of the must-show on specimen ``sp`` at n_grid N and 2N: peak, place and work at both, and the work
    within ``GRID_TOL`` between them."""
    r1, r2 = tf.run_case(sp, N, name), tf.run_case(sp, 2 * N, name)
    bad = failures(r1) + failures(r2)
    if not abs(r2["work"] / r1["work"] - 1) <= GRID_TOL:
        bad.append(f"{sp.name}: work to separate {r1['work']:.2f} J/m^2 at n_grid {N}, {r2['work']:.2f} at {2 * N}")
    return bad


def _cases():
    return [pytest.param(sp, n, id=f"{n}-{sp.name}",
                         marks=[pytest.mark.xfail(strict=True, reason=KNOWN[sp.name, n])] if (sp.name, n) in KNOWN
                         else [])
            for sp in tf.FAMILY for n in _names()]


@pytest.mark.slow
@pytest.mark.parametrize("sp, name", _cases())
def test_each_specimen_carries_f_t_breaks_in_its_gauge_and_takes_G_f(sp, name):
    """Bars of three lengths and two sections and dog-bones of two proportions at n_grid 24 and 48 (measured:
    benchmarks/results/tension_family.md; the crack band ``h = dx``, docs/fracture.md "The crack band")."""
    bad = family_failures(sp, name)
    assert bad == [], bad


@pytest.mark.parametrize("name", _names())
def test_a_bar_carries_f_t_breaks_in_the_gauge_and_takes_G_f(name):
    """The default tier's case: the bar L0.7 at N and 2N, every line of the must-show."""
    bad = family_failures(BAR, name)
    assert bad == [], bad


def band_of_before(monkeypatch) -> None:
    """Break the core's crack band: ``dx + p_vol^(1/3)`` (1.5 cells at 8 points a cell), the rule before round 31."""
    import gasp_core.seam.setup as su
    rule = su.crack_band

    def wide(dx, p_vol, body_id, n_bodies):
        h = rule(dx, p_vol, body_id, n_bodies)
        s = np.zeros(n_bodies)
        pv = np.asarray(p_vol, np.float64)
        np.maximum.at(s, np.asarray(body_id)[pv > 0], np.cbrt(pv[pv > 0]))
        return h + s
    monkeypatch.setattr(su, "crack_band", wide)


@pytest.mark.parametrize("name", _names())
def test_the_work_check_catches_the_band_of_before(name, monkeypatch):
    """With the band ``dx + p_vol^(1/3)`` the bar's work to separate at 2N is 31 % short: the check fails it."""
    band_of_before(monkeypatch)
    bad = family_failures(BAR, name)
    assert any("work to separate" in b for b in bad), bad


def test_the_dog_bone_check_catches_the_old_cosine_shoulders():
    """The 2:1 dog-bone of before round 30 (``tension_family.OLD_BONES``, its staircase fill) on one engine."""
    name = _names()[0]
    old = functools.partial(tf.build, partial=False)
    bad = strength_failures(tf.run_case(tf.OLD_BONES[0], N, name, build_fn=old))
    assert any("breaks at" in b for b in bad) and any("peak nominal" in b for b in bad), bad


@pytest.mark.parametrize("name", _names())
def test_the_family_check_catches_the_old_node_held_clamp(name, monkeypatch):
    old_clamp(monkeypatch, name)
    bad = failures(tf.run_case(BAR, N, name))
    assert any("breaks at" in b for b in bad) and any("peak nominal" in b for b in bad), bad


def test_the_dog_bones_shoulders_concentrate_little_and_the_old_ones_much():
    """The continuum's elastic Kt of the shoulders (``benchmarks/shoulder_kt.py``, plane stress, 8 elements across
    the half gauge): the family's fillets 1.09 and 1.05 (at 32: 1.0904 and 1.0457), the old cosine shoulders 1.5; a
    uniform bar 1 (the solver's patch check)."""
    import shoulder_kt as kt
    bar = kt.solve(lambda x: np.full_like(x, 0.075), 0.5, 0.15, 40, 8)["kt"]
    assert abs(bar - 1) < 1e-9, bar
    new = [kt.kt_of(sp, 8)["kt"] for sp in tf.FAMILY if sp.gauge_l > 0]
    old = [kt.kt_of(sp, 8)["kt"] for sp in tf.OLD_BONES]
    assert all(1.03 < k < 1.10 for k in new) and all(k > 1.4 for k in old), (new, old)


#: lattice and held faces off the grid's nodes (cells; ``tension_family.build``'s ``shift``): docs/fracture.md "The held
#: region" (the brittle held rule of round 32); measured: benchmarks/results/tension_family.md
SHIFTS = [(0.125, 0.0), (0.25, 0.0), (0.25, 0.25), (0.125, 0.125), (0.0, 0.25)]
#: shifted cases that miss, per engine, with the measured figures
SHIFT_KNOWN: dict = {(0.25, 0.25): (
    "n_grid 48: a near-tie of two bands, one by each held face (docs/fracture.md \"Round 46: the shifted bar's pulled "
    "face\"); since round 40's FIXED_BY_MASS the pulled band wins: x 0.781, held edge, work +2.1 % (taichi_mpm; "
    "with FIXED_BY_MASS off x 0.356, gauge, -5.3 %)")}


def shifted_failures(shift, name: str, grids=(N, 2 * N)) -> list[str]:
    """The peak, the place and the work to separate of the bar L0.7 with its lattice and faces shifted off the nodes,
    at ``grids`` (:func:`failures`)."""
    return [b for n in grids for b in failures(tf.run_case(BAR, n, name, shift=shift))]


def band_switch(monkeypatch, name: str, switch: str, on: bool) -> None:
    """Set the brittle crack band's class switch ``switch`` (``weighted_band``, ``oblique_band``) of engine ``name``:
    taichi_mpm's ``Constitutive``, warp_mpm's ``HeldRule``."""
    if name == "taichi_mpm":
        from gasp_taichi_mpm.constitutive import Constitutive
        monkeypatch.setattr(Constitutive, switch, on)
    else:
        from gasp_warp_mpm.held_rule import HeldRule
        monkeypatch.setattr(HeldRule, switch, on)


def one_sf(monkeypatch, name: str) -> None:
    """The engine ``name`` with one ``s_f`` for every brittle point, as before round 33 (its ``weighted_band``
    False): no crack band weight."""
    band_switch(monkeypatch, name, "weighted_band", False)


def test_the_band_weight_is_a_points_share_of_its_cells_opening():
    """``band_weight`` along an axis is the MLS gradient's weight on the point's own cell: ``sum_k c_k v_k`` with
    ``c_k = 4 w_k (k - fx)`` (quadratic B-splines) is ``-c_0 (v_1 - v_0) + c_2 (v_2 - v_1)``, ``-c_0 + c_2 = 1``;
    1 at a cell's middle, 1/2 on a node, 0.84375 at a quarter cell off it. Over a lattice of two points a cell at any
    offset, the shares of one cell's opening sum to 2 (so a band of a cell holds the cell's whole opening); the end
    of softening stays above ``f_t``."""
    from gasp_core.mpm.materials import band_softening_stress, band_weight
    ex = np.array([1.0, 0.0, 0.0])
    got = [band_weight([f, 1.0, 1.0], ex) for f in (0.5, 1.0, 0.75, 1.25, 1.49)]
    assert np.allclose(got[:4], [1.0, 0.5, 0.84375, 0.84375]) and 0.5 < got[4] <= 1.0, got
    rng = np.random.default_rng(3)
    for fx in rng.uniform(0.5, 1.5, 20):
        w = np.array([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2])
        c = 4 * w * (np.arange(3) - fx)
        assert abs(c.sum()) < 1e-12 and abs(-c[0] + c[2] - 1) < 1e-12
        assert abs(max(-c[0], c[2]) - band_weight([fx, 1.0, 1.0], ex)) < 1e-12
    for off in rng.uniform(0.0, 1.0, 20):      # the points along x at off + k / 2 cells; the cell [0, 1]
        xs = off + np.arange(-6, 7) / 2
        base = np.floor(xs - 0.5)
        fx = xs - base
        w0 = 2 * fx * (1.5 - fx) ** 2             # the share of the cell [base, base + 1]
        share = np.where(base == 0, w0, 0.0) + np.where(base + 1 == 0, 1 - w0, 0.0)
        assert abs(share.sum() - 2) < 1e-12, (off, share)
    assert band_softening_stress(1e4, 8e4, 0.5) == 4.5e4 and band_softening_stress(1e4, 1.1e4, 0.5) > 1e4


#: Round 54: under cfl_rule "sum" (the default) the catch below no longer catches: one s_f for every point meets the
#: work check too on this bar at n_grid 24 (both engines; warp_mpm: 20.84 J/m^2, +4.2 %, against 20.59 with the
#: weight); the bar itself still passes.
ONE_SF_CAUGHT_UNDER_MAX = ("round 54, cfl_rule sum: the one-s_f variant's work is within 20 % on the (1/4, 0) bar at "
                           "n_grid 24 (both engines), so the check no longer tells it apart (it did under 'max': +68 %)")


@pytest.mark.parametrize("name", _names())
def test_a_bar_with_a_layer_on_each_node_takes_G_f(name):
    """The default tier's node lattice (1/4, 0) at n_grid 24 (docs/fracture.md "Shifted lattices (round 33)"): in the
    gauge, work within 20 % of G_f with the crack band weight."""
    assert shifted_failures((0.25, 0.0), name, (N,)) == []


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=ONE_SF_CAUGHT_UNDER_MAX)
@pytest.mark.parametrize("name", _names())
def test_one_s_f_for_every_point_fails_the_bar_with_a_layer_on_each_node(name, monkeypatch):
    """The catch: one ``s_f`` for every point (before round 33) read +68 % (33.7 J/m^2 under cfl_rule "max": the node
    layers, at half the cell's opening, still carry stress when the cell's middle has broken through)."""
    one_sf(monkeypatch, name)
    bad = shifted_failures((0.25, 0.0), name, (N,))
    assert any("work to separate" in b for b in bad), bad


def held_rule_off(monkeypatch, name: str) -> None:
    """The engine ``name`` with the set box and the held points of before round 32 (its ``held_rule`` False)."""
    if name == "taichi_mpm":
        from gasp_taichi_mpm.grid import GridUpdate
        monkeypatch.setattr(GridUpdate, "held_rule", False)
    else:
        from gasp_warp_mpm.engine import WarpMPMEngine
        monkeypatch.setattr(WarpMPMEngine, "held_rule", False)


@pytest.mark.slow
@pytest.mark.parametrize("shift, name", [pytest.param(s, n, id=f"{s[0]}-{s[1]}-{n}", marks=[pytest.mark.xfail(
    strict=True, reason=SHIFT_KNOWN[s])] if s in SHIFT_KNOWN else []) for s in SHIFTS for n in _names()])
def test_shifted_bars_break_in_the_gauge_and_take_G_f(shift, name):
    """The bar L0.7 off the grid at n_grid 24 and 48: peak, place and work to separate."""
    bad = shifted_failures(shift, name)
    assert bad == [], bad


@pytest.mark.parametrize("name", _names())
def test_a_shifted_bar_breaks_in_the_gauge_and_the_set_box_of_before_at_its_face(name, monkeypatch):
    """The default tier's shifted case (1/4, 1/4) at n_grid 24: in the gauge (x 0.3875, work 22.0 J/m^2, +10.1 %); the
    catch: the set box as before (the engine's ``held_rule`` False) breaks the (1/8, 1/8) bar at 2N at the pulled face
    (x 0.794, face 0.800; work 4.1 J/m^2). (With round 33's crack band weight the set box of before no longer breaks
    the (1/4, 1/4) bar at N at its face; at 2N it breaks (1/4, 0), (1/4, 1/4) and (1/8, 1/8) there, taichi_mpm.)"""
    assert shifted_failures((0.25, 0.25), name, (N,)) == []
    held_rule_off(monkeypatch, name)
    bad = shifted_failures((0.125, 0.125), name, (2 * N,))
    assert any("breaks at" in b for b in bad) and any("work to separate" in b for b in bad), bad
