"""Issue 67 item 4: a block thrown along a block that rests on a frictionless ground (both MPM engines).

The scene (``block_setup``; ``gasp_core.testing.sand_ball.slide_setup``'s geometry): a 6 x 6 x 3 cm block (body 0)
thrown at ``V0`` along +x on a 40 x 16 x 3 cm block (body 1) lying on a **frictionless** ground, gravity straight
down, both blocks the same material. Known answers (Coulomb between the blocks, ``mu`` the pair's coefficient,
``gasp_core.mpm.fields.combine_friction`` of each body's ``body_friction``; ``m1``, ``m2`` the masses): the upper
block slows at ``mu g``, the lower speeds up at ``mu g m1 / m2``, so they slide over each other by
``d = V0^2 / (2 mu g (1 + m1 / m2))`` (``V0^2 / (2 mu g)`` on a fixed lower block, 5.6 % more) and then move together
at ``V0 m1 / (m1 + m2)``: the lower block takes up the momentum.

Figures: ``d`` is the change of the two mass centres' separation along x over ``T`` = 0.3 s (the slide is over at
0.1 s); tolerance ``SLIDE_TOL`` = 3.5 %, two-sided (the issue asks 10 %; measured -1.4 % to -1.7 % on warp_mpm at
n_grid 48 and 64, and a pair coefficient 5 % off must fail); the lower block's final velocity within ``MOMENTUM_TOL``
= 5 % of ``V0 m1 / (m1 + m2)`` (measured +0.8 %).

* **elastic on elastic** (jelly, E 1e5 Pa, rho 1000; the particle contact's field per soft body, ``docs/contact.md``):
  tested, n_grid 48 (a block 3 cells thick; at n_grid 32, 2 cells, it read -7.9 % until round 96's face rule, now
  -1.4 %; supports 1-3 cells thick over grids and offsets: ``tests/test_soft_support.py``). Default tier: warp_mpm at the default
  coefficient 0.5; slow: taichi_mpm, and a pair of coefficients 0.3 and 0.3.
* **rigid on rigid** (the same jelly, ``model = "rigid"``): the two bodies' contact taken on them as one, by force
  balance (``gasp_core.mpm.rigid_friction.pair_contact``: the centres' approach removed through the centres,
  then Coulomb's friction of that impulse, stick within ``mu P`` else slide at ``mu P``). A family
  (``RIGID_FAMILY``: n_grid 24 and 32, the upper block 4, 6 and 8 cm wide, the pair's coefficient 0.5 and 0.3) on
  both engines reads -1.55 % to -2.03 % on the slide, the lower block's final speed to 0.01 % (``docs/rigid.md``
  "A block on a block"). Before (one grid field for both: they stuck to each other) the slide read -80 %.
  ``test_the_rigid_checks_catch_broken_engines`` (warp_mpm by default, taichi_mpm slow): the engine before (one
  field, -88 % at mu 0.3), a brake at a rest speed (0.2 m/s: -15 %), ``mu`` ignored (0.5 always: -41 %), a
  frictionless pair (+273 %) and a figure 5 % high or low.

``test_the_checks_catch_broken_engines`` (warp_mpm, slow): an engine that ignores the pair's ``mu`` (0.5 whatever the bodies
say), one that never sticks (a frictionless pair), one field (the blocks glued), one that brakes at a rest speed
(the relative motion held once slower than 0.2 m/s), and a figure 5 % high or low.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from slopes import ENGINES, engine_param as _engine

from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points
from gasp_core.mpm import fields

G = 9.81
V0 = 0.5
T = 0.3
FPS = 60
N_GRID = 48
SIDE = 0.48
SLIDE_TOL = 0.035
MOMENTUM_TOL = 0.05


def block_setup(model: str = "elastic", friction: float | None = None, n_grid: int = N_GRID, options=None,
                half: float = 0.03) -> SimSetup:
    """The two blocks of the module docstring; ``friction``: each body's coefficient (None: the default); ``half``
    the upper block's half-width (m; its height stays 3 cm)."""
    dx = SIDE / n_grid
    lo = np.array([-0.12, -SIDE / 2, -3 * dx])
    xs, vs = box_points([-half, -half, 0.03], [half, half, 0.06], dx / 2)
    xb, vb = box_points([-0.08, -0.08, 0.0], [0.32, 0.08, 0.03], dx / 2)
    x = np.concatenate([xs, xb])
    v = np.zeros_like(x)
    v[:len(xs), 0] = V0
    mats = [Material("jelly", model=model, E=1.0e5, nu=0.3, rho=1000.0, friction=friction) for _ in range(2)]
    s = SimSetup(x=x, v=v, p_vol=np.concatenate([np.full(len(xs), vs), np.full(len(xb), vb)]),
                 body_id=np.concatenate([np.zeros(len(xs), int), np.ones(len(xb), int)]), materials=mats,
                 gravity=np.array([0.0, 0.0, -G]), domain_lo=lo, domain_hi=lo + SIDE, n_grid=n_grid,
                 frame_dt=1.0 / FPS, boundaries=[Boundary("ground", height=0.0, friction=0.0)],
                 options=dict(options or {}))
    s.n_render = 0
    return s


