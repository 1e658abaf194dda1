"""Where a tension specimen breaks, on synthetic layer data (``benchmarks/crack_place.py``; docs/fracture.md "Round
45: the step-started pull"): the crack's layer is a free one (never a point the scene holds), and of the free layers
tied at the most damage the first to reach it in time.

The synthetic bar is the step-started bar a0.30 at n_grid 48 as it was measured (``benchmarks/user_tension.py``): the
crack opens 1.2 cells past the clamp's face at frame 481 and the clamp's held layer beside it, whose damage mirrors
the crack's by design (the brittle held rule), reaches ``d = 1`` 85 frames later. The catches: the measure of before
(``argmax`` of the end damage over every layer, the first of the tied) names the held layer, inside the clamp, and
where two free layers tie the lower in x, not the first in time; the free layers read by the frame of ``d = 1`` alone
name the known case's other band layer (x 0.346, "gauge"), which trailed to every level up to 0.95.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import crack_layers as cl     # noqa: E402
import crack_place as cp      # noqa: E402
import tension_family as tf   # noqa: E402
import user_tension as ut     # noqa: E402

from gasp_core.colliders.model import Impulse   # noqa: E402
from gasp_core.seam.setup import Boundary       # noqa: E402

N_GRID, FRAMES = 48, 600
DX = tf.SIZE / N_GRID
H = DX / 4 ** (1 / 3)          # the fill's layer spacing at 4 points a cell


def old_crack_layer(dmean: np.ndarray, free: np.ndarray) -> int:
    """The measure of before: the most damaged layer at the end over every layer, the first of the tied."""
    return int(np.argmax(dmean[-1]))


def ramp(frame: int, level: float = 1.0) -> tuple[tuple, tuple]:
    """A layer's damage rising from 0 to ``level`` over the 10 frames up to ``frame``: (frames, levels)."""
    return (frame - 10, frame), (0.0, level)


#: the step-started bar a0.30 at n_grid 48 on warp_mpm (the frames at which its two free layers of
#: the crack band first reached d = 0, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.99, 0.999, 1, as measured)
LEVELS = (0.0, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.95, 0.99, 0.999, 1.0)
BAND = {0.330: ((481, 482, 487, 496, 509, 522, 542, 550, 560, 562, 563), LEVELS),
        0.346: ((482, 483, 487, 498, 511, 524, 543, 550, 557, 559, 559.5), LEVELS)}


def bar(breaks: dict[float, tuple[tuple, tuple]]) -> tuple[np.ndarray, dict, float, float]:
    """The synthetic bar a0.30 at n_grid 48: its layers' rest x ``lx`` (k,), a :func:`user_tension.record`-like
    ``rec`` whose layers nearest each x of ``breaks`` take their mean ``d`` piecewise linear through the given
    (frames, levels) (others stay at 0), the clamp's and the pulled faces (m). The points of a layer sit at its x;
    those in the clamp's ``fixed_region`` or the pulled set box are held."""
    sp = ut.USER[1]
    clamp, pulled = ut.faces(sp, N_GRID)
    lx = tf.X0 + (np.arange(int(sp.length / H)) + 0.5) * H
    k = len(lx)
    dmean = np.zeros((FRAMES, k))
    for x, (frames, levels) in breaks.items():
        dmean[:, int(np.argmin(np.abs(lx - x)))] = np.interp(np.arange(FRAMES), frames, levels)
    x0 = np.stack([lx, np.full(k, tf.Y0), np.full(k, tf.Y0)], axis=1)
    held = cp.held_points(x0, [Boundary("fixed_region", lo=(0, 0, 0), hi=(clamp, tf.SIZE, tf.SIZE))],
                          [Impulse("box", (tf.PULL, 0, 0), 0.0, 100.0, lo=(pulled, 0, 0),
                                      hi=(tf.SIZE, tf.SIZE, tf.SIZE), mode="set")])
    rec = {"force": np.zeros((FRAMES, k)), "pos": np.tile(lx, (FRAMES, 1)), "dmean": dmean,
           "thru": dmean.max(axis=1) >= 0.9, "vol": np.full(k, H * sp.gauge_w ** 2),
           "free": cp.free_layers(np.arange(k), held, k)}
    return lx, rec, clamp, pulled


def place(breaks: dict) -> dict:
    """:func:`user_tension.figures` on :func:`bar` with ``breaks``: ``crack_x`` and ``where``."""
    lx, rec, clamp, pulled = bar(breaks)
    return ut.figures(ut.USER[1], rec, lx, H, DX, clamp, pulled)


