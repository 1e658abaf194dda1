"""What a click and a box pick in ``gasp studio`` (gasp_core.studio.pick): known-answer geometry and the real donut."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.gs.gaussians import rotmat_to_quat
from gasp_core.studio import pick
from gasp_core.studio.pick import Hit, box_rows, camera_project, ray_pick

DONUT = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"


def _splats(centres, sigma, opacities):
    n = len(centres)
    return (np.asarray(centres, float), np.broadcast_to(np.eye(3), (n, 3, 3)).copy(),
            np.full((n, 3), sigma), np.asarray(opacities, float))


def test_faint_halo_in_front_does_not_take_the_click():
    # a ray along +x through a faint splat (opacity 0.3) at x = 1 and an opaque one (0.9) at x = 2:
    # accumulated opacity 0.3 after the first, 1 - 0.7 * 0.1 = 0.93 after the second: the second is seen
    m, R, s, o = _splats([[1, 0, 0], [2, 0, 0]], 0.1, [0.3, 0.9])
    hit = ray_pick(m, R, s, o, (0, 0, 0), (1, 0, 0))
    assert hit.row == 1
    assert hit.depth == pytest.approx(2.0, abs=1e-12)
    assert hit.opacity == pytest.approx(1 - 0.7 * 0.1, abs=1e-12)
    # an opaque one in front is seen first, at its own depth
    m, R, s, o = _splats([[1, 0, 0], [2, 0, 0]], 0.1, [0.9, 0.9])
    assert ray_pick(m, R, s, o, (0, 0, 0), (3, 0, 0)) == Hit(0, pytest.approx(1.0), pytest.approx(0.9))


def test_faint_halo_check_catches_a_first_along_the_ray_pick(monkeypatch):
    """The check above fails for a pick that takes the first splat the ray meets (threshold at 0)."""
    monkeypatch.setattr(pick, "HIT_OPACITY", 1e-9)
    m, R, s, o = _splats([[1, 0, 0], [2, 0, 0]], 0.1, [0.3, 0.9])
    assert ray_pick(m, R, s, o, (0, 0, 0), (1, 0, 0)).row == 0


def test_miss_behind_and_beside():
    m, R, s, o = _splats([[1, 0, 0]], 0.1, [0.9])
    assert ray_pick(m, R, s, o, (0, 0, 0), (-1, 0, 0)) is None            # behind the origin
    assert ray_pick(m, R, s, o, (0, 1.0, 0), (1, 0, 0)) is None           # 10 sigma beside it
    # at 1 sigma beside: alpha 0.9 exp(-1/2) = 0.546 >= 0.5: a hit; at 1.2 sigma 0.437: a miss
    assert ray_pick(m, R, s, o, (0, 0.1, 0), (1, 0, 0)).row == 0
    assert ray_pick(m, R, s, o, (0, 0.12, 0), (1, 0, 0)) is None


def test_flat_splat_face_on_and_edge_on():
    # a flat (GaMeS) splat: thin axis x (1e-8), 0.1 across in y and z
    m = np.array([[1.0, 0, 0]])
    R = np.eye(3)[None]
    s = np.array([[1e-8, 0.1, 0.1]])
    o = np.array([0.9])
    assert ray_pick(m, R, s, o, (0, 0.05, 0), (1, 0, 0)).row == 0        # face on, half a sigma off centre
    assert ray_pick(m, R, s, o, (1, -5, 0.05), (0, 1, 0)) is not None    # edge on, through its plane
    assert ray_pick(m, R, s, o, (1.01, -5, 0), (0, 1, 0)) is None         # edge on, 1 cm off its plane


def test_camera_project_known_answers():
    # camera at the origin looking along world +y, up +z: OpenCV axes x = world x, y = world -z, z = world y
    Rc = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])
    wxyz = rotmat_to_quat(Rc)
    fov, aspect = np.radians(60.0), 2.0
    top = np.tan(np.radians(30.0))
    pts = np.array([[0, 1, 0], [0, 1, top], [2 * top, 1, 0], [0, -1, 0]], float)
    uv, z = camera_project(pts, (0, 0, 0), wxyz, fov, aspect)
    np.testing.assert_allclose(uv[:3], [[0.5, 0.5], [0.5, 0.0], [1.0, 0.5]], atol=1e-12)
    np.testing.assert_allclose(z, [1, 1, 1, -1], atol=1e-12)
    # the box keeps the points inside it and in front (the one behind projects to the centre too)
    assert box_rows(pts, (0, 0, 0), wxyz, fov, aspect, (0.4, 0.4), (0.6, 0.6)).tolist() == [0]
    assert box_rows(pts, (0, 0, 0), wxyz, fov, aspect, (0.0, 0.0), (1.0, 1.0)).tolist() == [0, 1, 2]


@pytest.mark.skipif(not DONUT.is_file(), reason="examples/data/donut_v3dg.ply missing")
def test_donut_ring_is_hit_at_its_top_and_the_hole_is_not():
    from gasp_core.gs.io import read_gaussians
    from gasp_core.gs.splat_numpy import splats_from_gaussians
    g = read_gaussians(DONUT)
    sp = splats_from_gaussians(g)
    R, s = pick.world_frames(g, np.eye(3), 1.0)
    centre = np.median(sp.means, axis=0)
    r = np.hypot(*(sp.means[:, :2] - centre[:2]).T)
    ring = 0.5 * (np.percentile(r, 2) + np.percentile(r, 98))   # the ring's middle radius
    top = sp.means[:, 2].max() + 0.5
    # straight down through the hole: no splat of the donut, nothing under it in the file
    assert ray_pick(sp.means, R, s, sp.opacities, (*centre[:2], top), (0, 0, -1)) is None
    # straight down onto the ring: the top of the icing there, within 5 mm of the highest opaque centre near the ray
    o = np.array([centre[0] + ring, centre[1], top])
    hit = ray_pick(sp.means, R, s, sp.opacities, o, (0, 0, -1))
    assert hit is not None
    near = (np.hypot(*(sp.means[:, :2] - o[:2]).T) < 0.003) & (sp.opacities > 0.5)
    assert abs((top - hit.depth) - sp.means[near, 2].max()) < 0.005