def pair_mu(s) -> float:
    return fields.combine_friction(*(fields.body_friction(m) for m in s.materials))


def closed_form(s) -> tuple[float, float]:
    """``(d, v_f)``: the slide of the upper block on the lower (m) and their common final velocity (m/s)."""
    pm = np.asarray(s.p_mass, float)
    m1, m2 = pm[np.asarray(s.body_id) == 0].sum(), pm[np.asarray(s.body_id) == 1].sum()
    return V0 ** 2 / (2 * pair_mu(s) * G * (1 + m1 / m2)), V0 * m1 / (m1 + m2)


def measure(engine: str, s, output=None) -> tuple[float, float]:
    """``(d, v_lower)``: the change of the mass centres' separation along x over ``T`` (m), and the lower block's
    velocity over the last 0.1 s (m/s). ``output(separation per frame)`` breaks the engine on purpose."""
    e = build_engine(get_engine(engine), s)
    pm = np.asarray(s.p_mass, float)
    up = np.asarray(s.body_id) == 0
    X = [np.asarray(s.x, float)]
    for _ in range(round(T * FPS)):
        e.step_frame()
        X.append(e.positions().astype(float))
    X = np.array(X)
    c1 = (X[:, up, 0] * pm[up]).sum(1) / pm[up].sum()
    c2 = (X[:, ~up, 0] * pm[~up]).sum(1) / pm[~up].sum()
    sep = c1 - c2
    if output is not None:
        sep = output(sep)
    k = round(0.1 * FPS)
    return float(sep[-1] - sep[0]), float((c2[-1] - c2[-1 - k]) * FPS / k)


def check(s, figures, expect=None) -> str | None:
    """None when the slide and the lower block's velocity meet the closed forms (``expect``: :func:`closed_form`'s
    of ``s``, taken before an engine is broken), two-sided, else what is wrong."""
    d, v2 = figures
    d0, vf = expect or closed_form(s)
    err = d / d0 - 1.0
    if not abs(err) <= SLIDE_TOL:
        return f"slide {1000 * d:.2f} mm against {1000 * d0:.2f} ({100 * err:+.1f} %)"
    if not abs(v2 / vf - 1.0) <= MOMENTUM_TOL:
        return f"lower block at {v2:.4f} m/s against {vf:.4f} ({100 * (v2 / vf - 1):+.1f} %)"
    return None


WARP = [_engine("warp_mpm")]
TAICHI = [_engine("taichi_mpm", marks=[pytest.mark.slow])]


@pytest.mark.parametrize("engine", WARP + TAICHI)
def test_elastic_block_on_an_elastic_block(engine):
    s = block_setup()
    problem = check(s, measure(engine, s))
    assert problem is None, f"{engine}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_elastic_pair_takes_the_bodies_coefficients(engine):
    s = block_setup(friction=0.3)
    problem = check(s, measure(engine, s))
    assert problem is None, f"{engine}: {problem}"


#: The rigid pair's family: (n_grid, the upper block's half-width in m, each body's friction or None: 0.5).
RIGID_FAMILY = [(24, 0.03, None), (32, 0.03, None), (32, 0.02, None), (24, 0.04, 0.3)]


def _rigid_cases():
    """The family on warp_mpm (default tier, under 0.5 s a case) and taichi_mpm (one case by default, the rest slow:
    3-9 s a case)."""
    for case in RIGID_FAMILY:
        name = "-".join(map(str, case))
        yield pytest.param("warp_mpm", *case, marks=_engine("warp_mpm").marks, id=f"warp_mpm-{name}")
        slow = [pytest.mark.slow] if case != RIGID_FAMILY[1] else []
        yield pytest.param("taichi_mpm", *case, marks=list(_engine("taichi_mpm").marks) + slow, id=f"taichi_mpm-{name}")


