"""Several bodies of field B, each with its own ``friction`` (issue 67 item 4, "the pair's friction"; docs/contact.md
"Round 42: several bodies' frictions in field B").

In a ``"mixed"`` scene field A is the flowing bodies and field B every body that does not flow. Round 41 gave field B
one coefficient, the smallest any of its bodies named, so sand poured beside a wooden board (0.3) on a rubber mat
(1.0) slid on the mat at the board's friction. Now both grid engines build the pair's friction per node
(``gasp_core.mpm.fields.node_friction``): B's points scatter their body's coefficient weighted by ``w_ip m_p`` to one
more node channel, and a contact node's Coulomb limit is ``combine_friction(tan phi, mu_B(node))``, ``mu_B`` the
mass-weighted mean there. A scene whose field B brings one coefficient (every single-B scene) keeps the scalar path,
bit-identical (sha1 of the trajectories, docs/contact.md).

The engine check: ``sand_ball.two_slab_setup``, two 4.5 cm slabs side by side (friction 0.3 and 1.0), round 38's
sand block thrown along each at 1.2 and 1.6 m/s; each block's Coulomb ratio (``sand_ball.coulomb_ratio``, throw to
frame 3) within ``RATIO_TOL`` 2.5 % of its own pair's ``sqrt(tan 30 deg mu_slab)`` (0.416 and 0.760). Family: both
engines, n_grid 32 and 48, the values (0.6, 0.15), rigid slabs; warp_mpm at n_grid 32 and 1.2 m/s in the default
tier, the rest slow. **Catches:** the old rule (one scalar, the smallest: ``node_friction`` None) reads the 1.0
slab's block -45 %; a per-node pair 5 % off (``own`` scaled by 1.05^2 or 0.95^2) fails both blocks the right way.
"""
from __future__ import annotations

import dataclasses
import math

import pytest

from gasp_core.mpm import fields as F
from gasp_core.testing import sand_ball as S
from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS, RATIO_TOL

TAN30 = math.tan(math.radians(30.0))
pytestmark = pytest.mark.filterwarnings("ignore:engine .* share one grid velocity field")


def test_node_friction_only_where_field_b_brings_several():
    one = S.slide_setup(1.2, slab_h=S.COULOMB_SLAB_H)
    assert F.node_friction(one) is None                       # one body in B: the scalar path
    two = S.two_slab_setup(1.2)
    own, mu_b, lo, hi = F.node_friction(two)
    assert own == pytest.approx(TAN30, rel=1e-12) and (lo, hi) == (0.3, 1.0)
    assert list(mu_b) == [0.0, 0.3, 0.0, 1.0]
    assert F.field_friction(two) == pytest.approx(math.sqrt(TAN30 * 0.3), rel=1e-12)   # round 41's scalar
    pair = F.pair_frictions(two)
    assert pair[1] == pytest.approx(math.sqrt(TAN30 * 0.3)) and pair[3] == pytest.approx(math.sqrt(TAN30))
    same = S.two_slab_setup(1.2, (0.5, 0.5))
    assert F.node_friction(same) is None and F.field_friction(same) == pytest.approx(math.sqrt(TAN30 * 0.5))
    unnamed = S.two_slab_setup(1.2)                            # a body that names none brings the sand's own
    unnamed.materials[3] = dataclasses.replace(unnamed.materials[3], friction=None)
    assert F.b_frictions(unnamed)[3] == pytest.approx(TAN30) and F.pair_frictions(unnamed)[3] == TAN30
    unnamed.options["contact_fields"] = False                  # one field: no Coulomb contact at all
    assert F.node_friction(unnamed) is None


def test_a_rigid_body_holds_the_sand_with_its_own_pair():
    from gasp_core.mpm.rigid_hold import CM_FRICTION, COL_META, rigid_hold_tables
    from gasp_core.mpm.contact import contact_model, flowing_bodies
    setup = S.two_slab_setup(1.2, model="rigid")
    row, _sdf, _grad, meta = rigid_hold_tables(setup, S.DX, flowing_bodies(setup, contact_model(setup)))
    got = [meta[row[b] * COL_META + CM_FRICTION] for b in (1, 3)]
    assert got == pytest.approx([math.sqrt(TAN30 * 0.3), math.sqrt(TAN30 * 1.0)], rel=1e-12)


