"""Round 62's position term (``gasp_core.mpm.gap_push``, ``docs/contact.md`` "Round 62: letting an overlap out"): a
measured overlap of two soft bodies let out along the contact normal, no velocity changed (the switch ``PUSH``, off).

- The reference: the half-space profile's inverse (``table_distance``) is ``table_level``'s on both sides of the face;
  two lattice balls 0.2 dx inside each other are pushed apart along the line of their centres by their shares
  (BETA times the other's mass fraction), two balls 0.1 dx apart are not pushed (catch: the reach of round 60's
  separation pushes them); the shares keep the pair's centre of mass.
- Both engines' kernels move the points as the reference does (warp_mpm float64 and float32 in the default tier;
  taichi_mpm slow).
- The engine (warp_mpm; taichi_mpm slow): the stacked balls (R 2 dx, n_grid 24) started touching rest within 0.05 dx
  with ``CURVATURE`` and the push (-0.037 dx measured, both engines); catch: the push off (-0.068, the sink; slow). The
  kinetic energy of the dropped R 3 dx pair decays over 2 s (slow, both engines); catches: the push made a velocity
  (``KICK``: the energy doubles after the landing) and BETA x 10 (jitter: no decay).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gasp_core.mpm.gap_push as GP
import gasp_core.mpm.gap_touch as G
from test_gap_touch import DX, _balls, _scatter_ng

NG = 20
IN_A = np.array([0, 1])                                                 # body 1 in field A


def _pair(gap: float):
    x, in_a, measured = _balls(2.0, gap)
    vf = np.stack([_scatter_ng(x[in_a], NG), _scatter_ng(x[~in_a], NG)])
    return x, in_a.astype(int), vf                                       # body 1: the upper ball, field A


def _params(delta=0.25, share=(0.1, 0.1)):
    return np.r_[G.half_space_table(), delta, delta, share]


def test_the_profile_is_inverted_on_both_sides():
    t = G.half_space_table()
    s = np.array([-1.2, -0.3, -0.01, 0.0, 0.02, 0.37, 1.0])
    phi = np.where(s >= 0, G.table_level(t, np.abs(s)), 1.0 - G.table_level(t, np.abs(s)))
    assert GP.table_distance(t, phi) == pytest.approx(s, abs=1e-9)


@pytest.mark.parametrize("curve", [True, False])
def test_overlapping_balls_are_pushed_apart_and_separated_ones_are_not(curve):
    x, body, vf = _pair(-0.2)
    move = GP.gap_push(x, IN_A, body, vf, np.zeros(3), DX, _params(), curve)
    up, down = move[body == 1], move[body == 0]                          # body 1: the upper ball, field A
    assert np.allclose(up, up[0]) and np.allclose(down, down[0])          # each body translated
    assert up[0, 2] > 0.002 and down[0, 2] < -0.002                       # apart, along the line of centres
    assert abs(up[0, 0]) + abs(up[0, 1]) < 0.1 * up[0, 2]
    assert up[0, 2] == pytest.approx(-down[0, 2], rel=0.3)                 # equal shares, equal masses
    x, body, vf = _pair(0.1)
    assert not GP.gap_push(x, IN_A, body, vf, np.zeros(3), DX, _params(), curve).any()
    # the catch: the reach of round 60's separation (0.5 spacing more) pushes them 0.1 dx apart
    assert GP.gap_push(x, IN_A, body, vf, np.zeros(3), DX, _params(0.5), curve).any()


def test_the_shares_keep_the_centre_of_mass():
    from gasp_core.testing.scenes_pairs import _build_stack
    s = _build_stack(None)
    big = dataclasses.replace(s, p_vol=np.where(s.body_id == 0, 2.0, 1.0) * s.p_vol)
    share = GP.push_params(big)[-2:]
    assert share.sum() == pytest.approx(GP.BETA)
    assert share[0] == pytest.approx(GP.BETA / 3) and share[1] == pytest.approx(2 * GP.BETA / 3)
    mass = np.array([2.0, 1.0])                                           # m_0 d_0 + m_1 d_1 = 0 for opposite d
    assert float((mass * share) @ np.array([1.0, -1.0])) == pytest.approx(0.0, abs=1e-12)


def _warp_move(x, body, vf, params, curve, Ft):
    import warp as wp
    from gasp_warp_mpm.pair_push import build_gap_push
    from gasp_warp_mpm.precision import build_types
    vec3, vec4 = build_types(Ft)[:2]
    overlap, move, clear = build_gap_push(Ft)
    xa, acc = wp.array(x, dtype=vec3, device="cpu"), wp.zeros(2, dtype=vec4, device="cpu")
    pa = wp.array(params, dtype=Ft, device="cpu")
    b = wp.array(body.astype(np.int32), dtype=wp.int32, device="cpu")
    wp.launch(clear, dim=2, device="cpu", inputs=[acc])
    wp.launch(overlap, dim=len(x), device="cpu", inputs=[
        xa, b, wp.array(IN_A.astype(np.int32), dtype=wp.int32, device="cpu"),
        wp.array(vf.reshape(-1), dtype=Ft, device="cpu"), vec3(0.0, 0.0, 0.0), Ft(1.0), Ft(1.0), pa, NG, G.TABLE_N, 2,
        Ft(G.TABLE_STEP), Ft(G.SIGMA2), int(curve), acc])
    wp.launch(move, dim=len(x), device="cpu", inputs=[xa, b, pa, G.TABLE_N, 2, acc, Ft(1.0), Ft(GP.CAP)])
    return xa.numpy() - x


@pytest.mark.parametrize("curve", [True, False])
def test_the_warp_kernels_are_the_reference(curve):
    wp = pytest.importorskip("warp")
    x, body, vf = _pair(-0.2)
    ref = GP.gap_push(x, IN_A, body, vf, np.zeros(3), DX, _params(), curve)
    assert np.abs(ref).max() > 0.002
    for Ft, tol in ((wp.float64, 1e-12), (wp.float32, 1e-5)):
        assert np.abs(_warp_move(x, body, vf, _params(), curve, Ft) - ref).max() < tol


@pytest.mark.slow
def test_the_taichi_kernels_are_the_reference(monkeypatch):
    """taichi_mpm's ``PairPush.push_gap`` with ``CURVATURE``: an engine of the two balls (dx 1 cm) whose node volumes
    are set to the reference's, pushed once."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.setup import Material, SimSetup
    monkeypatch.setattr(G, "CURVATURE", True)
    monkeypatch.setattr(GP, "PUSH", True)
    x, body, vf = _pair(-0.2)
    dx = 0.01
    setup = SimSetup(x=x * dx, v=0.0, p_vol=np.full(len(x), (dx / 2) ** 3), body_id=body,
                     materials=[Material("jelly"), Material("jelly")], gravity=np.zeros(3), domain_lo=np.zeros(3),
                     domain_hi=np.full(3, NG * dx), n_grid=NG, frame_dt=1.0 / 30.0)
    eng = build_engine(engines()["taichi_mpm"], setup)
    try:
        sv = eng.solver
        assert sv.gap_push_on
        in_a = np.array([sv.in_a[0], sv.in_a[1]])
        fv = vf if in_a[1] == 1 else vf[::-1].copy()                     # the engine's field A first
        params = GP.push_params(setup)
        ref = GP.gap_push(x, in_a, body, fv, np.zeros(3), DX, params, True)
        x0 = sv.x.to_numpy()[:len(x)].copy()
        sv.grid_vf.from_numpy(np.moveaxis(fv, 0, -1) * dx ** 3)
        sv.push_gap()
        got = (sv.x.to_numpy()[:len(x)] - x0) / dx
        order = np.lexsort(x0.T[::-1])                                    # the engine's order of the points
        want = ref[np.lexsort((x * dx).T[::-1])]
        assert np.abs(ref).max() > 0.005 and np.abs(got[order] - want).max() < 1e-4
    finally:
        eng.close()


