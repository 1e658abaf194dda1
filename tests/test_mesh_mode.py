"""Mesh mode (issue 31, ``docs/mesh_mode.md``): Gaussians bound to mesh faces follow the mesh the engine moves.

Real data: the trained donut (city-super/V3DG, MIT) with a mesh of it extracted from its own occupancy
(``examples/make_donut_mesh.py``), and Keenan Crane's Spot (public domain) with Gaussians laid on it.
"""
from __future__ import annotations

import dataclasses

import json
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import needs_package

needs_package("rtree")   # mesh mode binds the Gaussians through trimesh's distance queries

from gasp_core.errors import SceneError  # noqa: E402
from gasp_core.gs.io import read_gaussians  # noqa: E402
from gasp_core.maps import mesh_bind  # noqa: E402
from gasp_core.prepare.placement import load_gaussians, prepare_object  # noqa: E402
from gasp_core.run.frames import rebuild  # noqa: E402
from gasp_core.scene.spec import load_scene, parse_scene  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DATA = EXAMPLES / "data"


def _scene(body: str, where: Path = EXAMPLES):
    import tomllib
    return parse_scene(tomllib.loads(body), where / "s.toml")


def _donut_spec(extra: str = ""):
    return _scene(f'[[object]]\nfile = "data/donut_v3dg.ply"\nmesh = "data/donut_mesh.ply"\n{extra}').objects[0]


def _donut_subset(step: int = 8):
    """Every ``step``-th Gaussian of the real donut (the binding is per Gaussian: a subset binds the same)."""
    g = read_gaussians(DATA / "donut_v3dg.ply")
    return g.subset(np.arange(0, g.n, step))


def _rotation(axis, degrees) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    t = np.radians(degrees)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(t) * K + (1 - np.cos(t)) * K @ K


def _world(o, g):
    """Means (m), rotation matrices and scales of an output frame in the world frame."""
    pl = o.placement
    return pl.to_world(g.means), pl.R @ g.rotmats(), g.scales * pl.scale


def _alone(o):
    """``o`` as the only object of a setup: its mesh vertices are the rows ``0 .. nv`` of ``x``."""
    return dataclasses.replace(o, vertex_slice=slice(0, len(o.surface.binding.vertices)))


def _rigid_error(o, Q, t, rebuild_fn=rebuild):
    """Largest gap (means and scales in metres, rotations as matrix entries) between the Gaussians rebuilt from the
    rigidly moved mesh and the rest Gaussians moved by the same motion."""
    x0 = o.surface.binding.vertices
    g0, _, _ = rebuild_fn(o, x0, o.rot_rest)
    g1, _, counts = rebuild_fn(o, x0 @ Q.T + t, o.rot_rest)
    rows = o.moving if o.moving is not None else np.arange(o.gaussians.n)
    m0, R0, s0 = (a[rows] for a in _world(o, g0))
    m1, R1, s1 = (a[rows] for a in _world(o, g1))
    return (float(np.abs(m1 - (m0 @ Q.T + t)).max()), float(np.abs(R1 - Q @ R0).max()),
            float(np.abs(s1 - s0).max()), counts)


def test_rigid_motion_moves_every_bound_gaussian_rigidly():
    """Under a rigid motion of the mesh every bound Gaussian moves rigidly: means, rotations, scales to 1e-6."""
    o = _alone(prepare_object(_donut_spec(), _donut_subset()))
    assert o.surface.form == "mesh" and len(o.surface.binding.face_of) == len(o.tri_rest)
    Q, t = _rotation([1.0, -2.0, 0.5], 73.0), np.array([0.3, -0.1, 0.25])
    dm, dR, ds, counts = _rigid_error(o, Q, t)
    assert dm < 1e-6 and dR < 1e-6 and ds < 1e-6, (dm, dR, ds)
    assert counts["clamped"] == 0 and counts["degenerate"] == 0
    # the rest frame is the input: frame 0 rebuilt from the rest mesh gives back the flattened Gaussians
    g0, _, _ = rebuild(o, o.surface.binding.vertices, o.rot_rest)
    rows = o.moving if o.moving is not None else np.arange(o.gaussians.n)
    assert np.abs(g0.means[rows] - o.gaussians.means[rows]).max() < 1e-9


