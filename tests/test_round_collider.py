"""Round 89 (``gasp_core.mpm.round_ground.collider_reach``, ``gasp_core.colliders.sdf.padded``,
``round_ground.collider_depth``): a collider's distance field padded out to the round bodies' radius, exact on the
added samples; the depth of a round shape in a collider read at its centre; a ball placed in a collider lifted out on
its exact shape; no padding without a round body or with the switch off."""
from __future__ import annotations

import math

import numpy as np
import pytest

import gasp_core.mpm.round_ground as rg
from gasp_core.colliders.sdf import SDF_PAD, box_collider, collider_from_splats, padded
from gasp_core.mpm.grid_tables import grid_tables
from gasp_core.mpm.rigid import lift_setup
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.scenes_passive import fibonacci_sphere

R, H = 0.05, 0.00625
SLAB = np.array([0.3, 0.3, 0.05])   # the box collider's centre: its top face at z = 0.1
TOP = 0.1


def _slab(h=H):
    return box_collider([0.2, 0.2, 0.05], h, name="slab", friction=0.5, position=SLAB)


def _ball(c, n=804, model="rigid"):
    x, _ = box_points(c - R, c + R, H)
    x = x[np.linalg.norm(x - c, axis=1) <= R - H / 2]
    shell = c + R * fibonacci_sphere(n)
    volume = 4.0 / 3.0 * math.pi * R ** 3
    p_vol = np.r_[np.full(n, 0.4 * volume / n), np.full(len(x), 0.6 * volume / len(x))]
    s = make_setup(np.concatenate([shell, x]), p_vol, Material("jelly", model=model, E=1.0e10, nu=0.3, rho=700.0),
                   lo=np.zeros(3), hi=np.full(3, 0.6), n_grid=48, frame_dt=1.0 / 60)
    s.n_render = n
    s.colliders = [_slab()]
    return s


def _exact_box(p, half):
    q = np.abs(p) - half   # the collider's own frame: centred on its origin
    return np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)


def test_the_padded_field_is_exact_on_its_added_samples_and_keeps_the_old():
    col = _slab(h=0.0125)
    out = padded(col, 0.1)
    add = int(np.ceil(0.1 / col.h)) + 2 - SDF_PAD
    assert out.phi.shape == tuple(s + 2 * add for s in col.phi.shape)
    assert np.allclose(out.origin, col.origin - add * col.h)
    old = tuple(slice(add, add + s) for s in col.phi.shape)
    assert np.array_equal(out.phi[old], col.phi)
    g = out.origin + col.h * np.stack(np.meshgrid(*(np.arange(s) for s in out.phi.shape), indexing="ij"), -1)
    assert np.abs(out.phi - _exact_box(g, [0.2, 0.2, 0.05])).max() < 1e-12
    assert padded(col, 0.0) is col   # its own padding already reaches


def test_a_field_from_gaussians_pads_with_its_own_rule():
    # a flat square of splats: the padded field on the old samples is the field itself, and outside it grows by the
    # distance to the occupied samples (its own rule), so its gradient there is a unit vector
    u = np.linspace(0.1, 0.3, 21)
    P = np.stack(np.meshgrid(u, u, indexing="ij"), -1).reshape(-1, 2)
    tri = np.stack([np.c_[P, np.full(len(P), 0.1)], np.c_[P + [0.01, 0], np.full(len(P), 0.1)],
                    np.c_[P + [0, 0.01], np.full(len(P), 0.1)]], axis=1)
    col = collider_from_splats(tri, 0.01, name="splats", shell=True)
    out = padded(col, 0.08)
    add = (out.phi.shape[0] - col.phi.shape[0]) // 2
    assert add > 0
    old = tuple(slice(add, add + s) for s in col.phi.shape)
    assert np.array_equal(out.phi[old], col.phi)
    top = out.phi[out.phi.shape[0] // 2, out.phi.shape[1] // 2, :]   # a column through the square's middle
    assert np.all(np.diff(top[-add - 3:]) > 0.0)   # it keeps rising beyond the old grid
    assert np.diff(top[-add - 3:]) == pytest.approx(col.h, rel=1e-6)


def test_the_reach_is_the_largest_round_radius_and_none_without(monkeypatch):
    s = _ball(np.array([0.3, 0.3, TOP + R]))
    assert rg.collider_reach(s) == pytest.approx(R, rel=1e-3)
    assert grid_tables(s).sdf.size > s.colliders[0].phi.size   # padded for it
    monkeypatch.setattr(rg, "ROUND_COLLIDER", 0)
    assert rg.collider_reach(s) == 0.0
    assert grid_tables(s).sdf.size == s.colliders[0].phi.size
    monkeypatch.undo()
    x, p_vol = box_points(np.array([0.25, 0.25, 0.1]), np.array([0.35, 0.35, 0.2]), H)
    cube = make_setup(x, p_vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0), lo=np.zeros(3),
                      hi=np.full(3, 0.6), n_grid=48, frame_dt=1.0 / 60)
    cube.colliders = [_slab()]
    assert rg.collider_reach(cube) == 0.0


def test_the_depth_in_a_collider_is_read_at_the_centre():
    col = padded(_slab(), 2 * R)
    shape = [R, 0.0, 0.0, 0.0, 0.0]
    for gap in (-0.01, -0.001, 0.0, 0.004):
        c = np.array([0.31, 0.27, TOP + R + gap])
        depth, n = rg.collider_depth(col, c, np.eye(3), shape)
        assert depth == pytest.approx(-gap, abs=1e-9)
        assert n == pytest.approx([0.0, 0.0, 1.0], abs=1e-9)
    assert rg.collider_depth(_slab(), np.array([0.3, 0.3, 5.0]), np.eye(3), shape) == (0.0, None)   # off its grid


def test_a_ball_placed_in_a_collider_is_lifted_out_on_its_sphere(monkeypatch):
    s = _ball(np.array([0.3, 0.3, TOP + R - 0.004]))
    z0 = np.asarray(s.x)[:, 2].copy()
    lifted = lift_setup(s)
    assert np.asarray(lifted.x)[:, 2] - z0 == pytest.approx(0.004, abs=1e-6)
    monkeypatch.setattr(rg, "ROUND_COLLIDER", 0)   # the broken variant: no lift off a collider
    assert lift_setup(_ball(np.array([0.3, 0.3, TOP + R - 0.004]))).x is not None
    assert np.asarray(lift_setup(_ball(np.array([0.3, 0.3, TOP + R - 0.004]))).x)[:, 2] == pytest.approx(z0)
