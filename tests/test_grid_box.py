"""Round 64 (``docs/performance.md`` "Round 64: the grid update over the touched box"): warp_mpm's grid update over
the hull of the nodes P2G touched this substep and the last (``gasp_warp_mpm/grid_box.py``, ``GRID_BOX``) must not
change a bit. The points' positions and every node's ``grid_v`` after three frames are compared bit for bit with
``GRID_BOX = False`` (the whole grid, as before) on a family: a jelly falling onto a ground (and with AFLIP, and in f64), a rigid
block falling onto a ground, two jellies touching (two fields: the field passes' box), a sand block on a ground
(the particle contact's budgets), a jelly with passive points on it and far beyond it (they read ``grid_v`` and
``grid_m`` where no material point is), a cube in wind (``grid_g``). The catch: the box kernel fed positions one cell
off (its box one node layer short on one side) leaves P2G's last layer of nodes un-updated, which changes the bits.
Round 65 sweeps the box with held boxes and viscous materials too (``tests/test_held_box.py``).
"""
from __future__ import annotations

import numpy as np
import pytest

from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing import scenes_rigid3 as S

pytest.importorskip("warp")
BLOCK = ([-0.03, -0.03, 0.03], [0.03, 0.03, 0.07])


def _one(model: str, flip=None, sand: bool = False, n_grid: int = 24, precision=None):
    s = S._setup([BLOCK], (model,), [0.2, 0.0, -0.3], n_grid, 0.5, [None])
    if precision is not None:
        s.options["precision"] = precision
    if sand:
        s.materials = [Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)]
    if flip is not None:
        s.options["flip"] = flip
    return s


def _two():
    return S._setup([BLOCK, ([-0.10, -0.08, 0.0], [0.18, 0.08, 0.03])], ("elastic", "elastic"), [0.0, 0.0, -0.3], 24,
                    0.5, [None, None])


def _passive():
    """The falling jelly with passive points: 40 on its top face, 40 in a far corner of the domain (beyond the
    material's box)."""
    s = _one("elastic")
    rng = np.random.default_rng(3)
    lo, hi = np.asarray(s.domain_lo, float), np.asarray(s.domain_hi, float)
    top = np.c_[rng.uniform(-0.03, 0.03, (40, 2)), np.full(40, 0.07)]
    far = lo + (hi - lo) * rng.uniform(0.8, 0.9, (40, 3))
    s.x = np.concatenate([top, far, s.x])
    s.v = np.concatenate([np.zeros((80, 3)) + s.v[0], s.v])
    s.p_vol = np.concatenate([np.zeros(80), s.p_vol])
    s.body_id = np.concatenate([np.zeros(80, int), s.body_id])
    s.passive = np.r_[np.ones(80, bool), np.zeros(len(s.x) - 80, bool)]
    s.n_render = 80
    return s


def _wind():
    from gasp_core.testing.scenes_wind import _build_wind
    return _build_wind(get_engine("warp_mpm"))


SCENES = {
    "jelly_on_ground": lambda: _one("elastic"),
    "jelly_on_ground_aflip": lambda: _one("elastic", flip=0.95),
    "jelly_on_ground_f64": lambda: _one("elastic", precision="f64"),
    "rigid_on_ground": lambda: _one("rigid"),
    "sand_on_ground": lambda: _one("elastic", sand=True),
    "jelly_on_jelly": _two,
    "passive_points": _passive,
    "wind": _wind,
}


def run(s, frames: int = 3) -> dict:
    """warp_mpm's run of ``s``: the points (setup order) and ``grid_v`` (bytes), the grid update's box."""
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        for _ in range(frames):
            eng.step_frame()
        return {"x": eng.positions().tobytes(), "v": eng.grid_v.numpy().tobytes(), "box": eng.grid_box.numpy().copy(),
                "moved": float(np.abs(eng.positions() - s.x).max())}
    finally:
        eng.close()


def grid_box_off(monkeypatch):
    from gasp_warp_mpm import grid_box
    monkeypatch.setattr(grid_box, "GRID_BOX", False)


@pytest.mark.parametrize("case", list(SCENES))
def test_the_grid_box_keeps_the_bits(case, monkeypatch):
    on = run(SCENES[case]())
    ng, box = SCENES[case]().n_grid, on["box"]
    assert 0 <= box[:3].min() and box[3:6].max() <= ng - 1 and (box[3:6] >= box[:3]).all()   # a box, in the grid
    assert int(np.prod(box[3:6] - box[:3] + 1)) < ng ** 3 and on["moved"] > 0.0   # less than the grid; it moved
    grid_box_off(monkeypatch)
    off = run(SCENES[case]())
    assert off["box"].tolist() == [0, 0, 0, ng - 1, ng - 1, ng - 1] * 2
    assert on["x"] == off["x"] and on["v"] == off["v"]


def test_the_check_catches_a_box_one_node_short(monkeypatch):
    """The box kernel fed ``lo + dx`` (the points seen one cell lower): the box's highest layer of P2G's nodes left
    out of the grid update, which the check above sees."""
    from gasp_warp_mpm import fields, grid_box
    real = grid_box.grid_box_launches

    def short(eng, Ft):
        lo = eng.setup.domain_lo
        eng.setup.domain_lo = [float(c) + eng.dx for c in lo]
        try:
            return real(eng, Ft)
        finally:
            eng.setup.domain_lo = lo
    good = run(SCENES["jelly_on_ground"]())
    monkeypatch.setattr(fields, "grid_box_launches", short)
    bad = run(SCENES["jelly_on_ground"]())
    assert good["x"] != bad["x"] and good["v"] != bad["v"]


def test_a_held_box_keeps_the_box():
    """A ``fixed_region`` far from the block: round 65 (``tests/test_held_box.py``) sweeps the box there too
    (``grid_box.whole_grid_reasons`` empty; round 64 kept the whole grid)."""
    s = _one("elastic")
    s.boundaries = list(s.boundaries) + [Boundary("fixed_region", lo=(-0.2, -0.2, -0.2), hi=(-0.15, 0.2, 0.2))]
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        from gasp_warp_mpm.grid_box import whole_grid_reasons
        assert not whole_grid_reasons(eng) and eng.grid_box_own and eng.grid_box_held
    finally:
        eng.close()


@pytest.mark.parametrize("case", ["jelly_on_ground", "passive_points", "jelly_on_jelly"])
def test_the_strided_sweep_of_cuda_keeps_the_bits(case, monkeypatch):
    """CUDA's sweep of the grid update (``along`` 0: thread ``t`` the hull's nodes ``t, t + threads, ...``), run on
    the CPU with 4,096 threads: the same points and ``grid_v`` as the whole grid where no sum hangs on the nodes'
    order (the grid contact: no balance)."""
    from gasp_warp_mpm import engine, grid_box

    def strided(eng):
        grid_box.allocate_grid_box(eng)
        return [eng.grid_box, 4096, 0]
    monkeypatch.setattr(engine, "grid_sweep", strided)
    on = run(SCENES[case]())
    monkeypatch.undo()
    grid_box_off(monkeypatch)
    off = run(SCENES[case]())
    assert on["x"] == off["x"] and on["v"] == off["v"]