def nearest(x: float) -> float:
    lx = bar({})[0]
    return float(lx[np.argmin(np.abs(lx - x))])


#: (breaks: x -> (frame at its end level, level), the crack's x, where): the known case and its two sides
CASES = [
    ({**BAND, 0.267: ramp(566)}, 0.330, "held edge"),                   # the known case: the held layer ties later
    ({0.330: ramp(481), 0.267: ramp(400)}, 0.330, "held edge"),         # held first: still never named
    ({0.420: ramp(300), 0.550: ramp(250)}, 0.550, "gauge"),             # free tie: the first in time, higher x
    ({0.420: ramp(250), 0.550: ramp(300)}, 0.420, "gauge"),             # free tie: the first in time, lower x
    ({0.420: ramp(250, 0.6), 0.550: ramp(300, 0.8)}, 0.550, "gauge"),   # no tie: the most damaged, though later
    ({0.790: ramp(250), 0.820: ramp(200), 0.4: ramp(300)}, 0.790, "held edge"),   # the pulled box's side
]


@pytest.mark.parametrize("breaks, x, where", CASES)
def test_the_crack_is_the_free_layer_first_at_the_most_damage(breaks, x, where):
    r = place(breaks)
    assert r["crack_x"] == pytest.approx(nearest(x), abs=1e-12) and r["where"] == where, r


def test_the_check_catches_the_measure_of_before(monkeypatch):
    """The old measure names the held layer of the known case (x 0.267, inside the clamp: "held edge" by its
    distance to the face, though no free layer broke there) and the lower of two tied free layers."""
    monkeypatch.setattr(cp, "crack_layer", old_crack_layer)
    missed = [(x, r["crack_x"]) for breaks, x, _ in CASES if (r := place(breaks))["crack_x"] != nearest(x)]
    assert len(missed) >= 3 and missed[0] == (0.330, nearest(0.267)), missed


def test_the_check_catches_the_first_at_d_1_alone(monkeypatch):
    """Free layers only, but of the tied the first whose ``d`` reached 1: the known case's band reads x 0.346, 1.84
    cells past the clamp's face ("gauge"), where x 0.330 led it to every level up to 0.95."""
    def first_at_one(dmean, free):
        tied = np.flatnonzero(free & (dmean[-1] >= dmean[-1][free].max() - cp.TIE))
        return int(tied[np.argmin(np.argmax(dmean[:, tied] >= dmean[-1][tied] - cp.TIE, axis=0))])
    monkeypatch.setattr(cp, "crack_layer", first_at_one)
    r = place(CASES[0][0])
    assert (r["crack_x"], r["where"]) == (nearest(0.346), "gauge"), r


def test_the_oblique_zone_takes_the_same_layer():
    """``crack_layers.crack_zone`` (the oblique specimens') names the same layer, and its zone is free."""
    lx, rec, clamp, pulled = bar({0.420: ramp(300), 0.550: ramp(250)})
    crack, span = cl.crack_zone(rec["dmean"], lx, rec["free"], DX)
    assert lx[crack] == nearest(0.550) and rec["free"][span].all() and crack in span


def test_held_points_and_free_layers():
    """A layer with one held point is not free; a set box holds its points, an ``add`` box does not; no free layer
    is an error."""
    x0 = np.array([[0.1, 0.5, 0.5], [0.25, 0.5, 0.5], [0.31, 0.5, 0.5], [0.9, 0.5, 0.5], [0.5, 0.5, 0.5]])
    clamp = [Boundary("fixed_region", lo=(0, 0, 0), hi=(0.25, 1, 1))]
    box = dict(lo=(0.8, 0, 0), hi=(1, 1, 1))
    held = cp.held_points(x0, clamp, [Impulse("box", (1, 0, 0), 0, 1, mode="set", **box)])
    assert held.tolist() == [True, True, False, True, False]
    assert cp.held_points(x0, clamp, [Impulse("box", (1, 0, 0), 0, 1, mode="add", **box)])[3] == False  # noqa
    assert cp.free_layers(np.array([0, 1, 1, 2, -1]), held, 4).tolist() == [False, False, False, False]
    assert cp.free_layers(np.array([0, 1, 2, 3, 2]), held, 4).tolist() == [False, False, True, False]
    with pytest.raises(ValueError, match="no free layer"):
        cp.crack_layer(np.ones((3, 4)), np.zeros(4, bool))
