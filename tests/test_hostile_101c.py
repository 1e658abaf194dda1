"""Round 101c's hostile inputs to the Python API, the writers and the readers, each read or written without a word or
refused for the wrong cause:

1. a :class:`Gaussians` changed after it was built (a NaN scale, a zero quaternion) was written as it stood: NaN in a
   PLY or SOG, a made-up scale and rotation in a compressed PLY; every writer now checks it first;
2. ``--format spz`` clamped a coordinate beyond its +-2048 file units to the edge without a word; it is refused;
3. a ``.sog`` or ``.glb`` of no Gaussians ended in numpy's "zero-size array" ValueError; now one line naming the file;
4. a binary PLY whose header counts fewer vertices than its data holds was read by the header, the rest of the
   Gaussians left out without a word; a warning now names the file and both counts;
5. a mesh whose face names a vertex it does not have: an IndexError traceback (PLY index past the end) or, for -1,
   the last vertex taken without a word; refused naming the face;
6. an ASCII PLY mesh whose header counts disagree with its rows was read as some other mesh (a face row read as a
   vertex); refused naming both counts;
7. :class:`SimSetup` took a negative ``body_id``, a NaN gravity, an infinite domain, a ground at NaN height, a NaN
   fixed box and ``n_render`` past the points: the engine failed later (blamed on the engine as an ``EngineBug``, or
   with a made-up substep count) or ran; a ``p_vol`` of the wrong length was numpy's broadcast error;
8. :func:`build_hierarchy` of no Gaussians was a ZeroDivisionError and of a NaN mean numpy's "invalid dims";
   :func:`gaussians_to_triangles` broadcast one rotation over many means.

Each case takes well under a second (no engine is built).
"""
from __future__ import annotations

import importlib.util
import struct
from pathlib import Path

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.gs import registry
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.maps.games import gaussians_to_triangles
from gasp_core.maps.hierarchy import build_hierarchy
from gasp_core.seam.setup import Boundary, Material, SimSetup


def needs_package(module: str):
    """Skip where ``module`` is not installed (a mark, for parameters and tests alike)."""
    return pytest.mark.skipif(importlib.util.find_spec(module) is None, reason=f"{module} is not installed")


def gaussians(n: int = 3, **fields) -> Gaussians:
    d = dict(means=np.arange(3 * n, dtype=float).reshape(n, 3) * 0.1, scales=np.full((n, 3), 0.01),
             rotations=np.tile([1.0, 0, 0, 0], (n, 1)), opacities=np.zeros(n), sh_dc=np.zeros((n, 3)))
    d.update(fields)
    return Gaussians(**d)


FORMATS = [pytest.param("ply", id="ply"),
           pytest.param("compressed_ply", marks=needs_package("gsply"), id="compressed_ply"),
           pytest.param("spz", marks=needs_package("gsply"), id="spz"),
           pytest.param("sog", marks=needs_package("PIL"), id="sog"),
           pytest.param("glb", marks=needs_package("pygltflib"), id="glb")]

CHANGES = {"nan_scale": (lambda g: g.scales.__setitem__((0, 1), np.nan), "scales"),
           "zero_quaternion": (lambda g: g.rotations.__setitem__(0, 0.0), "rotations"),
           "nan_mean": (lambda g: g.means.__setitem__((1, 2), np.nan), "means")}


# 1. ------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("change", sorted(CHANGES))
def test_gaussians_changed_after_they_were_built_are_refused_by_every_writer(tmp_path, fmt, change):
    """Before: ply, compressed_ply and sog wrote the NaN or zero quaternion (compressed_ply as a scale of 4.9e8 and a
    made-up rotation); spz and glb refused it through a copy, naming ``<in-memory Gaussians>``, not the file."""
    g = gaussians()
    edit, field = CHANGES[change]
    edit(g)
    path = tmp_path / f"out{registry.get(fmt).suffix}"
    with pytest.raises(SceneError, match=rf"{path}.*field '{field}'"):
        registry.write(path, g, fmt)
    assert not path.exists()


