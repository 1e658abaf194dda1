"""The studio's click on a dynamic model (:mod:`gasp_core.studio.pieces`), on a scene with a known answer: a heap
of leaves stirred on a still pan floor, its inner leaves still, and a hand moving 30 cm away."""
import itertools

import numpy as np

from gasp_core.studio.pieces import TAU_FACTOR, motion_pick, moving_pieces

N_HEAP, N_HAND = 2000, 400


def scene(seed=0):
    """``(means, dv, heap, floor, hand)``: an 80 x 80 cm floor of 6,400 still Gaussians 1 cm apart at z = 0; on it
    a heap (2,000 Gaussians drawn uniformly in a half ball of radius 5 cm) whose outer 2 cm move 3 cm and whose core
    moves 0.2 mm; a hand (400 Gaussians in a 3 cm cube, moving 5 cm) 30 cm from the heap. Displacements in metres."""
    rng = np.random.default_rng(seed)
    g = np.arange(-0.4, 0.4, 0.01)
    floor = np.c_[np.stack(np.meshgrid(g, g), -1).reshape(-1, 2), np.zeros(len(g) ** 2)]
    d = rng.normal(size=(N_HEAP, 3))
    d[:, 2] = np.abs(d[:, 2])
    r = 0.05 * rng.uniform(0, 1, N_HEAP) ** (1 / 3)
    heap = d / np.linalg.norm(d, axis=1)[:, None] * r[:, None] + [0, 0, 0.005]
    hand = rng.uniform(0, 0.03, (N_HAND, 3)) + [0.3, 0.0, 0.07]
    means = np.vstack([floor, heap, hand])
    dv = np.r_[np.full(len(floor), 1e-4), np.where(r > 0.03, 0.03, 2e-4), np.full(len(hand), 0.05)]
    floor_rows, heap_rows, hand_rows = (np.arange(a, b) for a, b in itertools.pairwise(
        np.cumsum([0, len(floor), len(heap), len(hand)])))
    return means, dv, heap_rows, floor_rows, hand_rows


def test_a_click_on_the_heap_takes_the_heap_with_its_still_core_and_not_the_floor():
    means, dv, heap, floor, hand = scene()
    mp = moving_pieces(means, dv)
    assert mp.tau == TAU_FACTOR * 1e-4 and set(mp.rows) == set(heap[dv[heap] > 0.01]) | set(hand)
    top = heap[np.argmax(means[heap, 2])]
    sel = motion_pick(means, int(top), mp)
    core = heap[dv[heap] < 0.01]
    assert sel[heap].mean() > 0.9 and sel[core].mean() > 0.85          # the still core inside the moving shell
    assert sel[floor].sum() <= 0.02 * len(floor) and not sel[hand].any()
    # the floor's Gaussians the hull takes lie under the heap (within its radius), none beyond it
    assert np.all(np.hypot(*means[floor[sel[floor]], :2].T) < 0.055)


def test_a_click_inside_the_heap_a_hand_and_the_bare_floor():
    means, dv, heap, floor, hand = scene()
    mp = moving_pieces(means, dv)
    core = heap[dv[heap] < 0.01]
    deep = core[np.argmin(np.linalg.norm(means[core] - [0, 0, 0.02], axis=1))]
    assert motion_pick(means, int(deep), mp)[heap].mean() > 0.9                   # held by the shell's hull
    sel = motion_pick(means, int(hand[0]), mp)
    assert sel[hand].all() and not sel[heap].any()
    far = floor[np.argmin(np.linalg.norm(means[floor] - [-0.15, -0.15, 0], axis=1))]
    assert motion_pick(means, int(far), mp) is None          # the studio falls back to the connected piece


def test_a_still_model_has_no_moving_pieces():
    means, dv, *_ = scene()
    assert moving_pieces(means, np.full(len(dv), 1e-3)) is None