def test_rigid_check_catches_a_binding_that_ignores_rotation(monkeypatch):
    """The check above fails for a binding that only translates (offsets kept in world axes, not face frames)."""
    o = _alone(prepare_object(_donut_spec(), _donut_subset(16)))
    rest_origin, rest_A = mesh_bind.face_frames(o.surface.binding.vertices[o.surface.binding.faces])

    def translate_only(b, x):
        origin, _ = mesh_bind.face_frames(np.asarray(x)[b.faces])
        return origin[b.face_of][:, None, :] + np.einsum("nij,nvj->nvi", rest_A[b.face_of], b.local)

    monkeypatch.setattr("gasp_core.maps.surface.bound_triangles", translate_only)
    dm, dR, _, _ = _rigid_error(o, _rotation([0, 0, 1], 30.0), np.zeros(3))
    assert dm > 1e-3 and dR > 0.1


def test_laid_gaussians_follow_an_affine_map_exactly():
    """Gaussians laid on Spot's faces lie in them (offset 0): under any affine map of the mesh their means are the
    map's image (barycentric coordinates are affine invariants), and they lie on their faces at rest."""
    spec = load_scene(EXAMPLES / "spot_mesh.toml").objects[0]
    o = prepare_object(spec)
    b = o.surface.binding
    assert b.report["mode"] == "laid" and b.report["n_far"] == 0 and b.report["n_faces_used"] == len(b.faces)
    assert np.abs(b.offset).max() < 1e-9 * b.report["size"]
    assert np.all(b.barycentric > -1e-9) and np.allclose(b.barycentric.sum(1), 1.0)
    M = np.array([[1.2, 0.3, 0.0], [0.0, 0.8, 0.1], [0.05, 0.0, 1.1]])
    tri = mesh_bind.bound_triangles(b, b.vertices @ M.T)
    assert np.abs(tri[:, 0] - o.tri_rest[:, 0] @ M.T).max() < 1e-9


def test_mesh_of_another_object_is_one_clear_error():
    """The donut's Gaussians with Spot's mesh: one line naming the share of Gaussians far from every face."""
    spec = _scene('[[object]]\nfile = "data/donut_v3dg.ply"\nmesh = "data/spot_triangulated.obj"').objects[0]
    with pytest.raises(SceneError) as e:
        prepare_object(spec, _donut_subset())
    msg = str(e.value)
    assert "\n" not in msg and "spot_triangulated.obj" in msg and "not of the same object" in msg
    share = float(msg.split("(")[1].split(" %")[0])
    assert share > 50.0, msg


def test_far_gaussians_named_and_left_static_or_refused():
    """Four small Gaussians of the donut's top lifted 5 cm (outside its mesh) are named in the report and left
    static; with mesh_far = "error" the scene is refused naming them."""
    g = _donut_subset()
    small = np.flatnonzero(g.scales.max(axis=1) < 0.002)
    lifted = np.sort(small[np.argsort(g.means[small, 2])[-4:]])
    g.means[lifted] += [0.0, 0.0, 0.05]
    with pytest.warns(UserWarning, match="left static"):
        o = prepare_object(_donut_spec(), g)
    assert set(lifted) <= set(o.surface.binding.report["far_rows"])
    assert not np.isin(lifted, o.moving).any() and len(o.static_tri) == o.surface.binding.report["n_far"]
    with pytest.raises(SceneError, match=r"first rows \[" + ", ".join(map(str, lifted))):
        prepare_object(_donut_spec('mesh_far = "error"'), g)


@pytest.mark.parametrize("body, words", [
    ('mesh = "data/donut_mesh.ply"\nfile = "data/donut_v3dg.ply"\nselect = { box = { lo = [0, 0, 0], hi = [1, 1, 1] } }',
     "sets both 'mesh' and 'select'"),
    ('mesh = "data/donut_mesh.ply"\nfile = "data/donut_v3dg.ply"\ngaussians_per_face = 3', "applies to a bare mesh"),
    ('mesh = "data/spot_triangulated.obj"\nmesh_far = "error"', "applies to a Gaussian 'file'"),
    ('mesh = "data/nothing.obj"', "is not a file"),
    ('file = "data/donut_v3dg.ply"\nmesh_tolerance = 0.1', "needs 'mesh'"),
    ('mesh = "data/donut_mesh.ply"\nfile = "data/donut_v3dg.ply"\nmesh_far = "drop"', "mesh_far"),
])
def test_mesh_keys_checked(body, words):
    with pytest.raises(SceneError, match=words):
        _scene(f"[[object]]\n{body}")


