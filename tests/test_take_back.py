"""The balance's take-back bound on a patch that is not flat (``gasp_core.mpm.take_back``, round 86): the NumPy
reference on patches with known answers, and warp_mpm's kernel function against it.

Known answers: an affine field of heights has no departure from its plane (``f = 0``), whatever the plane's tilt;
a checkerboard of heights ``+-d`` on an even lattice is orthogonal to every plane, so ``rho^2 = d^2 n / (n - 3)``
exactly; three points always lie in a plane (``f = 1``, unresolved); collinear points are an edge (``f = 0``).
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.mpm.contact import JSUMS, SKIN
from gasp_core.mpm.take_back import unresolved_fraction

H = 0.0125


def lattice(k: int = 8, tilt_deg: float = 3.0, heights=None):
    """A k x k patch at spacing H on a plane turned ``tilt_deg`` about y, its normal turned with it; optional extra
    heights (m) along that normal."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    t = np.radians(tilt_deg)
    e1, e2, n = np.array([np.cos(t), 0.0, -np.sin(t)]), np.array([0.0, 1.0, 0.0]), np.array([np.sin(t), 0.0,
                                                                                              np.cos(t)])
    x = (i.reshape(-1, 1) * e1 + j.reshape(-1, 1) * e2) * H + np.array([0.3, 0.2, 0.1])
    if heights is not None:
        x = x + np.asarray(heights).reshape(-1, 1) * n
    return x, n, (i + j).reshape(-1)


def test_a_flat_patch_is_resolved_whatever_its_tilt_and_load():
    for tilt in (0.0, 3.0, 30.0):
        x, n, _ = lattice(tilt_deg=tilt)
        j = 1.0 + (x - x.mean(axis=0)) @ np.array([8.0, -4.0, 2.0])   # an affine pressure, 0.4 to 1.6
        assert j.min() > 0.0
        # f64 roundoff of the second moments about the origin, 0.3 m away: about 1e-6
        assert unresolved_fraction(j, x, n, H) < 1e-5


def test_a_checkerboard_of_heights_gives_its_closed_form():
    d = 0.1 * SKIN * H
    for k in (6, 8):
        _, _, parity = lattice(k)
        x, n, _ = lattice(k, heights=np.where(parity % 2 == 0, d, -d))
        ne = k * k
        want = np.sqrt(12.0 * d * d * ne / (ne - 3.0)) / (SKIN * H)
        assert unresolved_fraction(np.ones(len(x)), x, n, H) == pytest.approx(want, rel=1e-9)


def test_heights_spread_over_the_skin_resolve_nothing():
    rng = np.random.default_rng(86)
    x, n, _ = lattice(heights=rng.uniform(-0.5, 0.5, 64) * SKIN * H)
    assert unresolved_fraction(np.ones(len(x)), x, n, H) > 0.85


def test_three_points_are_unresolved_and_a_row_is_an_edge():
    x, n, _ = lattice()
    assert unresolved_fraction(np.ones(3), x[[0, 9, 20]], n, H) == 1.0
    assert unresolved_fraction(np.ones(8), x[:8], n, H) == 0.0
    assert unresolved_fraction(np.zeros(4), x[:4], n, H) == 1.0   # no impulse: the bound as it was


def test_the_warp_kernel_spells_the_reference():
    pytest.importorskip("gasp_warp_mpm")
    from take_back_kernel import fractions
    rng = np.random.default_rng(7)
    rows, want = [], []
    for heights, jw in ((None, None), (rng.uniform(-0.5, 0.5, 64) * SKIN * H, rng.uniform(0.5, 1.5, 64)),
                        (0.05 * SKIN * H * np.where(lattice()[2] % 2 == 0, 1.0, -1.0), None)):
        x, n, _ = lattice(heights=heights)
        j = np.ones(len(x)) if jw is None else jw
        row = np.zeros(len(JSUMS))
        row[0], row[1:4] = j.sum(), j @ x
        second = np.einsum("i,ij,ik->jk", j, x, x)
        row[20:26] = second[0, 0], second[0, 1], second[0, 2], second[1, 1], second[1, 2], second[2, 2]
        row[26] = (j * j).sum()
        rows.append(row)
        want.append((n, unresolved_fraction(j, x, n, H)))
    got = fractions(np.array(rows), np.array([w[0] for w in want]), H)
    assert got == pytest.approx([w[1] for w in want], abs=1e-9)
