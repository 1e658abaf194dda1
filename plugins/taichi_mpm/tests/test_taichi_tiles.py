"""The tiled P2G of the GPU schedule on CUDA (issue 65, :mod:`gasp_taichi_mpm.schedule.tiles`), tested on ``ti.cpu``.

Its shared-memory kernel runs on CUDA only (``benchmarks/gpu_checks.py`` compares it there with the atomic P2G); what
it calls is checked here: the block keys, the two-level scan and the placement against NumPy, and the tiles' per-point
scatter and flush, run one tile at a time into a field standing for the shared array, against the atomic P2G's grid
on the same state, over a family of scenes (viscous with the contact's channels, two bodies with walls, sand).
"""
import numpy as np
import pytest

ti = pytest.importorskip("taichi")

from test_taichi_mpm import build  # noqa: E402
from test_taichi_schedule import FAMILY  # noqa: E402

from gasp_taichi_mpm.schedule import tiles  # noqa: E402

pytestmark = pytest.mark.filterwarnings("ignore:.*non-taichi function")

SCENES = ("viscous_on_ground", "two_bodies_walls", "sand_column")


@ti.kernel
def _tiles_one_at_a_time(s: ti.template(), pad: ti.template()):
    """The tiled P2G with the tiles in turn on one thread, ``pad`` standing for each tile's shared array."""
    for _ in range(1):
        for t in range(s.t_n_active[None]):
            key = s.t_active[t]
            o = s.tile_origin(key)
            for q in range(pad.shape[0]):
                pad[q] = 0.0
            for k in range(s.t_lo[key], s.t_lo[key] + s.t_count[key]):
                s.tile_point(s.t_order[k], o, pad)
            for q in range(tiles.TILE ** 3):
                s.tile_flush(o, q, pad)


def _fields(s):
    """The point state a G2P writes: ``x, v, C, F, Jp``, and the trapezoid's last gradient ``C_prev`` where the
    solver has it (``stress_at = "trapezoid"``, the default since round 70: a reference that did not put it back
    fed the tiles' G2P the atomic one's gradient, 3e-3 of the momentum apart; round 78)."""
    return (s.x, s.v, s.C, s.F, s.Jp) + ((s.C_prev,) if s.trap_stress else ())


def _state(s):
    return [f.to_numpy() for f in _fields(s)]


def _restore(s, saved):
    for f, a in zip(_fields(s), saved):
        f.from_numpy(a)


def _atomic_grid(s):
    """``grid_mv`` after one fused G2P + atomic P2G from the solver's state, the state then put back and the grid
    cleared."""
    saved = _state(s)
    s.grid_mv.fill(0)
    s.g2p_p2g(1)
    atomic = s.grid_mv.to_numpy()[0]
    _restore(s, saved)
    s.grid_mv.fill(0)
    return atomic


def _tolerance(atomic):
    """Per channel, f32 rounding of the same terms summed in another order: 1e-5 of its largest node value."""
    return 1e-5 * np.abs(atomic).max(axis=(0, 1, 2)) + 1e-30


def _both_p2gs(name):
    """After two frames of FAMILY[name] on the GPU schedule: grid_mv after one fused G2P + P2G, atomic and tiled, from
    the same state; and the solver."""
    e = build(FAMILY[name]("gpu"))
    for _ in range(2):
        e.step_frame()
    s = e.solver
    s.allocate_tiles()
    atomic = _atomic_grid(s)
    s.g2p_keys(1)
    s.scan_keys()
    pad = ti.field(s.real, shape=tiles.TILE ** 3 * s.acc_width)
    _tiles_one_at_a_time(s, pad)
    return atomic, s.grid_mv.to_numpy()[0], s


