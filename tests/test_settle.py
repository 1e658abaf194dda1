"""Round 84 (issue 67 item 3; ``docs/contact.md`` "Round 84: a settled start"): the scene key ``settle``
(:mod:`gasp_core.seam.settle`), a start from the bodies at rest in their own weight.

The undamped jelly cube released unstressed on a 30 degree slope at mu 0.6 walks down it on the particle contact
(``tests/test_elastic_slope.py``'s strict xfail: its ring's swing of the normal force lets the base slip each period,
as explicit finite elements do too, round 80). A captured body is at rest, its weight carried: started settled, the
same cube must hold (Coulomb: ``tan theta < mu``), on both contacts and engines, and so must its neighbours (a flat
block, a tall block on 25 degrees), at two grids. Two-sided: where ``tan theta > mu`` the settled block slides at
Coulomb's ``g (sin - mu cos)`` within ``SLIDE_TOL`` (2.5 %), and the settle warns that the scene was not at rest.
Round 85 (``docs/contact.md`` "Round 85: the tall block topples"): on 30 degrees the tall block has no rest as an
elastic body (explicit finite elements topple it), so it must topple there, and a stiff one must not.

The checks are ``tests/test_elastic_slope.py``'s (:func:`check`: under 1 mm in 1 s from 0.1 s where it sticks).
Their catches: the same scene without the settle (the released cube walks or is still landing), and an engine that
never sticks (the ground's friction halved: tan / mu 1.92).
"""
from __future__ import annotations

import dataclasses
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from fresh_process import last_line
from slopes import ENGINES, closed_form, coulomb_figure, engine_param, turn_deg
from test_elastic_slope import CUBE, FPS, SETTLE_T, SLIDE_FROM, SLIDE_T, STICK_T, _friction, block_setup, check

from gasp_core.errors import SceneError
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.runner import EngineRun, RunStats

#: The family's bodies (m): the issue's cube, a flat block, a tall one (on 30 degrees a rigid one would stand, its
#: weight's line inside its base: ``tan 30 = 0.58 < w / h = 0.67``; an elastic one of E 1e5 leans past it, round 85).
BODIES = {"cube": CUBE, "flat": (0.15, 0.15, 0.05), "tall": (0.1, 0.1, 0.15)}


def settled_figure(engine: str, theta: float, mu: float, contact: str, n_grid: int, side=CUBE, settle: bool = True,
                   spoil=None) -> tuple[float, dict | None]:
    """The block of ``side`` started settled (``settle``) on the slope: Coulomb's figure (the acceleration where it
    slides, the travel in mm from ``SETTLE_T`` over ``STICK_T`` where it sticks: ``coulomb_figure``) and the settle's
    record. ``spoil(setup)`` breaks the engine."""
    s = block_setup(theta, mu, contact, side, n_grid)
    if spoil is not None:
        spoil(s)
    slides = math.tan(math.radians(theta)) > mu
    stats = RunStats()
    c = [np.asarray(s.x, float).mean(axis=0)]
    with EngineRun(get_engine(engine), s, stats, settle=settle) as run:
        c += [rec.x.mean(axis=0) for rec in run.frames(round((SLIDE_T if slides else SETTLE_T + STICK_T) * FPS))]
    return coulomb_figure(np.array(c), theta, mu, FPS, SLIDE_FROM, settle=round(SETTLE_T * FPS)), stats.settle


def test_the_scene_key_settle(tmp_path):
    """``settle = true`` is read (default false) and a value that is not a boolean is refused by name."""
    from gasp_core.scene.spec import load_scene
    examples = Path(__file__).resolve().parents[1] / "examples"
    text = (examples / "donut_jelly.toml").read_text(encoding="utf-8")
    data = examples / "data"
    text = text.replace('file = "data/', f'file = "{data.as_posix()}/')
    for body, want in (("", False), ("settle = true\n", True)):
        p = tmp_path / f"s{int(want)}.toml"
        p.write_text(body + text, encoding="utf-8")
        assert load_scene(p).settle is want
    p = tmp_path / "bad.toml"
    p.write_text("settle = 1\n" + text, encoding="utf-8")
    with pytest.raises(SceneError, match="settle"):
        load_scene(p)


