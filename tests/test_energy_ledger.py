"""The energy ledger of the MPM engines closes and no energy is gained (issue 66 item 6; docs/fracture.md "Round 46:
where the landing's energy goes"; ``benchmarks/energy_ledger.py``).

Fast: the ledger's transfers on NumPy points (a spinning, stretching body of random points): P2G and G2P each lose
energy, never gain it, when the points' kinetic energy counts the APIC affine part; the catch drops that part, and
P2G then gains. Slow: the jelly ball of ``benchmarks/energy_ledger_family.py`` at n_grid 32 and 48, 2 and 4.43 m/s,
both engines: the untraced terms (the stress's work against the stored energy, gravity's against the potential) end
within 2 % of the energy brought and never pass 6 %; no sink's sum is a gain beyond 0.1 %; the energy never rises
over the start's by 0.1 %; the transfers and the grid rule gain nothing in any substep (1e-5 of the energy brought;
the contact's penalty and the balance's fix may give back up to 1e-4 in a substep, and are checked on their sums);
the catch builds the engine with gravity 5 % too strong (the ledger keeps g), which the grid update then gains.
Round 53: the explicit elastic step's gain, half-step paired, under 1 % of the energy brought (the ball at n_grid 48;
strict xfails: n_grid 32 at 4.43 m/s and the jelly donut at cfl 0.8), its catch at cfl 0.8 under ``cfl_rule`` "max",
and the ``cfl_rule`` option's rule ("sum", the default since round 54).
Round 70 (docs/fracture.md "Round 70: the trapezoid as the default"): the slow checks run under the trapezoid (the
default since then) and under "start"; under the trapezoid the ledger books ``F``'s owed increment
(``energy_ledger.OWED``; the free bar's ledger closes with it, its catches: unbooked or booked by half) and the stress's
work on the part of it the grid never carried (the ``gradient`` sink; its catch: unbooked, the ball's sum does not
close), and the gain is read unpaired; the family meets the 1 % gate under it (round 69's strict xfails; they stay
under "start").
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from energy_ledger import grid_ke, p2g, weights   # noqa: E402

LO, DX, NG = np.zeros(3), 0.02, 24
CLOSE_END, CLOSE_WORST, GAIN, STEP_GAIN = 0.02, 0.06, 1e-3, 1e-5
PAIRED_GAIN = 0.01   # the elastic step's gain, half-step paired (round 53): at most 1 % of the energy brought


def cloud(seed: int = 0, n: int = 4000):
    """Points of mass 1e-3 kg in a 0.2 m box inside the grid, spinning at 20 rad/s and stretching at 5 /s, plus
    noise: positions (n, 3), velocities (n, 3), masses (n,)."""
    rng = np.random.default_rng(seed)
    x = 0.14 + 0.2 * rng.random((n, 3))
    c = x - x.mean(0)
    w = np.array([3.0, -5.0, 20.0])
    v = np.cross(w, c) + 5.0 * c + 0.1 * rng.standard_normal((n, 3))
    return x, v, np.full(n, 1e-3)


def g2p(x, grid_v):
    """The APIC gather: ``v_p = sum w v_i``, ``C_p = 4 / dx^2 sum w v_i (x_i - x_p)^T``."""
    base, fx, w = weights(x, LO, 1.0 / DX)
    v, C = np.zeros((len(x), 3)), np.zeros((len(x), 3, 3))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                off = np.array([i, j, k])
                wt = w[:, 0, i] * w[:, 1, j] * w[:, 2, k]
                idx = base + off
                vi = grid_v[(idx[:, 0] * NG + idx[:, 1]) * NG + idx[:, 2]]
                v += wt[:, None] * vi
                C += (4.0 / DX ** 2) * wt[:, None, None] * np.einsum("ni,nj->nij", vi, (off - fx) * DX)
    return v, C


def losses(affine: bool = True):
    """The P2G and G2P losses (J) of a round trip from the points' APIC state after one gather."""
    x, v, m = cloud()
    g = p2g(x, np.c_[m[:, None] * v, m], LO, DX, NG)
    gv = np.where(g[:, 3:] > 0, g[:, :3] / np.maximum(g[:, 3:], 1e-300), 0.0)
    v, C = g2p(x, gv)        # the points' APIC state
    ep = lambda v, C: 0.5 * float(m @ (v ** 2).sum(1)) + (   # noqa: E731
        0.5 * float(m @ (C ** 2).sum((1, 2))) * DX ** 2 / 4 if affine else 0.0)
    g = p2g(x, np.c_[m[:, None] * v, m], LO, DX, NG, C=C, m=m)
    k = grid_ke(g[:, :3], g[:, 3])
    gv = np.where(g[:, 3:] > 0, g[:, :3] / np.maximum(g[:, 3:], 1e-300), 0.0)
    v1, C1 = g2p(x, gv)
    return ep(v, C) - k, k - ep(v1, C1), k