@pytest.mark.parametrize("name", SCENES)
def test_the_sort_and_scan_give_numpys_block_order(name):
    """Every awake point filed under the block of its stencil base, each block's first slot the counts' exclusive
    cumulative sum, the non-empty blocks listed in key order, the points placed by block."""
    _a, _t, s = _both_p2gs(name)
    n = s.n_points[None]
    x = s.x.to_numpy()[:n].astype(np.float64)
    base = np.floor((x - s.lo[None].to_numpy()) * float(s.inv_dx[None]) - 0.5).astype(int)
    b = np.clip(base, 0, s.n_grid - 1) // tiles.TILE_BLOCK
    key = (b[:, 0] * s.nb_tile + b[:, 1]) * s.nb_tile + b[:, 2]
    counts = np.bincount(key, minlength=s.n_tile_keys)
    assert np.array_equal(s.t_key.to_numpy()[:n], key)
    assert np.array_equal(s.t_count.to_numpy(), counts)
    assert np.array_equal(s.t_lo.to_numpy(), np.r_[0, np.cumsum(counts)[:-1]])
    active = np.flatnonzero(counts)
    assert s.t_n_active[None] == len(active) and np.array_equal(s.t_active.to_numpy()[:len(active)], active)
    order = s.t_order.to_numpy()[:n]
    assert np.array_equal(np.sort(order), np.arange(n))
    assert np.array_equal(key[order], np.sort(key))


@pytest.mark.parametrize("name", SCENES)
def test_the_tiles_give_the_atomic_grid(name):
    """Every channel of every node (momentum, mass, and the viscous and contact channels where the scene has them)
    within f32 rounding of the atomic P2G's (the same terms summed in another order)."""
    atomic, tiled, s = _both_p2gs(name)
    assert atomic[..., 3].sum() > 0 and s.t_n_active[None] > 1
    assert np.all(np.abs(tiled - atomic).max(axis=(0, 1, 2)) <= _tolerance(atomic))


def test_the_check_catches_a_tile_that_swaps_two_axes(monkeypatch):
    """A tiled scatter that files node (i, j, k) of a point's stencil under (k, j, i) of its tile is caught."""
    real = tiles.TileP2G.tile_point

    @ti.func
    def swapped(self, p, o, pad: ti.template()):
        base, fx, ok = self.base_fx(self.x[p])
        if ok and (base >= o).all() and (base < o + tiles.TILE_BLOCK).all():
            mv0, A, S, m, jvec, eta_v, budget = self.p2g_prep(p, base, fx)
            w = self.weights(fx)
            r = base - o
            for i, j, k in ti.static(ti.ndrange(3, 3, 3)):
                val = (w[i][0] * w[j][1] * w[k][2]) * self.node_val(i, j, k, fx, mv0, A, S, m, jvec, eta_v, budget)
                q = (((r[2] + k) * tiles.TILE + r[1] + j) * tiles.TILE + r[0] + i) * self.acc_width
                for c in ti.static(range(self.acc_width)):
                    ti.atomic_add(pad[q + c], val[c])
        else:
            self.p2g_point(p, 0, ti.Vector([0, 0, 0]), ti.Vector([0, 0, 0]))

    monkeypatch.setattr(tiles.TileP2G, "tile_point", swapped)
    atomic, tiled, _s = _both_p2gs("two_bodies_walls")
    assert real is not swapped
    assert np.any(np.abs(tiled - atomic).max(axis=(0, 1, 2)) > _tolerance(atomic))


@pytest.mark.parametrize("name", SCENES[:2])
def test_tiles_between_sorts_give_the_atomic_grid(name):
    """``tile_sort_every > 1``: the tiles on an earlier sort's lists, after the points moved (by 1.5 dx along x, so
    that many leave their block), give the atomic P2G's grid: those points take the atomic path."""
    e = build(FAMILY[name]("gpu"))
    for _ in range(2):
        e.step_frame()
    s = e.solver
    s.allocate_tiles(4)
    s.g2p_keys(1)
    s.scan_keys()
    n = s.n_points[None]
    x = s.x.to_numpy()
    x[:n, 0] += 1.5 * float(s.dx[None])
    s.x.from_numpy(x)
    sorted_keys = s.t_key.to_numpy()[:n]
    atomic = _atomic_grid(s)
    s.g2p_awake()
    x = s.x.to_numpy()[:n].astype(np.float64)
    b = np.clip(np.floor((x - s.lo[None].to_numpy()) * float(s.inv_dx[None]) - 0.5).astype(int), 0, s.n_grid - 1)
    b //= tiles.TILE_BLOCK
    moved = np.count_nonzero((b[:, 0] * s.nb_tile + b[:, 1]) * s.nb_tile + b[:, 2] != sorted_keys)
    pad = ti.field(s.real, shape=tiles.TILE ** 3 * s.acc_width)
    _tiles_one_at_a_time(s, pad)
    tiled = s.grid_mv.to_numpy()[0]
    assert moved > 0
    assert np.all(np.abs(tiled - atomic).max(axis=(0, 1, 2)) <= _tolerance(atomic))
