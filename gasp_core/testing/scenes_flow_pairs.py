"""Conformance scenes of a flowing body against another body (issue 53 item 6), each with a known answer; they need
the feature ``body_friction`` (the bodies slide on each other by Coulomb's law: a flowing body's own grid velocity
field, ``gasp_core.mpm.fields``, docs/contact.md "Sand that slides on what it touches"). The scenes are
``gasp_core.testing.sand_ball``'s, measured there first (``tests/test_contact_fields.py``, ``benchmarks/bench_sand_ball.py``).

- ``sand_on_ball``: a 6 x 6 x 15 cm sand column (E 3.5e5 Pa, friction angle 30 deg) collapsing against a 5 cm jelly
  ball resting 5 mm beyond its face, 36 frames of 1/30 s, n_grid 32 (dx 15 mm); the same column alone gives the free
  pile. Known answer (issue 53's must-show): sand that slides piles against the ball as it piles on its own, and
  neither sticks to it nor enters it. Checks: the sand's share on the ball's side steeper than 50 degrees under
  ``STEEP_TOL`` = 1 %; the pile against the ball (95th percentile of the sand's height within 1.5 dx of it) within
  ``PILE_TOL`` = 20 % of the free pile's (99th percentile), either side; the deepest sand surface inside the ball (a
  point plus half its spacing, round 75; or the gap to it) within ``DEPTH_TOL`` = 0.3 dx; the ball turned under ``TURN_TOL`` = 2 degrees (the issue's limits).
  One velocity field (a no-slip contact) heaps the pile about 1.35 times, holds the sand a cell short of the ball and
  turns it several degrees (docs/contact.md); slow tier (two runs of 36 frames).

- ``sand_slide``: a 6 x 6 x 3 cm block of the same sand thrown along a 40 x 16 x 3 cm jelly slab (on the ground) at
  0.4, 0.6 and 0.8 m/s, 6 frames. A sand block spreads as it slides (its back slips backwards once it slows), so
  Coulomb's ``v0^2 / (2 mu g)`` is not its answer (the grid's own boundary rule gives it 0.39-0.47 for tan 30 deg =
  0.577). Known answer, measured: the same block thrown along the ground of the same friction, no slab (the
  boundary rule; a jelly block there stops within 0.4 % of Coulomb's travel). Checks: the effective coefficient
  ``v0^2 / (2 g travel)`` over the ground's, averaged over the three speeds, within ``MU_TOL`` = 4 %, and each speed's
  travel within ``SLIDE_TOL`` = 5 % of the ground's. One field sticks the block; no friction lets it slide on.
  Since round 36 (the ground's touched layer, docs/contact.md "Round 36") the ground's answer is within 2.5 % of
  Coulomb's (effective mu 0.563-0.570); the block on the slab read 22 % below it (a known failure in round 36) until
  round 37's flowing body's touch (``gasp_core.mpm.fields.flow_touch``, docs/contact.md "Round 37"): now within
  1 % of the ground's on both MPM engines.
- ``sand_slide_coulomb`` (round 38, docs/contact.md "Round 38"): the same sand block thrown at 1.2 and 1.6 m/s along
  the slab made 4.5 cm thick (``S.COULOMB_SLAB_H``: 3 cells; on the 3 cm slab the ratio read 1.2-2.3 % high before
  round 41, docs/contact.md "Round 41", now within 0.1 % too),
  3 frames, while all of its base still slides forward. Known answer: Coulomb's law on the block, its horizontal
  momentum lost over the normal impulse the slab gave it (``S.coulomb_ratio``: gravity's impulse plus its vertical
  momentum gained), is the pair's ``mu`` = tan 30 deg, however the sand slumps. Check: each speed within
  ``RATIO_TOL`` = 2.5 %, either side. It reads the pair's friction with a slope of 1 (measured 0.95 and 1.05 times
  it: -5.0 and +4.9 %), so both 5 % biases fail it; ``sand_slide``'s travel against the ground's answer keeps its own
  +1.9 % and reads a 5 % low friction as -3 %.
- ``solid_slide`` (slow tier): a jelly block (the slab's jelly, 6 x 6 x 3 cm) thrown along the slab at the same
  speeds, n_grid 64 (``gasp_core.testing.sand_ball.SOLID_N_GRID``). Known answer: a block that keeps its shape stops
  after Coulomb's ``v0^2 / (2 mu g)``, ``mu`` = 0.5 (``gasp_core.mpm.fields.SOLID_FRICTION``, two soft bodies);
  the same two checks against it. Figures of the engines and the broken ones caught: docs/tolerances.md.
"""
from __future__ import annotations

