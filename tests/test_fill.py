"""Interior fill from Gaussian footprints: known volumes of real closed meshes, the real donut, open shapes."""

import numpy as np
import pytest
from gasp_testing import ROOT, needs_package

from gasp_core.errors import SceneError
from gasp_core.maps.fill import fill_interior, fill_spacing
from gasp_core.maps.games import flatten, gaussians_to_triangles

trimesh = needs_package("trimesh")
SPOT = ROOT / "examples" / "data" / "spot_triangulated.obj"   # Keenan Crane's cow, public domain (spot_README.txt)


def mesh_gaussians(mesh, n, seed=0, sigma_factor=0.5):
    """GaMeS mesh mode: ``n`` flat Gaussians laid on the faces at uniform barycentric samples.

    Faces are drawn by area; each Gaussian lies in its face's plane (r2 along the first edge,
    r3 = n x r2) with in-plane scale ``sigma_factor * sqrt(area / n)`` (half the mean spacing).
    Returns the GaMeS triangles, shape (n, 3, 3).
    """
    rng = np.random.default_rng(seed)
    tri = np.asarray(mesh.vertices)[np.asarray(mesh.faces)]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    f = rng.choice(len(tri), n, p=area / area.sum())
    u, v = rng.random(n), rng.random(n)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    m = tri[f, 0] + u[:, None] * e1[f] + v[:, None] * e2[f]
    r2 = e1[f] / np.linalg.norm(e1[f], axis=1, keepdims=True)
    nrm = np.cross(e1[f], e2[f])
    r3 = np.cross(nrm / np.linalg.norm(nrm, axis=1, keepdims=True), r2)
    s = sigma_factor * np.sqrt(area.sum() / n)
    return np.stack([m, m + s * r2, m + s * r3], 1)


def spot_mesh():
    mesh = trimesh.load(SPOT, process=False)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)     # the OBJ splits vertices at UV seams
    assert mesh.is_watertight
    return mesh, float(mesh.volume)


def torus_mesh():
    R, r = 0.3, 0.1
    return trimesh.creation.torus(major_radius=R, minor_radius=r, major_sections=128, minor_sections=64), \
        2 * np.pi ** 2 * R * r ** 2


@pytest.mark.parametrize("shape", ["spot", "torus"])
@pytest.mark.parametrize("n", [3000, 10000, 40000])
def test_closed_mesh_volume_within_3_percent(shape, n):
    """Flat Gaussians on a closed real mesh (and an analytic torus) fill its volume to 3 %.

    At these densities the former fill (means' vertices, one closing) kept 15-60 % of it.
    """
    mesh, v_true = spot_mesh() if shape == "spot" else torus_mesh()
    T = mesh_gaussians(mesh, n)
    h = np.ptp(mesh.vertices, axis=0).max() / 64
    fr = fill_interior(T.reshape(-1, 3), h, splats=T, name=shape)
    assert fr.report.closed and fr.report.method == "six-ray" and not fr.report.warning
    assert fr.volume == pytest.approx(v_true, rel=0.03)
    # volumes are shared, never double counted: they sum to the solid's cell count
    assert fr.p_vol_surface.sum() + fr.p_vol_fill.sum() == pytest.approx(fr.volume)
    assert fr.report.n_fill == len(fr.fill_x) > 0
    if shape == "torus":   # the fill points are inside the analytic torus (up to one occupancy voxel)
        x = fr.fill_x
        d = np.hypot(np.hypot(x[:, 0], x[:, 1]) - 0.3, x[:, 2]) - 0.1
        assert d.max() < fr.report.voxel and (d < 0).mean() > 0.9


def test_torus_lying_on_a_ground_keeps_its_overhang_out():
    """On a ground (``floor``, issue 54 item 6) the ground closes the soles whose outline it touches; a torus touches
    it along a ring whose hole is open upwards, so the overhang under its inner half stays out: its volume within
    3 % and every fill point within one occupancy voxel of the analytic torus (measured: 1.0046, 0.62 voxel; with
    every outline taken for a sole, 1.0286 and 4.27 voxels)."""
    mesh, v_true = torus_mesh()
    T = mesh_gaussians(mesh, 10000)
    fr = fill_interior(T.reshape(-1, 3), np.ptp(mesh.vertices, axis=0).max() / 64, splats=T, name="torus",
                       floor=float(mesh.vertices[:, 2].min()))
    assert fr.volume == pytest.approx(v_true, rel=0.03)
    d = np.hypot(np.hypot(fr.fill_x[:, 0], fr.fill_x[:, 1]) - 0.3, fr.fill_x[:, 2]) - 0.1
    assert d.max() < fr.report.voxel


