"""Round 60's touch by geometry (``gasp_core.mpm.gap_touch``, ``docs/contact.md`` "Round 60: a touch by geometry"):
its NumPy reference marks two flat lattices that touch or lie within the separation, and not two a cell apart,
wherever the face lies in its cell; the level is the half-space integral's, and the switch picks the scenes.

Two slabs of points at dx / 2 (the lower one, field B, below z = c; the upper one, field A, from c + gap), their
volumes scattered with the quadratic B-spline as P2G does, marked by :func:`gap_marks` at their bodies' levels
(:func:`gap_levels` of a two-body scene): some node marked at gap 0 and at half the separation, none at 1 dx and at
twice the separation (the rule before marked across a 0.53 dx gap: ``tests/test_contact_fine_step.py``).

Round 61 (``gap_touch.CURVATURE``, off by default; ``docs/contact.md`` "Round 61: a touch that reads the curvature"):
the reference with the curvature read marks flat faces and two balls at contact (each with a catch), and both
engines' kernels mark exactly its nodes."""
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


# Round 61 (``gap_touch.CURVATURE``, ``docs/contact.md`` "Round 61: a touch that reads the curvature"): the level at
# half a point spacing plus the smoothing's shift of the curvature both fields share; no separation.

def _marks(x: np.ndarray, in_a: np.ndarray, ng: int, curve: bool, sep: float = 0.0, keep=None) -> np.ndarray:
    """The reference's marks of two lattices at spacing dx / 2 on a grid of ``ng`` (dx 1, origin 0): round 61's
    (``curve``) or round 60's at separation ``sep``; by the points ``keep`` (all unless given)."""
    vf = np.stack([_scatter_ng(x[in_a], ng), _scatter_ng(x[~in_a], ng)])
    k = np.ones(len(x), bool) if keep is None else keep
    if curve:
        return G.gap_marks(x[k], in_a[k], vf, np.zeros(3), DX, None, np.full(k.sum(), 0.25), G.half_space_table())
    return G.gap_marks(x[k], in_a[k], vf, np.zeros(3), DX, np.full(k.sum(), F.flow_touch_level((0.5 + sep) * 0.5)))


def _scatter_ng(x: np.ndarray, ng: int) -> np.ndarray:
    global NG
    keep, NG = NG, ng
    try:
        return _scatter(x, (DX / 2) ** 3)
    finally:
        NG = keep


def _slabs(gap: float, face: float) -> tuple[np.ndarray, np.ndarray]:
    """Two slabs (points at dx / 2 over x, y in [3, 17], 2 cells thick) ``gap`` cells apart, the lower face at ``5 +
    face``: ``(x, in_a)``, the upper slab field A."""
    s = DX / 2
    g = np.arange(3.0, 17.0, s) + s / 2
    xy = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    zb = np.arange(3.0 + face, 5.0 + face - 1e-9, s) + s / 2
    za = np.arange(5.0 + face + gap, 7.0 + face + gap - 1e-9, s) + s / 2
    x = np.array([[u, v, z] for u, v in xy for z in np.r_[za, zb]])
    return x, np.tile(np.r_[np.ones(len(za), bool), np.zeros(len(zb), bool)], len(xy))


