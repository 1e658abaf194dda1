"""The rebuild on the host's cores (issue 65 item 3, :mod:`gasp_core.maps.rows`): ``T^-1``, the control rule and the
quaternions of a large object in chunks of rows on a thread pool give the one-call result **bit for bit**.

The object: the bundled README donut's Gaussians (``examples/data/donut_v3dg.ply``, flattened, GaMeS triangles),
seven copies side by side (319k rows, above :data:`~gasp_core.maps.rows.MIN_ROWS`), moved by a shear and a stretch
past alpha so the control rule clamps some scales; both rebuild rules. The catch: chunks put back out of order.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.gs.io import read_gaussians
from gasp_core.maps import rows
from gasp_core.maps.games import flatten, gaussians_to_triangles
from gasp_core.maps.surface import surface_map

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"


@pytest.fixture(scope="module")
def moved():
    """(rest triangles, rot, scales, moved triangles) of seven donuts side by side."""
    g = read_gaussians(DONUT)
    scales, rot, _ = flatten(g.scales, quat_to_rotmat(g.rotations))
    tri = gaussians_to_triangles(g.means, rot, scales)
    k = 7
    shift = np.arange(k)[:, None, None, None] * np.array([0.3, 0.0, 0.0])
    tri = (tri[None] + shift).reshape(-1, 3, 3)
    rot, scales = np.tile(rot, (k, 1, 1)), np.tile(scales, (k, 1))
    F = np.array([[1.0, 0.4, 0.0], [0.0, 2.2, 0.0], [0.0, 0.1, 0.9]])   # shear and stretch past alpha 1.5
    return tri, rot, scales, tri @ F.T


@pytest.mark.parametrize("rebuild", ["games", "covariance"])
def test_chunks_on_threads_give_the_one_call_bits(moved, rebuild, monkeypatch):
    tri, rot, scales, tri_t = moved
    assert len(tri) >= rows.MIN_ROWS
    m = surface_map(tri, rot, scales, surface_points="triangles", rebuild=rebuild, alpha=1.5)
    x = tri_t.reshape(-1, 3)
    monkeypatch.setenv("GASP_REBUILD_THREADS", "1")
    one = m.gaussians(x, np.zeros((0, 3)), rot)
    monkeypatch.setenv("GASP_REBUILD_THREADS", "2")
    calls = []
    real = rows.ThreadPoolExecutor
    monkeypatch.setattr(rows, "ThreadPoolExecutor", lambda **kw: calls.append(kw) or real(**kw))
    two = m.gaussians(x, np.zeros((0, 3)), rot)
    assert calls == [{"max_workers": 2}]          # it did run on the pool
    assert one[3] == two[3] and one[3]["clamped"] > 1000
    for a, b in zip(one[:3], two[:3]):
        assert a.dtype == b.dtype and np.array_equal(a, b)


def test_the_check_catches_chunks_out_of_order(moved, monkeypatch):
    tri, rot, scales, tri_t = moved
    m = surface_map(tri, rot, scales, surface_points="triangles", rebuild="games", alpha=1.5)
    monkeypatch.setenv("GASP_REBUILD_THREADS", "1")
    one = m.gaussians(tri_t.reshape(-1, 3), np.zeros((0, 3)), rot)
    monkeypatch.setenv("GASP_REBUILD_THREADS", "2")
    real = np.concatenate
    monkeypatch.setattr(rows.np, "concatenate", lambda parts, *a, **kw: real(parts[::-1], *a, **kw))
    two = m.gaussians(tri_t.reshape(-1, 3), np.zeros((0, 3)), rot)
    monkeypatch.setattr(rows.np, "concatenate", real)
    assert not np.array_equal(one[0], two[0])


def test_a_non_finite_vertex_is_named_by_its_row_in_the_whole_object(moved, monkeypatch):
    tri, rot, scales, tri_t = moved
    m = surface_map(tri, rot, scales, surface_points="triangles", rebuild="games", alpha=1.5)
    bad = tri_t.copy()
    bad[300_000, 2, 1] = np.nan
    monkeypatch.setenv("GASP_REBUILD_THREADS", "2")
    with pytest.raises(ValueError, match="face 300000"):
        m.gaussians(bad.reshape(-1, 3), np.zeros((0, 3)), rot)
