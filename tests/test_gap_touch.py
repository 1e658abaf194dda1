"""Round 60's touch by geometry (``gasp_core.mpm.gap_touch``, ``docs/contact.md`` "Round 60: a touch by geometry"):
its NumPy reference marks two flat lattices that touch or lie within the separation, and not two a cell apart,
wherever the face lies in its cell; the level is the half-space integral's, and the switch picks the scenes.

Two slabs of points at dx / 2 (the lower one, field B, below z = c; the upper one, field A, from c + gap), their
volumes scattered with the quadratic B-spline as P2G does, marked by :func:`gap_marks` at their bodies' levels
(:func:`gap_levels` of a two-body scene): some node marked at gap 0 and at half the separation, none at 1 dx and at
twice the separation (the rule before marked across a 0.53 dx gap: ``tests/test_contact_fine_step.py``)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import gasp_core.mpm.fields as F
import gasp_core.mpm.gap_touch as G
from gasp_core.testing.scenes_pairs import _build_stack

NG, DX = 12, 1.0


def _scatter(x: np.ndarray, vol: float) -> np.ndarray:
    """The node volumes (NG, NG, NG) of points ``x`` (n, 3), each ``vol``: P2G's quadratic B-spline scatter."""
    out = np.zeros((NG,) * 3)
    base = np.floor(x / DX - 0.5).astype(int)
    fx = x / DX - base
    w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
    for i in range(3):
        for j in range(3):
            for k in range(3):
                np.add.at(out, (base[:, 0] + i, base[:, 1] + j, base[:, 2] + k),
                          vol * w[i][:, 0] * w[j][:, 1] * w[k][:, 2])
    return out


def _marked(gap_cells: float, face: float) -> bool:
    s = DX / 2
    g = np.arange(2.0, NG - 2.0, s) + s / 2
    xy = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    c = 5.0 + face
    zb = np.arange(c - 2.0, c - 1e-9, s) + s / 2
    za = np.arange(c + gap_cells, c + gap_cells + 2.0 - 1e-9, s) + s / 2
    xb = np.array([[u, v, z] for u, v in xy for z in zb])
    xa = np.array([[u, v, z] for u, v in xy for z in za])
    vf = np.stack([_scatter(xa, s ** 3), _scatter(xb, s ** 3)])
    level = G.flow_touch_level(round((0.5 + G.SEPARATION) * s / DX, 3))
    x = np.vstack([xa, xb])
    in_a = np.r_[np.ones(len(xa), bool), np.zeros(len(xb), bool)]
    return bool(G.gap_marks(x, in_a, vf, np.zeros(3), DX, np.full(len(x), level)).any())


@pytest.mark.parametrize("face", [0.0, 0.3, 0.5, 0.8])
def test_touching_lattices_are_marked_and_separated_ones_are_not(face):
    eps = G.SEPARATION * DX / 2
    assert _marked(0.0, face) and _marked(0.5 * eps, face)
    assert not _marked(2.0 * eps, face) and not _marked(1.0, face)


def test_the_levels_are_the_half_space_integrals_and_the_switch_picks_the_pairs(monkeypatch):
    s = _build_stack(None)
    lv = G.gap_levels(s)
    assert lv is not None and lv.shape == (2,)
    d = G.body_delta(s)
    assert d[0] == pytest.approx(0.5, abs=0.02)                          # points about dx / 2 apart: 1 spacing
    assert lv[0] == pytest.approx(F.flow_touch_level(float(d[0])), abs=1e-12)
    assert F.flow_touch_level(0.5) < lv[0] < F.flow_touch_level(0.25)   # outside the face, less than a cell
    assert F.field_setup(s)[-1] == pytest.approx(lv)
    assert F.field_setup(dataclasses.replace(s, options={"contact_fields": False}))[0] is None   # one field
    monkeypatch.setattr(F, "GAP_TOUCH", False)
    assert F.field_setup(s)[-1] is None
