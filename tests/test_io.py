"""Gaussian Splatting file I/O on the real files shipped in ``examples/data`` (licences beside them)."""
import math
import os
from pathlib import Path

import numpy as np
import pytest
from plyfile import PlyData, PlyElement
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import Gaussians, quat_to_rotmat, rotmat_to_quat
from gasp_core.maps.games import EPS as FLAT_EPS
from gasp_core.gs.describe import describe
from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.gs.ply import SH_C0
from gasp_core.gs.splatv import read_splatv, splatv_at

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
DONUT, GUITAR = DATA / "donut_v3dg.ply", DATA / "guitar.compressed.ply"
TRAIN, PC_SHORT = DATA / "train-1000.ply", DATA / "pc_short.ply"
SPLATV = DATA / "spinach_4.splatv"

# file -> (count, SH degree, layout, has normals) as documented in data/README.md
EXPECTED = {
    DONUT: (45_624, 0, "3dgs", False),
    GUITAR: (90_854, 0, "compressed", False),
    TRAIN: (1_000, 3, "3dgs", True),
    PC_SHORT: (100, 3, "3dgs", True),
}


@pytest.fixture(scope="module")
def loaded():
    return {p: read_gaussians(p) for p in EXPECTED}


def bits(a):
    """View of a float32 array as uint32, for bit-for-bit comparison (NaN-safe)."""
    a = np.ascontiguousarray(a)
    assert a.dtype == np.float32
    return a.view(np.uint32)


def raw_vertex(path):
    return PlyData.read(str(path))["vertex"].data


def write_ply(path, data: np.ndarray, extra_elements=()):
    PlyData([PlyElement.describe(data, "vertex"), *extra_elements], byte_order="<").write(str(path))


def drop_fields(data: np.ndarray, drop) -> np.ndarray:
    names = [n for n in data.dtype.names if n not in drop]
    out = np.empty(len(data), dtype=[(n, data.dtype[n]) for n in names])
    for n in names:
        out[n] = data[n]
    return out


# ---------------------------------------------------------------- quaternions


def test_quat_to_rotmat_matches_scipy_and_columns_are_local_axes():
    rng = np.random.default_rng(1)
    q = rng.normal(size=(2000, 4)) * rng.uniform(0.3, 3.0, size=(2000, 1))  # unnormalised
    R = quat_to_rotmat(q)
    ref = Rotation.from_quat(q[:, [1, 2, 3, 0]]).as_matrix()  # scipy is x,y,z,w
    assert np.abs(R - ref).max() < 1e-12
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # 90 degrees about z: local x axis (column 0) goes to world +y
    Rz = quat_to_rotmat([math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)])
    assert np.allclose(Rz[:, 0], [0, 1, 0]) and np.allclose(Rz[:, 1], [-1, 0, 0])


def test_rotmat_to_quat_round_trip_including_half_turns():
    rng = np.random.default_rng(2)
    q = rng.normal(size=(5000, 4))
    # half turns (w = 0) about random and coordinate axes, where a trace-only formula fails
    q[:100, 0] = 0.0
    q[100:103] = np.eye(4)[1:]
    q[103] = [1, 0, 0, 0]
    q[104] = [1e-9, 1, 1e-9, 0]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    back = rotmat_to_quat(quat_to_rotmat(q))
    assert np.allclose(np.linalg.norm(back, axis=1), 1.0, atol=1e-14)
    assert np.all(back[:, 0] >= 0)
    # equal up to the sign (q and -q are the same rotation) to 1e-12
    sign = np.where(np.sum(back * q, axis=1) < 0, -1.0, 1.0)
    assert np.abs(back - sign[:, None] * q).max() < 1e-12
    # canonical sign for w clearly away from 0
    far = np.abs(q[:, 0]) > 1e-6
    assert np.abs(back[far] - q[far] * np.sign(q[far, 0])[:, None]).max() < 1e-12
    assert np.abs(quat_to_rotmat(back) - quat_to_rotmat(q)).max() < 1e-12


# ---------------------------------------------------------------- Gaussians