def test_transfers_lose_energy_with_the_affine_part():
    lp, lg, k = losses()
    assert lp >= -1e-12 * k and lg >= -1e-12 * k, (lp, lg, k)
    assert lp + lg < 0.5 * k   # a loss, not all of it


def test_transfers_catch_a_ledger_without_the_affine_part():
    lp, _lg, k = losses(affine=False)
    assert lp < -1e-3 * k, (lp, k)   # without its affine part the points' energy is short: P2G "gains"


def test_cfl_rule_sum_adds_the_material_speed():
    """The engine option ``cfl_rule`` (round 53): ``"sum"`` (the engines' default since round 54) steps at
    ``cfl dx / (c_p + v_max)``, ``"max"`` at ``cfl dx / max(c_p, v_max)``; a brittle body's speed is the same under
    both (its impact speed already adds ``v_max``); an unknown rule is refused."""
    from gasp_core.errors import SceneError
    from gasp_core.mpm.substeps import impact_wave_speed, mpm_stable_dt, substeps_from_options
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    jelly, brittle = Material("jelly", E=1e5, nu=0.3, rho=1000.0), Material("brittle")
    g, dx, h, v0 = (0.0, 0.0, -9.81), 0.0125, 0.6, 4.43
    vmax = v0 + np.sqrt(2 * 9.81 * h)
    c = jelly.p_wave_speed
    assert mpm_stable_dt([jelly], dx, g, h, v0, 0.8, rule="max") == pytest.approx(0.8 * dx / c)
    assert mpm_stable_dt([jelly], dx, g, h, v0, 0.8, rule="sum") == pytest.approx(0.8 * dx / (c + vmax))
    cb = impact_wave_speed(brittle, vmax)
    for rule in ("max", "sum"):
        assert mpm_stable_dt([brittle], dx, g, h, v0, 0.8, rule=rule) == pytest.approx(0.8 * dx / cb)
    s = make_setup(np.full((1, 3), 0.3), np.full(1, 1e-6), jelly, v=(0.0, 0.0, -v0), hi=(0.6, 0.6, 0.6), n_grid=48)
    n_max, _ = substeps_from_options(s, {"cfl": 0.8, "cfl_rule": "max"})
    n_sum, _ = substeps_from_options(s, {"cfl": 0.8, "cfl_rule": "sum"})
    assert (n_max, n_sum) == (39, 65)
    assert substeps_from_options(s, {"cfl": 0.8})[0] == n_sum   # the default (round 54)
    with pytest.raises(SceneError, match="cfl_rule"):
        substeps_from_options(s, {"cfl_rule": "min"})


def ledger_checks(r: dict) -> list[str]:
    """The ledger's failures of one run of ``energy_ledger_family.run`` (empty: it passes)."""
    e0, s, bad = r["E0"], r["sums"], []
    if abs(s["elastic"] + s["gravity"]) > CLOSE_END * e0:
        bad.append(f"untraced at the end {s['elastic'] + s['gravity']:.4f} J")
    if r["untraced_worst"] > CLOSE_WORST * e0:
        bad.append(f"untraced on the way {r['untraced_worst']:.4f} J")
    bad += [f"{k} gains {s[k]:.4f} J" for k in ("p2g", "contact", "friction", "rule", "balance", "g2p")
            if s[k] < -GAIN * e0]
    if max(t["E"] for t in r["trace"]) > (1 + GAIN) * e0:
        bad.append("energy over the start's")
    bad += [f"{k} gains {r['least'][k]:.2e} J in a substep" for k in ("p2g", "rule", "g2p")
            if r["least"][k] < -STEP_GAIN * e0]
    return bad