def test_the_settle_frame_follows_the_slowest_compression_period():
    """``compression_period`` is ``4 L / c_p`` of the slowest non-rigid body (the cube: L its extent, ``c_p`` from
    E 1e5, nu 0.3, rho 1000: 11.6 m/s), 0 for rigid bodies alone."""
    from gasp_core.seam.settle import compression_period
    s = block_setup(30, 0.6, "particle", CUBE, 24)
    x = np.asarray(s.x)
    L = float((x.max(axis=0) - x.min(axis=0)).max())
    c_p = math.sqrt(1.0e5 * 0.7 / (1.3 * 0.4 * 1000.0))
    assert compression_period(s) == pytest.approx(4.0 * L / c_p, rel=1e-12)
    s.materials = [dataclasses.replace(s.materials[0], model="rigid")]
    assert compression_period(s) == 0.0


def test_the_settle_refuses_what_it_cannot_do():
    """An engine without the feature ``state`` and a body with a velocity are refused, each named."""
    from gasp_core.seam.settle import check_settle
    s = block_setup(30, 0.6, "particle", CUBE, 24)
    info = get_engine("warp_mpm")
    caps = dataclasses.replace(info.capabilities, features=frozenset(info.capabilities.features) - {"state"})
    with pytest.raises(SceneError, match="feature 'state'.*warp_mpm"):
        check_settle(dataclasses.replace(info, capabilities=caps), s)
    v = np.zeros_like(np.asarray(s.v))
    v[0, 0] = 0.5
    with pytest.raises(SceneError, match="at rest.*bodies \\[0\\]"):
        check_settle(info, s.replace(v=v))


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
def test_a_settled_jelly_cube_holds_where_the_released_one_walks(engine):
    """The must-show's cube (30 degrees, mu 0.6, the particle contact, n_grid 24), started settled: under 1 mm in 1 s
    (measured 0.0002 mm; its settle 140 frames, residual 9e-6 cells). The catches: released unstressed (no settle) it
    fails the same check, and settled on a ground of half the friction it slides."""
    fig, rec = settled_figure(engine, 30, 0.6, "particle", 24)
    assert check(30, 0.6, fig) is None, fig
    assert rec["settled"] and rec["frames"] > 0, rec
    released, none = settled_figure(engine, 30, 0.6, "particle", 24, settle=False)
    assert none is None and check(30, 0.6, released) is not None, released
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)   # the halved friction's settle is not at rest: it slides
        halved, _ = settled_figure(engine, 30, 0.6, "particle", 24, spoil=_friction(factor=0.5))
    assert check(30, 0.6, halved) is not None, halved


#: Each body's slope and frictions (``tan / mu`` 0.96 and 0.82 on 30 degrees). The tall block holds on 25 degrees at
#: the same ratios: on 30 degrees an elastic body of its shape has no rest (round 85,
#: :func:`test_a_tall_jelly_block_topples_where_the_continuum_does`).
SLOPES = {"cube": (30.0, (0.6, 0.7)), "flat": (30.0, (0.6, 0.7)), "tall": (25.0, (0.49, 0.57))}
#: Measured misses, strict xfails (warp_mpm, round 85; mm in 1 s from 0.1 s): the tall block on 25 degrees at mu 0.49
#: (``tan / mu`` 0.95) on the grid contact leans on (2.9 to 3.9 degrees) and its base creeps, where explicit finite
#: elements hold it still (``benchmarks/results/tall85_fem.json``).
TALL_GRID = {(24, 0.49): "1.21 mm (its turn 2.93 to 3.88 degrees)",
             (32, 0.49): "0.52 mm, but its settle is not at rest (0.002 cells a frame; its turn 3.02 to 3.51 degrees)"}


def _family():
    for name, (theta, mus) in SLOPES.items():
        for mu in mus:
            for contact in ("particle", "grid"):
                for n_grid in (24, 32):
                    why = TALL_GRID.get((n_grid, mu)) if (name, contact) == ("tall", "grid") else None
                    miss = [pytest.mark.xfail(strict=True, reason=f"the tall block on the grid contact: {why}")] \
                        if why else []
                    for engine in ("warp_mpm", "taichi_mpm"):
                        yield pytest.param(engine, name, theta, mu, contact, n_grid,
                                           marks=[*engine_param(engine).marks, *miss],
                                           id=f"{engine}-{name}-{theta:g}deg-mu{mu}-{contact}-{n_grid}")