def _tiny(n=4, **kw):
    rng = np.random.default_rng(0)
    args = dict(means=rng.normal(size=(n, 3)), scales=np.full((n, 3), 0.1),
                rotations=np.tile([2.0, 0, 0, 0], (n, 1)), opacities=np.zeros(n),
                sh_dc=np.zeros((n, 3)), source="tiny.ply")
    args.update(kw)
    return Gaussians(**args)


def test_gaussians_validation_names_file_field_index():
    means = np.zeros((5, 3))
    means[3, 1] = np.nan
    with pytest.raises(SceneError, match=r"tiny\.ply.*means.*index 3"):
        _tiny(5, means=means)
    rot = np.tile([1.0, 0, 0, 0], (5, 1))
    rot[2] = 0
    with pytest.raises(SceneError, match=r"tiny\.ply.*rotations.*zero-norm.*index 2"):
        _tiny(5, rotations=rot)
    rot[2] = [np.inf, 0, 0, 0]
    with pytest.raises(SceneError, match=r"rotations.*non-finite.*index 2"):
        _tiny(5, rotations=rot)
    with pytest.raises(SceneError, match=r"scales.*expected shape \(5, 3\)"):
        _tiny(5, scales=np.ones((5, 2)))
    with pytest.raises(SceneError, match=r"sh_rest.*K in \(0, 3, 8, 15\)"):
        _tiny(5, sh_rest=np.zeros((5, 4, 3)))
    with pytest.raises(SceneError, match="layout"):
        _tiny(5, layout="nerf")


def test_gaussians_normalise_copy_subset(loaded):
    g = _tiny(4)
    assert np.allclose(g.rotations, [1, 0, 0, 0])  # stored norm 2 dropped
    src = loaded[PC_SHORT]
    c = src.copy()
    c.means[0] += 1.0
    c.extra["nx"][0] += 1.0
    assert src.means[0, 0] != c.means[0, 0] and src.extra["nx"][0] != c.extra["nx"][0]
    assert np.array_equal(src.copy().rotations, src.rotations)
    sub = src.subset([5, 7, 9])
    assert sub.n == len(sub) == 3 and sub.sh_degree == 3
    assert np.array_equal(sub.sh_rest, src.sh_rest[[5, 7, 9]])
    assert np.array_equal(sub.extra["ny"], src.extra["ny"][[5, 7, 9]])
    mask = src.opacities > 0
    assert src.subset(mask).n == int(mask.sum())


# ---------------------------------------------------------------- real files


@pytest.mark.parametrize("path", list(EXPECTED), ids=lambda p: p.name)
def test_real_file_counts_degree_layout(loaded, path):
    n, deg, layout, normals = EXPECTED[path]
    g = loaded[path]
    assert (g.n, g.sh_degree, g.layout, g.source) == (n, deg, layout, str(path))
    assert g.sh_rest.shape == (n, {0: 0, 3: 15}[deg], 3)
    assert g.means.dtype == np.float64 and g.scales.dtype == np.float64
    assert g.opacities.dtype == np.float32 and g.sh_dc.dtype == np.float32
    assert np.allclose(np.linalg.norm(g.rotations, axis=1), 1.0, atol=1e-12)
    assert np.all(g.scales > 0)
    assert (set(g.extra) == {"nx", "ny", "nz"}) == normals


@pytest.mark.parametrize("path", [DONUT, TRAIN, PC_SHORT], ids=lambda p: p.name)
def test_graphdeco_fields_match_raw_columns(loaded, path):
    """Means, exp(log scale), normalised quaternions, and raw float32 opacity/f_dc vs plyfile."""
    g, v = loaded[path], raw_vertex(path)
    assert np.array_equal(g.means, np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64))
    log_s = np.stack([v[f"scale_{i}"] for i in range(3)], 1).astype(np.float64)
    assert np.allclose(g.scales, np.exp(log_s), rtol=1e-14)
    q = np.stack([v[f"rot_{i}"] for i in range(4)], 1).astype(np.float64)
    norms = np.linalg.norm(q, axis=1)
    assert norms.min() < 0.9 and norms.max() > 1.1  # the files really store unnormalised ones
    assert np.allclose(g.rotations, q / norms[:, None], atol=1e-14)
    assert np.array_equal(bits(g.opacities), bits(np.asarray(v["opacity"])))
    assert np.array_equal(bits(g.sh_dc[:, 2]), bits(np.asarray(v["f_dc_2"])))


