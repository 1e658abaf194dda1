"""Field A's liquid beside its sand, and field B's named and unnamed bodies beside several sands (issue 67 item 4,
"the pair's friction"; docs/contact.md "Round 44: liquid beside sand, unnamed bodies beside several sands").

Two limits round 43 left: (1) a flowing body with no friction angle (liquid, snow; alone it slides freely, pair 0)
beside sand took the sand's largest angle, so a water block beside a sand block rubbed on its slab as sand;
(2) where field B mixes bodies that name a ``friction`` with bodies that name none and A brings several angles, the
unnamed bodies brought the largest angle's ``tan`` into B's per-node mean. Now (``gasp_core.mpm.fields``) a liquid
brings 0 to A's per-node mean (``a_frictions``; ``a_node_friction`` on where A's smallest is 0), and B's unnamed
bodies scatter their mass to a channel of their own, taken at the node's ``tan_A`` (``b_unnamed_mix``): the pair of
an unnamed body is the touching sand's own ``tan(phi)``, round 41's rule per node.

Checks (both engines, n_grid 32 and 48, two-sided): (1) :func:`water_sand_setup`, round 42's two slabs of one
``friction`` (0.6, or none), a water block (liquid, K 4e5 Pa) on one and a 30 deg sand block on the other, thrown
along +x; the water's Coulomb ratio (``sand_ball.coulomb_ratio``: its momentum lost over the normal impulse, an
effective coefficient) within ``RATIO_TOL`` times the sand's pair of the same water alone on the slabs (its
reference: what the grid takes from water at pair 0), and the sand's ratio within ``RATIO_TOL`` of its pair.
**Catches:** the old rule (the water at the sand's pair, ``a_node_friction`` None) and a water pair 5 % of the
sand's. (2) :func:`named_unnamed_setup`, the two slabs one named and one not, a sand block of its own angle on each
(the smaller angle on the unnamed slab); each block's ratio within ``RATIO_TOL`` of its own pair. **Catch:** the old
rule (``b_unnamed_mix`` False: the unnamed slab at the largest angle's ``tan``) reads that block about +50 %.
Default tier: the rules' unit check alone (one engine case takes 15-16 s with its compile, over the tier's ~5 s); the
engine checks, the catches and warp_mpm's gpu schedule (run on the CPU, one case of each check) are slow.
"""
from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest

from gasp_core.mpm import fields as F
from gasp_core.seam.setup import Material
from gasp_core.testing import sand_ball as S
from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS, RATIO_TOL

pytestmark = pytest.mark.filterwarnings("ignore:engine .* share one grid velocity field")
#: The water block: a liquid of bulk modulus 4e5 Pa (``E = 3 K (1 - 2 nu)``, nu 0.3; sound speed 20 m/s, the dam
#: break's of ``gasp_core.testing.scenes_materials``), rho 1000.
WATER = Material("liquid", E=3 * 4e5 * (1 - 2 * 0.3), nu=0.3, rho=1000.0)


def slabs_setup(v0: float, blocks, slab_mus, options: dict | None = None, model: str = ""):
    """``sand_ball.two_slab_setup`` with the blocks (bodies 0 and 2) of materials ``blocks`` and the slabs (1 and 3)
    of ``friction`` ``slab_mus`` (None: unnamed)."""
    setup = S.two_slab_setup(v0, (0.5, 0.5), options, model=model)
    mats = list(setup.materials)
    for b, mat in zip((0, 2), blocks):
        mats[b] = mat
    for b, mu in zip((1, 3), slab_mus):
        mats[b] = dataclasses.replace(mats[b], friction=mu)
    setup.materials = mats
    return setup


def sand(phi: float) -> Material:
    return dataclasses.replace(S.SAND, friction_angle=float(phi))


def water_sand_setup(v0: float, slab_mu, options=None, model: str = "", alone: bool = False):
    """The water block on slab 1 and a 30 deg sand block on slab 2, both slabs ``slab_mu``; ``alone``: the sand
    block's points dropped (the water's reference: no sand, the pair 0 everywhere)."""
    setup = slabs_setup(v0, (WATER, sand(30.0)), (slab_mu, slab_mu), options, model)
    if alone:
        keep = np.asarray(setup.body_id) != 2
        bid = np.asarray(setup.body_id)[keep]
        setup = dataclasses.replace(setup, x=setup.x[keep], v=setup.v[keep], p_vol=np.asarray(setup.p_vol)[keep],
                                    body_id=np.where(bid == 3, 2, bid), materials=list(setup.materials[:2])
                                    + [setup.materials[3]])
    return setup


def named_unnamed_setup(v0: float, angles, slab_mus, options=None, model: str = ""):
    """Sand blocks of ``angles`` (deg) on slabs of ``slab_mus``, one of them None (unnamed)."""
    return slabs_setup(v0, tuple(sand(a) for a in angles), slab_mus, options, model)