@pytest.mark.slow
@pytest.mark.parametrize("engine,name,theta,mu,contact,n_grid", list(_family()))
def test_settled_jelly_blocks_hold_on_a_slope(engine, name, theta, mu, contact, n_grid):
    """Three jelly blocks at ``tan / mu`` 0.96 and 0.82 (:data:`SLOPES`: the cube and the flat block on 30 degrees at
    mu 0.6 and 0.7, the tall block on 25 degrees at mu 0.49 and 0.57), both contacts, n_grid 24 and 32, both
    engines: started settled, each moves under 1 mm in 1 s (measured 0.000-0.051 mm, warp_mpm), but
    :data:`TALL_GRID` (strict xfails)."""
    fig, rec = settled_figure(engine, theta, mu, contact, n_grid, BODIES[name])
    assert check(theta, mu, fig) is None and rec["settled"], (fig, rec)


def tall_turn(engine: str, theta: float, mu: float, contact: str, n_grid: int, spoil=None) -> float:
    """The tall block (:data:`BODIES`) started settled on ``theta`` degrees: how far it has turned (degrees, negative
    downhill: :func:`slopes.turn_deg`) from the scene as given, at the last of ``SETTLE_T + STICK_T`` s of frames.
    ``spoil(setup)`` breaks the engine."""
    s = block_setup(theta, mu, contact, BODIES["tall"], n_grid)
    if spoil is not None:
        spoil(s)
    x0 = np.asarray(s.x, float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)   # a block that topples is not at rest after its settle
        with EngineRun(get_engine(engine), s, RunStats(), settle=True) as run:
            for rec in run.frames(round((SETTLE_T + STICK_T) * FPS)):
                x = np.asarray(rec.x, float)
    return turn_deg(x0, x)


#: Toppled: turned downhill past this (degrees) at 1.1 s. A rigid tall block's margin on 30 degrees is 3.7 degrees
#: (``atan(w / h) - 30``); the continuum's rest on 25 degrees is turned 2.4-3.0 degrees (finite elements).
TOPPLE_DEG = 20.0
#: The tall block on 30 degrees at mu 0.7 (``tan / mu`` 0.82: Coulomb holds it) where the engines hold what the
#: continuum topples (warp_mpm and taichi_mpm alike, its turn at 1.1 s; ``benchmarks/results/tall85_mpm.json``): the
#: grid contact leans nearer the continuum (2.9 to 4.6 degrees settled) and turns it over on n_grid 48 alone. The
#: particle contact held it on n_grid 24, 32 and 48 until round 85 (turned 1.61, 1.76 and 3.54 degrees): its balance
#: took back a net contact torque up to ``J TORQUE_REACH h`` on every patch, as a base two point spacings wider would
#: hold it. Since round 86 the bound follows the patch's departure from a plane (``gasp_core.mpm.take_back``), and a
#: flat base keeps its torque: it topples on every grid (``benchmarks/results/tall86_mpm.json``).
TOPPLE_MISS = {("grid", 24): "-2.97 deg", ("grid", 32): "-5.06 deg, still turning"}


def _topple_cases():
    for contact in ("particle", "grid"):
        for n_grid in (24, 32, 48):
            why = TOPPLE_MISS.get((contact, n_grid))
            miss = [pytest.mark.xfail(strict=True, reason=f"held, not toppled: {why}")] if why else []
            for engine in ("warp_mpm", "taichi_mpm"):
                yield pytest.param(engine, contact, n_grid, marks=[*engine_param(engine).marks, *miss],
                                   id=f"{engine}-{contact}-{n_grid}")


@pytest.mark.slow
@pytest.mark.parametrize("engine,contact,n_grid", list(_topple_cases()))
def test_a_tall_jelly_block_topples_where_the_continuum_does(engine, contact, n_grid):
    """The tall jelly block on 30 degrees at mu 0.7: Coulomb and the rigid tipping rule hold it, but its elastic lean
    does not leave it a rest. Explicit finite elements (``benchmarks/studies/tall85.py``: the engines' fixed corotated
    law, relaxed in its own weight with kinetic damping) topple it at 4, 6 and 8 elements across, on a ground that
    never slips and at mu 0.7, and rest it on 25 degrees. Started settled, it must have turned past
    :data:`TOPPLE_DEG` by 1.1 s; where the engines hold it, :data:`TOPPLE_MISS` (strict xfails)."""
    turn = tall_turn(engine, 30.0, 0.7, contact, n_grid)
    assert turn < -TOPPLE_DEG, turn


