"""Round 103 (``docs/performance.md`` "Round 103: Grady's cells over the touched box"): warp_mpm's node passes of
Grady's cells (``gasp_warp_mpm/cells.py``: the reference cells' clear before P2G, the cells' contact and the clear
after it) sweep the grid update's box (the hull of the nodes P2G touched this substep and the last,
``gasp_warp_mpm/grid_box.py``), not the whole grid, and must not change a bit: compared with ``cells.CELL_BOX =
False`` (the whole grid, round 102's), the points' ``x, v, F, C, Jp`` after the landing, on the pieces family's ball
and its neighbour the cube (``gasp_core.testing.scenes_pieces``), laid out in cells at 7 and 10 m/s, n_grid 28 and 32
(the cells part there: ``tests/test_grady_cells.py``).

Why the hull is enough: the reference cells (``grid_ref``) are written by ``cell_ref`` and the fields' sums
(``grid_cs``, ``grid_cd``) by P2G only at their points' 27 nodes, this substep's box; the clear before P2G sweeps the
box as the last substep left it (its hull holds the last substep's writes), the clear after the contact this
substep's; the contact writes both fields' offsets (``grid_cdv``, zero where they move as one) at every node of the
hull, and G2P reads them only at its points' nodes, in this substep's box; the contact reads its neighbours' sums,
zero outside the box. taichi_mpm's cells already sweep its touched box.

The catch: the contact and the clear launched before the grid update's box is built (the order of round 102's
launches, harmless over the whole grid) sweep the last substep's hull, and the landing's leading nodes are left out:
the bits change on every case.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from gasp_core.run.grady_cells import laid
from gasp_core.seam import build_engine, get_engine
from gasp_core.testing.scenes_pieces import shape_setup

pytest.importorskip("warp")

FRAMES = 12
#: (shape, speed m/s, n_grid): about 1 s a run.
CASES = [("ball", 7.0, 28), ("ball", 10.0, 32), ("cube:0.16", 7.0, 28), ("cube:0.16", 10.0, 32)]


def run(shape: str, speed: float, n_grid: int) -> dict:
    """warp_mpm's run of the laid-out ``shape`` for :data:`FRAMES` frames: the points' state as bytes, the share of
    the grid in the box, how far the points moved (m) and the cells laid."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")   # cells laid larger than Grady's on a coarse grid
        s, rec = laid(shape_setup(shape, speed, n_grid))
    assert rec is not None and rec["cells"] >= 2, rec
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        for _ in range(FRAMES):
            eng.step_frame()
        st = eng.get_state()
        b = eng.grid_box.numpy()
        ext = np.maximum(b[3:6], b[9:12]) - np.minimum(b[:3], b[6:9]) + 1
        return {"state": {k: np.asarray(st[k]).tobytes() for k in ("x", "v", "F", "C", "Jp") if k in st},
                "share": float(np.prod(np.maximum(ext, 0))) / n_grid ** 3,
                "moved": float(np.abs(np.asarray(st["x"]) - s.x).max()), "cells": rec["cells"]}
    finally:
        eng.close()


def whole_grid(monkeypatch):
    from gasp_warp_mpm import cells
    monkeypatch.setattr(cells, "CELL_BOX", False)


def launched_early(monkeypatch):
    """Round 102's order: the cells' contact and clear before the grid update's box is built."""
    from gasp_warp_mpm import cells, engine, fields
    real = fields.field_launches

    def early(eng, Ft):
        if eng.fields:
            return real(eng, Ft)
        return cells.cell_launches(eng, Ft)[1] + fields.grid_box_launches(eng, Ft)
    monkeypatch.setattr(fields, "field_launches", early)
    monkeypatch.setattr(engine, "field_launches", early)


def check(case, monkeypatch) -> None:
    on = run(*case)
    assert 0.0 < on["share"] < 0.2 and on["moved"] > 0.05, (on["share"], on["moved"])   # a small box; it landed
    with monkeypatch.context() as m:
        whole_grid(m)
        off = run(*case)
    assert off["state"] == on["state"], case


@pytest.mark.parametrize("case", CASES, ids=lambda c: f"{c[0]}-{c[1]}-{c[2]}")
def test_the_cells_passes_over_the_box_keep_the_bits_over_the_family(case, monkeypatch):
    check(case, monkeypatch)


@pytest.mark.parametrize("case", [CASES[0], CASES[2]], ids=lambda c: f"{c[0]}-{c[1]}-{c[2]}")
def test_the_check_catches_the_contact_launched_before_the_box(case, monkeypatch):
    good = run(*case)
    launched_early(monkeypatch)
    assert run(*case)["state"] != good["state"], case