def own_pair(phi: float, slab_mu) -> float:
    """A sand block's pair: ``sqrt(tan(phi) mu)``, or ``tan(phi)`` on a slab that names none."""
    t = math.tan(math.radians(phi))
    return t if slab_mu is None else math.sqrt(t * slab_mu)


def test_the_rules_only_where_the_scene_mixes():
    t30 = math.tan(math.radians(30.0))
    mixed = water_sand_setup(1.2, 0.6)
    mu_a, lo, hi, mu_b = F.a_node_friction(mixed)
    assert list(mu_a) == pytest.approx([0.0, 0.0, t30, 0.0]) and (lo, hi, mu_b) == (0.0, pytest.approx(t30), 0.6)
    assert F.hold_pairs(mixed)[0, 1] == 0.0 and F.node_friction(mixed) is None and not F.b_unnamed_mix(mixed)
    assert F.a_node_friction(water_sand_setup(1.2, 0.6, alone=True)) is None   # water alone: the scalar 0
    assert F.field_friction(water_sand_setup(1.2, 0.6, alone=True)) == 0.0
    mix = named_unnamed_setup(1.2, (40.0, 20.0), (0.6, None))
    t20, t40 = (math.tan(math.radians(a)) for a in (20.0, 40.0))
    own, mu_b, lo, hi = F.node_friction(mix)
    assert F.b_unnamed_mix(mix) and list(mu_b) == [0.0, 0.6, 0.0, F.UNNAMED]
    assert (lo, hi) == (pytest.approx(t20), pytest.approx(t40)) and own == pytest.approx(t40)
    assert F.hold_pairs(mix)[2, 3] == pytest.approx(t20)
    one_angle = named_unnamed_setup(1.2, (30.0, 30.0), (0.6, None))   # A one angle: round 42's rule, unchanged
    assert not F.b_unnamed_mix(one_angle) and F.node_friction(one_angle)[1][3] == pytest.approx(t30)
    assert not F.b_unnamed_mix(named_unnamed_setup(1.2, (40.0, 20.0), (None, None)))   # B names none: round 43
    assert F.combine_friction(0.0, 0.6) == 0.0


def _trace(engine: str, setup):
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    return run_trace(get_engine(engine), setup, RATIO_FRAMES)


@functools.cache
def water_alone(engine: str, n_grid: int, v0: float, slab_mu, model: str, opts: tuple = ()) -> float:
    """The water block's Coulomb ratio alone on the slabs (no sand: the pair 0): the grid's own drag (``opts``:
    more engine options, as pairs)."""
    old, S.N_GRID = S.N_GRID, n_grid
    try:
        setup = water_sand_setup(v0, slab_mu, {"threads": 1, **dict(opts)}, model, alone=True)
        return S.coulomb_ratio(_trace(engine, setup).v, setup, 0, RATIO_FRAMES, body=0)
    finally:
        S.N_GRID = old


def run_water_sand(engine: str, n_grid: int, slab_mu, monkeypatch, speeds=RATIO_SPEEDS, model: str = "",
                   opts: tuple = ()) -> dict:
    """Per speed ``(dw, e2, rw, vw)``: the water's ratio less its reference over the sand's pair (the check's
    quantity, ``RATIO_TOL`` either side), the sand's ratio error, the water's ratio and its x velocity kept (V / v0)."""
    out = {}
    for v0 in speeds:
        ref = water_alone(engine, n_grid, v0, slab_mu, model, opts)
        monkeypatch.setattr(S, "N_GRID", n_grid)
        setup = water_sand_setup(v0, slab_mu, {"threads": 1, **dict(opts)}, model)
        tr = _trace(engine, setup)
        rw = S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES, body=0)
        pair = own_pair(30.0, slab_mu)
        sel = np.asarray(setup.body_id) == 0
        vw = float(setup.p_mass[sel] @ tr.v[-1, sel, 0] / setup.p_mass[sel].sum()) / v0
        out[v0] = ((rw - ref) / pair, S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES, body=2) / pair - 1.0, rw, vw)
    print(f"water+sand {engine} n_grid {n_grid} slabs {slab_mu} {model or 'jelly'} {opts}: {out}")   # with -s
    return out


def run_named_unnamed(engine: str, n_grid: int, angles, slab_mus, monkeypatch, speeds=RATIO_SPEEDS,
                      model: str = "", opts: tuple = ()) -> dict:
    """Per speed each block's ratio error against its own pair: ``{v0: (e0, e2)}``."""
    monkeypatch.setattr(S, "N_GRID", n_grid)
    out = {}
    for v0 in speeds:
        setup = named_unnamed_setup(v0, angles, slab_mus, {"threads": 1, **dict(opts)}, model)
        tr = _trace(engine, setup)
        out[v0] = tuple(S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES, body=b) / own_pair(phi, mu) - 1.0
                        for b, phi, mu in ((0, angles[0], slab_mus[0]), (2, angles[1], slab_mus[1])))
    print(f"named+unnamed {engine} n_grid {n_grid} {angles} slabs {slab_mus} {model or 'jelly'} {opts}: {out}")
    return out


