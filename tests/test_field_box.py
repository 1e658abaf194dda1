"""Round 64 (``docs/performance.md`` "Round 64: the field passes over the touched box"): two speed-ups that must not
change a figure.

- **warp_mpm's field passes over the field box** (``gasp_warp_mpm/field_nodes.py``, ``FIELD_BOX``): the two-field
  contact's node passes sweep the hull of the nodes P2G touched this substep and the last instead of the whole grid.
  The points' positions after a few frames are compared bit for bit with ``FIELD_BOX = False`` (round 63's passes over
  the whole grid) on a family: two jellies touching, a rigid block on a jelly, the same with AFLIP (``field_old``),
  two blocks falling beside each other (the box moves), a heap of rigid blocks (coloured fields, the pairs' list)
  and sand sliding on a thin jelly slab (the mixed contact's ``flow_apply``).
  The catch: the box kernel fed positions one cell off (its box one node layer short on one side) leaves P2G's last
  layer of the fields' channels uncleared.
- **the recolouring's contact graph** (``gasp_core.mpm.colouring.contact_graph``): the same pairs, in the same order,
  as round 61's loop (:func:`graph_before`, kept here as the reference) on scenes of many shapes, sizes and reaches;
  the catch: a pad of half the reach in ``_near_box`` loses pairs.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from gasp_core.mpm import colouring
from gasp_core.seam import build_engine, get_engine
from gasp_core.testing import scenes_rigid3 as S
from gasp_core.testing import scenes_three as T

JELLY = ([-0.10, -0.08, 0.0], [0.18, 0.08, 0.04])


def graph_before(setup, r=None) -> list[tuple[int, int]]:
    """Round 61's ``contact_graph`` as it was (a mask a body, a loop over the pairs, every point of the smaller body
    asked): the reference."""
    from scipy.spatial import cKDTree
    x, _, _, body = colouring._material_view(setup)
    nb = len(setup.materials)
    r = colouring.reach(setup) if r is None else np.broadcast_to(np.asarray(r, float), (nb, nb))
    pts = [x[body == b] for b in range(nb)]
    box = [(p.min(0), p.max(0)) if len(p) else None for p in pts]
    trees, edges = {}, []
    for i in range(nb):
        for j in range(i + 1, nb):
            if box[i] is None or box[j] is None:
                continue
            if np.any(box[i][1] + r[i, j] < box[j][0]) or np.any(box[j][1] + r[i, j] < box[i][0]):
                continue
            a, b = (i, j) if len(pts[i]) >= len(pts[j]) else (j, i)
            if a not in trees:
                trees[a] = cKDTree(pts[a])
            d, _ = trees[a].query(pts[b], k=1, p=np.inf, distance_upper_bound=r[i, j])
            if np.isfinite(d).any():
                edges.append((float(d[np.isfinite(d)].min()), i, j))
    return [(i, j) for _, i, j in sorted(edges)]


def random_scene(seed: int, nb: int, spread: float):
    """``nb`` clusters of random points (sizes 1 to 400, boxes of 1 to 6 cm) scattered over ``spread`` m, random
    velocities, one body empty; dx 1 cm."""
    from types import SimpleNamespace
    rng = np.random.default_rng(seed)
    xs, vs, bs = [], [], []
    for b in range(nb):
        n = 0 if b == nb // 2 else int(rng.integers(1, 400))
        c, h = rng.uniform(0, spread, 3), rng.uniform(0.005, 0.03, 3)
        xs.append(c + rng.uniform(-1, 1, (n, 3)) * h)
        vs.append(rng.normal(0, 0.3, (n, 3)))
        bs.append(np.full(n, b))
    x = np.concatenate(xs)
    return SimpleNamespace(x=x, v=np.concatenate(vs), p_vol=np.full(len(x), 1e-6), body_id=np.concatenate(bs),
                           materials=[None] * nb, dx=0.01, frame_dt=1 / 30, gravity=[0, 0, -9.81], n_material=None)


def graph_scenes():
    out = [random_scene(seed, nb, spread) for seed, (nb, spread) in enumerate(
        [(3, 0.05), (8, 0.1), (20, 0.2), (40, 0.3), (60, 0.25), (12, 0.02)])]
    return out + [S.heap_setup(48, 4, 3), S.heap_setup(32, 3, 2), T.stack3("ball"), T.slide3(32), T.fall3(0.3)]


def test_the_contact_graph_is_round_61s():
    for s in graph_scenes():
        assert colouring.contact_graph(s) == graph_before(s)
        r = 0.5 * colouring.reach(s)   # a smaller reach, given: the same too
        assert colouring.contact_graph(s, r) == graph_before(s, r)


def test_the_graph_check_catches_a_short_pad(monkeypatch):
    real = colouring._near_box
    monkeypatch.setattr(colouring, "_near_box", lambda q, lo, hi, r: real(q, lo, hi, 0.5 * r))
    assert any(colouring.contact_graph(s) != graph_before(s) for s in graph_scenes())


def _pair(models, top=([-0.03, -0.03, 0.04], [0.03, 0.03, 0.07]), below=JELLY, n_grid=32, flip=None):
    s = S._setup([top, below], models, [0.0, 0.0, 0.0], n_grid, 0.0, [None, None])
    s.materials = [dataclasses.replace(m, E=1.0e5) for m in s.materials]
    if flip is not None:
        s.options["flip"] = flip
    return s


BOX_SCENES = {
    "jelly_on_jelly": lambda: _pair(("elastic", "elastic")),
    "block_on_jelly": lambda: _pair(("rigid", "elastic")),
    "block_on_jelly_aflip": lambda: _pair(("rigid", "elastic"), flip=0.95),
    "two_falling_blocks": lambda: _pair(("elastic", "elastic"), below=([0.035, -0.03, 0.05], [0.08, 0.03, 0.1])),
    "heap": lambda: S.heap_setup(32, 2, 2),
    "sand_on_slab_mixed": lambda: sand_slide(),
}


def sand_slide():
    """The sand block on a thin jelly slab of ``warp_ordered_bits.py`` (the mixed contact: the flowing body's touch,
    ``flow_apply``)."""
    from gasp_core.testing import sand_ball as B
    return B.slide_setup(1.2, {}, slab_h=2 * B.SIDE / B.N_GRID)


def warp_run(s, frames: int) -> dict:
    """warp_mpm's run of ``s`` over ``frames`` frames: the points (setup order), the field box, the offsets
    ``grid_dv`` of the last substep (bytes), and the largest value left in ``grid_sv`` and ``grid_vf`` (0: cleared)."""
    eng = build_engine(get_engine("warp_mpm"), s)
    try:
        for _ in range(frames):
            eng.step_frame()
        left = max(float(np.abs(eng.grid_sv.numpy()).max()), float(np.abs(eng.grid_vf.numpy()).max()))
        return {"x": eng.positions().tobytes(), "box": eng.field_box.numpy().copy(), "left": left,
                "dv": eng.grid_dv.numpy().tobytes()}
    finally:
        eng.close()


def box_off(monkeypatch):
    from gasp_warp_mpm import field_nodes
    monkeypatch.setattr(field_nodes, "FIELD_BOX", False)


@pytest.mark.parametrize("case", list(BOX_SCENES))
def test_the_field_box_keeps_the_bits(case, monkeypatch):
    """The points, and every node's offsets, bit for bit with the whole-grid passes; the fields' channels cleared."""
    pytest.importorskip("warp")
    on = warp_run(BOX_SCENES[case](), 3)
    ng, box = BOX_SCENES[case]().n_grid, on["box"]
    assert 0 <= box[:3].min() and box[3:6].max() <= ng - 1 and (box[3:6] >= box[:3]).all()   # a box, in the grid
    assert int(np.prod(box[3:6] - box[:3] + 1)) < ng ** 3   # less than the grid
    box_off(monkeypatch)
    off = warp_run(BOX_SCENES[case](), 3)
    assert off["box"].tolist() == [0, 0, 0, ng - 1, ng - 1, ng - 1] * 2
    assert on["x"] == off["x"] and on["dv"] == off["dv"] and on["left"] == off["left"] == 0.0


def test_the_box_check_catches_a_box_one_node_short(monkeypatch):
    """The box kernel fed ``lo + dx`` (its points seen one cell lower on every axis): its box's highest nodes one
    short, P2G's last layer not cleared, which the check above sees."""
    pytest.importorskip("warp")
    from gasp_warp_mpm import fields, field_nodes
    real = field_nodes.box_launches

    def short(eng, Ft):
        lo = eng.setup.domain_lo
        eng.setup.domain_lo = [float(c) + eng.dx for c in lo]
        try:
            return real(eng, Ft)
        finally:
            eng.setup.domain_lo = lo
    good = warp_run(BOX_SCENES["jelly_on_jelly"](), 3)
    monkeypatch.setattr(fields, "box_launches", short)
    bad = warp_run(BOX_SCENES["jelly_on_jelly"](), 3)
    assert good["left"] == 0.0 and bad["left"] > 0.0


@pytest.mark.parametrize("case", ["jelly_on_jelly", "block_on_jelly_aflip"])
def test_the_strided_sweep_of_cuda_keeps_the_bits(case, monkeypatch):
    """CUDA's sweep (``along`` 0: thread ``t`` the box's nodes ``t, t + threads, ...``), run on the CPU with 4,096
    threads: the same points and offsets as the whole grid's passes where no sum hangs on the shared list's order (two
    soft bodies; a rigid block on a jelly, its collider's sums per node)."""
    pytest.importorskip("warp")
    from gasp_warp_mpm import collider_launch, fields
    for module in (fields, collider_launch):   # round 69: the rigid collider's node passes sweep the box too
        monkeypatch.setattr(module, "sweep_args", lambda eng: [eng.field_box, 4096, 0])
    strided = warp_run(BOX_SCENES[case](), 3)
    monkeypatch.undo()
    box_off(monkeypatch)
    whole = warp_run(BOX_SCENES[case](), 3)
    assert strided["x"] == whole["x"] and strided["dv"] == whole["dv"] and strided["left"] == 0.0