#: The engines' ``stress_at`` schemes the slow checks run, by name (round 70): "trapezoid" (the default since round
#: 70) and "start" (the default before, still selectable: its figures kept).
SCHEMES = ["trapezoid", "start"]


@pytest.mark.slow
@pytest.mark.parametrize("stress_at", SCHEMES)
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@pytest.mark.parametrize("n_grid,speed", [(32, 2.0), (32, 4.43), (48, 2.0), (48, 4.43)])
def test_ledger_closes_and_gains_nothing(engine, n_grid, speed, stress_at):
    """Under both schemes, the same tolerances. Under the trapezoid (round 70) the ledger books the increment ``F``
    owes (``energy_ledger.OWED``) and the stress's work on the part of it the grid never carried (the ``gradient``
    sink: 3.37 % of the energy brought on n_grid 32 at 4.43 m/s); without the sink the sum ends -3.19 % (the catch
    below)."""
    from energy_ledger_family import run
    r = run("ball", engine, n_grid, speed, 40.0, stress_at=stress_at)
    assert r["mass_err"] < 1e-5
    assert not ledger_checks(r), ledger_checks(r)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_ledger_catches_the_trapezoids_gradient_unbooked(engine):
    """The catch of the closing sum under the trapezoid (round 70): the ``gradient`` sink left unbooked (round 69's
    ledger) leaves the ball at n_grid 32, 4.43 m/s -3.19 % of the energy brought untraced at the end."""
    from energy_ledger_family import run
    r = run("ball", engine, 32, 4.43, 40.0, stress_at="trapezoid", gradient=False)
    assert any("untraced at the end" in b for b in ledger_checks(r)), ledger_checks(r)


def free_bar_end(engine: str, owed: str | None = None) -> float:
    """The free bar's (``free_vibration.py``: cfl 0.8, n_grid 32, two periods) ledger under the trapezoid: its elastic
    term at the end over the energy brought (``owed``: the ledger's booking, None the scheme's)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks" / "studies"))
    from free_vibration import offsets
    return offsets(engine, 32, 0.8, "trapezoid", 1, owed)["elastic_end"] / 100.0


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_free_bars_ledger_closes_under_the_trapezoid(engine):
    """Round 70: under the trapezoid the ledger books the increment ``F`` owes (the next P2G's, ``dt (C_prev + C) /
    2``): the free bar's elastic term ends within the closing tolerance (measured 0.32 % of the energy brought, the
    one-pass guess's offset; 0.000 % with 3 passes; under "start" 2.61 %, its half-step offset)."""
    assert abs(free_bar_end(engine)) < CLOSE_END, free_bar_end(engine)


@pytest.mark.slow
@pytest.mark.parametrize("owed", ["none", "half"])
def test_the_free_bar_check_catches_the_owed_increment_unbooked(owed):
    """The catch (warp_mpm): the increment left unbooked (round 69's ledger: 5.47 %) or booked by half (2.58 %)."""
    pytest.importorskip("gasp_warp_mpm")
    assert abs(free_bar_end("warp_mpm", owed)) > CLOSE_END, free_bar_end("warp_mpm", owed)


DONUT = ("the jelly donut at the default quality's cfl 0.8 gains 2.75 % (round 54, cfl_rule sum: (c(F) + |v|) dt / dx"
         " up to 0.93; 8.70 % under 'max', round 53), both engines; 1.33 % with the ground's friction 0 (round 68); "
         "0.18 % under the option stress_at 'mid' (round 68, tests/test_stress_at.py), off by default")


def paired_gain(r: dict) -> float:
    """The elastic step's largest gain on the way over the energy brought, each scheme read with its own offset
    (``energy_ledger_family``'s ``elastic_own_worst``): "start" and "mid" half-step paired (round 53), "trapezoid"
    unpaired, its ledger booking ``F``'s owed increment (round 70; round 69's whole-step pairing)."""
    return r["elastic_own_worst"] / r["E0"]


