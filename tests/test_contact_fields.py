"""The two-field grid contact (issue 53 item 3, ``docs/contact.md`` "Sand that slides on what it touches").

- The node correction (``gasp_core.mpm.fields.field_offsets``) against Coulomb's law on hand-made nodes: momentum
  conserved, the approach along the normal removed, sliding kept where the tangential speed exceeds ``mu`` times the
  approach (its loss exactly ``mu`` times the approach), sticking below it, separation untouched.
- Which scenes run it (mixed scenes only, option ``contact_fields``) and its friction (``tan`` of the sand's angle).
- Both engines (slow tier): ``gasp_core.testing.sand_ball``'s 6 x 6 x 15 cm column (friction angle 30) collapsing
  against a jelly ball, 36 frames: at most ``STEEP_TOL`` = 1 % of the sand on the ball's side steeper than 50
  degrees, the pile against the ball within ``PILE_TOL`` = 20 % of the free pile's height (two-sided), no sand point
  deeper than ``DEPTH_TOL`` = 0.3 dx inside the ball, the ball turned under ``TURN_TOL`` = 2 degrees. With the
  contact switched off (``contact_fields = false``, one velocity field: the no-slip before issue 53) the same checks
  fail (:func:`test_the_checks_fail_with_one_field`): the ball turned 6.7 degrees on warp_mpm, the pile 1.36 times
  the free pile's height. The column with points 5 mm apart on its faces, 60 frames, warp_mpm: the same limits.
- Both engines (taichi_mpm in the slow tier): a sand block thrown at 0.4, 0.6 and 0.8 m/s over a jelly slab
  (``sand_ball.slide_setup``) travels as the same block thrown along the ground of the same friction (the boundary
  rule, the sand's ``tan 30 deg``) within ``SLIDE_TOL`` = 5 % (warp_mpm -1.9 to -2.8 % until round 35; in round
  36 a strict xfail, the ground meeting Coulomb and the slab 22 % short; since round 37's flowing body's touch,
  ``gasp_core.mpm.fields.flow_touch``, +0.4 to +1.0 % on both engines); with the friction switched off
  (``field_friction`` made 0), one field, or the flowing body's touch off (``FLOW_TOUCH`` False, the rule of round
  36) the check fails (:func:`test_the_slide_check_fails_without_friction_or_with_one_field`), and the conformance
  scene ``sand_slide`` fails with the body friction 5 % high
  (:func:`test_the_sand_slide_catches_a_friction_5pct_off`; 5 % low passes it: ``solid_slide`` and, for the sand,
  ``sand_slide_coulomb`` catch that side, ``tests/test_slide_coulomb.py``).
  The family (grids, a stiffer slab, a second friction angle): ``tests/test_flow_touch.py``. The solid block against
  Coulomb's travel is the conformance scene ``solid_slide``.
- Both engines (slow tier): the light ball against the column in float64, 3 frames, the same points to 1e-9 m: the
  contact's balance reads each body's motion on the same state in both (taichi_mpm's read it one substep late and
  turned the light ball 2.37 degrees against warp_mpm's 1.51:
  :func:`test_the_engines_run_the_same_balance_against_the_sand`).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from gasp_core.testing import sand_ball as S
from gasp_core.mpm.fields import field_friction, field_offsets, mass_normals, uses_fields

STEEP_TOL, PILE_TOL, DEPTH_TOL, TURN_TOL = 0.01, 0.20, 0.3, 2.0
SLIDE_TOL, SLIDE_FRAMES, SPEEDS = 0.05, 6, (0.4, 0.6, 0.8)
FRAMES = 36
ENGINES = ["warp_mpm", "taichi_mpm"]


def _node(u_a, u_b, m_a=2.0, m_b=3.0, n=(1.0, 0.0, 0.0), mu=0.5):
    """One node: field A at velocity u_a, B at u_b; returns (dv_a, dv_b, v_cm, v_a', v_b')."""
    u_a, u_b = np.asarray(u_a, float), np.asarray(u_b, float)
    m, p_a = m_a + m_b, m_a * u_a
    p = p_a + m_b * u_b
    dva, dvb = field_offsets(np.array([m]), np.array([m_a]), p[None], p_a[None], np.asarray(n, float)[None], mu)
    v_cm = p / m
    return dva[0], dvb[0], v_cm, v_cm + dva[0], v_cm + dvb[0]


def test_the_node_correction_follows_coulomb():
    # sliding: A approaches B at 1 m/s along n and slides past at 2 m/s; mu 0.5 takes 0.5 m/s of the 2 relative
    dva, dvb, v_cm, va, vb = _node([1.0, 2.0, 0.0], [0.0, 0.0, 0.0])
    assert np.allclose(2.0 * dva + 3.0 * dvb, 0.0, atol=1e-12)                 # momentum
    assert abs((va - vb)[0]) < 1e-12                                            # no approach left
    assert (va - vb)[1] == pytest.approx(2.0 - 0.5 * 1.0, rel=1e-12)            # Coulomb: mu times the approach
    # sticking: the tangential speed under mu times the approach: one velocity
    _, _, v_cm, va, vb = _node([1.0, 0.3, 0.0], [0.0, 0.0, 0.0])
    assert np.allclose(va, v_cm) and np.allclose(vb, v_cm)
    # separating: each keeps its own velocity
    _, _, _, va, vb = _node([-1.0, 2.0, 0.0], [0.0, 0.5, 0.0])
    assert np.allclose(va, [-1.0, 2.0, 0.0]) and np.allclose(vb, [0.0, 0.5, 0.0])
    # frictionless: the tangential slip kept whole
    _, _, _, va, vb = _node([1.0, 2.0, 0.0], [0.0, 0.0, 0.0], mu=0.0)
    assert (va - vb)[1] == pytest.approx(2.0, rel=1e-12)
    # a node one field barely reaches (1e-9 of the mass) moves as one
    dva, dvb, *_ = _node([1.0, 2.0, 0.0], [0.0, 0.0, 0.0], m_a=3e-9)
    assert np.all(dva == 0.0) and np.all(dvb == 0.0)


def test_the_normals_point_out_of_field_a():
    # field A fills x < 0.5 of a 6^3 grid, B the rest: the normal at the interface is +x
    m = np.ones((6, 6, 6))
    m_a = np.zeros_like(m)
    m_a[:3] = 1.0
    n = mass_normals(m, m_a, 0.1)
    assert n[2, 2, 2, 0] > 0 and n[3, 2, 2, 0] > 0 and np.allclose(n[2:4, 2, 2, 1:], 0.0)


def test_only_mixed_scenes_run_two_fields_and_the_friction_is_the_sands():
    assert uses_fields(S.pair_setup())
    assert not uses_fields(S.pair_setup(ball=False))                        # sand alone: one field
    assert not uses_fields(S.pair_setup(options={"contact_fields": False}))
    assert not uses_fields(S.pair_setup(options={"contact": "grid"}))
    assert field_friction(S.pair_setup()) == pytest.approx(math.tan(math.radians(30.0)), rel=1e-12)


def _figures(engine: str, fields: bool, surface: bool = False, frames: int = FRAMES) -> dict:
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    setup = S.pair_setup(surface=surface, options={"threads": 1, "contact_fields": fields})
    tr = run_trace(get_engine(engine), setup, frames)
    free = run_trace(get_engine(engine), S.pair_setup(ball=False, surface=surface, options={"threads": 1}), frames)
    return S.pair_figures(tr.x[0], tr.x[-1], np.asarray(setup.body_id), free.x[-1])


def _failures(f: dict) -> list[str]:
    out = []
    if f["steep"] > STEEP_TOL:
        out.append(f"{100 * f['steep']:.2f} % of the sand on the ball's steep side")
    if abs(f["pile"] - 1.0) > PILE_TOL:
        out.append(f"pile against the ball {f['h_pair_mm']:.1f} mm, the free pile {f['h_free_mm']:.1f} mm")
    if f["depth_dx"] > DEPTH_TOL:
        out.append(f"sand {f['depth_dx']:.2f} dx inside the ball")
    if f["turn_deg"] > TURN_TOL:
        out.append(f"ball turned {f['turn_deg']:.2f} deg")
    return out


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "round 86: the ball rolls 2.23 degrees (warp_mpm; taichi_mpm 2.27), its centre 2.24 mm on, away from the sand, "
    "against issue 53's limit of 2; every other figure as before. Until round 85 the balance took back up to two "
    "spacings of its contact torque on every patch, the flat bottom layer of the ball's fill lattice too, and the ball "
    "turned 0.056 degrees while it slid 0.67 mm. Since round 86 a flat patch keeps its torque "
    "(gasp_core.mpm.take_back). Round 87: the conformance scene sand_on_ball (the same run) fails alike and is a "
    "known failure of both engines (gasp_core.mpm.failures); the same ball on the rigid route, resting on its fill "
    "lattice, is no reference (docs/contact.md 'Round 87')"))
@pytest.mark.parametrize("engine", ENGINES)
def test_sand_slides_on_the_ball(engine):
    f = _figures(engine, True)
    assert not _failures(f), (_failures(f), f)


@pytest.mark.xfail(strict=True, raises=AssertionError, reason=(
    "round 75: the touch at the flowing body's surface (gasp_core.mpm.flow_reach.FLOW_REACH) holds the sand half its "
    "point spacing further off the ball, and the pile against it stands 50.8 mm against the free pile's 41.9 mm "
    "(1.213, limit 1.20; warp_mpm, 60 frames); the rule before passed it, with the sand's Gaussians 0.38-0.55 dx "
    "inside the ball (issue 67's must-show, docs/contact.md 'Round 75')"))
def test_sand_with_surface_points_slides_on_the_ball():
    """The column with points 5 mm apart on its faces runs to the end (60 frames: at 36 its pile is still 1.21 times
    the free pile's height, settling) and meets the same limits (warp_mpm; taichi_mpm in bench_sand_ball.py)."""
    f = _figures("warp_mpm", True, surface=True, frames=60)
    assert not _failures(f), (_failures(f), f)


@pytest.mark.parametrize("engine", ENGINES)
def test_the_checks_fail_with_one_field(engine):
    f = _figures(engine, False)
    assert _failures(f), f


def _slide(engine: str, v0: float, fields: bool = True, **kw) -> tuple[float, float]:
    """(the block's travel on the slab, the same block's on the ground of the same friction), m."""
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    out = []
    for ground in (False, True):
        setup = S.slide_setup(v0, {"threads": 1, "contact_fields": fields}, ground=ground, **kw)
        tr = run_trace(get_engine(engine), setup, SLIDE_FRAMES)
        out.append(S.slide_travel(tr.x[0], tr.x[-1], setup))
    return out[0], out[1]


@pytest.mark.parametrize("engine", ENGINES)
def test_a_sand_block_slides_on_a_slab_as_on_the_ground(engine):
    """The body contact's friction is the boundary rule's, the same Coulomb coefficient (tan 30 deg): the sand block
    on the jelly slab travels as the same block on the ground (warp_mpm -1.9 to -2.8 % at 0.4-0.8 m/s until round
    35, when the ground's free node layer short-changed both alike; round 36's touched layer gave the ground Coulomb
    and left the slab 22 % short, a strict xfail; since round 37's flowing body's touch -1.0 to -0.4 % in travel,
    both engines: docs/contact.md "Round 37")."""
    for v0 in SPEEDS:
        got, want = _slide(engine, v0)
        assert abs(got / want - 1.0) <= SLIDE_TOL, (v0, got, want)


def test_the_slide_check_fails_without_friction_or_with_one_field(monkeypatch):
    got, want = _slide("warp_mpm", 0.6, fields=False)           # one field: the block sticks
    assert got / want < 1.0 - SLIDE_TOL, (got, want)
    import gasp_warp_mpm.fields as wf
    monkeypatch.setattr(wf, "field_friction", lambda setup: 0.0)   # the contact without friction
    got, want = _slide("warp_mpm", 0.6)
    assert got / want > 1.0 + SLIDE_TOL, (got, want)
    monkeypatch.undo()
    import gasp_core.mpm.fields as gf
    monkeypatch.setattr(gf, "FLOW_TOUCH", False)   # round 36's rule: the volume test, the node's share alone
    got, want = _slide("warp_mpm", 0.4)
    assert got / want > 1.0 + SLIDE_TOL, (got, want)


@pytest.mark.slow
@pytest.mark.parametrize("factor", [1.05])
def test_the_sand_slide_catches_a_friction_5pct_off(monkeypatch, factor):
    """The conformance scene ``sand_slide`` passes on warp_mpm (+1.95 % mean, docs/contact.md "Round 37") and fails
    with the body friction 5 % high (its answer, the block on the ground, keeps the boundary's tan 30 deg). 5 % low
    reads about -3 % and passes: that side is ``solid_slide``'s catch (unbiased, +0.55 %) and, for the sand,
    ``sand_slide_coulomb``'s (``tests/test_slide_coulomb.py``)."""
    pytest.importorskip("gasp_warp_mpm")
    import gasp_warp_mpm.fields as wf
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import evaluate_scene
    from gasp_core.testing.scenes import scene_by_name
    mu = math.tan(math.radians(S.SAND.friction_angle))
    monkeypatch.setattr(wf, "field_friction", lambda setup: factor * mu)
    r = evaluate_scene(get_engine("warp_mpm"), scene_by_name("sand_slide"), {})
    assert r.status == "fail", r


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.95, 1.05])
def test_the_solid_slide_catches_a_friction_5pct_off(monkeypatch, factor):
    """The conformance scene ``solid_slide`` (a jelly block along a jelly slab against Coulomb's travel, mu 0.5) passes
    on warp_mpm (+0.55 % mean) and fails with the engine's body friction 5 % low or high (the known answer keeps 0.5)."""
    pytest.importorskip("gasp_warp_mpm")
    import gasp_warp_mpm.fields as wf
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import evaluate_scene
    from gasp_core.testing.scenes import scene_by_name
    from gasp_core.mpm.fields import SOLID_FRICTION
    monkeypatch.setattr(wf, "field_friction", lambda setup: factor * SOLID_FRICTION)
    r = evaluate_scene(get_engine("warp_mpm"), scene_by_name("solid_slide"), {})
    assert r.status == "fail", r