def test_write_gaussians_refuses_a_changed_nan_scale(tmp_path):
    g = gaussians()
    g.scales[2, 0] = np.nan
    with pytest.raises(SceneError, match="field 'scales'.*index 2"):
        write_gaussians(tmp_path / "a.ply", g)
    assert not (tmp_path / "a.ply").exists()


def test_an_unchanged_gaussians_still_writes_every_format(tmp_path):
    for fmt in ("ply", "compressed_ply", "spz", "sog", "glb"):
        if registry.get(fmt).missing():
            continue
        p = registry.write(tmp_path / f"ok{registry.get(fmt).suffix}", gaussians(), fmt)
        assert read_gaussians(p).n == 3


# 2. ------------------------------------------------------------------------------------------------------------
@needs_package("gsply")
@pytest.mark.parametrize("x", [2100.0, -5000.0, 1e17])
def test_spz_refuses_a_coordinate_past_its_range(tmp_path, x):
    """Before: written as 2048 (or -2048) and read back there: the Gaussian moved without a word."""
    g = gaussians(means=np.array([[0.0, 0, 0], [0.1, 0.2, 0.3], [0.5, x, 0]]))
    path = tmp_path / "far.spz"
    with pytest.raises(SceneError, match=r"far\.spz: Gaussian at index 2 .*2048"):
        registry.write(path, g, "spz")
    assert not path.exists()


@needs_package("gsply")
def test_spz_still_writes_a_coordinate_inside_its_range(tmp_path):
    g = gaussians(means=np.array([[0.0, 0, 0], [0.1, 0.2, 0.3], [2047.0, -2047.0, 1000.0]]))
    back = read_gaussians(registry.write(tmp_path / "near.spz", g, "spz"))
    np.testing.assert_allclose(back.means, g.means, atol=1e-3)


# 3. ------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", [pytest.param("sog", marks=needs_package("PIL")),
                                 pytest.param("glb", marks=needs_package("pygltflib"))])
def test_no_gaussians_is_one_line_naming_the_file(tmp_path, fmt):
    """Before: ValueError "zero-size array to reduction operation minimum which has no identity"."""
    path = tmp_path / f"empty{registry.get(fmt).suffix}"
    with pytest.raises(SceneError, match=rf"{path}: no Gaussians to write"):
        registry.write(path, gaussians(0), fmt)
    assert not path.exists()


# 4. ------------------------------------------------------------------------------------------------------------
STD = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
       "rot_0", "rot_1", "rot_2", "rot_3"]


def splat_ply(path: Path, rows: int, said: int, tail: bytes = b"") -> Path:
    """A float32 graphdeco PLY of ``rows`` Gaussians whose header says ``said``."""
    data = np.zeros((rows, len(STD)), "<f4")
    data[:, 0] = np.arange(rows) * 0.1
    data[:, 7:10] = -4.0
    data[:, 10] = 1.0
    head = f"ply\nformat binary_little_endian 1.0\nelement vertex {said}\n" + \
        "".join(f"property float {p}\n" for p in STD) + "end_header\n"
    path.write_bytes(head.encode() + data.tobytes() + tail)
    return path


@pytest.mark.parametrize("said", [0, 3])
def test_a_ply_holding_more_vertices_than_its_header_says_is_said(tmp_path, said):
    """Before: read as ``said`` Gaussians, the other ``5 - said`` left out without a word. Now a warning names both
    counts (a refusal would break files cut short by their header on purpose, as the bundled pc_short.ply)."""
    with pytest.warns(UserWarning, match=rf"short\.ply: its header says {said} vertices but the file holds 5 "):
        assert read_gaussians(splat_ply(tmp_path / "short.ply", 5, said)).n == said