def run_two_slabs(engine: str, n_grid: int, mus, monkeypatch, speeds=RATIO_SPEEDS, model: str = "") -> dict:
    """Per speed, each block's ratio error against its own pair's ``sqrt(tan 30 deg mu)``: ``{v0: (e0, e2)}``."""
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.kit import run_trace
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    info = get_engine(engine)
    monkeypatch.setattr(S, "N_GRID", n_grid)
    out = {}
    for v0 in speeds:
        setup = S.two_slab_setup(v0, mus, {"threads": 1}, model=model)
        tr = run_trace(info, setup, RATIO_FRAMES)
        out[v0] = tuple(S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES, body=b) / math.sqrt(TAN30 * mu) - 1.0
                        for b, mu in ((0, mus[0]), (2, mus[1])))
    print(f"two slabs {engine} n_grid {n_grid} {mus} {model or 'jelly'}: {out}")   # the figures, with -s
    return out


FAMILY = [(32, (0.3, 1.0), ""), (48, (0.3, 1.0), ""), (32, (0.6, 0.15), ""), (32, (0.3, 1.0), "rigid")]


def _family_params():
    for engine in ("warp_mpm", "taichi_mpm"):
        for n_grid, mus, model in FAMILY:
            fast = engine == "warp_mpm" and n_grid == 32 and mus == (0.3, 1.0) and not model
            yield pytest.param(engine, n_grid, mus, model, id=f"{engine}-n{n_grid}-{mus[0]}-{mus[1]}{model}",
                               marks=() if fast else pytest.mark.slow)


@pytest.mark.parametrize("engine, n_grid, mus, model", list(_family_params()))
def test_each_block_slides_with_its_own_slabs_friction(engine, n_grid, mus, model, monkeypatch):
    fast = engine == "warp_mpm" and n_grid == 32 and mus == (0.3, 1.0) and not model
    out = run_two_slabs(engine, n_grid, mus, monkeypatch, speeds=RATIO_SPEEDS[:1] if fast else RATIO_SPEEDS,
                        model=model)
    assert all(abs(e) <= RATIO_TOL for pair in out.values() for e in pair), out


def smallest_rule(monkeypatch) -> None:
    """Round 41's rule: one scalar for field B, the smallest named (``node_friction`` None in core and warp_mpm)."""
    import gasp_warp_mpm.fields as wf
    monkeypatch.setattr(F, "node_friction", lambda setup: None)
    monkeypatch.setattr(wf, "node_friction", lambda setup: None)


def bias_node_friction(monkeypatch, factor: float) -> None:
    """The per-node pair ``factor`` times the right one (``own`` scaled by ``factor^2``)."""
    import gasp_warp_mpm.fields as wf
    real = F.node_friction

    def biased(setup):
        got = real(setup)
        return None if got is None else (got[0] * factor ** 2, *got[1:])
    monkeypatch.setattr(F, "node_friction", biased)
    monkeypatch.setattr(wf, "node_friction", biased)


@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_the_check_catches_the_smallest_rule(engine, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    smallest_rule(monkeypatch)
    out = run_two_slabs(engine, 32, (0.3, 1.0), monkeypatch, speeds=RATIO_SPEEDS[:1])
    assert all(abs(e0) <= RATIO_TOL and e2 < -RATIO_TOL for e0, e2 in out.values()), out


@pytest.mark.slow
@pytest.mark.parametrize("factor", [0.95, 1.05])
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_check_catches_a_per_node_friction_5pct_off(engine, factor, monkeypatch):
    pytest.importorskip("gasp_warp_mpm")
    bias_node_friction(monkeypatch, factor)
    out = run_two_slabs(engine, 32, (0.3, 1.0), monkeypatch)
    assert all((e < -RATIO_TOL) if factor < 1 else (e > RATIO_TOL) for pair in out.values() for e in pair), out