def _balls(radius: float, gap: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Two lattice balls (points at dx / 2 within ``radius`` cells of their centres, the upper one field A) on a
    vertical line, their lattices' surfaces ``gap`` cells apart in ``tests/test_stacked_balls.py``'s measure: ``(x,
    in_a, measured gap)``."""
    from gasp_core.testing.scenes_pairs import surface_gap
    s = DX / 2
    g = np.arange(-radius - 1.0, radius + 1.0, s) + s / 2
    c = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    ball = c[np.linalg.norm(c, axis=1) <= radius]
    lo = ball + [9.3, 9.6, 5.2]
    top0 = lo + [0.1, 0.2, 2 * radius]
    body = np.repeat([1, 0], len(lo))
    a, b = -1.0, 2.0                                                      # the lift (cells) by bisection
    for _ in range(50):
        m = 0.5 * (a + b)
        a, b = (m, b) if surface_gap(np.vstack([top0 + [0, 0, m], lo]), body, s ** 3) < gap else (a, m)
    x = np.vstack([top0 + [0, 0, 0.5 * (a + b)], lo])
    return x, body == 1, surface_gap(x, body, s ** 3)


@pytest.mark.parametrize("face", [0.0, 0.3, 0.5, 0.8])
def test_curved_touch_marks_flat_faces_at_contact(face):
    """Flat faces (the points 3 cells or more from the slabs' sides mark): marked 0.1 dx inside each other, not 0.1
    dx apart (the first mark -0.04 to +0.03 dx with the face's place in its cell); round 60's level (half a
    spacing's separation) marks 0.1 apart (first +0.27). Not checked: the two slabs' flush corners, where both
    fields are curved, mark early (+0.07 to +0.15 dx, ``docs/contact.md`` "Round 61")."""
    def inner(x):
        return ((x[:, :2] > 6.0) & (x[:, :2] < 14.0)).all(1)
    x, in_a = _slabs(-0.1, face)
    assert _marks(x, in_a, 20, True, keep=inner(x)).any()
    x, in_a = _slabs(0.1, face)
    assert not _marks(x, in_a, 20, True, keep=inner(x)).any()
    assert _marks(x, in_a, 20, False, 0.5, keep=inner(x)).any()          # the catch: round 60's rule


@pytest.mark.parametrize("radius", [2.0, 3.0])
def test_curved_touch_marks_touching_balls(radius):
    """Two balls of ``radius`` cells: marked touching (the measure's gap 0), not 0.25 dx apart (the first mark
    +0.06 to +0.13 dx); the half-space level at half a spacing (round 60 at separation 0) does not mark them touching
    (its first mark -0.19 to -0.05 dx: the smoothing moves a ball's level surface inward)."""
    x, in_a, gap = _balls(radius, 0.0)
    assert gap == pytest.approx(0.0, abs=1e-6)
    assert _marks(x, in_a, 20, True).any()
    assert not _marks(*_balls(radius, 0.25)[:2], 20, True).any()
    assert not _marks(x, in_a, 20, False, 0.0).any()                      # the catch: no curvature read


def test_least_curvature_of_a_ball_and_a_cylinder():
    """``least_curvature`` of a radial field: 1 / r on a sphere, 0 on a cylinder (its axis direction flat)."""
    r = 2.5
    g = np.array([[-1.0, 0.0, 0.0]])                                     # a field decreasing outward along x
    sphere = np.diag([0.3, -1.0 / r, -1.0 / r])[None]                    # tangential second derivatives -|g| / r
    cylinder = np.diag([0.3, -1.0 / r, 0.0])[None]
    assert G.least_curvature(g, sphere)[0] == pytest.approx(1.0 / r)
    assert G.least_curvature(g, cylinder)[0] == pytest.approx(0.0, abs=1e-12)


def _kernel_case():
    x, in_a, _ = _balls(2.0, 0.05)
    ng = 20
    vf = np.stack([_scatter_ng(x[in_a], ng), _scatter_ng(x[~in_a], ng)])
    ref = G.gap_marks(x, in_a, vf, np.zeros(3), DX, None, np.full(len(x), 0.25), G.half_space_table())
    return x, in_a, vf, ng, ref


def test_the_warp_kernel_is_the_reference():
    """warp_mpm's ``gap_curve`` kernel marks the reference's nodes (two balls 0.05 dx apart), in float64 and float32."""
    wp = pytest.importorskip("warp")
    from gasp_warp_mpm.pair_touch import build_gap_curve
    from gasp_warp_mpm.precision import build_types
    x, in_a, vf, ng, ref = _kernel_case()
    assert ref.any()
    params = np.r_[G.half_space_table(), 0.25, 0.25]
    for Ft in (wp.float64, wp.float32):
        vec3 = build_types(Ft)[0]
        marks = wp.zeros(ng ** 3, dtype=wp.int32, device="cpu")
        wp.launch(build_gap_curve(Ft), dim=len(x), device="cpu", inputs=[
            wp.array(x, dtype=vec3, device="cpu"), wp.array((~in_a).astype(np.int32), dtype=wp.int32, device="cpu"),
            wp.array(np.array([1, 0], np.int32), dtype=wp.int32, device="cpu"),
            wp.array(vf.reshape(-1), dtype=Ft, device="cpu"), marks, vec3(0.0, 0.0, 0.0), Ft(1.0), Ft(1.0),
            wp.array(params, dtype=Ft, device="cpu"), ng, G.TABLE_N, Ft(G.TABLE_STEP), Ft(G.SIGMA2)])
        assert np.array_equal(marks.numpy().reshape((ng,) * 3).astype(bool), ref)


@pytest.mark.slow
def test_the_taichi_kernel_is_the_reference(monkeypatch):
    """taichi_mpm's ``PairTouch.mark_gap`` with ``CURVATURE`` marks the reference's nodes (the same two balls): an
    engine of the two balls (dx 1 cm) whose node volumes are set to the reference's, marked once."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    from gasp_core.seam.setup import Material, SimSetup
    monkeypatch.setattr(G, "CURVATURE", True)
    x, in_a, vf, ng, ref = _kernel_case()
    dx = 0.01
    setup = SimSetup(x=x * dx, v=0.0, p_vol=np.full(len(x), (dx / 2) ** 3), body_id=(~in_a).astype(int),
                     materials=[Material("jelly"), Material("jelly")], gravity=np.zeros(3), domain_lo=np.zeros(3),
                     domain_hi=np.full(3, ng * dx), n_grid=ng, frame_dt=1.0 / 30.0)
    eng = build_engine(engines()["taichi_mpm"], setup)
    try:
        sv = eng.solver
        assert sv.gap_curve
        if sv.in_a[0] == 0:                                               # the engine's field A: body 1, the lower ball
            in_a = ~in_a
            vf = vf[::-1].copy()
            ref = G.gap_marks(x, in_a, vf, np.zeros(3), DX, None, np.full(len(x), 0.25), G.half_space_table())
        sv.grid_vf.from_numpy(np.moveaxis(vf, 0, -1) * dx ** 3)
        sv.grid_ft.fill(0)
        sv.mark_gap()
        assert np.array_equal(sv.grid_ft.to_numpy().astype(bool), ref)
    finally:
        eng.close()
