"""A contact node's support in the contact's balance does not hang on the points' order (round 55,
``gasp_core.mpm.contact_mark``, docs/contact.md "Round 55: a node's support").

Until round 55 a node that points of several rows of the balance marked (a corner of the ground and a wall) kept the
row of the last point to write: the two MLS-MPM engines order their points differently, so on the conformance sand
column in its channel (the particle contact) they parted from the first contact, taichi_mpm's front at -14.4 % of Lube
et al.'s runout and warp_mpm's at +46.4 % (round 55's first measurement), and on a GPU the mark was a race. Now the
node keeps the row of the point that pushes it most (an atomic max of a packed key): the same on any order.

Round 59 (docs/contact.md "Round 59: the balance on a flowing body"): the balance no longer acts on a flowing body,
so on the sand column the marks decide nothing. The column stays the check's scene, as the sensitive case it was
(a ground, a back wall and two side walls all marking the same nodes), with the balance put back on the sand
(``gasp_core.mpm.contact.BALANCE_FLOWING`` True, :func:`balance_on_the_sand`): the check reads the marks' order, not
the sand's physics.

The check (slow tier): the column (a = 2 at n_grid 48; a = 1 at n_grid 32), run to its end on both engines in f64,
gives the same runout within 5 % of Lube's and the same height within 2 % of his. The catch: taichi_mpm with the last
writer's mark against warp_mpm fails it (round 79, f64: runout -8.7 % at both columns, height +4.2 and +2.6 %).

Round 79 (docs/contact.md "Round 79: the marks' check reads roundoff in f32"): the check ran in f32 until then, and
the a = 1 column's heights parted by 5.9 % of Lube's from 96088329 on. In f32 one engine's height moves that much
with the substep count alone (warp_mpm 0.937, 0.961, 0.906 of Lube's at 22, 23, 24 substeps; taichi_mpm 0.950,
0.902, 0.900), so the check read the flow's amplified roundoff, not the marks. In f64 the engines' heights agree to
0.05 % (0.9117 and 0.9112).
"""
from __future__ import annotations

import sys

import pytest

from gasp_testing import ROOT
from gasp_core.mpm.contact_mark import MARK_ROW_BITS, MARK_ROW_MASK, check_mark_rows, mark_key
from gasp_core.seam.plugins import engines
from gasp_core.testing import scenes_granular as sg
from gasp_core.testing.kit import resolve_engine

sys.path.insert(0, str(ROOT / "benchmarks"))
import lube_family as lf  # noqa: E402

BOTH = all(n in engines() and engines()[n].unavailable_reason() is None for n in ("taichi_mpm", "warp_mpm"))
#: (aspect a, n_grid, substeps a frame): about the default cfl's step on each grid.
COLUMNS = [(2.0, 48, 34), (1.0, 32, 23)]
RUNOUT_TOL, HEIGHT_TOL = 0.05, 0.02


@pytest.fixture
def balance_on_the_sand(monkeypatch):
    """The contact's balance on the sand column, as before round 59 (the marks' sensitive scene; module notes)."""
    import gasp_core.mpm.contact as gc
    monkeypatch.setattr(gc, "BALANCE_FLOWING", True)


def test_the_key_orders_by_push_then_by_row():
    assert mark_key(2.0, 3) > mark_key(1.0, 7)   # the larger push wins, whatever the row
    assert mark_key(1.0, 7) > mark_key(1.0, 3)   # a tie: the higher row
    assert mark_key(1.0, 5) & MARK_ROW_MASK == 5 and mark_key(0.0, 9) == 9
    assert mark_key(1e-12, 2) < mark_key(1e-11, 1)
    assert 0 < mark_key(1e30, MARK_ROW_MASK) < 2 ** 31   # a positive int32


def test_a_balance_with_more_rows_than_a_key_holds_is_refused():
    check_mark_rows(1 << MARK_ROW_BITS)
    with pytest.raises(ValueError, match="contact_balance"):
        check_mark_rows((1 << MARK_ROW_BITS) + 1)


def column_gap(a: float, n_grid: int, k: int) -> tuple[float, float]:
    """``(runout, height)`` of taichi_mpm less warp_mpm's on the column, over Lube's (signed), in f64 (round 79: in
    f32 the flowing column's deposit amplifies roundoff, so the engines' heights differed by what a substep more or
    less moves one engine's: module notes)."""
    opts = {"n_substeps": k, "contact": "particle", "precision": "f64"}
    (rt, ht), (rw, hw) = (lf.column_end(resolve_engine(n), a, n_grid, opts) for n in ("taichi_mpm", "warp_mpm"))
    return (rt - rw) / sg.lube_runout(a), (ht - hw) / sg.lube_height(a)


@pytest.mark.slow
@pytest.mark.skipif(not BOTH, reason="needs both MLS-MPM engines")
@pytest.mark.parametrize("a,n_grid,k", COLUMNS)
def test_the_engines_give_the_column_in_its_channel_the_same_deposit(a, n_grid, k, balance_on_the_sand):
    dr, dh = column_gap(a, n_grid, k)
    assert abs(dr) < RUNOUT_TOL and abs(dh) < HEIGHT_TOL, (a, n_grid, dr, dh)


@pytest.mark.slow
@pytest.mark.skipif(not BOTH, reason="needs both MLS-MPM engines")
def test_the_check_catches_the_last_writers_mark(monkeypatch, balance_on_the_sand):
    import taichi as ti
    from gasp_taichi_mpm.balance import Balance

    @ti.func
    def last_writer(self, base, w, jvec, sup):   # round 54's mark: the last point to write wins
        if ti.static(self.n_planes > 0 or self.n_colc > 0):
            if self.n_spin > 0 and sup >= 0:
                for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                    self.grid_fbody[base + ti.Vector([i, j, k])] = sup

    monkeypatch.setattr(Balance, "mark_contact_nodes", last_writer)
    dr, dh = column_gap(*COLUMNS[0])
    assert abs(dr) > RUNOUT_TOL or abs(dh) > HEIGHT_TOL, (dr, dh)