# The engine: the stacked balls (``stacked_gap``'s scene, R 2 dx, n_grid 24, the jelly pair's friction 0.5) with
# ``CURVATURE`` and the push. Figures: ``python benchmarks/studies/gap_push.py`` (docs/contact.md "Round 62").

def _stacked(monkeypatch, engine: str, drop: float, frames: int | None = None):
    """The stacked balls started ``drop`` dx over the touch: ``(gap at rest in dx, kinetic energy per frame in J)``."""
    import gasp_core.testing.scenes_pairs as P
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    monkeypatch.setattr(P, "STACK_DROP", drop)
    s = dataclasses.replace(P._build_stack(None), options={"threads": 1})
    tr = run_trace(get_engine(engine), s, frames or round(P.STACK_T * 30))
    (c,) = P._eval_stack(None, tr)
    m = np.broadcast_to(np.asarray(s.p_vol, float), (len(s.x),)) * float(s.materials[0].rho)
    return c.figures["signed"], np.array([0.5 * float((m[:, None] * np.asarray(v) ** 2).sum()) for v in tr.v])


def _on(monkeypatch, push=True, **kw):
    monkeypatch.setattr(G, "CURVATURE", True)
    monkeypatch.setattr(GP, "PUSH", push)
    for k, v in kw.items():
        monkeypatch.setattr(GP, k, v)


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_the_push_rests_the_stacked_balls_from_touch(monkeypatch, engine):
    """Started touching (no landing), the stacked balls rest within 0.05 dx of touching with the push (-0.037 dx on
    both engines); the sink without it is the catch (``test_the_sink_comes_back_without_the_push``)."""
    _on(monkeypatch)
    gap, _ = _stacked(monkeypatch, engine, 0.0)
    assert abs(gap) <= 0.05, gap


