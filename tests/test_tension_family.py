"""Tension over a family (issue 66, "Tension, over a family"; ``benchmarks/tension_family.py``, docs/fracture.md "The
held region" and "The dog-bones' shoulders"): a straight bar and a dog-bone of the family, held by a
``fixed_region`` at one end and pulled by a set impulse at the other, on both MPM engines:

- the peak nominal stress in the gauge is f_t within 5 % (two-sided);
- the break is in the gauge, not at the held edge (a dog-bone's gauge: where its section is within 2 % of the
  narrowest, ``tension_family.SECTION_TOL``);
- the work to separate over the section (``int sigma_c dw``) is G_f within 20 % (two-sided) at n_grid N for the bar;
  at 2N, between N and 2N (15 %), and for the dog-bone at N it is not met (strict xfails with the measured figures).

The catches: the engines with the held region before issue 66 (the fixed region's nodes at 0, its points rigid, no
ghost nodes) fail the bar: it breaks at its clamp's edge at a peak under 0.9 f_t. The dog-bone before round 30 (a
square section, cosine shoulders as long as the gauge is wide: elastic Kt 1.5, benchmarks/shoulder_kt.py; a
staircase fill) fails the dog-bone's check: it breaks in its shoulder at 0.92 f_t. The shoulders' continuum Kt
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
BAR, BONE = tf.FAMILY[1], tf.FAMILY[4]    # bar_L0.7_a0.15, dogbone_2to1


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


@pytest.mark.parametrize("name", _names())
def test_a_bar_carries_f_t_breaks_in_the_gauge_and_takes_G_f_at_N(name):
    """The peak and the break's place at N and 2N, the work to separate at N (measured:
    benchmarks/results/tension_family.md)."""
    r1, r2 = tf.run_case(BAR, N, name), tf.run_case(BAR, 2 * N, name)
    bad = failures(r1) + strength_failures(r2)
    assert bad == [], bad


@pytest.mark.xfail(strict=True, reason="issue 66: the work to separate falls with n_grid (the bar at n_grid 48: "
                                       "13.8 J/m^2, -31 % against G_f, -35 % from n_grid 24's 21.1; docs/fracture.md)")
@pytest.mark.parametrize("name", _names()[:1])
def test_the_work_to_separate_is_G_f_at_2N_and_within_15_percent_of_N(name):
    r1, r2 = tf.run_case(BAR, N, name), tf.run_case(BAR, 2 * N, name)
    bad = failures(r2)
    if not abs(r2["work"] / r1["work"] - 1) <= GRID_TOL:
        bad.append(f"{BAR.name}: work to separate {r1['work']:.2f} J/m^2 at n_grid {N}, {r2['work']:.2f} at {2 * N}")
    assert bad == [], bad


@pytest.mark.parametrize("name", _names())
def test_a_dog_bone_carries_f_t_and_breaks_in_its_gauge(name):
    """The flat 2:1 dog-bone (fillets of R / d 3, elastic Kt 1.09) at N and 2N: peak and place (measured:
    benchmarks/results/tension_family.md)."""
    r1, r2 = tf.run_case(BONE, N, name), tf.run_case(BONE, 2 * N, name)
    bad = strength_failures(r1) + strength_failures(r2)
    assert bad == [], bad


@pytest.mark.xfail(strict=True, reason="issue 66: the 2:1 dog-bone's work to separate at n_grid 24 is 13.5 J/m^2, "
                                       "-33 % against G_f (docs/fracture.md \"The dog-bones' shoulders\")")
@pytest.mark.parametrize("name", _names()[:1])
def test_a_dog_bone_takes_G_f_at_N(name):
    assert failures(tf.run_case(BONE, N, name)) == []


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
