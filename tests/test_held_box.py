"""Round 65 (``docs/performance.md`` "Round 65: the held boxes over the touched box"): with held boxes (a
``fixed_region``, a box impulse of ``mode = "set"``) warp_mpm's grid update and its held passes (the broken faces'
clear, the brittle held rule's face nodes, the mirror) sweep the grid update's box (the hull of the nodes P2G touched
this substep and the last, stretched to a domain edge it comes within ``HELD_REACH`` nodes of;
``gasp_warp_mpm/grid_box.py``), not the whole grid, and must not change a bit of what is read. Compared bit for bit
with ``grid_box.HELD_BOX = False`` (the whole grid, round 64's): the points' ``x, v, F, C, Jp`` and ``grid_m`` at
every node, ``grid_v`` at every node outside the held boxes and every node of the box (a held box's nodes outside it
hold values no kernel reads: the module notes), after a run, on a family: a straight bar and a dog-bone of
``benchmarks/tension_family.py`` (brittle, held by a fixed region and pulled by a set box: the broken faces' marks and
the held rule's face nodes run; f64, and the bar in f32), an elastic block held by a fixed region under gravity, a
set box that starts and stops mid-run on a free block, a block held by a fixed region at the domain's wall (its
ghosts' images at the wall's nodes, outside P2G's hull), and two viscous bodies (``tests/test_viscous_bodies.py``'s,
both schedules, f32 and f64: the implicit step writes only at nodes with mass; its lists and labels over its own
box, ``viscosity.ImplicitViscosity.box``); and CUDA's strided order run on the
CPU.

The catches: the box kernel fed positions one cell off (the box one node layer short) changes the bits of the bar and
of the viscous bodies, and so does the viscous step's own box (its lists and labels) one node short. Two safeguards of the proof change no bit of the family when taken out (their cases read
zeros here; module notes): the stretch to a wall (``test_the_box_reaches_the_wall_it_nears``) and the whole grid where
a fixed region comes within ``HELD_REACH`` cells of another held box.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.setup import Boundary
from gasp_core.testing import scenes_rigid3 as S

pytest.importorskip("warp")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import tension_family as tf   # noqa: E402

DX24 = S.SIDE / 24


def _specimen(name: str, precision: str = "f64"):
    sp = tf.FAMILY[1] if name == "bar" else next(s for s in tf.FAMILY if s.gauge_l > 0)
    s = tf.build(sp, 24, "warp_mpm")[0]
    s.options["precision"] = precision
    return s


def _held_block(at_wall: bool = False, precision=None):
    """A 14 x 6 x 6 cm jelly block under gravity, its first 4 cm held by a fixed region: away from the walls, or
    (``at_wall``) starting 2.5 cells from the domain's -x wall, the region from that wall (its ghosts near the wall
    read their mirror images at the wall's first nodes)."""
    x0 = -0.20 + 2.5 * DX24 if at_wall else -0.08
    s = S._setup([([x0, -0.03, 0.10], [x0 + 0.14, 0.03, 0.16])], ("elastic",), [0.0, 0.0, 0.0], 24, None, [None])
    lo = (-0.20, -0.10, 0.05) if at_wall else (x0 - 0.02, -0.10, 0.05)
    s.boundaries = list(s.boundaries) + [Boundary("fixed_region", lo=lo, hi=(x0 + 0.04, 0.10, 0.20))]
    if precision is not None:
        s.options["precision"] = precision
    return s


def _set_box_on_off():
    """A free jelly block whose right third a set box pulls along +x from 0.03 s to 0.08 s (then it lets go)."""
    from gasp_core.colliders.model import Impulse
    s = S._setup([([-0.06, -0.03, 0.10], [0.06, 0.03, 0.16])], ("elastic",), [0.0, 0.0, 0.0], 24, None, [None])
    s.impulses = [Impulse("box", (0.5, 0.0, 0.0), 0.03, 0.08, lo=(0.02, -0.1, 0.0), hi=(0.2, 0.1, 0.3), mode="set")]
    return s


def _two_fields_held():
    """``tests/test_grid_box.py``'s jelly thrown onto a jelly slab (two fields: the field passes' box is the grid
    update's), the slab's left 4 cm held by a fixed region."""
    s = S._setup([([-0.03, -0.03, 0.03], [0.03, 0.03, 0.07]), ([-0.10, -0.08, 0.0], [0.18, 0.08, 0.03])],
                 ("elastic", "elastic"), [0.0, 0.0, -0.3], 24, 0.5, [None, None])
    s.boundaries = list(s.boundaries) + [Boundary("fixed_region", lo=(-0.12, -0.1, -0.01), hi=(-0.06, 0.1, 0.04))]
    return s


