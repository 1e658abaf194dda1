"""Sand's and snow's plastic work in the energy ledger (round 56; issue 66 item 6 "No energy is gained";
docs/fracture.md "Round 56: sand and snow in the ledger"; ``benchmarks/energy_ledger.py``,
``benchmarks/energy_ledger_plastic.py``).

Fast: the stored energy the ledger books for each model and the stress it books the plastic work with are one pair
(the principal Kirchhoff stress is the energy's derivative in the log stretches, by central differences: sand's
Hencky energy, snow's fixed corotated energy with its hardening); the catch: the ledger before round 56 (fixed
corotated without hardening) against snow's stress. Which points return. Slow: the family of
``energy_ledger_plastic`` (sand column, sand cube, sand ball, snow ball, snow block; n_grid 32 and 48; both engines):
the untraced term within ``CLOSE_END`` (2 %) of the energy brought at the end and ``CLOSE_WORST`` (6 %) on the way
(``tests/test_energy_ledger.py``'s gates), the plastic work non-negative in sum (and with snow's hardening term)
and, for sand, in every substep (``STEP_GAIN``), no transfer or rule summing to a gain, the energy never over the
start's; the catches: the same runs booked by the ledger before round 56 (their figures, run alongside) fail the
gates, and a ledger told moduli 5 % too high (the engine built with E x 0.95) fails them too; round 57's: the snow
block run at the step chosen once from the materials' constants (the state's step off, ``gasp_core.mpm.state_step``)
fails them (+6.83 %).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from energy_ledger import Stored   # noqa: E402
from test_energy_ledger import CLOSE_END, CLOSE_WORST, GAIN, STEP_GAIN   # noqa: E402

ENGINES = ["taichi_mpm", "warp_mpm"]


def material(name):
    from gasp_core.seam.setup import Material
    return Material(name, E=3.5e5, nu=0.3, rho=1600.0)


def fd_stress(st: Stored, s: np.ndarray, jp: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """The energy's derivative in the log stretches (Pa: per unit rest volume) at diagonal ``F = diag(s)``, (n, 3)."""
    out = np.zeros_like(s)
    for i in range(3):
        up, dn = s.copy(), s.copy()
        up[:, i] *= np.exp(h)
        dn[:, i] *= np.exp(-h)
        F = lambda q: np.einsum("ni,ij->nij", q, np.eye(3))   # noqa: E731
        one = np.ones(len(s))
        out[:, i] = (st.points(F(up), jp, one, None)[0] - st.points(F(dn), jp, one, None)[0]) / (2 * h)
    return out


def stretches(seed=0, n=64):
    rng = np.random.default_rng(seed)
    return 1.0 + 0.04 * rng.standard_normal((n, 3)), 0.9 + 0.2 * rng.random(n)


@pytest.mark.parametrize("name", ["sand", "snow"])
def test_the_booked_stress_is_the_booked_energys(name):
    s, jp = stretches()
    st = Stored(material(name), None)
    num, ana = fd_stress(st, s, jp), st.principal(s, jp)
    assert np.abs(num - ana).max() < 1e-5 * np.abs(ana).max(), np.abs(num - ana).max()


def test_catch_the_energy_before_round_56_is_not_snows():
    s, jp = stretches()
    old, new = Stored(material("snow"), None, plastic=False), Stored(material("snow"), None)
    err = np.abs(fd_stress(old, s, jp) - new.principal(s, jp)).max() / np.abs(new.principal(s, jp)).max()
    assert err > 0.05, err   # the hardening exp(xi (1 - Jp)) up to e^1 at Jp 0.9


def test_which_points_return():
    jp = np.array([0.5, 1.0, 1.2])
    assert Stored(material("sand"), None).returns(jp).all() and Stored(material("snow"), None).returns(jp).all()
    assert not Stored(material("jelly"), None).returns(jp).any()
    assert not Stored(material("sand"), None, plastic=False).returns(jp).any()
    assert not Stored(material("snow"), None, plastic=False).returns(jp).any()


def failures(r: dict, before: bool = False) -> list[str]:
    """The ledger's failures of one run of ``energy_ledger_plastic.run`` (empty: it passes); ``before``: the ledger
    before round 56's untraced terms (run alongside)."""
    e0, s, bad = r["E0"], r["sums"], []
    end, worst = (r["before_end"], r["before_worst"]) if before else (r["untraced_end"], r["untraced_worst"])
    if abs(end) > CLOSE_END * e0:
        bad.append(f"untraced at the end {100 * end / e0:+.2f} %")
    if worst > CLOSE_WORST * e0:
        bad.append(f"untraced on the way {100 * worst / e0:.2f} %")
    if before:
        return bad
    bad += [f"{k} gains {100 * s[k] / e0:.3f} %" for k in ("p2g", "rule", "balance", "g2p", "plastic")
            if s[k] < -GAIN * e0]
    if s["plastic"] + s["hardening"] < -GAIN * e0:
        bad.append(f"the return gains {100 * (s['plastic'] + s['hardening']) / e0:.3f} %")
    # snow's clamp may raise a point's stored energy in a substep (a stretch clamped against a pressure), so only
    # sand's return (Drucker-Prager, its deviator shortened along the stress) is held to no gain in every substep
    steps = ("p2g", "rule", "g2p") + (("plastic",) if r["body"].startswith("sand") else ())
    bad += [f"{k} gains {r['least'][k]:.2e} J in a substep" for k in steps if r["least"][k] < -STEP_GAIN * e0]
    if r["gain"] > GAIN:
        bad.append(f"energy over the start's by {100 * r['gain']:.3f} %")
    return bad