@pytest.mark.parametrize("path", [TRAIN, PC_SHORT], ids=lambda p: p.name)
def test_sh_rest_is_channel_major(loaded, path):
    """sh_rest[i, k, c] == f_rest_{c*K + k}: all red coefficients, then green, then blue."""
    g, v = loaded[path], raw_vertex(path)
    K = 15
    for c in range(3):
        for k in range(K):
            assert np.array_equal(bits(g.sh_rest[:, k, c]), bits(np.asarray(v[f"f_rest_{c * K + k}"])))
    # spot check of the layout: green's first coefficient is f_rest_15, not f_rest_1
    assert np.array_equal(g.sh_rest[:, 0, 1], v["f_rest_15"])
    assert not np.array_equal(g.sh_rest[:, 0, 1], v["f_rest_1"])


@pytest.mark.parametrize("path", list(EXPECTED), ids=lambda p: p.name)
def test_round_trip_bit_exact(loaded, tmp_path, path):
    g = loaded[path]
    out = write_gaussians(tmp_path / "out.ply", g)
    h = read_gaussians(out)
    assert h.n == g.n and h.sh_degree == g.sh_degree
    assert np.array_equal(bits(h.opacities), bits(g.opacities))
    assert np.array_equal(bits(h.sh_dc), bits(g.sh_dc))
    assert np.array_equal(bits(h.sh_rest), bits(g.sh_rest))
    assert list(h.extra) == list(g.extra)
    for k in g.extra:
        assert h.extra[k].dtype == g.extra[k].dtype and np.array_equal(h.extra[k], g.extra[k])
    if path != GUITAR:  # against the file itself too: float32 values untouched
        v = raw_vertex(path)
        assert np.array_equal(bits(h.opacities), bits(np.asarray(v["opacity"])))
        for k in g.extra:
            assert np.array_equal(h.extra[k], v[k])
        assert np.array_equal(h.means, g.means)  # float32 -> float64 -> float32 is exact
    # geometry: float64 written as float32
    ext = np.ptp(g.means, axis=0).max()
    assert np.abs(h.means - g.means).max() <= 1e-6 * ext
    assert np.abs(h.scales / g.scales - 1).max() < 1e-5
    assert np.abs(np.abs(np.sum(h.rotations * g.rotations, axis=1)) - 1).max() < 1e-6
    # the written header is the graphdeco order that viewers expect
    names = raw_vertex(out).dtype.names
    assert names[:3] == ("x", "y", "z")
    assert names[-7:] == ("scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3")
    assert names.index("opacity") == names.index("scale_0") - 1
    assert PlyData.read(str(out)).byte_order == "<" and not PlyData.read(str(out)).text


# ---------------------------------------------------------------- GaMeS and 2DGS files


def test_games_flat_file(tmp_path, loaded):
    v = raw_vertex(PC_SHORT).copy()
    v["scale_0"] = np.float32(math.log(1e-8))
    write_ply(tmp_path / "games.ply", v)
    g = read_gaussians(tmp_path / "games.ply")
    src = loaded[PC_SHORT]
    assert g.layout == "games"
    assert np.allclose(g.scales[:, 0], FLAT_EPS, rtol=1e-6)
    assert np.array_equal(g.scales[:, 1:], src.scales[:, 1:])
    assert np.array_equal(g.rotations, src.rotations)
    write_gaussians(tmp_path / "games2.ply", g)
    h = read_gaussians(tmp_path / "games2.ply")
    assert h.layout == "games"
    assert np.array_equal(raw_vertex(tmp_path / "games2.ply")["scale_0"], v["scale_0"])