def _viscous(schedule: str, precision=None):
    """``tests/test_viscous_bodies.py``'s sheared viscous block beside a resting viscous cube (n_grid 24)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_viscous_bodies import two_bodies
    s = two_bodies(24, 4, 4, schedule)[0]
    if precision is not None:
        s.options["precision"] = precision
    return s


SCENES = {
    "bar": (lambda: _specimen("bar"), 12),
    "bar_f32": (lambda: _specimen("bar", "f32"), 12),
    "bone": (lambda: _specimen("bone"), 12),
    "elastic_held": (_held_block, 6),
    "elastic_held_f64": (lambda: _held_block(precision="f64"), 6),
    "set_box_on_off": (_set_box_on_off, 7),
    "held_at_wall": (lambda: _held_block(True), 6),
    "two_fields_held": (_two_fields_held, 4),
    "viscous_cpu": (lambda: _viscous("cpu"), 2),
    "viscous_gpu": (lambda: _viscous("gpu"), 2),
    "viscous_cpu_f64": (lambda: _viscous("cpu", "f64"), 2),
}


def held_mask(s, ng: int) -> np.ndarray:
    """(n_grid^3,) bool: the nodes inside a held box of ``s`` (any time), x-major as the grid."""
    lo, dx = np.asarray(s.domain_lo, float), (np.asarray(s.domain_hi, float) - np.asarray(s.domain_lo, float)) / ng
    X = lo + dx * np.stack(np.meshgrid(*[np.arange(ng)] * 3, indexing="ij"), -1).reshape(-1, 3)
    boxes = [(b.lo, b.hi) for b in s.boundaries if b.kind == "fixed_region"]
    boxes += [(i.lo, i.hi) for i in (getattr(s, "impulses", None) or []) if i.shape == "box" and i.mode == "set"]
    out = np.zeros(len(X), bool)
    for a, b in boxes:
        out |= np.all((X >= np.asarray(a, float) - 1e-9) & (X <= np.asarray(b, float) + 1e-9), axis=1)
    return out


def run(case: str) -> dict:
    """warp_mpm's run of ``case``: the points' state, ``grid_m``, ``grid_v``, the box (hull of its halves), mask."""
    build, frames = SCENES[case]
    s = build()
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        for _ in range(frames):
            eng.step_frame()
        st = eng.get_state()
        b = eng.grid_box.numpy()
        ng = eng.n_grid
        lo, hi = np.minimum(b[:3], b[6:9]), np.maximum(b[3:6], b[9:12])
        I = np.stack(np.meshgrid(*[np.arange(ng)] * 3, indexing="ij"), -1).reshape(-1, 3)
        in_box = np.all((I >= lo) & (I <= hi), axis=1)
        return {"state": {k: np.asarray(st[k]).tobytes() for k in ("x", "v", "F", "C", "Jp") if k in st},
                "m": eng.grid_m.numpy().tobytes(), "v": eng.grid_v.numpy().reshape(ng ** 3, 3),
                "keep": in_box | ~held_mask(s, ng), "share": float(in_box.mean()), "lo": lo,
                "moved": float(np.abs(np.asarray(st["x"]) - s.x).max())}
    finally:
        eng.close()


def same(on: dict, off: dict) -> bool:
    """The bits that must match (module notes)."""
    keep = on["keep"] & off["keep"]
    return (on["state"] == off["state"] and on["m"] == off["m"]
            and on["v"][keep].tobytes() == off["v"][keep].tobytes())


def held_box_off(monkeypatch):
    from gasp_warp_mpm import grid_box
    monkeypatch.setattr(grid_box, "HELD_BOX", False)
    monkeypatch.setattr(grid_box, "VISC_BOX", False)


@pytest.mark.parametrize("case", list(SCENES))
def test_the_held_box_keeps_the_bits(case, monkeypatch):
    on = run(case)
    assert 0.0 < on["share"] < 0.5 and on["moved"] > 0.0   # a box well inside the grid; the points moved
    held_box_off(monkeypatch)
    off = run(case)
    assert off["share"] == 1.0 and same(on, off)


def test_the_check_catches_a_box_one_node_short(monkeypatch):
    """The box kernels (the grid update's own, and the field passes' where the viscous bodies' two fields share it)
    fed ``lo + dx`` (the points seen one cell lower): the box's highest layer of P2G's nodes left out of the grid
    update and the mirror, which the check sees on the held bar and on the viscous bodies."""
    from gasp_warp_mpm import fields

    def shifted(real):
        def short(eng, Ft):
            lo = eng.setup.domain_lo
            eng.setup.domain_lo = [float(c) + eng.dx for c in lo]
            try:
                return real(eng, Ft)
            finally:
                eng.setup.domain_lo = lo
        return short
    good = {c: run(c) for c in ("bar", "viscous_cpu")}
    monkeypatch.setattr(fields, "grid_box_launches", shifted(fields.grid_box_launches))
    monkeypatch.setattr(fields, "box_launches", shifted(fields.box_launches))
    for c in good:
        assert not same(good[c], run(c)), c


def test_the_check_catches_the_viscous_step_s_box_one_node_short(monkeypatch):
    """The viscous step's own box (its lists and labels, ``viscosity.ImplicitViscosity.box_launch``) fed ``lo + dx``:
    the lists miss the highest layer of nodes with mass, which the check sees on the viscous bodies (cpu schedule)."""
    from gasp_warp_mpm.viscosity import ImplicitViscosity
    real = ImplicitViscosity.box_launch

    def short(self):
        lo = self.e.setup.domain_lo
        self.e.setup.domain_lo = [float(c) + self.e.dx for c in lo]
        try:
            return real(self)
        finally:
            self.e.setup.domain_lo = lo
    good = run("viscous_cpu")
    monkeypatch.setattr(ImplicitViscosity, "box_launch", short)
    assert not same(good, run("viscous_cpu"))


def test_the_box_reaches_the_wall_it_nears(monkeypatch):
    """The block held at the wall: its box stretched to the wall's nodes (``held_box``), P2G's hull 2 nodes from it
    without the stretch (``HELD_REACH`` 0). Both give the whole grid's bits here: the ghosts' images clamped at the
    wall read nodes whose values the mirror computes from zeros (module notes: the stretch makes them the whole grid's
    in every case, the 0 / 0 of an image on the wall's node included), so no scene of the family catches its loss."""
    from gasp_warp_mpm import grid_box
    on = run("held_at_wall")
    monkeypatch.setattr(grid_box, "HELD_REACH", 0)
    hull = run("held_at_wall")
    assert on["lo"][0] == 0 and hull["lo"][0] == 2 and same(on, hull)


def _near_set_box():
    """The set box that starts and stops, a fixed region one cell from it (holding the block's middle)."""
    s = _set_box_on_off()
    s.boundaries = list(s.boundaries) + [Boundary("fixed_region", lo=(-0.03, -0.1, 0.0), hi=(0.0, 0.1, 0.3))]
    return s


def test_held_boxes_near_each_other_keep_the_whole_grid(monkeypatch):
    """A fixed region within ``HELD_REACH`` cells of a set box (a ghost may read the other box's ghosts): the whole
    grid (``grid_box.whole_grid_reasons``); the bar's boxes, far apart, do not. With ``held_apart`` forced true the
    scene still gives the whole grid's bits (its ghosts read nodes with mass there): the rule is a safeguard of the
    proof that the family does not reach (module notes)."""
    from gasp_warp_mpm import grid_box
    s = _near_set_box()
    assert not grid_box.held_apart(s, DX24) and grid_box.held_apart(_specimen("bar"), tf.SIZE / 24)
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        assert grid_box.whole_grid_reasons(eng) and not eng.grid_box_held
        assert eng.grid_box.numpy().tolist() == [0, 0, 0, s.n_grid - 1, s.n_grid - 1, s.n_grid - 1] * 2
    finally:
        eng.close()
    SCENES["near_set_box"] = (_near_set_box, 7)
    try:
        off = run("near_set_box")
        monkeypatch.setattr(grid_box, "held_apart", lambda setup, dx: True)
        on = run("near_set_box")
    finally:
        del SCENES["near_set_box"]
    assert off["share"] == 1.0 and on["share"] < 0.5 and same(on, off)


@pytest.mark.parametrize("case", ["bar", "elastic_held", "held_at_wall", "viscous_gpu"])
def test_the_strided_sweep_of_cuda_keeps_the_bits(case, monkeypatch):
    """CUDA's sweeps (``along`` 0: thread ``t`` the box's nodes ``t, t + threads, ...``) of the grid update and the
    held passes, run on the CPU with 4,096 threads: the same bits as the whole grid (no balance: no sum hangs on
    the nodes' order)."""
    from gasp_warp_mpm import engine, grid_box, held

    def strided(eng):
        grid_box.allocate_grid_box(eng)
        return [eng.grid_box, 4096, 0]
    for mod in (engine, held, grid_box):
        monkeypatch.setattr(mod, "grid_sweep", strided)
    on = run(case)
    monkeypatch.undo()
    held_box_off(monkeypatch)
    off = run(case)
    assert same(on, off)   # (held_rule.py imports grid_box.grid_sweep when it records: patched above)
