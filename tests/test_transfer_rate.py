"""The transfers' damping as a rate (engine option ``transfer_damping``, :mod:`gasp_core.mpm.transfer`,
``docs/dissipation.md`` "Round 56: the transfers' damping per second").

An APIC round trip removes a point's non-affine velocity every substep, so its damping per second grows as
``1 / dt``: the conformance ``bounce_hertz`` ball (jelly, R 0.12 m, E 2e5 Pa, n_grid 32) bounced with restitution
0.874, 0.840, 0.795, 0.747 at 7, 14, 28, 56 substeps a frame, and ``tests/test_contact_step.py``'s floor of 0.8 failed
at cfl 0.1 once the step rule became "sum". Under ``"rate"`` (the default) a substep shorter than the step at cfl 0.4
blends AFLIP with ``alpha = 1 - n_ref / n``: 0.874, 0.867, 0.862, 0.861.

Fast: the blend's rule and the reference step on a real scene (alpha 0 at the engines' default step and at a longer
one, so those runs are APIC to the bit). Slow, both engines, a family of four balls (n_grid 24, 32 and 48, radius 0.12
and 0.08 m, E 2e5 and 5e4 Pa) each at N, 2 N, 4 N and 8 N substeps a frame (N the reference's): restitution moves
at most 2.5 % a halving (a 5 % bias in any halving fails) and at most 1 % in the last; the catch, APIC's damping per
substep (``"step"``), fails it (-3.84 % at the first halving of the n_grid 32 ball).
"""
from __future__ import annotations

import dataclasses
import importlib.util
import sys
from pathlib import Path

import pytest

from gasp_core.errors import SceneError
from gasp_core.mpm.grid_engine import grid_substeps, transfer_alpha
from gasp_core.mpm.transfer import blend_alpha
from gasp_core.testing import scenes_analytic as sa

sys.path.insert(0, str(Path(__file__).parent))
from test_contact_step import _bounce_restitution  # noqa: E402

ENGINES = [e for e in ("taichi_mpm", "warp_mpm") if importlib.util.find_spec(f"gasp_{e}") is not None]
HALVING_TOL, LAST_TOL = 0.025, 0.01
#: (n_grid, radius m, E Pa or None for the conformance ball's 2e5)
BALLS = ((32, 0.12, None), (24, 0.12, None), (48, 0.08, None), (32, 0.12, 5e4))


def test_the_blend_keeps_the_reference_steps_damping_per_second():
    assert blend_alpha(0.0, "rate", 7, 7) == 0.0 and blend_alpha(0.0, "rate", 5, 7) == 0.0
    assert blend_alpha(0.0, "rate", 14, 7) == 0.5 and blend_alpha(0.0, "rate", 56, 7) == 0.875
    assert blend_alpha(0.0, "step", 56, 7) == 0.0 and blend_alpha(0.9, "rate", 28, 7) == 0.9
    assert blend_alpha(0.3, "rate", 28, None) == 0.3
    with pytest.raises(ValueError, match="transfer_damping"):
        blend_alpha(0.0, "linear", 14, 7)


def test_the_reference_is_the_step_at_cfl_04():
    """On the conformance bounce scene: the engines' default step and a longer one are APIC (alpha 0); twice the
    substeps is alpha 1/2; ``"step"`` and a hand-set ``flip`` are kept."""
    s = sa._build_bounce(None)
    n = grid_substeps(s)
    base = dict(s.options)
    assert transfer_alpha(s, base, n) == 0.0
    assert transfer_alpha(s, {**base, "cfl": 0.8}, grid_substeps(dataclasses.replace(s, options={**base, "cfl": 0.8}))) == 0.0
    assert transfer_alpha(s, {**base, "n_substeps": 2 * n}, 2 * n) == 0.5
    assert transfer_alpha(s, {**base, "n_substeps": 2 * n, "transfer_damping": "step"}, 2 * n) == 0.0
    assert transfer_alpha(s, {**base, "n_substeps": 4 * n, "flip": 0.9}, 4 * n) == 0.9


@pytest.mark.skipif(not ENGINES, reason="no grid engine installed")
def test_an_unknown_damping_is_refused_naming_the_option():
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    info = engines()[ENGINES[0]]
    s = sa._build_bounce(info)
    with pytest.raises(SceneError, match="transfer_damping"):
        build_engine(info, dataclasses.replace(s, options={**s.options, "transfer_damping": "linear"}))


def ball_family(engine: str, damping: str, balls=BALLS) -> list[str]:
    """Each ball's restitution at N, 2 N, 4 N, 8 N substeps (``transfer_damping = damping``); the failures of the
    halving and last-halving bounds, as text."""
    base = (sa.BOUNCE_NGRID, sa.BOUNCE_R, sa.BOUNCE_MAT)
    bad = []
    try:
        for ng, r, E in balls:
            sa.BOUNCE_NGRID, sa.BOUNCE_R = ng, r
            sa.BOUNCE_MAT = base[2] if E is None else dataclasses.replace(base[2], E=E)
            n = grid_substeps(sa._build_bounce(None))
            e = [_bounce_restitution(engine, {"n_substeps": k * n, "transfer_damping": damping}) for k in (1, 2, 4, 8)]
            steps = [e[i + 1] / e[i] - 1 for i in range(3)]
            print(engine, damping, (ng, r, E), n, [round(x, 4) for x in e], [f"{100 * c:+.2f} %" for c in steps])
            if max(abs(c) for c in steps) > HALVING_TOL or abs(steps[-1]) > LAST_TOL:
                bad.append(f"ball n_grid {ng} R {r} E {E or 'conformance'}: restitution {[round(x, 4) for x in e]} "
                           f"at {n}, {2 * n}, {4 * n}, {8 * n} substeps")
    finally:
        sa.BOUNCE_NGRID, sa.BOUNCE_R, sa.BOUNCE_MAT = base
    return bad


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_bounce_converges_as_the_step_shrinks(engine):
    assert ball_family(engine, "rate") == []


@pytest.mark.slow
@pytest.mark.skipif("warp_mpm" not in ENGINES, reason="warp_mpm not installed")
def test_apics_damping_per_substep_fails_the_family():
    bad = ball_family("warp_mpm", "step", BALLS[:1])
    assert bad and "n_grid 32" in bad[0], bad