WATER_FAMILY = [(32, 0.6, ""), (48, 0.6, ""), (32, None, ""), (48, None, ""), (32, 0.6, "rigid")]
NAMED_FAMILY = [(32, (40.0, 20.0), (0.6, None), ""), (48, (40.0, 20.0), (0.6, None), ""),
                (32, (20.0, 35.0), (None, 0.15), ""), (32, (40.0, 20.0), (0.6, None), "rigid")]
ENGINES = ("warp_mpm", "taichi_mpm")


@pytest.mark.slow
def test_warp_gpu_schedule_takes_both_rules(monkeypatch):
    """warp_mpm's gpu schedule (run on the CPU) shares P2G and the contact kernel with the cpu schedule: the water
    beside sand and the unnamed slab's 20 deg block hold there too (n_grid 32, 1.2 m/s, jelly slabs)."""
    gpu = (("schedule", "gpu"),)
    water = run_water_sand("warp_mpm", 32, 0.6, monkeypatch, speeds=RATIO_SPEEDS[:1], opts=gpu)
    named = run_named_unnamed("warp_mpm", 32, (40.0, 20.0), (0.6, None), monkeypatch, speeds=RATIO_SPEEDS[:1],
                              opts=gpu)
    assert all(abs(dw) <= RATIO_TOL and abs(e2) <= RATIO_TOL for dw, e2, _, _ in water.values()), water
    assert all(abs(e) <= RATIO_TOL for pair in named.values() for e in pair), named


def _params(family):
    for engine in ENGINES:
        for case in family:
            yield pytest.param(engine, *case, id="-".join([engine] + [str(c) for c in case if c != ""]))


@pytest.mark.slow
@pytest.mark.parametrize("engine, n_grid, slab_mu, model", list(_params(WATER_FAMILY)))
def test_water_beside_sand_slides_as_alone(engine, n_grid, slab_mu, model, monkeypatch):
    out = run_water_sand(engine, n_grid, slab_mu, monkeypatch, RATIO_SPEEDS, model)
    assert all(abs(dw) <= RATIO_TOL and abs(e2) <= RATIO_TOL for dw, e2, _, _ in out.values()), out


@pytest.mark.slow
@pytest.mark.parametrize("engine, n_grid, angles, slab_mus, model", list(_params(NAMED_FAMILY)))
def test_an_unnamed_slab_pairs_each_sand_at_its_own_angle(engine, n_grid, angles, slab_mus, model, monkeypatch):
    out = run_named_unnamed(engine, n_grid, angles, slab_mus, monkeypatch, RATIO_SPEEDS, model)
    assert all(abs(e) <= RATIO_TOL for pair in out.values() for e in pair), out


def _patch(monkeypatch, name, fn) -> None:
    import gasp_warp_mpm.fields as wf
    monkeypatch.setattr(F, name, fn)
    if hasattr(wf, name):
        monkeypatch.setattr(wf, name, fn)


def water_at_sand_rule(monkeypatch) -> None:
    """Round 43's rule for water beside one sand: A one coefficient, the sand's (``a_node_friction`` None)."""
    _patch(monkeypatch, "a_node_friction", lambda setup: None)


def water_pair_5pct(monkeypatch) -> None:
    """The water's pair 5 % of the sand's on a named slab: its ``tan`` 0.05^2 times the sand's."""
    real = F.a_node_friction

    def leaky(setup):
        got = real(setup)
        if got is None:
            return None
        mu_a, lo, hi, mu_b = got
        mu_a = np.where(np.array([m.name == "liquid" for m in setup.materials]), 0.0025 * hi, mu_a)
        return mu_a, 0.0025 * hi, hi, mu_b
    _patch(monkeypatch, "a_node_friction", leaky)


def unnamed_at_largest_rule(monkeypatch) -> None:
    """Round 43's rule for B's unnamed bodies: the largest angle's ``tan`` in B's mean (``b_unnamed_mix`` False)."""
    monkeypatch.setattr(F, "b_unnamed_mix", lambda setup: False)


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
@pytest.mark.parametrize("rule", [water_at_sand_rule, water_pair_5pct])
def test_the_water_check_catches(engine, rule, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    rule(monkeypatch)
    out = run_water_sand(engine, 32, 0.6, monkeypatch, speeds=RATIO_SPEEDS[:1])
    assert all(dw > RATIO_TOL and abs(e2) <= RATIO_TOL for dw, e2, _, _ in out.values()), out


@pytest.mark.slow
@pytest.mark.parametrize("engine", ENGINES)
def test_the_unnamed_check_catches_the_largest_angle(engine, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    unnamed_at_largest_rule(monkeypatch)
    out = run_named_unnamed(engine, 32, (40.0, 20.0), (0.6, None), monkeypatch, speeds=RATIO_SPEEDS[:1])
    assert all(abs(e0) <= RATIO_TOL and e2 > RATIO_TOL for e0, e2 in out.values()), out
