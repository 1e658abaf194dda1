"""GaMeS maps T and T^-1, flattening and the alpha rule, on the real Gaussian files."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.maps.games import EPS, alpha_rule, flatten, gaussians_to_triangles, triangles_to_gaussians
from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.io import read_gaussians

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
GS_FILES = sorted(p for p in DATA.glob("*.ply") if p.name not in ("donut_mesh.ply", "bun_zipper.ply", "cup_mesh.ply"))   # meshes


@pytest.fixture(scope="module", params=[p.name for p in GS_FILES])
def real(request):
    g = read_gaussians(next(p for p in GS_FILES if p.name == request.param))
    return g


def test_a_mesh_ply_is_named_as_a_mesh():
    """The bundled mesh PLY, read as Gaussians, is refused as a mesh (it said "unknown layout: scale properties")."""
    from gasp_core.errors import SceneError
    with pytest.raises(SceneError, match="donut_mesh.ply: a triangle mesh .* faces.*'mesh'"):
        read_gaussians(DATA / "donut_mesh.ply")


def test_real_files_found():
    """examples/data ships five real scenes: the donut, the compressed guitar, its slab, train-1000 and pc_short."""
    assert len(GS_FILES) >= 5, f"expected the five bundled real files in {DATA}"


def test_round_trip_real_file(real):
    """T^-1(T(g)) returns means, normals (up to sign), in-plane scales and rotations to 1e-6."""
    scales, rot, report = flatten(real.scales, real.rotmats())
    assert report.n == real.n
    assert np.allclose(np.linalg.det(rot), 1.0, atol=1e-9)
    assert np.all(scales[:, 1] >= scales[:, 2])
    tri = gaussians_to_triangles(real.means, rot, scales)
    means, rot2, scales2, degenerate = triangles_to_gaussians(tri, fallback=rot)
    ext = np.ptp(real.means, axis=0).max()
    assert np.abs(means - real.means).max() <= 1e-6 * max(ext, 1.0)
    ok = ~degenerate
    # normals up to sign, in-plane axes and scales exactly (float64 tolerance 1e-6)
    normal_dot = np.abs(np.sum(rot[ok, :, 0] * rot2[ok, :, 0], axis=1))
    assert np.all(np.abs(normal_dot - 1.0) < 1e-6)
    assert np.abs(rot[ok, :, 1:] - rot2[ok, :, 1:]).max() < 1e-6
    assert np.all(np.abs(scales2[ok, 1:] - scales[ok, 1:]) <= 1e-6 * np.maximum(scales[ok, 1:], 1e-12) + 1e-15)
    # quaternions agree up to sign
    q1, q2 = rotmat_to_quat(rot[ok]), rotmat_to_quat(rot2[ok])
    assert np.all(np.abs(np.abs(np.sum(q1 * q2, axis=1)) - 1.0) < 1e-6)
    # degenerate faces only where the input scale is below float64 resolution of the mean
    assert degenerate.sum() <= 0.001 * real.n


def test_flatten_reports_flatness(real):
    _, _, report = flatten(real.scales, real.rotmats())
    ratio = real.scales.min(1) / real.scales.max(1)
    assert report.n_flat == int(np.sum(ratio < 0.01))
    assert report.median_ratio == pytest.approx(np.median(ratio))


def test_flatten_keeps_thin_axis_as_normal():
    rng = np.random.default_rng(0)
    q = rng.normal(size=(500, 4))
    R = quat_to_rotmat(q)
    s = rng.uniform(0.01, 1.0, size=(500, 3))
    s_flat, R_flat, _ = flatten(s, R)
    k = np.argmin(s, axis=1)
    thin_axis = R[np.arange(500), :, k]
    assert np.allclose(np.abs(np.sum(thin_axis * R_flat[:, :, 0], axis=1)), 1.0)
    assert np.all(s_flat[:, 0] == EPS)
    # the covariance in the plane is unchanged: R S^2 R^T restricted to the in-plane axes
    cov = np.einsum("nij,nj,nkj->nik", R, s ** 2, R)
    cov_f = np.einsum("nij,nj,nkj->nik", R_flat, s_flat ** 2, R_flat)
    thin = np.einsum("ni,nj->nij", thin_axis, thin_axis) * (s[np.arange(500), k] ** 2)[:, None, None]
    assert np.allclose(cov - thin, cov_f, atol=1e-12)


def test_inverse_is_proper_rotation_for_any_triangle():
    rng = np.random.default_rng(1)
    tri = rng.normal(size=(2000, 3, 3))
    _, R, s, deg = triangles_to_gaussians(tri)
    assert not deg.any()
    assert np.allclose(np.linalg.det(R), 1.0)
    assert np.allclose(np.einsum("nji,njk->nik", R, R), np.eye(3), atol=1e-12)
    assert np.all(s[:, 2] > 0)
    # the Gaussian reproduces the triangle: v2 = m + s2 r2; v3 lies in the plane with the same r3 component
    assert np.allclose(tri[:, 0] + s[:, 1:2] * R[:, :, 1], tri[:, 1])
    e3 = tri[:, 2] - tri[:, 0]
    assert np.allclose(np.sum(e3 * R[:, :, 2], axis=1), s[:, 2])
    assert np.allclose(np.sum(e3 * R[:, :, 0], axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("case", ["collapsed_edge", "all_coincident", "collinear", "tiny"])
def test_degenerate_triangles_never_nan(case):
    v = np.array([1.0, 2.0, 3.0])
    tri = {
        "collapsed_edge": [v, v, v + [0, 1, 0]],
        "all_coincident": [v, v, v],
        "collinear": [v, v + [1, 0, 0], v + [2, 0, 0]],
        "tiny": [v, v + [1e-200, 0, 0], v + [0, 1e-200, 0]],
    }[case]
    fallback = quat_to_rotmat(np.array([[0.9, 0.1, 0.3, -0.2]]))
    m, R, s, deg = triangles_to_gaussians(np.array([tri]), fallback=fallback)
    assert np.all(np.isfinite(m)) and np.all(np.isfinite(R)) and np.all(np.isfinite(s))
    assert deg[0]
    assert np.allclose(R[0], fallback[0])
    assert np.all(s >= EPS)
    q = rotmat_to_quat(R)
    assert np.all(np.isfinite(q))


def test_nonfinite_triangle_is_an_error():
    tri = np.zeros((3, 3, 3))
    tri[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match="face 2"):
        triangles_to_gaussians(tri)


def test_alpha_rule_clamps_only_stretched_edges():
    rest = np.array([[[0, 0, 0], [1.0, 0, 0], [0, 2.0, 0]]] * 3)
    moved = rest.copy()
    moved[1, 1] = [3.0, 0, 0]       # edge v1-v2 stretched 3x
    moved[2, 2] = [0, 2.5, 0]       # edge v1-v3 stretched 1.25x
    _, _, s_rest, _ = triangles_to_gaussians(rest)
    _, _, s_t, _ = triangles_to_gaussians(moved)
    out, clamped = alpha_rule(rest, moved, s_t, s_rest, alpha=1.5)
    assert clamped.tolist() == [[False, False], [True, False], [False, False]]
    assert out[1, 1] == pytest.approx(1.5 * 1.0)
    assert out[2, 2] == pytest.approx(2.5)
    out1, clamped1 = alpha_rule(rest, moved, s_t, s_rest, alpha=1.0)
    assert clamped1[2, 1] and out1[2, 2] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="alpha"):
        alpha_rule(rest, moved, s_t, s_rest, alpha=0.0)


def _sheared_random_gaussians(n: int, gamma: float, seed: int = 0):
    """``n`` random flat Gaussians (uniform random rotations, in-plane scales 0.5-2, s2 >= s3) as
    rest triangles, and the same triangles under simple shear ``x += gamma y``."""
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(n, 4))
    rot = quat_to_rotmat(q / np.linalg.norm(q, axis=1, keepdims=True))
    s = np.sort(rng.uniform(0.5, 2.0, size=(n, 2)), axis=1)[:, ::-1]
    scales = np.column_stack([np.full(n, EPS), s])
    means = rng.normal(size=(n, 3))
    rest = gaussians_to_triangles(means, rot, scales)
    F = np.eye(3)
    F[0, 1] = gamma
    return rest, rest @ F.T


def _alpha_rule_faults(rule, gamma: float, alpha: float = 1.5) -> list[str]:
    """What is wrong with control rule ``rule`` (signature of :func:`alpha_rule`) on 20k random
    Gaussians under simple shear ``gamma``: an empty list when it only ever shrinks (no scale above
    what T^-1 gives), bounds every triggered scale by alpha s_rest, and leaves untriggered scales alone."""
    rest, moved = _sheared_random_gaussians(20_000, gamma)
    _, _, s_rest, _ = triangles_to_gaussians(rest)
    _, _, s_t, _ = triangles_to_gaussians(moved)
    out, _ = rule(rest, moved, s_t, s_rest, alpha)
    d_t = np.linalg.norm(moved[:, 1:] - moved[:, :1], axis=2)
    d_0 = np.linalg.norm(rest[:, 1:] - rest[:, :1], axis=2)
    triggered = d_t > alpha * d_0
    faults = []
    grown = np.any(out[:, 1:] > s_t[:, 1:] * (1 + 1e-12), axis=1)
    if grown.any():
        faults.append(f"gamma {gamma}: {grown.mean():.1%} of Gaussians enlarged, largest factor "
                      f"x{(out[:, 1:] / s_t[:, 1:]).max():.2f}")
    if not triggered.any():
        faults.append(f"gamma {gamma}: the rule never triggers (the test shears too little)")
    if np.any(out[:, 1:][triggered] > alpha * s_rest[:, 1:][triggered] * (1 + 1e-12)):
        faults.append(f"gamma {gamma}: a triggered scale above alpha s_rest")
    if not np.array_equal(out[:, 1:][~triggered], s_t[:, 1:][~triggered]):
        faults.append(f"gamma {gamma}: an untriggered scale changed")
    return faults


@pytest.mark.parametrize("gamma", [1.0, 2.0, 3.0])
def test_alpha_rule_never_enlarges_under_shear(gamma):
    """The control rule only shrinks: under simple shear (gamma 1, 2, 3) on 20k random Gaussians at
    alpha 1.5 no scale ends above what T^-1 of the sheared triangle gives, every triggered scale is
    at most alpha times its rest value, and untriggered scales are left as T^-1 gives them; ``clamped``
    marks exactly the scales it made smaller.

    Before the fix (the rule *set* s_i = alpha s_i_rest) 4.7 %, 24.6 % and 36.2 % of the Gaussians grew,
    by up to x1.29, x2.84 and x4.39 (issue 17, item 2)."""
    assert _alpha_rule_faults(alpha_rule, gamma) == []
    rest, moved = _sheared_random_gaussians(20_000, gamma)
    _, _, s_rest, _ = triangles_to_gaussians(rest)
    _, _, s_t, _ = triangles_to_gaussians(moved)
    out, clamped = alpha_rule(rest, moved, s_t, s_rest, alpha=1.5)
    assert np.array_equal(clamped, out[:, 1:] < s_t[:, 1:])


def test_enlarging_control_rule_is_caught():
    """The check above fails on a control rule that enlarges: the rule before issue 17, which set
    s_i = alpha s_i_rest wherever the edge stretched past alpha."""
    def enlarging(tri_rest, tri_t, scales_t, scales_rest, alpha):
        d_t = np.linalg.norm(tri_t[:, 1:] - tri_t[:, :1], axis=2)
        d_0 = np.linalg.norm(tri_rest[:, 1:] - tri_rest[:, :1], axis=2)
        hit = d_t > alpha * d_0
        out = np.array(scales_t, dtype=np.float64)
        out[:, 1:] = np.where(hit, alpha * scales_rest[:, 1:], out[:, 1:])
        return out, hit

    faults = [f for g in (1.0, 2.0, 3.0) for f in _alpha_rule_faults(enlarging, g)]
    assert len(faults) == 3 and all("enlarged" in f for f in faults), faults