def test_2dgs_file_converted_to_games_convention_and_back(tmp_path, loaded):
    v = drop_fields(raw_vertex(PC_SHORT), {"scale_2"})
    write_ply(tmp_path / "2dgs.ply", v)
    g = read_gaussians(tmp_path / "2dgs.ply")
    assert g.layout == "2dgs" and g.meta["rotation_columns_from_file"] == (2, 0, 1)
    q_file = np.stack([v[f"rot_{i}"] for i in range(4)], 1).astype(np.float64)
    R_file = quat_to_rotmat(q_file)
    R = g.rotmats()
    assert np.allclose(np.linalg.det(R), 1.0, atol=1e-12)
    # thin axis (column 0) is the 2DGS normal (file column 2); in-plane axes follow
    assert np.abs(R[:, :, 0] - R_file[:, :, 2]).max() < 1e-12
    assert np.abs(R[:, :, 1] - R_file[:, :, 0]).max() < 1e-12
    assert np.abs(R[:, :, 2] - R_file[:, :, 1]).max() < 1e-12
    assert np.all(g.scales[:, 0] == FLAT_EPS)
    assert np.allclose(g.scales[:, 1:], np.exp(np.stack([v["scale_0"], v["scale_1"]], 1).astype(float)))
    # the covariance is the 2DGS one (R_file diag(s1^2, s2^2, 0) R_file^T) up to the 1e-8 thickness
    s1s2 = np.exp(np.stack([v["scale_0"], v["scale_1"], np.full(len(v), -np.inf)], 1).astype(float))
    cov_file = np.einsum("nij,nj,nkj->nik", R_file, s1s2 ** 2, R_file)
    cov = np.einsum("nij,nj,nkj->nik", R, g.scales ** 2, R)
    assert np.abs(cov - cov_file).max() <= 1e-12 * np.abs(cov_file).max()
    src = loaded[PC_SHORT]
    assert np.array_equal(bits(g.opacities), bits(src.opacities))
    # write back as 2DGS: same stored rotation (up to sign and normalisation) and scales
    write_gaussians(tmp_path / "back.ply", g, layout="2dgs")
    w = raw_vertex(tmp_path / "back.ply")
    assert "scale_2" not in w.dtype.names
    q_back = np.stack([w[f"rot_{i}"] for i in range(4)], 1).astype(np.float64)
    assert np.abs(quat_to_rotmat(q_back) - R_file).max() < 1e-6
    assert np.allclose(w["scale_0"], v["scale_0"], atol=1e-6)
    assert np.allclose(w["scale_1"], v["scale_1"], atol=1e-6)
    assert read_gaussians(tmp_path / "back.ply").layout == "2dgs"


# ---------------------------------------------------------------- bad input


def _one_line(exc_info):
    msg = str(exc_info.value)
    assert "\n" not in msg
    return msg