import math

import numpy as np

from gasp_core.seam.engine import EngineInfo
import gasp_core.testing.sand_ball as S
from gasp_core.testing.helpers import Check, check
from gasp_core.testing.kit import Requires, Scene, Trace, run_trace

STEEP_TOL, PILE_TOL, DEPTH_TOL, TURN_TOL = 0.01, 0.20, 0.3, 2.0
PAIR_FRAMES = 36
MU_TOL, SLIDE_TOL = 0.04, 0.05
SPEEDS = (0.4, 0.6, 0.8)
SLIDE_FRAMES = 6
#: ``sand_slide_coulomb``: the tolerance, the speeds (m/s: the block still slides at 3 frames at tan 35 deg, 0.69 m/s
#: lost) and the frames.
RATIO_TOL, RATIO_SPEEDS, RATIO_FRAMES = 0.025, (1.2, 1.6), 3
_REQ = Requires(frozenset({"sand", "jelly"}), frozenset({"ground"}), frozenset({"body_friction"}))
_REQ_SOLID = Requires(frozenset({"jelly"}), frozenset({"ground"}), frozenset({"body_friction"}))


def _eval_pair(info: EngineInfo, tr: Trace) -> list[Check]:
    free = run_trace(info, S.pair_setup(ball=False), PAIR_FRAMES)
    f = S.pair_figures(tr.x[0], tr.x[-1], np.asarray(tr.setup.body_id), free.x[-1], S.sand_reach(tr.setup))
    return [check("steep_side", f["steep"], STEEP_TOL, "share of the sand within 1 dx of the ball's side where it is "
                  "steeper than 50 degrees"),
            check("pile_height", abs(f["pile"] - 1.0), PILE_TOL,
                  f"|pile against the ball / free pile - 1| ({f['h_pair_mm']:.1f} mm / {f['h_free_mm']:.1f} mm; "
                  f"signed {f['pile'] - 1.0:+.3f})", signed=f["pile"] - 1.0),
            check("sand_depth", abs(f["depth_dx"]), DEPTH_TOL, f"|deepest sand surface (a point plus half its spacing) "
                  f"inside the ball's sphere| in dx "
                  f"(signed {f['depth_dx']:+.3f}: negative a gap)", signed=f["depth_dx"]),
            check("ball_turn", f["turn_deg"], TURN_TOL, "rotation of the ball from its start, degrees")]


def _travels(info: EngineInfo, tr: Trace | None = None, **kw) -> dict:
    """The block's travel (m) at each of :data:`SPEEDS` (``S.slide_setup(v0, **kw)``); ``tr``, when given, is the run
    at the middle one."""
    runs = {v0: tr if (tr is not None and v0 == SPEEDS[1]) else run_trace(info, S.slide_setup(v0, **kw), SLIDE_FRAMES)
            for v0 in SPEEDS}
    return {v0: S.slide_travel(r.x[0], r.x[-1], r.setup) for v0, r in runs.items()}


def _slide_checks(travel: dict, want: dict, what: str) -> list[Check]:
    """The mean effective coefficient's bias and the worst speed's travel error against ``want`` (m per speed)."""
    mu_eff = {v0: v0 ** 2 / (2.0 * 9.81 * max(travel[v0], 1e-12)) for v0 in SPEEDS}
    bias = float(np.mean([want[v0] / max(travel[v0], 1e-12) for v0 in SPEEDS])) - 1.0   # mu_eff / the answer's
    err = {v0: travel[v0] / want[v0] - 1.0 for v0 in SPEEDS}
    each = ", ".join(f"{v0:g} m/s {1e3 * travel[v0]:.1f} mm / {1e3 * want[v0]:.1f} ({err[v0]:+.1%})" for v0 in SPEEDS)
    worst = max(SPEEDS, key=lambda v0: abs(err[v0]))
    return [check("coulomb_mu", abs(bias), MU_TOL, f"|mean effective friction / {what} - 1| over {len(SPEEDS)} "
                  f"speeds (mu_eff {', '.join(f'{mu_eff[v0]:.3f}' for v0 in SPEEDS)}; signed {bias:+.4f})",
                  signed=bias),
            check("coulomb_travel", abs(err[worst]), SLIDE_TOL, f"|travel / {what} travel - 1| at the worst speed ({each})",
                  signed=err[worst])]