@pytest.mark.parametrize("engine,n_grid,half,friction", list(_rigid_cases()))
def test_rigid_block_on_a_rigid_block(engine, n_grid, half, friction):
    s = block_setup("rigid", friction=friction, n_grid=n_grid, half=half)
    problem = check(s, measure(engine, s))
    assert problem is None, f"{engine}, n_grid {n_grid}, half-width {half} m, friction {friction}: {problem}"


@pytest.mark.parametrize("engine", WARP + TAICHI)
def test_the_rigid_checks_catch_broken_engines(engine, monkeypatch):
    """The rigid pair's checks fail: one field (the engine before issue 67 item 4: the blocks glued within 4.9 mm of
    Coulomb's 24.1), a brake at a rest speed (0.2 m/s), ``mu`` ignored (0.5 whatever the bodies say), a pair that
    never sticks (frictionless) and a figure 5 % high or low."""
    s = block_setup("rigid", friction=0.3, n_grid=32)
    expect = closed_form(s)
    assert check(s, measure(engine, s)) is None
    caught = {
        "one field (glued: the engine before)": check(s, measure(engine, block_setup(
            "rigid", friction=0.3, n_grid=32, options={"contact_fields": False}))),
        "brakes at a rest speed (0.2 m/s)": check(s, measure(engine, s, output=lambda sep: _rest_brake(sep, 0.2))),
        "5 % high": check(s, (1.05 * expect[0], expect[1])),
        "5 % low": check(s, (0.95 * expect[0], expect[1])),
    }
    with monkeypatch.context() as mp:
        mp.setattr(fields, "combine_friction", lambda a, b: fields.SOLID_FRICTION)
        caught["ignores mu (0.5 always)"] = check(s, measure(engine, block_setup("rigid", friction=0.3, n_grid=32)),
                                                  expect)
        mp.setattr(fields, "combine_friction", lambda a, b: 0.0)
        caught["never sticks (frictionless pair)"] = check(s, measure(engine, block_setup(
            "rigid", friction=0.3, n_grid=32)), expect)
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the checks miss {missed}"


def mixed_setup(upper: str, **kw) -> SimSetup:
    """:func:`block_setup` with one body rigid (``upper`` "rigid": the thrown block; "soft": the slab) and the other
    jelly: a field each (:func:`gasp_core.mpm.fields.mixed_pair`)."""
    s = block_setup(**kw)
    b = 0 if upper == "rigid" else 1
    s.materials[b] = Material("jelly", model="rigid", E=1.0e5, nu=0.3, rho=1000.0, friction=kw.get("friction"))
    return s


#: The mixed pairs: (which is rigid, n_grid, each body's friction or None: 0.5).
MIXED_FAMILY = [("rigid", 48, None), ("soft", 48, None), ("rigid", 32, 0.3), ("soft", 32, 0.3)]


def _mixed_cases():
    """The family on both engines; warp_mpm's first case in the default tier (about 7 s), the rest slow."""
    for case in MIXED_FAMILY:
        for eng in ("warp_mpm", "taichi_mpm"):
            slow = [] if (eng, case) == ("warp_mpm", MIXED_FAMILY[0]) else [pytest.mark.slow]
            yield pytest.param(eng, *case, marks=list(_engine(eng).marks) + slow,
                               id=f"{eng}-{'-'.join(map(str, case))}")


@pytest.mark.parametrize("engine,upper,n_grid,friction", list(_mixed_cases()))
def test_rigid_and_elastic_blocks_slide_as_coulomb_says(engine, upper, n_grid, friction):
    """Rigid on elastic and elastic on rigid (issue 67 item 4): the slide and the lower block's final speed meet the
    closed forms (two-sided, :data:`SLIDE_TOL`, :data:`MOMENTUM_TOL`). Measured before the pair took a field each:
    the blocks glued, the slide 0.26 mm against 24.1 (-99 %)."""
    s = mixed_setup(upper, friction=friction, n_grid=n_grid)
    assert fields.mixed_pair(s) and fields.uses_fields(s)
    problem = check(s, measure(engine, s))
    assert problem is None, f"{engine}, {upper} block on top, n_grid {n_grid}, friction {friction}: {problem}"


@pytest.mark.slow
@pytest.mark.parametrize("engine", WARP)
def test_the_mixed_pair_check_catches_one_field_and_mu_ignored(engine, monkeypatch):
    """One field for the rigid and the soft block (the engine before: glued) and a pair that ignores ``mu`` fail."""
    s = mixed_setup("rigid", friction=0.3, n_grid=32)
    expect = closed_form(s)
    one = mixed_setup("rigid", friction=0.3, n_grid=32, options={"contact_fields": False})
    caught = {"one field": check(s, measure(engine, one))}
    with monkeypatch.context() as mp:
        mp.setattr(fields, "combine_friction", lambda a, b: fields.SOLID_FRICTION)
        caught["ignores mu"] = check(s, measure(engine, mixed_setup("rigid", friction=0.3, n_grid=32)), expect)
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the checks miss {missed}"