def test_truncated_ply(tmp_path):
    data = DONUT.read_bytes()
    bad = tmp_path / "donut_half.ply"
    bad.write_bytes(data[: len(data) // 2])
    with pytest.raises(SceneError) as e:
        read_gaussians(bad)
    msg = _one_line(e)
    assert str(bad) in msg and "truncated" in msg


def test_missing_scales_and_positions(tmp_path):
    v = raw_vertex(PC_SHORT)
    write_ply(tmp_path / "noscale.ply", drop_fields(v, {"scale_0", "scale_1", "scale_2"}))
    with pytest.raises(SceneError) as e:
        read_gaussians(tmp_path / "noscale.ply")
    msg = _one_line(e)
    assert "noscale.ply" in msg and "scale_0..scale_2" in msg
    write_ply(tmp_path / "noxyz.ply", drop_fields(v, {"x", "y", "z"}))
    with pytest.raises(SceneError, match=r"noxyz\.ply.*no x, y, z"):
        read_gaussians(tmp_path / "noxyz.ply")
    write_ply(tmp_path / "rest.ply", drop_fields(v, {"f_rest_44"}))
    with pytest.raises(SceneError, match=r"rest\.ply: unknown layout: 44 f_rest_"):
        read_gaussians(tmp_path / "rest.ply")
    # a PLY that is no Gaussian file at all (a triangle mesh, as trimesh writes one)
    import trimesh
    trimesh.creation.box().export(tmp_path / "mesh.ply")
    with pytest.raises(SceneError, match=r"mesh\.ply.*unknown layout"):
        read_gaussians(tmp_path / "mesh.ply")
    with pytest.raises(FileNotFoundError, match="nope.ply"):
        read_gaussians(tmp_path / "nope.ply")


def test_nan_position(tmp_path):
    v = raw_vertex(DONUT).copy()
    v["y"][1234] = np.nan
    write_ply(tmp_path / "nan.ply", v)
    with pytest.raises(SceneError) as e:
        read_gaussians(tmp_path / "nan.ply")
    msg = _one_line(e)
    assert "nan.ply" in msg and "vertex 1234" in msg and "position" in msg


def test_overwrite_refused_and_atomic(tmp_path, loaded, monkeypatch):
    g = loaded[PC_SHORT]
    target = tmp_path / "out.ply"
    target.write_bytes(b"keep me")
    with pytest.raises(FileExistsError, match=str(target)):
        write_gaussians(target, g)
    assert target.read_bytes() == b"keep me"
    write_gaussians(target, g, overwrite=True)
    assert read_gaussians(target).n == g.n
    assert sorted(os.listdir(tmp_path)) == ["out.ply"]  # no temp file left
    # a failure while writing leaves neither a temp file nor a changed target

    def boom(self, stream):
        stream.write(b"partial")
        raise OSError("disk full")

    before = target.read_bytes()
    monkeypatch.setattr(PlyData, "write", boom)
    with pytest.raises(OSError, match="disk full"):
        write_gaussians(target, g, overwrite=True)
    assert target.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["out.ply"]


# ---------------------------------------------------------------- compressed PLY (guitar)


def test_guitar_compressed_sanity(loaded):
    g = loaded[GUITAR]
    header = PlyData.read(str(GUITAR))
    assert "min_r" in header["chunk"].data.dtype.names  # this file has per-chunk colour ranges
    assert np.allclose(np.linalg.norm(g.rotations, axis=1), 1.0, atol=1e-12)
    assert np.all(g.scales > 0)
    ratio = g.scales.min(axis=1) / g.scales.max(axis=1)
    assert 0.24 < np.mean(ratio < 0.01) < 0.26  # README: 25 %
    cb = g.meta["chunk_bounds"]  # (n_chunks, 2, 3)
    ci = np.arange(g.n) // 256
    assert np.all(g.means >= cb[ci, 0] - 1e-6) and np.all(g.means <= cb[ci, 1] + 1e-6)
    ext = np.ptp(g.means, axis=0)
    assert np.allclose(ext, [1.48, 4.38, 1.45], atol=0.01)
    assert np.all(np.abs(g.opacities) <= 40)
    # opacity byte 255 decodes to +40 as in PlayCanvas
    alpha = header["vertex"].data["packed_color"] & 0xFF
    assert np.all(g.opacities[alpha == 255] == 40) and (alpha == 255).any()


def _surface_agreement(g, rotations):
    """Median |cos| between flat Gaussians' thin axes and the local surface normal (PCA of the
    16 nearest centres, planar neighbourhoods only)."""
    s = g.scales
    m = np.flatnonzero(s.min(axis=1) / s.max(axis=1) < 0.05)
    _, nb = cKDTree(g.means).query(g.means[m], k=16)
    P = g.means[nb] - g.means[nb].mean(axis=1, keepdims=True)
    w, V = np.linalg.eigh(np.einsum("nki,nkj->nij", P, P))
    planar = w[:, 0] / w[:, 1] < 0.1
    R = quat_to_rotmat(rotations[m])
    n = R[np.arange(len(m)), :, np.argmin(s[m], axis=1)]
    return float(np.median(np.abs(np.sum(n * V[:, :, 0], axis=1))[planar]))


def test_guitar_rotation_decoding_matches_surface(loaded):
    """The decoded thin axes are the surface normals of the point cloud; a wrong component order
    or sign of the smallest-three unpacking breaks that (measured: 0.88 vs <= 0.59)."""
    g = loaded[GUITAR]
    good = _surface_agreement(g, g.rotations)
    assert good > 0.8
    for wrong in (g.rotations[:, [1, 2, 3, 0]], g.rotations * [1, -1, -1, -1]):
        assert _surface_agreement(g, wrong) < good - 0.15


def test_compressed_without_chunk_colours(tmp_path, loaded):
    """12-float chunks: the colour byte is the colour itself (no lerp)."""
    ply = PlyData.read(str(GUITAR))
    chunk, vert = ply["chunk"].data, ply["vertex"].data.copy()
    g = loaded[GUITAR]
    c = np.clip(np.round((g.sh_dc.astype(np.float64) * SH_C0 + 0.5) * 255), 0, 255).astype(np.uint32)
    vert["packed_color"] = (c[:, 0] << 24) | (c[:, 1] << 16) | (c[:, 2] << 8) | (vert["packed_color"] & 0xFF)
    chunk12 = drop_fields(chunk, {"min_r", "min_g", "min_b", "max_r", "max_g", "max_b"})
    PlyData([PlyElement.describe(chunk12, "chunk"), PlyElement.describe(vert, "vertex")],
            byte_order="<").write(str(tmp_path / "c12.ply"))
    h = read_gaussians(tmp_path / "c12.ply")
    assert h.layout == "compressed"
    # without chunk ranges a colour byte spans [0, 1] only (the chunk ranges of this file go
    # beyond it for about 30 % of the splats): decoded = clip(colour) to half a byte
    col_g = np.clip(g.sh_dc.astype(np.float64) * SH_C0 + 0.5, 0, 1)
    col_h = h.sh_dc.astype(np.float64) * SH_C0 + 0.5
    assert np.abs(col_h - col_g).max() <= 0.5 / 255 + 1e-6
    assert np.array_equal(h.means, g.means) and np.array_equal(bits(h.opacities), bits(g.opacities))
    # chunk count that does not match the splat count
    PlyData([PlyElement.describe(chunk12[:-1], "chunk"), PlyElement.describe(vert, "vertex")],
            byte_order="<").write(str(tmp_path / "c_bad.ply"))
    with pytest.raises(SceneError, match=r"c_bad\.ply.*354 chunks for 90854 splats"):
        read_gaussians(tmp_path / "c_bad.ply")


# ---------------------------------------------------------------- splaTV


@pytest.fixture(scope="module")
def spinach():
    return read_splatv(SPLATV)


def test_splatv_read(spinach):
    base, mot = spinach
    assert base.n == 62_442 and base.layout == "splatv" and base.sh_degree == 0
    assert mot["motion"].shape == (62_442, 9) and mot["omega"].shape == (62_442, 4)
    assert int(np.isinf(mot["trbf_scale"]).sum()) == 821
    assert base.meta["header"][0]["type"] == "splat"
    assert np.all(base.scales > 0)
    # the JSON header's texture size covers exactly these records (4 texels of 16 bytes each)
    h = base.meta["header"][0]
    assert base.n * 4 <= h["texwidth"] * h["texheight"] < (base.n + 1024) * 4


def test_splatv_motion(spinach):
    base, mot = spinach
    g0, g1, gh = splatv_at(base, mot, 0.0), splatv_at(base, mot, 1.0), splatv_at(base, mot, 0.5)
    disp = np.linalg.norm(g1.means - g0.means, axis=1)
    # README figures are over the splats the viewer draws at both times (factor >= 0.02)
    vis = (g0.extra["temporal_opacity"] > 0.02) & (g1.extra["temporal_opacity"] > 0.02)
    assert 0.7 < vis.mean() < 0.9  # measured 0.80
    assert 0.15 < np.median(disp[vis]) < 0.19  # README: 0.17 (measured 0.169)
    assert 2.2 < np.percentile(disp[vis], 99) < 2.6  # README: 2.4 (measured 2.41)
    assert np.median(disp) > 0.1  # every splat moves, not only the visible ones
    lo, hi = np.percentile(gh.means, [1, 99], axis=0)
    assert np.allclose(hi - lo, [34, 22, 14], rtol=0.1)  # README: about 34 x 22 x 14
    # at t = trbf_center the splat is at its stored position with full opacity
    i = int(np.argmax(np.isfinite(mot["trbf_scale"]) & (np.abs(mot["motion"]).sum(axis=1) > 0)))
    gi = splatv_at(base.subset([i]), {k: v[[i]] for k, v in mot.items()}, float(mot["trbf_center"][i]))
    assert np.allclose(gi.means, base.means[i]) and gi.extra["temporal_opacity"][0] == 1.0
    # cubic polynomial by hand at t = 0.9
    dt = 0.9 - float(mot["trbf_center"][i])
    m = mot["motion"][i].astype(np.float64)
    want = base.means[i] + m[0:3] * dt + m[3:6] * dt ** 2 + m[6:9] * dt ** 3
    g9 = splatv_at(base, mot, 0.9)
    assert np.allclose(g9.means[i], want, rtol=1e-12, atol=1e-12)
    data = SPLATV.read_bytes()
    hlen = int(np.frombuffer(data[4:8], "<u4")[0])
    raw = np.frombuffer(data[8 + hlen:], "<f2").reshape(-1, 32)[i, 6:10]  # words 3-4
    assert np.allclose(base.rotations[i] * base.extra["rot_norm"][i], raw, rtol=1e-12, atol=0)
    q = raw.astype(np.float64) + mot["omega"][i] * dt
    assert np.allclose(g9.rotations[i], q / np.linalg.norm(q) * np.sign(np.dot(q, g9.rotations[i])))
    f = math.exp(-(dt / float(mot["trbf_scale"][i])) ** 2)
    assert math.isclose(float(g9.extra["temporal_opacity"][i]), f, rel_tol=1e-6)
    sig = lambda x: 1 / (1 + np.exp(-np.float64(x)))  # noqa: E731
    assert math.isclose(sig(g9.opacities[i]), sig(base.opacities[i]) * f, rel_tol=1e-5, abs_tol=1e-12)
    # inf trbf_scale: always fully visible
    inf = np.isinf(mot["trbf_scale"])
    assert np.all(g9.extra["temporal_opacity"][inf] == 1.0)
    assert np.allclose(np.linalg.norm(g9.rotations, axis=1), 1.0)


def test_splatv_bad_input(tmp_path):
    data = SPLATV.read_bytes()
    (tmp_path / "cut.splatv").write_bytes(data[:-10])
    with pytest.raises(SceneError, match=r"cut\.splatv.*64-byte records"):
        read_splatv(tmp_path / "cut.splatv")
    (tmp_path / "magic.splatv").write_bytes(b"\x00" * 4 + data[4:])
    with pytest.raises(SceneError, match=r"magic\.splatv: magic 0x0; expected 0x674b"):
        read_splatv(tmp_path / "magic.splatv")


# ---------------------------------------------------------------- describe


def test_describe_donut_and_guitar():
    d = describe(DONUT)
    assert (d["count"], d["sh_degree"], d["layout"]) == (45_624, 0, "3dgs")
    assert np.allclose(d["extent"], [0.209, 0.207, 0.095], atol=0.002)
    assert d["up_axis_guess"] == "+z" and d["up_axis_confidence"] > 0.7
    g = describe(GUITAR)
    assert (g["count"], g["layout"]) == (90_854, "compressed")
    assert g["up_axis_guess"] == "-y" and g["up_axis_confidence"] > 0.7
    assert 0.24 < g["flat_fraction"] < 0.26
    assert g["median_scale_ratio"] < d["median_scale_ratio"]  # the guitar is the flat one
    assert d["bbox_min"][2] < 0.0 < d["bbox_max"][2]  # donut rests on z = 0 (min -0.009)


def test_describe_up_axis_follows_a_rotation(tmp_path, loaded):
    """Turn the donut so that +z goes to -x: the guess must follow (it is geometry, not a rule)."""
    g = loaded[DONUT].copy()
    R = Rotation.from_euler("y", -90, degrees=True).as_matrix()  # +z -> -x
    g.means = g.means @ R.T
    g.rotations = rotmat_to_quat(R @ g.rotmats())
    write_gaussians(tmp_path / "turned.ply", g)
    assert describe(tmp_path / "turned.ply")["up_axis_guess"] == "-x"


@pytest.mark.parametrize("path", [TRAIN, PC_SHORT, SPLATV], ids=["train-1000", "pc_short", "spinach_4"])
def test_describe_says_unknown_for_scenes(path):
    """Slices of scenes have no bottom: two axes show similar asymmetry, so no up axis is claimed."""
    d = describe(path)
    assert d["up_axis_guess"] == "unknown" and d["up_axis_confidence"] < 0.5
    assert any(c.startswith("flat-area asymmetry: ") and "x " in c for c in d["up_axis_cues"])
    assert "state up_axis" in d["up_axis_note"]