def test_donut_volume_between_hole_and_hull(donut):
    """The real donut's filled volume: below its convex hull (the hole is empty), above 60 % of it.

    A torus with major/minor radius ratio R/r = 2 fills 2 pi^2 R r^2 / (pi (R+r)^2 2r) = 0.56 of its
    enclosing cylinder, whose volume is above the hull's; a real donut's flat top and bottom raise that.
    """
    opaque = 1 / (1 + np.exp(-donut.opacities)) >= 0.1
    s, R, _ = flatten(donut.scales[opaque], donut.rotmats()[opaque])
    T = gaussians_to_triangles(donut.means[opaque], R, s)
    hull = trimesh.convex.convex_hull(donut.means[opaque]).volume
    h = fill_spacing(np.ptp(donut.means, axis=0).max() * 1.2 / 64, 8)
    fr = fill_interior(T.reshape(-1, 3), h, splats=T, name="donut")
    assert fr.report.closed
    assert 0.6 * hull < fr.volume < hull


def test_open_shape_warns_or_refuses():
    """A hemisphere (an open bowl) encloses nothing: a shell with a warning naming it, or an error."""
    mesh = trimesh.creation.icosphere(subdivisions=4, radius=0.2)
    keep = mesh.triangles_center[:, 2] < 0.0
    bowl = trimesh.Trimesh(mesh.vertices, mesh.faces[keep])
    T = mesh_gaussians(bowl, 8000)
    h = 0.4 / 48
    fr = fill_interior(T.reshape(-1, 3), h, splats=T, name="bowl")
    assert not fr.report.closed and fr.report.method == "shell-open"
    assert "bowl" in fr.report.warning and " mm)" in fr.report.warning and " m^3." in fr.report.warning
    # gasp info without --size: the coordinates are file units, and the warning says so (issue 33)
    w = fill_interior(T.reshape(-1, 3), h, splats=T, name="bowl", unit="file units").report.warning
    assert "file units^3." in w and " m^3" not in w and " mm" not in w
    # a shell: much less than the half ball
    assert fr.volume < 0.3 * (2 / 3 * np.pi * 0.2 ** 3)
    with pytest.raises(SceneError, match="object 'bowl'.*refusing"):
        fill_interior(T.reshape(-1, 3), h, splats=T, name="bowl", if_open="error")


def test_shell_mode_and_bad_input():
    mesh, _ = torus_mesh()
    T = mesh_gaussians(mesh, 5000)
    fr = fill_interior(T.reshape(-1, 3), 0.01, splats=T, fill=False)
    assert fr.report.method == "shell" and not fr.report.warning
    with pytest.raises(SceneError, match="h must be > 0"):
        fill_interior(T.reshape(-1, 3), 0.0, splats=T)


def test_fill_spacing_follows_core_fraction():
    assert fill_spacing(0.01, 8) == pytest.approx(0.005)
    assert fill_spacing(0.01, 8, 0.5) == pytest.approx(0.01 / 4 ** (1 / 3))
    assert fill_spacing(0.01, 8, 0.01) == 0.01        # never fewer than one point per cell


def test_capture_without_its_underside_fills_within_10_percent():
    """Spot standing z up with every face looking down more than 60 degrees removed (1,272 faces: the belly,
    the hooves' soles; what cameras around a standing object never see): the five-ray vote forgives the open
    base and fills 0.93 of the closed mesh's volume; the former flood fill leaked through the hole."""
    mesh, v_true = spot_mesh()
    up = trimesh.Trimesh(mesh.vertices[:, [0, 2, 1]] * [1, -1, 1], mesh.faces, process=False)  # +y up -> +z up
    keep = up.face_normals[:, 2] > -0.5
    T = mesh_gaussians(trimesh.Trimesh(up.vertices, up.faces[keep], process=False), 10000)
    fr = fill_interior(T.reshape(-1, 3), np.ptp(up.vertices, axis=0).max() / 64, splats=T, name="spot")
    assert fr.report.closed and fr.report.sealed < 0.75
    assert fr.volume == pytest.approx(v_true, rel=0.10)