def _rest_brake(sep: np.ndarray, v_rest: float) -> np.ndarray:
    """The separation of an engine that stops the relative motion once it is slower than ``v_rest`` (m/s; a frame
    here, 1/60 s, takes 0.086 m/s off the relative speed at mu 0.3, so 0.1 m/s would stop it at most one frame
    early: 0.2 m/s, about two)."""
    v = np.diff(sep) * FPS
    stop = np.argmax(np.abs(v) < v_rest) if np.any(np.abs(v) < v_rest) else len(v)
    out = sep.copy()
    out[stop + 1:] = out[stop]
    return out


@pytest.mark.slow   # five runs of about 7 s
@pytest.mark.parametrize("engine", WARP)
def test_the_checks_catch_broken_engines(engine, monkeypatch):
    s = block_setup(friction=0.3)
    expect = closed_form(s)
    caught = {
        "brakes at a rest speed (0.2 m/s)": check(s, measure(engine, s, output=lambda sep: _rest_brake(sep, 0.2))),
        "one field (glued)": check(s, measure(engine, block_setup(friction=0.3, options={"contact_fields": False}))),
        "5 % high": check(s, (1.05 * closed_form(s)[0], closed_form(s)[1])),
        "5 % low": check(s, (0.95 * closed_form(s)[0], closed_form(s)[1])),
    }
    with monkeypatch.context() as mp:
        mp.setattr(fields, "combine_friction", lambda a, b: fields.SOLID_FRICTION)
        caught["ignores mu (0.5 always)"] = check(s, measure(engine, block_setup(friction=0.3)), expect)
        mp.setattr(fields, "combine_friction", lambda a, b: 0.0)
        caught["never sticks (frictionless pair)"] = check(s, measure(engine, block_setup(friction=0.3)), expect)
    missed = [k for k, v in caught.items() if v is None]
    assert not missed, f"{engine}: the checks miss {missed}"


def test_combine_friction():
    """Bullet's geometric mean: a body on its own material keeps its coefficient, a frictionless one slides."""
    assert fields.combine_friction(0.5, 0.5) == 0.5
    assert fields.combine_friction(0.0, 0.9) == 0.0
    assert fields.combine_friction(0.2, 0.8) == pytest.approx(0.4)
    assert fields.combine_friction(100.0, 100.0) == 10.0
    assert math.isclose(pair_mu(block_setup(friction=0.3, n_grid=16)), 0.3)


def test_pair_contact_reference():
    """``pair_contact`` (the NumPy reference the engines spell): the approach removed through the centres, then the
    tangential slip stopped when within ``mu P`` (stick), else ``mu P`` against it (slide); momentum kept."""
    from gasp_core.mpm.rigid_friction import pair_contact
    I = np.eye(3) * 1e-3
    n = np.array([0.0, 0.0, -1.0])                       # from A (above) into B
    A = (np.array([0.5, 0.0, -0.01]), np.zeros(3), I, 1.0, np.array([0.0, 0.0, 0.05]))
    B = (np.zeros(3), np.zeros(3), I, 4.0, np.array([0.0, 0.0, 0.01]))
    x_c = np.array([0.0, 0.0, 0.03])
    (VA, _), (VB, _), P = pair_contact(A, B, x_c, n, 0.5)
    assert P == pytest.approx(0.01 / (1.0 + 0.25))      # the centres' approach, through them
    assert VA[2] - VB[2] == pytest.approx(0.0, abs=1e-15)
    assert VA[0] == pytest.approx(0.5 - 0.5 * P)         # slides: mu P against the slip
    assert 1.0 * VA + 4.0 * VB == pytest.approx(1.0 * A[0] + 4.0 * B[0])
    slow = (np.array([1e-3, 0.0, -0.01]),) + A[1:]
    (VA, _), (VB, _), P = pair_contact(slow, B, x_c, n, 0.5)
    assert VA[0] == pytest.approx(VB[0]) and VA[0] == pytest.approx(1e-3 / 5.0)   # sticks: moves with B
    (VA, _), _, P = pair_contact((np.array([0.5, 0.0, 0.01]),) + A[1:], B, x_c, n, 0.5)
    assert P == 0.0 and VA[0] == 0.5                    # separating: no contact, no friction