def _eval_slide(info: EngineInfo, tr: Trace) -> list[Check]:
    """The sand block's travels on the slab against the same block's on the ground of the same friction."""
    return _slide_checks(_travels(info, tr), _travels(info, ground=True), "the ground's")


def _eval_solid_slide(info: EngineInfo, tr: Trace) -> list[Check]:
    """The jelly block's travels against Coulomb's ``v0^2 / (2 mu g)``, ``mu`` the soft bodies' friction."""
    from gasp_core.mpm.fields import field_friction
    mu = field_friction(tr.setup)
    return _slide_checks(_travels(info, tr, solid=True), {v0: v0 ** 2 / (2.0 * mu * 9.81) for v0 in SPEEDS},
                         f"Coulomb's (mu {mu:g})")


def _eval_slide_coulomb(info: EngineInfo, tr: Trace) -> list[Check]:
    """Coulomb's law on the sand block (``S.coulomb_ratio`` from the throw to the last frame) at each speed against
    the pair's friction."""
    from gasp_core.mpm.fields import field_friction
    mu = field_friction(tr.setup)
    runs = {v0: tr if v0 == RATIO_SPEEDS[0] else
            run_trace(info, S.slide_setup(v0, slab_h=S.COULOMB_SLAB_H), RATIO_FRAMES) for v0 in RATIO_SPEEDS}
    err = {v0: S.coulomb_ratio(r.v, r.setup, 0, RATIO_FRAMES) / mu - 1.0 for v0, r in runs.items()}
    worst = max(RATIO_SPEEDS, key=lambda v0: abs(err[v0]))
    each = ", ".join(f"{v0:g} m/s {err[v0]:+.2%}" for v0 in RATIO_SPEEDS)
    return [check("coulomb_ratio", abs(err[worst]), RATIO_TOL, f"|the block's momentum lost along x / the normal "
                  f"impulse / mu - 1| at the worst speed (mu {mu:.4f}; {each})", signed=err[worst])]


SCENES_FLOW_PAIRS = [
    Scene("sand_on_ball", f"a sand column collapsing against a jelly ball piles as it does alone (within "
          f"{PILE_TOL:.0%}), does not stick to its steep side or enter it, and turns it under {TURN_TOL:g} deg",
          _REQ, lambda info: S.pair_setup(), PAIR_FRAMES, _eval_pair, slow=True),
    Scene("sand_slide", f"a sand block thrown along a jelly slab slides as along the ground of the same friction "
          f"(tan 30 deg; a sand block spreads, so the grid's boundary rule gives its answer): mean effective mu within "
          f"{MU_TOL:.0%}, each speed within {SLIDE_TOL:.0%}", _REQ, lambda info: S.slide_setup(SPEEDS[1]),
          SLIDE_FRAMES, _eval_slide),
    Scene("sand_slide_coulomb", f"a sand block thrown along a jelly slab at {RATIO_SPEEDS[0]:g} and "
          f"{RATIO_SPEEDS[1]:g} m/s loses momentum along x at mu (tan 30 deg) times the normal impulse while it "
          f"slides (Coulomb's law on the block): within {RATIO_TOL:.1%} at each speed", _REQ,
          lambda info: S.slide_setup(RATIO_SPEEDS[0], slab_h=S.COULOMB_SLAB_H), RATIO_FRAMES, _eval_slide_coulomb),
    Scene("solid_slide", f"a jelly block thrown along a jelly slab (n_grid {S.SOLID_N_GRID}) stops after Coulomb's "
          f"v0^2 / (2 mu g), mu the soft bodies' friction: mean effective mu within {MU_TOL:.0%}, each speed within "
          f"{SLIDE_TOL:.0%}", _REQ_SOLID, lambda info: S.slide_setup(SPEEDS[1], solid=True), SLIDE_FRAMES,
          _eval_solid_slide, slow=True),
]
assert math.isclose(S.SAND.friction_angle, 30.0)