def test_unreadable_mesh_is_one_line(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_text("this is not a mesh\n")
    spec = _scene('[[object]]\nmesh = "bad.obj"', tmp_path).objects[0]
    with pytest.raises(SceneError) as e:
        load_gaussians(spec)
    assert "bad.obj" in str(e.value) and "\n" not in str(e.value)


def test_spot_example_falls_freely(tmp_path):
    """The Spot example on the MPM engine: the mesh's vertices are simulated, the Gaussians follow; two frames of
    free fall (it starts 5 cm above the ground) drop the Gaussians by g t^2 / 2 (5 %); run.json reports the
    binding."""
    from gasp_core.run.pipeline import simulate_scene
    scene = load_scene(EXAMPLES / "spot_mesh.toml")
    try:
        res = simulate_scene(scene, tmp_path / "out", n_frames=2, quiet=True)
    except Exception as e:  # the example's engine may be absent on this machine
        if "unknown engine" in str(e) or "cannot run" in str(e):
            pytest.skip(str(e))
        raise
    run = json.loads((tmp_path / "out" / "run.json").read_text())
    o = run["objects"][0]
    assert o["mesh"]["n_vertices"] == 2930 and o["mesh"]["n_bound"] == o["n_gaussians"]
    assert run["n_render_points"] == 2930
    frames = sorted((tmp_path / "out" / o["name"]).glob("frame_*.ply"))
    assert len(frames) == 3
    g0, g2 = read_gaussians(frames[0]), read_gaussians(frames[-1])
    t = 2 * scene.frame_dt
    drop = -(g2.means - g0.means)[:, 1].mean() * scene.objects[0].scale   # file +y is world up
    assert drop == pytest.approx(0.5 * 9.81 * t * t, rel=0.05)
    assert res.summary["objects"][0]["n_simulated_gaussians"] == o["n_gaussians"]


def test_laid_gaussians_take_the_vertex_colours(tmp_path):
    """A bare mesh with vertex colours: each laid Gaussian's colour is its barycentric mix of its face's corners
    (a red, a green and a blue corner give back the barycentric coordinates); without colours, grey."""
    import trimesh
    from gasp_core.prepare.mesh import GREY, SH_C0, laid_gaussians
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.2]])
    f = np.array([[0, 1, 2], [1, 3, 2]])
    rgb = np.array([[255, 0, 0, 255], [0, 255, 0, 255], [0, 0, 255, 255], [0, 0, 255, 255]], np.uint8)
    trimesh.Trimesh(v, f, vertex_colors=rgb, process=False).export(tmp_path / "c.ply")
    g = laid_gaussians(tmp_path / "c.ply", 8)
    colour = 0.5 + SH_C0 * g.sh_dc.astype(np.float64)
    first = np.flatnonzero(np.abs(g.means[:, 2]) < 1e-12)          # on face 0: corners red, green, blue
    bary = np.stack([1 - g.means[first, 0] - g.means[first, 1], g.means[first, 0], g.means[first, 1]], axis=1)
    assert len(first) >= 4 and np.abs(colour[first] - bary).max() < 1e-5
    trimesh.Trimesh(v, f, process=False).export(tmp_path / "plain.ply")
    plain = laid_gaussians(tmp_path / "plain.ply", 8)
    assert np.allclose(0.5 + SH_C0 * plain.sh_dc.astype(np.float64), GREY, atol=1e-6)


def _sphere_obj(path, mutate=None):
    """A 320-face icosphere written as OBJ (trimesh), optionally mutated (vertices, faces) first."""
    import trimesh
    m = trimesh.creation.icosphere(subdivisions=2, radius=0.1)
    v, f = np.array(m.vertices), np.array(m.faces)
    if mutate is not None:
        v, f = mutate(v, f)
    lines = [f"v {a:.17g} {b:.17g} {c:.17g}" for a, b, c in v.tolist()] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in f.tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path


def _far_vertex(v, f):
    v[0] = [1e30, 0.0, 0.0]
    return v, f


def _collinear(v, f):
    t = np.linspace(0.0, 1.0, len(v))
    return np.stack([t, 2 * t, 3 * t], axis=1), f


@pytest.mark.parametrize("mutate, words", [
    (_far_vertex, ["beyond 1e+06 from the origin", "vertex 0 at [1e+30"]),
    (_collinear, ["all 320 faces are degenerate", "collinear"]),
])
def test_a_mesh_with_a_far_vertex_or_only_degenerate_faces_names_it(tmp_path, mutate, words):
    # issue 41: both gave "the file has 0 Gaussians; nothing to simulate"
    from gasp_core.prepare.mesh import laid_gaussians
    obj = _sphere_obj(tmp_path / "bad.obj", mutate)
    with pytest.raises(SceneError) as e:
        laid_gaussians(obj, 4.0)
    msg = str(e.value)
    assert "\n" not in msg and "bad.obj" in msg and all(w in msg for w in words), msg
    laid_gaussians(_sphere_obj(tmp_path / "good.obj"), 4.0)   # the same mesh unmutated lays its Gaussians