@pytest.mark.parametrize("schedule", ["cpu", "gpu"])
def test_the_particle_contact_topples_the_tall_block_on_both_schedules(schedule):
    """The default tier's case of the family above: warp_mpm, the particle contact, n_grid 24, on each of its
    schedules (``gpu`` runs its GPU kernels' layout on the CPU: the take-back's sums folded by blocks)."""
    pytest.importorskip("gasp_warp_mpm")

    def on(s):
        s.options = {**(s.options or {}), "schedule": schedule}
    assert tall_turn("warp_mpm", 30.0, 0.7, "particle", 24, spoil=on) < -TOPPLE_DEG


CATCH = """
import gasp_core.mpm.take_back as tb
tb.PLANE_BOUND = False
from test_settle import tall_turn
print(tall_turn("warp_mpm", 30.0, 0.7, "particle", 24))
"""


def test_the_topple_check_catches_a_take_back_on_a_flat_base():
    """The catch of the particle contact's case: its take-back as it was until round 85, on every patch
    (``PLANE_BOUND`` off, set before the kernels compile: a fresh process), holds the tall block (measured -1.61
    degrees), and the check fails it."""
    pytest.importorskip("gasp_warp_mpm")
    assert float(last_line(CATCH)) > -TOPPLE_DEG


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_topple_check_catches_a_stiff_block(engine):
    """The catch: where the tall block topples (the grid contact, n_grid 48), a block ten times stiffer (E 1e6: its
    lean a tenth, well inside the rigid margin) stands, and the check fails; the check's own case, 25 degrees at mu
    0.57, stands too."""
    def stiff(s):
        s.materials = [dataclasses.replace(m, E=10.0 * m.E) for m in s.materials]
    assert tall_turn(engine, 30.0, 0.7, "grid", 48, spoil=stiff) > -TOPPLE_DEG
    assert tall_turn(engine, 25.0, 0.57, "grid", 24) > -TOPPLE_DEG


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_settled_jelly_cube_sticks_on_the_particle_contact(engine):
    """The must-show's cube as ``tests/test_elastic_slope.py`` runs it (30 degrees, mu 0.6, the particle contact,
    n_grid 32 and 48), started settled: under 1 mm in 1 s (measured 0.0096 and 0.0012 mm, warp_mpm). The catch, the friction halved, is the default tier's."""
    for n_grid in (32, 48):
        fig, rec = settled_figure(engine, 30, 0.6, "particle", n_grid)
        assert check(30, 0.6, fig) is None, (n_grid, fig, rec)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_a_settled_block_still_slides_at_coulombs_rate(engine):
    """Two-sided: where ``tan theta > mu`` (30 degrees at mu 0.4 and 0.2) the settled cube slides at ``g (sin - mu
    cos)`` within 2.5 %, and the settle warns that the scene was not at rest."""
    for mu in (0.4, 0.2):
        with pytest.warns(UserWarning, match="not at rest"):
            fig, rec = settled_figure(engine, 30, mu, "particle", 24)
        assert not rec["settled"] and check(30, mu, fig) is None, (mu, fig / closed_form(30, mu) - 1.0, rec)


def column_strain(engine: str, contact: str, n_grid: int, h: float) -> np.ndarray:
    """A jelly column (10 x 10 cm, ``h`` high; E 1e5, nu 0: uniaxial) settled on a level ground: per fill layer, its
    points' mean ``F_zz - 1`` over the closed form of a column carrying its own weight, ``-rho g (h - z) / E``."""
    s = block_setup(0.0, 0.5, contact, (0.1, 0.1, h), n_grid)
    s.materials = [dataclasses.replace(s.materials[0], nu=0.0)]
    with EngineRun(get_engine(engine), s, RunStats(), settle=True) as run:
        F = run.engine.to_setup_order(np.asarray(run.engine.read_array("F"), float).reshape(-1, 3, 3))
    x0 = np.asarray(s.x, float)
    layer = np.round((x0[:, 2] - x0[:, 2].min()) / (s.dx / 2)).astype(int)
    top = x0[:, 2].max() + s.dx / 4
    m = s.materials[0]
    return np.array([np.mean(F[layer == k, 2, 2] - 1.0) / (-m.rho * 9.81 * (top - x0[layer == k, 2].mean()) / m.E)
                     for k in range(layer.max() + 1)])