@pytest.mark.slow
def test_the_gain_check_catches_the_owed_increment_unbooked():
    """The catch of the trapezoid's reading (round 70, warp_mpm): its gain read unpaired with the increment ``F`` owes
    left unbooked (round 69's ledger) is the whole-step offset: the ball at n_grid 32, 4.43 m/s reads 4.10 % (0.13 %
    booked)."""
    from energy_ledger_family import run
    r = run("ball", "warp_mpm", 32, 4.43, 40.0, stress_at="trapezoid", owed="none")
    assert r["elastic_raw_worst"] / r["E0"] > PAIRED_GAIN, r["elastic_raw_worst"] / r["E0"]


def gain_cases():
    """The family under the trapezoid (all within the gate, round 70) and under "start" (its strict xfail, the donut,
    its figure in the reason)."""
    out = []
    for at in SCHEMES:
        for body, n_grid, speed, cfl in [("ball", 32, 2.0, None), ("ball", 32, 4.43, None), ("ball", 48, 2.0, None),
                                         ("ball", 48, 4.43, None), ("donut", 48, 4.43, 0.8)]:
            why = DONUT if body == "donut" else None
            marks = [pytest.mark.xfail(strict=True, reason=why)] if at == "start" and why else []
            out.append(pytest.param(body, n_grid, speed, cfl, at, marks=marks, id=f"{body}-{n_grid}-{speed}-{at}"))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
@pytest.mark.parametrize("body,n_grid,speed,cfl,stress_at", gain_cases())
def test_the_elastic_step_gains_under_one_percent(engine, body, n_grid, speed, cfl, stress_at):
    """The explicit elastic step's gain (:func:`paired_gain`: the ledger's elastic term read with the scheme's own
    offset) stays under 1 % of the energy brought (round 53). Under the trapezoid (the default since round 70) the
    whole family: the ball at n_grid 32 and 48, 2 and 4.43 m/s, the README jelly donut at cfl 0.8 (figures:
    docs/fracture.md "Round 70"). Under "start": the ball at n_grid 48 (0.43 % at 4.43 m/s, round 54, cfl_rule sum;
    0.78 % under "max"), at n_grid 32 at 2 m/s (0.80 %; 1.05 % under "max") and at n_grid 32 at 4.43 m/s (0.97 % on
    both engines since round 102, round 104's measure; 1.10 % in round 54, a strict xfail until round 104); a strict
    xfail: the donut (its figure in the reason)."""
    from energy_ledger_family import run
    r = run(body, engine, n_grid, speed, 40.0, cfl=cfl, stress_at=stress_at)
    assert paired_gain(r) < PAIRED_GAIN, paired_gain(r)


@pytest.mark.slow
@pytest.mark.parametrize("stress_at", SCHEMES)
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_ledger_catches_the_elastic_gain_at_cfl_08(engine, stress_at):
    """The catch of the check above: the ball of the family stepped with ``cfl_rule`` ``"max"`` (``dt = cfl dx /
    max(c_p, v_max)``, the default until round 53; at cfl 0.8 its points cross cells at ``(c_p + |v|) dt / dx`` =
    1.10) gains 3.82 % at cfl 0.8 under "start" (round 53). Under the trapezoid it gained 1.53 % at cfl 0.8 (round 70)
    and 0.75 % by round 102 (the later rounds' contact and cells changed this landing), under the check's 1 %: at cfl
    1.0, the largest the engines take, it gains 1.82 % on both engines (round 104)."""
    from energy_ledger_family import run
    cfl = 1.0 if stress_at == "trapezoid" else 0.8
    r = run("ball", engine, 48, 4.43, 40.0, cfl=cfl, rule="max", stress_at=stress_at)
    assert paired_gain(r) > PAIRED_GAIN, paired_gain(r)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_ledger_catches_gravity_too_strong(engine):
    from energy_ledger_family import run
    r = run("ball", engine, 32, 2.0, 20.0, gravity_scale=1.05)
    assert any("rule gains" in b for b in ledger_checks(r)), ledger_checks(r)