@pytest.mark.slow
def test_the_sink_comes_back_without_the_push(monkeypatch):
    """The catch of the check above: ``CURVATURE`` without the push rests -0.068 dx from touch (warp_mpm)."""
    _on(monkeypatch, push=False)
    gap, _ = _stacked(monkeypatch, "warp_mpm", 0.0)
    assert abs(gap) > 0.05, gap


def _decays(ke: np.ndarray) -> bool:
    """The kinetic energy after the landing decays: over the run's three thirds (frame 1 on) each third's mean is at
    most half the one before (a damped rest; measured 0.09-0.23 with the push, 0.00-0.13 without, warp_mpm)."""
    th = [float(t.mean()) for t in np.array_split(ke[1:], 3)]
    return th[1] <= 0.5 * th[0] and th[2] <= 0.5 * th[1]


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_push_gains_no_energy(monkeypatch, engine):
    """The stacked balls (R 3 dx, n_grid 24) dropped 1.5 dx and resting for 2 s: the kinetic energy decays."""
    import gasp_core.testing.scenes_pairs as P
    monkeypatch.setattr(P, "STACK_R", 0.075)
    _on(monkeypatch)
    _, ke = _stacked(monkeypatch, engine, 1.5, 60)
    assert _decays(ke), ke[::10]


@pytest.mark.slow
@pytest.mark.parametrize("broken", [{"KICK": True}, {"BETA": 2.0}])
def test_the_energy_check_catches_a_push_that_moves_the_velocity_or_overshoots(monkeypatch, broken):
    """The catches (warp_mpm): the push made a velocity (``KICK``, Baumgarte's bias: the KE after the landing doubles,
    0.22 to 0.43 J) and BETA x 10 (jitter: the last third's KE 0.92 of the second's)."""
    import gasp_core.testing.scenes_pairs as P
    monkeypatch.setattr(P, "STACK_R", 0.075)
    _on(monkeypatch, **broken)
    _, ke = _stacked(monkeypatch, "warp_mpm", 1.5, 60)
    assert not _decays(ke), ke[::10]
