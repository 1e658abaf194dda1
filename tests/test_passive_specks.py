"""Passive surface points away from the material (issue 66, "What a user sees": no speck away from every piece;
round 37, docs/fracture.md "Round 37").

The measure (default tier): :func:`gasp_core.testing.specks.count_specks` on a known layout (a slab of material
points, passive points at 0.5, 0.9, 1.1 and 3 spacings above it, and one below) counts the two past the reach and
reports the farthest; its catch, a count that ignores the reach (every passive point a speck), fails it.

The must-show (slow tier, a strict xfail on both engines): the oblique 1.5:1 dog-bone at 45 deg, n_grid 48, pulled
by a ramped set box (``benchmarks/passive_specks.py``, ``user_oblique``'s scene): at most ``OBLIQUE_SPECKS`` passive
points further than 1 ``dx`` from every material point at any frame, none further than ``OBLIQUE_FAR`` dx. Measured
with the engines' gather 138 and 33.8 dx on both (the material's bursts by the set box at nodes of tiny mass fling
its vertices); the gather weighted by mass with its mean at the weights' centroid meets it (9 and 1.39 dx) but biases
a surface point towards the material's centroid (the conformance ``passive_spin`` skin shrinks 0.65 % in a turn,
limit 0.06 %), and read at the point it does not (118 and 30.6 dx): neither was adopted.
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.testing import specks

#: The must-show on the oblique dog-bone: the most specks at a frame and the farthest passive point (dx)
OBLIQUE_SPECKS, OBLIQUE_FAR = 20, 2.0
SPACING = 0.01   # m: the layout's material spacing


def layout() -> tuple[np.ndarray, np.ndarray]:
    """A 10 x 10 slab of material points at z = 0 (spacing :data:`SPACING`) and 5 passive points over its middle at
    heights 0.5, 0.9, 1.1, 3 and -2 spacings: positions (n, 3; m) and the passive mask (n,)."""
    g = np.arange(10) * SPACING
    mat = np.stack(np.meshgrid(g, g, [0.0], indexing="ij"), -1).reshape(-1, 3)
    mid = np.array([0.04, 0.04, 0.0])
    pas = mid + np.outer([0.5, 0.9, 1.1, 3.0, -2.0], [0.0, 0.0, SPACING]) + np.array([0.005, 0.005, 0.0])
    x = np.concatenate([pas, mat])
    return x, np.arange(len(x)) < len(pas)


def layout_failures(count=specks.count_specks) -> list[str]:
    """The layout counted at the reach 1.5 spacings: want the 2 passive points at 3 and -2 spacings off (the
    centre of a cell of the slab sits 0.71 spacings from its corners), the farthest sqrt(0.5 + 9) spacings."""
    x, passive = layout()
    n, far = count(x, passive, 1.5 * SPACING)
    want_far = np.sqrt(0.5 + 9.0) * SPACING
    out = []
    if n != 2:
        out.append(f"{n} specks, want 2")
    if abs(far - want_far) > 1e-9:
        out.append(f"farthest {far:.6f} m, want {want_far:.6f}")
    return out


def test_the_speck_count_finds_the_points_past_the_reach_on_a_known_layout():
    assert layout_failures() == []


def test_catch_a_count_that_ignores_the_reach_fails_the_layout():
    def every_point(x, passive, reach):
        n, far = specks.count_specks(x, passive, reach)
        return int(np.sum(passive)), far
    assert layout_failures(every_point) == ["5 specks, want 2"]


def _engines():
    from gasp_core.seam.plugins import engines
    return [n for n, i in engines().items() if i.unavailable_reason() is None and n in ("taichi_mpm", "warp_mpm")]


def oblique_failures(name: str) -> list[str]:
    """The must-show on the oblique dog-bone (1125 frames, about 100 s an engine)."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import passive_specks as ps
    r = specks.speck_run(name, ps.oblique_setup(name), ps.OBLIQUE_FRAMES)
    far = max(r["farthest"]) / r["dx"]
    out = []
    if max(r["specks"]) > OBLIQUE_SPECKS:
        out.append(f"oblique dog-bone: {max(r['specks'])} specks at frame {int(np.argmax(r['specks']))}")
    if far > OBLIQUE_FAR:
        out.append(f"oblique dog-bone: a passive point {far:.2f} dx from the material")
    return out


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="measured 138 specks, one 33.8 dx off, on both engines (docs/fracture.md "
                                       "\"Round 37\"): the set box's material bursts fling the vertices")
@pytest.mark.parametrize("name", _engines())
def test_the_pulled_oblique_dog_bone_leaves_no_speck(name):
    assert oblique_failures(name) == []
