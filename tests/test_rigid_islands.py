"""Round 81: the GPU schedules solve the touching pairs of rigid bodies island by island
(``gasp_core.mpm.rigid_pairs.ISLANDS``, taichi_mpm's ``RigidPairs.rigid_pairs_gpu``, warp_mpm's
``build_rigid_pairs_gpu``), which must give the bits of the one-thread solve (``docs/performance.md`` "Round 81").

- The NumPy reference: :func:`rigid_pairs.islands` joins bodies through later pairs, and sweeping each island alone
  gives :func:`rigid_pairs.solve_pairs`'s velocities on a random pile.
- Both engines, the GPU schedule run on the CPU on one thread (its bits repeat there): a heap of 2 x 2 columns of 3
  rigid blocks (``scenes_rigid3.heap_setup``, 4 islands) gives the same positions and velocities after 3 frames with
  the islands and with the one-thread solve; a broken island kernel gives others, so the comparison bites (warp_mpm:
  every pair an island of its own, ``rigid_islands_broken``; taichi_mpm: a union-find that hands out a new root at
  each call). Either way a body's pairs are swept one after the other instead of in turn.
"""
import hashlib

import numpy as np
import pytest
import taichi as ti

from gasp_core.mpm import rigid_pairs
from gasp_core.seam.plugins import engines


def test_islands_join_bodies_through_later_pairs():
    """Pairs (0,1), (2,3), (1,4), (5,6), (3,0): the first four bodies meet only through the last pair."""
    assert rigid_pairs.islands([(0, 1), (2, 3), (1, 4), (5, 6), (3, 0)], 7) == [[0, 1, 2, 4], [3]]
    assert rigid_pairs.islands([], 3) == []
    with pytest.raises(ValueError, match=r"\[0, 3\)"):
        rigid_pairs.islands([(0, 3)], 3)


def _random_pile(seed: int, groups: int = 3, per: int = 4, pairs: int = 5):
    """``groups`` groups of ``per`` bodies, ``pairs`` random touching pairs within each group, shuffled together."""
    rng = np.random.default_rng(seed)
    nb = groups * per
    bodies = []
    for _ in range(nb):
        bodies.append((rng.normal(size=3), rng.normal(size=3), np.diag(rng.uniform(0.01, 0.05, 3)),
                       float(rng.uniform(0.5, 3.0)), rng.normal(size=3) * 0.1))
    contacts = []
    for k in range(groups * pairs):
        a, b = k // pairs * per + rng.choice(per, 2, replace=False)
        n = rng.normal(size=3)
        contacts.append((int(a), int(b), rng.normal(size=3) * 0.1, n / np.linalg.norm(n), float(rng.uniform(0.2, 0.8))))
    rng.shuffle(contacts)
    return bodies, contacts


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sweeping_each_island_alone_is_the_sweep_over_all(seed):
    """The reference solve on a random pile of 12 bodies in 3 groups, 15 pairs, all at once and island by island."""
    bodies, contacts = _random_pile(seed)
    g = [0.0, 0.0, -9.81]
    whole, P = rigid_pairs.solve_pairs(bodies, contacts, g)
    order = sorted(range(len(contacts)), key=lambda k: float(-np.dot(g, contacts[k][2])))
    isl = rigid_pairs.islands([contacts[k][:2] for k in order], len(bodies))
    assert len(isl) >= 2   # the pile falls apart into islands, or the check shows nothing
    parts = [None] * len(bodies)
    for members in isl:
        sub = [contacts[order[q]] for q in members]
        used = sorted({b for c in sub for b in c[:2]})
        local = {b: i for i, b in enumerate(used)}
        out, _ = rigid_pairs.solve_pairs([bodies[b] for b in used],
                                         [(local[a], local[b], *rest) for a, b, *rest in sub], g)
        for b, vw in zip(used, out):
            parts[b] = vw
    for b, (V, w) in enumerate(whole):
        if parts[b] is None:   # in no pair: untouched
            parts[b] = (bodies[b][0], bodies[b][1])
        assert np.array_equal(parts[b][0], V) and np.array_equal(parts[b][1], w), b


# ---------------------------------------------------------------- the engines' island kernels
@ti.func
def _new_root(self, x):
    """A broken ``RigidPairs.pair_find``: a new root at each call (a counter in the spare last entry of
    ``pair_isl_fill``, modulo the bodies), so the pairs of one body fall into islands of their own."""
    return ti.atomic_add(self.pair_isl_fill[self.n_bodies], 1) % self.n_bodies


def _broken_warp_islands(monkeypatch):
    """warp_mpm's ``build_rigid_pairs_gpu`` with its ``islands`` kernel replaced by ``rigid_islands_broken``'s."""
    from gasp_warp_mpm import rigid_islands as wrp
    import rigid_islands_broken as broken
    real = wrp.build_rigid_pairs_gpu

    def build(Ft):
        prep, bodies, rank, _islands, sweep, advance, clear = real(Ft)
        return prep, bodies, rank, broken.lone_pairs, sweep, advance, clear
    monkeypatch.setattr(wrp, "build_rigid_pairs_gpu", build)


def _heap_bits(engine: str, kept: list, frames: int = 3) -> str:
    """The sha1 of the heap's positions and velocities after ``frames`` frames; the engine is kept in ``kept`` (open:
    Taichi reuses a kernel compiled for an earlier engine at the same address, and the broken variant must compile
    its own)."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing.scenes_rigid3 import heap_setup
    s = heap_setup(48, 2, 3)
    s.options = {**(s.options or {}), "schedule": "gpu", "threads": 1}
    e = build_engine(get_engine(engine), s)
    kept.append(e)
    for _ in range(frames):
        e.step_frame()
    x, v = np.ascontiguousarray(e.positions()), np.ascontiguousarray(e.velocities())
    return hashlib.sha1(x.tobytes() + v.tobytes()).hexdigest()


ENGINES = [e for e in ("taichi_mpm", "warp_mpm") if e in engines()]


@pytest.mark.parametrize("engine", ENGINES)
def test_the_islands_give_the_bits_of_the_one_thread_solve(engine, monkeypatch):
    """The heap's bits with the islands, with the one-thread solve, and with a broken island kernel."""
    kept: list = []
    monkeypatch.setattr(rigid_pairs, "ISLANDS", True)
    islands = _heap_bits(engine, kept)
    monkeypatch.setattr(rigid_pairs, "ISLANDS", False)
    serial = _heap_bits(engine, kept)
    assert islands == serial
    monkeypatch.setattr(rigid_pairs, "ISLANDS", True)
    if engine == "taichi_mpm":
        from gasp_taichi_mpm.rigid_pairs import RigidPairs
        monkeypatch.setattr(RigidPairs, "pair_find", _new_root)
    else:
        _broken_warp_islands(monkeypatch)
    try:
        assert _heap_bits(engine, kept) != serial
    finally:
        for e in kept:
            e.close()