def test_a_ply_with_a_few_stray_bytes_after_its_vertices_says_nothing(tmp_path):
    """Less than one row after the data (a trailing newline a tool added) is no left-out Gaussian."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert read_gaussians(splat_ply(tmp_path / "tail.ply", 5, 5, tail=b"\n")).n == 5


# 5, 6. ---------------------------------------------------------------------------------------------------------
TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def binary_mesh(path: Path, faces) -> Path:
    head = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
            "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n").encode()
    body = b"".join(struct.pack("<3f", *v) for v in TET_V) + b"".join(struct.pack("<B3i", 3, *f) for f in faces)
    path.write_bytes(head + body)
    return path


def ascii_mesh(path: Path, n_v: int, n_f: int) -> Path:
    head = (f"ply\nformat ascii 1.0\nelement vertex {n_v}\nproperty float x\nproperty float y\nproperty float z\n"
            f"element face {n_f}\nproperty list uchar int vertex_indices\nend_header\n")
    body = "".join(" ".join(map(str, v)) + "\n" for v in TET_V) + "".join(f"3 {a} {b} {c}\n" for a, b, c in TET_F)
    path.write_text(head + body)
    return path


@needs_package("trimesh")
@pytest.mark.parametrize("index", [9, -1])
def test_a_mesh_face_naming_a_missing_vertex_is_refused(tmp_path, index):
    """Before: 9 was an IndexError traceback; -1 was read as the last vertex without a word."""
    from gasp_core.prepare.mesh import read_mesh
    path = binary_mesh(tmp_path / "bad.ply", TET_F[:3] + [(1, 2, index)])
    with pytest.raises(SceneError, match=rf"bad\.ply: face 3 names vertex {index}; .*4 vertices"):
        read_mesh(path)


@needs_package("trimesh")
@pytest.mark.parametrize("n_v, n_f", [(6, 4), (4, 6), (4, 2), (3, 4)])
def test_an_ascii_ply_mesh_whose_header_disagrees_with_its_rows_is_refused(tmp_path, n_v, n_f):
    """Before: (6, 4) read a face row as a vertex (4 vertices, 2 faces), (4, 6) and (4, 2) read 4 and 2 faces."""
    from gasp_core.prepare.mesh import read_mesh
    with pytest.raises(SceneError, match=rf"lies\.ply: .*{n_v + n_f} rows.*holds 8;"):
        read_mesh(ascii_mesh(tmp_path / "lies.ply", n_v, n_f))


@needs_package("trimesh")
def test_a_true_ascii_ply_mesh_still_reads(tmp_path):
    from gasp_core.prepare.mesh import read_mesh
    mesh, _, _ = read_mesh(ascii_mesh(tmp_path / "tet.ply", 4, 4))
    assert len(mesh.vertices) == 4 and len(mesh.faces) == 4


# 7. ------------------------------------------------------------------------------------------------------------
def setup_fields(**changed) -> dict:
    x = 0.4 + 0.2 * np.random.default_rng(1).random((20, 3))
    d = dict(x=x, v=np.zeros(3), p_vol=1e-6, body_id=0, materials=[Material("jelly", E=1e4, nu=0.3, rho=300.0)],
             gravity=[0, 0, -9.81], domain_lo=[0, 0, 0], domain_hi=[1, 1, 1], n_grid=16,
             boundaries=[Boundary("ground", height=0.1)])
    d.update(changed)
    return d


SETUPS = {
    "negative_body_id": (dict(body_id=np.r_[np.zeros(19, int), -1]), r"body_id.*-1 at point 19"),
    "nan_gravity": (dict(gravity=[0, 0, np.nan]), r"gravity"),
    "infinite_domain": (dict(domain_hi=[1, 1, np.inf]), r"domain_hi"),
    "nan_ground": (dict(boundaries=[Boundary("ground", height=np.nan)]), r"boundaries\[0\].*height"),
    "negative_friction": (dict(boundaries=[Boundary("ground", friction=-1.0)]), r"boundaries\[0\].*friction"),
    "nan_fixed_box": (dict(boundaries=[Boundary("fixed_region", lo=(np.nan, 0, 0), hi=(1, 1, 1))]),
                      r"boundaries\[0\].*lo"),
    "p_vol_wrong_length": (dict(p_vol=np.ones(7)), r"p_vol.*\(7,\).*\(20,\)"),
    "v_wrong_shape": (dict(v=np.ones((20, 2))), r"SimSetup\.v.*\(20, 2\)"),
}


@pytest.mark.parametrize("case", sorted(SETUPS))
def test_a_simsetup_the_engine_cannot_take_is_refused_naming_the_field(case):
    changed, said = SETUPS[case]
    with pytest.raises(SceneError, match=said):
        SimSetup(**setup_fields(**changed))


def test_a_good_simsetup_is_still_taken():
    s = SimSetup(**setup_fields(boundaries=[Boundary("ground", height=0.1), Boundary("walls"),
                                            Boundary("fixed_region", lo=(0, 0, 0), hi=(0.5, 0.5, 0.5))]))
    assert s.n_render == 20


def test_an_n_render_past_the_points_reads_as_every_point():
    """A subset made by ``dataclasses.replace`` keeps its parent's ``n_render`` (round 101 lead: refusing it broke
    ``tests/test_field_mixed_frictions.py``'s water alone): rows ``[:n_render]`` are then every row, as -1 says."""
    assert SimSetup(**setup_fields(n_render=1000)).n_render == 20