AGREE_FRAMES, AGREE_TOL_M, AGREE_TURN_TOL = 3, 1e-9, 1e-3


def test_the_engines_run_the_same_balance_against_the_sand():
    """The light ball (``pair_setup(light=True)``, the column touching it) in float64, 3 frames: the two engines'
    points agree to ``AGREE_TOL_M`` = 1e-9 m (measured 2e-15 m) and the ball's turn to 0.1 %. taichi_mpm took the
    balance's moments one substep behind and predicted the body's motion from gravity and the last fix, missing the
    sand's push through the two fields: 1.4e-4 m apart at frame 3, the turn 0.146 against 0.192 degrees (-24 %),
    and 2.37 against 1.51 degrees at frame 60 (``benchmarks/light_ball_turn.py``)."""
    pytest.importorskip("gasp_warp_mpm")
    pytest.importorskip("gasp_taichi_mpm")
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    setup = S.pair_setup(ball=True, options={"threads": 1, "contact_fields": True, "precision": "f64"}, light=True)
    xs = {e: run_trace(get_engine(e), setup, AGREE_FRAMES).x[-1] for e in ENGINES}
    ball = setup.body_id == max(setup.body_id)
    turns = {e: S.rotation_deg(setup.x[ball], x[ball]) for e, x in xs.items()}
    assert turns["warp_mpm"] > 0.05, turns   # the sand has turned the ball (0.069 deg since round 37's touch)
    assert np.abs(xs["taichi_mpm"] - xs["warp_mpm"]).max() < AGREE_TOL_M
    assert abs(turns["taichi_mpm"] / turns["warp_mpm"] - 1.0) < AGREE_TURN_TOL, turns