_RUNS: dict = {}


def family_run(body, engine, n_grid, stiffness_scale=1.0):
    """``energy_ledger_plastic.run``, once a session per case (the catch reads the same runs)."""
    from energy_ledger_plastic import run
    k = (body, engine, n_grid, stiffness_scale)
    if k not in _RUNS:
        _RUNS[k] = run(body, engine, n_grid, stiffness_scale=stiffness_scale)
    return _RUNS[k]


#: The cases that fail the gates (strict xfails, both engines; docs/fracture.md "Round 56"), with their cause.
XFAIL = {("sand_ball", 32): "the untraced term ends at -2.60 % (worst 2.62 %), both engines: the step's error at the "
                            "landing (-1.12 % at cfl 0.1 over 30 ms; n_grid 48: -1.40 %)"}
# the snow block (+6.83 % / +6.03 % at n_grid 32 / 48 in round 56: snow's hardening outrunning the step) closes
# since round 57's step from the state (gasp_core.mpm.state_step): +1.99 % / +1.46 %, both engines; the fixed
# step's figure is test_catch_the_fixed_step_gains_on_the_snow_block's
# round 58: the snow step's neighbours (energy_ledger_plastic.BODIES: a snow column at 4 m/s, a snow ball at 5 m/s, a
# 20 x 20 x 3 cm slab landing flat at 3 m/s), bodies the step was not built on; the slab misses the gate
XFAIL.update({("snow_slab", g): f"the untraced term ends at {end} (worst {worst}), both engines: the landing's step "
              "error, first order in the step (n_grid 32, first frame: +3.65 % at cfl 0.4, +1.50 % at 0.2, +0.67 % at "
              "0.1); the flat 3 m/s landing of a slab 1.6 cells thick, the state's step stable (docs/fracture.md "
              "\"Round 58: the snow step's neighbours\")" for g, end, worst in ((32, "+3.62 %", "4.64 %"),
                                                                              (48, "+2.50 %", "2.96 %"))})
FAMILY = [pytest.param(b, g, marks=[pytest.mark.xfail(strict=True, reason=XFAIL[b, g])] if (b, g) in XFAIL else [])
          for b in ("sand_column", "sand_block", "sand_ball", "snow_ball", "snow_block", "snow_column",
                    "snow_ball_fast", "snow_slab") for g in (32, 48)]


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("body,n_grid", FAMILY)
def test_sand_and_snow_ledgers_close(body, n_grid, engine):
    r = family_run(body, engine, n_grid)
    assert r["mass_err"] < 1e-5, r["mass_err"]
    assert not failures(r), failures(r)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("body,n_grid", [(b, g) for b in ("sand_column", "sand_block", "sand_ball", "snow_ball",
                                                           "snow_block") for g in (32, 48)])
def test_catch_the_ledger_before_round_56_does_not_close(body, n_grid, engine):
    r = family_run(body, engine, n_grid)
    assert failures(r, before=True), (r["before_end"] / r["E0"], r["before_worst"] / r["E0"])


BLIND = ("the sand column's untraced term moves from -0.28 % to +1.35 % (taichi_mpm; warp_mpm +1.34 %), inside the 2 %"
         " gate: a 5 % modulus bias is 1.6 % of the energy brought there (its plastic work 30 %)")


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("body", [pytest.param("sand_column", marks=pytest.mark.xfail(strict=True, reason=BLIND)),
                                  "snow_ball"])
def test_catch_a_ledger_told_moduli_5_percent_high(body, engine):
    """The engine built with E x 0.95, the ledger kept on the scene's E (its stresses and energies 5.3 % high): the
    snow ball's untraced term ends at +4.93 % (both engines), over the gate; the sand column's stays inside it (a
    strict xfail, its figures in the reason)."""
    r = family_run(body, engine, 32, stiffness_scale=0.95)
    assert failures(r), (r["untraced_end"] / r["E0"], r["untraced_worst"] / r["E0"])


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("body", ["snow_block", "snow_column", "snow_ball_fast"])
def test_catch_the_fixed_step_gains_on_the_snow_block(engine, body, monkeypatch):
    """Round 57's catch (``gasp_core.mpm.state_step``): with the step chosen once from the materials' constants (round
    56's rule: the state's step switched off) the snow block at n_grid 32 gains +6.83 % of its energy untraced (worst
    7.41 %, both engines), over the gate its state-stepped run closes within; round 58: the neighbours the state's
    step closes too, the snow column +13.70 % and the fast snow ball +23.90 % (taichi_mpm)."""
    import gasp_core.mpm.state_step as state_step
    from energy_ledger_plastic import run
    monkeypatch.setattr(state_step, "applies", lambda setup, opts: False)
    r = run(body, engine, 32)
    assert r["frames"] == [r["frames"][0]] * 3, r["frames"]   # one step for the run, the setup's
    assert failures(r) and r["untraced_end"] > CLOSE_END * r["E0"], (r["untraced_end"] / r["E0"], failures(r))