# 8. ------------------------------------------------------------------------------------------------------------
def test_a_hierarchy_of_no_gaussians_is_refused():
    """Before: ZeroDivisionError: float division by zero."""
    with pytest.raises(SceneError, match="no Gaussians"):
        build_hierarchy(np.zeros((0, 3)), np.zeros((0, 3, 3)), 0.5)


def test_a_hierarchy_of_a_nan_mean_names_it():
    """Before: numpy's "invalid dims: array size defined by dims is larger than the maximum possible size"."""
    means = np.array([[0.0, 0, 0], [np.nan, 0, 0], [1, 0, 0]])
    with pytest.raises(ValueError, match="means.*index 1"):
        build_hierarchy(means, np.zeros((3, 3, 3)), 0.5)


def test_the_map_t_refuses_rows_that_disagree():
    """Before: one rotation and one scale row were broadcast over two means."""
    with pytest.raises(ValueError, match=r"gaussians_to_triangles.*\(2, 3\).*\(1, 3, 3\)"):
        gaussians_to_triangles(np.zeros((2, 3)), np.eye(3)[None], np.ones((1, 3)))


OBJ_TET = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\n"


@needs_package("trimesh")
@pytest.mark.parametrize("face", ["f 1 4 0", "f 1/1 4/2 0/3", "f 1//1 0//2 4//3"])
def test_an_obj_face_naming_vertex_0_is_refused(tmp_path, face):
    """Round 101 (lead): OBJ counts vertices from 1; a face naming 0 was read as some other vertex without a word."""
    from gasp_core.prepare.mesh import read_mesh
    path = tmp_path / "bad.obj"
    path.write_text(OBJ_TET + face + "\n")
    with pytest.raises(SceneError, match=r"bad\.obj: line 8: a face names vertex 0; OBJ counts vertices from 1"):
        read_mesh(path)


@needs_package("trimesh")
def test_an_obj_of_1_based_and_negative_indices_still_reads(tmp_path):
    from gasp_core.prepare.mesh import read_mesh
    path = tmp_path / "good.obj"
    path.write_text(OBJ_TET + "f -4 -1 -3\n")
    assert len(read_mesh(path)[0].faces) == 4


@pytest.mark.parametrize("logit, warned", [(-20.0, True), (-np.inf, True), (-5.0, False)])
def test_an_object_of_invisible_gaussians_is_warned_about(tmp_path, logit, warned):
    """Round 101 (lead): a file whose every Gaussian is under 1/255 opacity simulated without a word, and every frame
    rendered empty. It warns now, naming the file; one Gaussian at sigmoid(-5) = 0.0067 is visible, and is quiet."""
    import warnings as w
    from gasp_core.prepare.checks import check_object
    from gasp_core.scene.spec import ObjectSpec
    g = gaussians(3)
    g.opacities[:] = logit
    with w.catch_warnings(record=True) as got:
        w.simplefilter("always")
        check_object(ObjectSpec(file=tmp_path / "ghost.ply"), g)
    said = [str(x.message) for x in got if "invisible" in str(x.message)]
    assert bool(said) == warned, said
    if warned:
        assert "ghost.ply" in said[0] and "3 Gaussians" in said[0] and "1/255" in said[0], said
