"""Sand sliding on a rigid body by Coulomb's law (issue 67 item 5, docs/contact.md "Round 41: sand on a rigid body").

Round 38's known-answer scene (``sand_ball.slide_setup``, the sand block thrown along the 4.5 cm slab at 1.2 and
1.6 m/s, ``COULOMB_SLAB_H``) with the slab made rigid (``model = "rigid"``): a ``"mixed"`` scene whose field B is a
rigid body (its nodes projected onto its rigid motion, its distance field holding the sand's points out,
``gasp_core.mpm.rigid_hold``). The figure: Coulomb's ratio (``sand_ball.coulomb_ratio``, the block's horizontal
momentum lost over the normal impulse its support gave it, from the throw to frame 3) against the pair's friction
(``gasp_core.mpm.fields.field_friction``: tan 30 deg with the slab's ``friction`` unset, ``sqrt(tan 30 deg mu)`` with
it set), within ``RATIO_TOL`` = 2.5 % at each speed. Besides: the slab (2.9 kg on the ground, friction 0.5) moves
under ``SLAB_TOL`` along x, and the sand's 20 lowest points stay in ``REST_BAND`` over the slab's top face (the
sand does not sink into it). The rigid slab settles a quarter cell onto the ground in the first frame (its lowest
points on the plane: a rigid body on the grid contact keeps no skin; the jelly slab sags 0.003 dx); the face is read
from the slab's top points at each frame.

- The family: n_grid 32 and 48, the slab's ``friction`` unset and 0.3, both grid engines (warp_mpm n_grid 32 unset
  in the default tier, the rest slow). Measured (1.2 / 1.6 m/s, both engines the same digits): n32 -0.63 / -0.28 %,
  n32 0.3 -0.41 / -0.20 %, n48 -0.40 / -0.19 %, n48 0.3 -0.30 / -0.15 %; the slab along x 0.0007-0.0018 dx; the
  lowest sand 0.18-0.27 dx above the slab's face.
- **Catches** (both engines the same digits, n_grid 32, 1.2 / 1.6 m/s): the engine's pair friction (the two fields'
  and the rigid hold's, the answer kept) 0.95 times reads -5.55 / -5.25 %, 1.05 times +4.29 / +4.69 %, and fails
  the ratio; the rigid hold and round 37's flowing body's touch both off lets the sand sink to -0.13 dx and fails
  the rest band (the touch alone off: -0.02 dx, fails it too; the hold alone off changes nothing here: the touch
  keeps the sand out of the hold's reach); the slab on a frictionless ground moves 0.092 dx and fails the slab
  check. Neither switch moves the ratio past its tolerance (-0.91 / -0.37 % and +1.97 / +0.31 %).
- **The face anywhere in its cell** (round 41, docs/contact.md "Round 41: the sand's affine momentum at the face"):
  thrown at 0.7 m/s the ratio read -6.9 % on the rigid slab (its face settled 3/4 of a cell above a node layer) and
  -6.5 % on the jelly slab put there, from field A's affine (APIC) momentum at B's face; with it left out for A's
  points that touch B (``F.PIC_AT_B``) the family (the face at 0, 1/4, 1/2, 3/4 of a cell, rigid and jelly, n_grid
  32 and 48, 0.7 and 1.2 m/s, both engines) keeps the checks above but one case (strict xfail: the jelly slab at
  n_grid 48 not lowered, -3.12 % at 0.7 m/s, before -5.08 %); the catch: ``PIC_AT_B`` off fails the 3/4 cases. The
  figures of the family above were read before round 41's ``PIC_AT_B`` (with it, n32 unset -0.03 % at 1.2 m/s).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from gasp_testing import set_pair_friction

from gasp_core.colliders.model import COL_META
from gasp_core.mpm import fields as F
from gasp_core.mpm import rigid_hold as RH
from gasp_core.mpm.grid_tables import CM_FRICTION
from gasp_core.testing import sand_ball as S
from gasp_core.testing.scenes_flow_pairs import RATIO_FRAMES, RATIO_SPEEDS, RATIO_TOL

#: The slab's travel along x over the 3 frames (cells): the sand's friction (about 1 N) against the ground's hold
#: on 3 kg; on a frictionless ground it would move about 0.1 cells.
SLAB_TOL = 0.01
#: The band of the sand's 20 lowest points over the slab's top face (cells) at every frame: the flowing body's touch
#: (round 37) rests sand 0.25-0.27 dx over a jelly slab and the ground; under 0.1 it is entering the slab.
REST_BAND = (0.1, 0.4)
#: (n_grid, the slab's ``friction``: None the sand's own tan phi)
FAMILY = [(32, None), (32, 0.3), (48, None), (48, 0.3)]


def _engine(engine: str):
    pytest.importorskip({"warp_mpm": "gasp_warp_mpm", "taichi_mpm": "gasp_taichi_mpm"}[engine])
    from gasp_core.seam.plugins import get_engine
    return get_engine(engine)


def rigid_slide_setup(v0: float, slab_mu: float | None, model: str = "rigid", slab_h: float = S.COULOMB_SLAB_H):
    """Round 38's scene (``S.slide_setup`` on the 4.5 cm slab) with the slab rigid (``model``) and its ``friction``
    set."""
    setup = S.slide_setup(v0, {"threads": 1}, slab_h=slab_h)
    setup.materials = [setup.materials[0], dataclasses.replace(setup.materials[1], model=model, friction=slab_mu)]
    return setup


def run_family(engine: str, n_grid: int, slab_mu: float | None, monkeypatch, speeds=RATIO_SPEEDS,
               **slab_kw) -> dict:
    """Per speed ``(ratio error, slab travel along x in cells, lowest sand over the slab's top in cells per frame)``;
    the answer ``F.field_friction`` read before the run (a catch may bias the engine's). ``slab_kw``: ``model`` and
    ``slab_h`` of :func:`rigid_slide_setup`."""
    from gasp_core.testing.kit import run_trace
    info = _engine(engine)
    monkeypatch.setattr(S, "N_GRID", n_grid)
    dx = S.SIDE / n_grid
    out = {}
    for v0 in speeds:
        setup = rigid_slide_setup(v0, slab_mu, **slab_kw)
        mu = F.field_friction(setup)
        tr = run_trace(info, setup, RATIO_FRAMES)
        body = np.asarray(setup.body_id)
        slab, sand = body == 1, body == 0
        m = setup.p_mass[slab]
        travel = float(m @ (tr.x[-1][slab, 0] - setup.x[slab, 0]) / m.sum()) / dx
        top = setup.x[slab, 2] >= setup.x[slab, 2].max() - 1e-9          # the top layer, dx / 4 under the face
        rest = [float(np.sort(tr.x[f][sand, 2])[:20].mean() - tr.x[f][slab][top, 2].mean()) / dx - 0.25
                for f in range(RATIO_FRAMES + 1)]
        out[v0] = (S.coulomb_ratio(tr.v, setup, 0, RATIO_FRAMES) / mu - 1.0, travel, rest)
    return out


def _checks(out: dict) -> dict:
    """Which checks pass: the ratio within ``RATIO_TOL``, the slab still, the sand in ``REST_BAND``, every speed."""
    return {"ratio": all(abs(e) <= RATIO_TOL for e, _t, _r in out.values()),
            "slab": all(abs(t) <= SLAB_TOL for _e, t, _r in out.values()),
            "rest": all(REST_BAND[0] <= min(r) and max(r) <= REST_BAND[1] for _e, _t, r in out.values())}


def _family_params():
    for engine in ("warp_mpm", "taichi_mpm"):
        for n_grid, mu in FAMILY:
            fast = engine == "warp_mpm" and n_grid == 32 and mu is None
            yield pytest.param(engine, n_grid, mu, id=f"{engine}-n{n_grid}-{mu}",
                               marks=() if fast else pytest.mark.slow)


@pytest.mark.parametrize("engine, n_grid, slab_mu", list(_family_params()))
def test_sand_slides_on_a_rigid_slab_by_coulombs_law(engine, n_grid, slab_mu, monkeypatch):
    out = run_family(engine, n_grid, slab_mu, monkeypatch)
    assert all(_checks(out).values()), (_checks(out), out)


def bias_friction(monkeypatch, engine: str, factor: float) -> None:
    """The engine's pair friction ``factor`` times the right one: the two fields' coefficient and the rigid hold's
    (its tables' ``CM_FRICTION``; both engines build them through ``RH.hold_setup``); ``F.field_friction``, the
    answer, kept."""
    real_tables = RH.rigid_hold_tables

    def tables(*a, **k):
        t = real_tables(*a, **k)
        if t is not None:
            t[3][CM_FRICTION::COL_META] *= factor
        return t
    monkeypatch.setattr(RH, "rigid_hold_tables", tables)
    set_pair_friction(monkeypatch, engine, lambda setup: factor * F.field_friction(setup))


@pytest.mark.parametrize("factor", [0.95, 1.05])
@pytest.mark.parametrize("engine", ["warp_mpm", pytest.param("taichi_mpm", marks=pytest.mark.slow)])
def test_the_ratio_catches_a_friction_5pct_off(engine, factor, monkeypatch):
    bias_friction(monkeypatch, engine, factor)
    out = run_family(engine, 32, None, monkeypatch)
    assert all((e < -RATIO_TOL) if factor < 1 else (e > RATIO_TOL) for e, _t, _r in out.values()), out


def _switch_off(monkeypatch, engine: str, hold: bool) -> None:
    """Round 37's flowing body's touch off (``F.FLOW_TOUCH``), and with ``hold`` the rigid hold too: nothing keeps
    the sand out of the rigid slab but the two fields' volume test (``tests/test_rigid_hold.py``'s broken engine)."""
    monkeypatch.setattr(F, "FLOW_TOUCH", False)
    if not hold:
        return
    monkeypatch.setattr(RH, "rigid_hold_tables", lambda *a, **k: None)   # both engines build it through RH.hold_setup


@pytest.mark.slow
@pytest.mark.parametrize("hold", [True, False], ids=["touch_and_hold_off", "touch_off"])
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_rest_check_catches_sand_sinking_without_the_touch(engine, hold, monkeypatch):
    _switch_off(monkeypatch, engine, hold)
    out = run_family(engine, 32, None, monkeypatch)
    assert not _checks(out)["rest"], out


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["warp_mpm", "taichi_mpm"])
def test_the_slab_check_catches_a_slab_that_slides(engine, monkeypatch):
    """The slab on a frictionless ground: the sand's friction pushes it along."""
    monkeypatch.setattr(S, "MU_GROUND", 0.0)
    out = run_family(engine, 32, None, monkeypatch)
    assert not _checks(out)["slab"], out


#: The face's place in its cell (the slab lowered by this many cells: the rigid slab's face then sits 3/4, 1/2, 1/4
#: and 0 of a cell above a node layer at n_grid 32, the jelly slab's 0, 3/4, 1/2, 1/4), the slab, n_grid: the
#: family of round 41's affine momentum at B (``F.PIC_AT_B``), at 0.7 and 1.2 m/s.
LOWERS = (0.0, 0.25, 0.5, 0.75)
#: The failure left until round 74: the jelly slab at n_grid 48 (its face half a cell above a node layer) at 0.7 m/s,
#: -3.12 % (before round 41 -5.08 %): round 37's mark (points within FLOW_TOUCH_DELTA of B) missed the sand's lowest
#: points. Round 75's touch at the flowing body's surface (``gasp_core.mpm.flow_reach``, a mark half a point spacing
#: wider) passes it on both engines (it was a strict xfail; its XPASS is how round 75's guard found it).


def _face_params():
    for engine in ("warp_mpm", "taichi_mpm"):
        for n_grid in (32, 48):
            for model in ("rigid", "jelly"):
                for lower in LOWERS:
                    fast = engine == "warp_mpm" and n_grid == 32 and model == "rigid" and lower == 0.0
                    marks = [] if fast else [pytest.mark.slow]
                    yield pytest.param(engine, n_grid, model, lower, id=f"{engine}-n{n_grid}-{model}-{lower}",
                                       marks=marks)


def run_face(engine: str, n_grid: int, model: str, lower: float, monkeypatch, speeds=(0.7, 1.2)) -> dict:
    """:func:`run_family` at ``speeds`` (m/s) with the slab ``model`` ("rigid" or "jelly") lowered ``lower``
    cells."""
    monkeypatch.setattr(S, "N_GRID", n_grid)
    h = S.COULOMB_SLAB_H - lower * S.SIDE / n_grid
    return run_family(engine, n_grid, None, monkeypatch, speeds=speeds,
                      model=S.SLAB.model if model == "jelly" else model, slab_h=h)


@pytest.mark.parametrize("engine, n_grid, model, lower", list(_face_params()))
def test_a_slower_slide_with_the_face_anywhere_in_its_cell(engine, n_grid, model, lower, monkeypatch):
    """Thrown at 0.7 m/s (and 1.2) on a rigid or jelly slab whose face sits anywhere in its cell: with field A's
    affine momentum left out where A touches B (``F.PIC_AT_B``, round 41) the ratio within ``RATIO_TOL``; before,
    -6.88 / -6.76 % (rigid, face 3/4 of a cell above a node layer) and -6.50 / -6.49 % (jelly lowered a quarter
    cell), warp_mpm / taichi_mpm. The default tier's case at 0.7 m/s alone."""
    fast = engine == "warp_mpm" and n_grid == 32 and model == "rigid" and lower == 0.0
    out = run_face(engine, n_grid, model, lower, monkeypatch, speeds=(0.7,) if fast else (0.7, 1.2))
    assert all(_checks(out).values()), (_checks(out), out)


@pytest.mark.parametrize("engine, model, lower", [
    ("warp_mpm", "rigid", 0.0),
    pytest.param("taichi_mpm", "rigid", 0.0, marks=pytest.mark.slow),
    pytest.param("warp_mpm", "jelly", 0.25, marks=pytest.mark.slow),
    pytest.param("taichi_mpm", "jelly", 0.25, marks=pytest.mark.slow)])
def test_the_face_family_catches_the_affine_momentum_at_b(engine, model, lower, monkeypatch):
    """The catch: ``F.PIC_AT_B`` off (every point keeps its affine momentum, the rule before) fails the ratio at
    0.7 m/s with the face 3/4 of a cell above a node layer."""
    monkeypatch.setattr(F, "PIC_AT_B", False)
    out = run_face(engine, 32, model, lower, monkeypatch, speeds=(0.7,))
    assert out[0.7][0] < -RATIO_TOL, out