#: The column's check: the mean over its interior layers (two at each face left out: the free surface's and the
#: ground's half-cells) within this of the closed form (single interior layers read 0.93-1.08, warp_mpm).
COLUMN_TOL = 0.025


def _interior(r: np.ndarray) -> float:
    return float(np.mean(r[2:-2]))


@pytest.mark.parametrize("engine", [engine_param("warp_mpm"), engine_param("taichi_mpm", marks=[pytest.mark.slow])])
def test_a_settled_column_carries_its_weight(engine, monkeypatch):
    """Settled, the column's strain is its weight's (interior mean within :data:`COLUMN_TOL` of
    ``rho g (h - z) / E``). The catch: a settle whose gravity ends 5 % short
    reads 0.95 and fails."""
    assert abs(_interior(column_strain(engine, "particle", 24, 0.2)) - 1.0) <= COLUMN_TOL
    import gasp_core.seam.settle as settle
    still = settle._still
    monkeypatch.setattr(settle, "_still", lambda setup, g, dt: still(setup, 0.95 * g, dt))
    assert abs(_interior(column_strain(engine, "particle", 24, 0.2)) - 1.0) > COLUMN_TOL


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("contact", ("particle", "grid"))
@pytest.mark.parametrize("n_grid,h", [(24, 0.1), (32, 0.1), (32, 0.2), (48, 0.2)])
def test_settled_columns_carry_their_weight(engine, contact, n_grid, h):
    """The column over two heights, three grids, both contacts and engines."""
    r = column_strain(engine, contact, n_grid, h)
    assert abs(_interior(r) - 1.0) <= COLUMN_TOL, np.round(r, 3).tolist()


#: Neighbours of the tall block that rigid statics decides for any elastic body (mu 0.9, above every ``tan theta``, so
#: nothing slides): past the rigid angle ``atan(w / h)`` the elastic lean only adds, so it must topple; well inside
#: it (8.7 and 13.7 degrees of margin against a lean of about 5) it must stand. (side (m), theta (deg), topples).
STATICS = [((0.1, 0.1, 0.2), 30.0, True), ((0.08, 0.08, 0.16), 30.0, True), ((0.1, 0.1, 0.15), 20.0, False),
           ((0.12, 0.12, 0.15), 30.0, False)]


def _statics_cases():
    for side, theta, topples in STATICS:
        for n_grid in (24, 32):
            for engine in ("warp_mpm", "taichi_mpm"):
                yield pytest.param(engine, side, theta, topples, n_grid, marks=engine_param(engine).marks,
                                   id=f"{engine}-{'x'.join(f'{s * 100:g}' for s in side)}-{theta:g}deg-{n_grid}")


@pytest.mark.slow
@pytest.mark.parametrize("engine,side,theta,topples,n_grid", list(_statics_cases()))
def test_jelly_blocks_tip_where_rigid_statics_decides(engine, side, theta, topples, n_grid, monkeypatch):
    """Round 86's neighbours of the tall block (the particle contact, started settled, mu 0.9): turned past
    :data:`TOPPLE_DEG` by 1.1 s where rigid statics tips them, under it where it stands them. Measured (warp_mpm;
    taichi_mpm at n_grid 24 the same to 0.01 degree): toppled -90.4 to -90.7; stood -1.41 to -2.19. Under round 85's
    take-back (``PLANE_BOUND`` off) three of the four topples stood at -2.9 to -5.1 degrees (the 10 x 10 x 20 cm
    block on n_grid 24, the 8 x 8 x 16 on 24 and 32)."""
    monkeypatch.setitem(BODIES, "tall", side)
    turn = tall_turn(engine, theta, 0.9, "particle", n_grid)
    assert (turn < -TOPPLE_DEG) == topples, turn


STATICS_CATCH = """
import gasp_core.mpm.take_back as tb
tb.PLANE_BOUND = False
import test_settle as T
T.BODIES["tall"] = (0.08, 0.08, 0.16)
print(T.tall_turn("warp_mpm", 30.0, 0.9, "particle", 24))
"""


def test_the_statics_check_catches_a_take_back_on_a_flat_base():
    """The catch: round 85's take-back (fresh process) holds the 8 x 8 x 16 cm block 3.4 degrees past its rigid angle
    (measured -2.92 degrees), where the check above asks for a topple."""
    pytest.importorskip("gasp_warp_mpm")
    assert float(last_line(STATICS_CATCH)) > -TOPPLE_DEG
