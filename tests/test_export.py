"""glTF (KHR_gaussian_splatting) and OpenUSD out (issue 42 items 1 and 2): ``gasp simulate --format glb|usd`` and
``gasp export RUN --format glb|usd``, checked against the run's own PLY frames (the same engine, deterministic)."""
import json
import shutil
import subprocess

import numpy as np
import pytest
from gasp_testing import needs_package, scene_text

from gasp_core.cli.main import main
from gasp_core.gs.gltf import UP_TO_Z, Z_TO_Y, read_glb, turned, write_glb
from gasp_core.gs.io import read_gaussians
from gasp_core.run.layout import open_frames
from gasp_core.run.pipeline import simulate_scene
from gasp_core.scene.spec import load_scene

needs_package("gasp_taichi_mpm")
pytest.importorskip("pygltflib", reason="the export extra (pip install -e '.[export]') is not installed")

SELECT = "select = { box = { lo = [-1.0, -1.0, -1.0], hi = [0.0, 1.0, 1.0] } }"   # file x <= 0 moves


@pytest.fixture(scope="module")
def ply_run(tmp_path_factory, donut_small):
    """A 3-frame run (half the donut moving, a static donut beside it), PLY frames."""
    tmp = tmp_path_factory.mktemp("export")
    scene = tmp / "scene.toml"
    scene.write_text(scene_text(donut_small, n_frames=3, n_grid=16, extra_object=SELECT)
                     + f'\n[[object]]\nfile = "{donut_small}"\nposition = [0.5, 0.0, 0.0]\nstatic = true\n')
    simulate_scene(load_scene(scene), tmp / "run", quiet=True)
    return tmp / "run"


def _extent(g):
    return float(np.ptp(g.means, axis=0).max())


def test_glb_round_trip_keeps_every_field_and_turns_to_y_up(donut, tmp_path):
    g = donut.subset(np.arange(0, donut.n, 40))
    write_glb(tmp_path / "a.glb", g, up_axis="-y")
    with pytest.raises(FileExistsError):
        write_glb(tmp_path / "a.glb", g)
    h = read_glb(tmp_path / "a.glb")                       # +Z up again: the -y file turned by UP_TO_Z["-y"]
    M = UP_TO_Z["-y"]
    np.testing.assert_allclose(h.means, g.means @ M.T, atol=1e-6 * _extent(g))
    back = turned(h, M.T)
    np.testing.assert_allclose(back.scales, g.scales, rtol=1e-6)
    np.testing.assert_allclose(np.abs((back.rotations * g.rotations).sum(1)), 1.0, atol=1e-6)
    np.testing.assert_allclose(back.sh_rest, g.sh_rest, atol=1e-5)
    np.testing.assert_allclose(back.opacities, g.opacities, atol=1e-3)
    # in the file itself: +Z-up -> +Y-up, (x, y, z) -> (x, z, -y)
    raw = turned(h, Z_TO_Y)
    assert np.allclose(raw.means[:, 1], h.means[:, 2]) and np.allclose(raw.means[:, 2], -h.means[:, 1])


def test_simulate_format_glb_frames_equal_the_ply_run(ply_run, tmp_path, donut_small):
    scene = ply_run.parent / "scene.toml"
    simulate_scene(load_scene(scene), tmp_path / "glb", quiet=True, fmt="glb")
    manifest = json.loads((tmp_path / "glb" / "frames.json").read_text())
    assert manifest["format"] == "glb" and manifest["layout"] == "frames"
    a, b = open_frames(ply_run), open_frames(tmp_path / "glb")
    assert a.n_frames == b.n_frames == 4
    for f in (0, 3):
        for k in (0, 1):
            ga, gb = a.gaussians(f, k), b.gaussians(f, k)
            assert ga.n == gb.n
            np.testing.assert_allclose(gb.means, ga.means, atol=1e-6 * _extent(ga))   # up_axis +z: no turn
    assert np.abs(a.gaussians(3, 0).means - a.gaussians(0, 0).means).max() > 1e-3   # it did move


def test_glb_frames_of_a_turned_object_read_back_in_its_file_frame(donut, tmp_path):
    """A -y-up object's GLB frames are +Y up in the file and come back in the file frame through open_frames
    (gasp view, gasp render, --resume), as a PLY run's do."""
    from gasp_core.run.layout import FrameWriter
    g = donut.subset(np.arange(0, donut.n, 40))
    (tmp_path / "a").mkdir()
    w = FrameWriter(tmp_path, ["a"], [False], [None], "glb", "frames", up_axes=["-y"])
    w.write(0, [g])
    raw = read_glb(tmp_path / "a" / "frame_0000.glb")          # +Z up: the file's -y turned up
    np.testing.assert_allclose(raw.means, g.means @ UP_TO_Z["-y"].T, atol=1e-6 * _extent(g))
    back = open_frames(tmp_path).gaussians(0, 0)
    np.testing.assert_allclose(back.means, g.means, atol=1e-6 * _extent(g))
    np.testing.assert_allclose(np.abs((back.rotations * g.rotations).sum(1)), 1.0, atol=1e-6)
    assert np.abs(raw.means - g.means).max() > 0.1 * _extent(g)   # the turn is not the identity


def test_gasp_export_glb_refuses_an_existing_output(ply_run, tmp_path, capsys):
    out = tmp_path / "glb"
    assert main(["export", str(ply_run), "--format", "glb", "-o", str(out)]) == 0
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*.glb"))
    assert len(files) == 8 and files[0].endswith("frame_0000.glb")
    before = (out / files[0]).read_bytes()
    assert main(["export", str(ply_run), "--format", "glb", "-o", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
    assert (out / files[0]).read_bytes() == before
    assert main(["export", str(ply_run), "--format", "glb", "-o", str(out), "--overwrite"]) == 0


def test_gasp_export_usd_time_samples_every_frame(ply_run, tmp_path):
    pxr = pytest.importorskip("pxr", reason="usd-core (the export extra) is not installed")
    from pxr import Usd, UsdGeom
    out = tmp_path / "run.usdc"
    assert main(["export", str(ply_run), "--format", "usd", "-o", str(out)]) == 0
    stage = Usd.Stage.Open(str(out))
    frames = open_frames(ply_run)
    assert UsdGeom.GetStageUpAxis(stage) == "Z"
    assert stage.GetTimeCodesPerSecond() == pytest.approx(1 / 0.0333333)
    from gasp_core.run.usd_export import prim_name
    names = [prim_name(o["name"]) for o in frames.manifest["objects"]]
    moving = stage.GetPrimAtPath(f"/Run/{names[0]}")
    assert moving.GetTypeName() == "ParticleField3DGaussianSplat"
    pos = moving.GetAttribute("positions")
    assert pos.GetTimeSamples() == [0.0, 1.0, 2.0, 3.0]
    for f in range(frames.n_frames):
        g = frames.gaussians(f, 0)
        got = np.asarray(pos.Get(Usd.TimeCode(f)))
        np.testing.assert_allclose(got, g.means, atol=1e-6 * _extent(g))
        q = np.asarray(moving.GetAttribute("orientations").Get(Usd.TimeCode(f)))[:, [3, 0, 1, 2]]
        np.testing.assert_allclose(np.abs((q * g.rotations).sum(1)), 1.0, atol=1e-5)
    static = stage.GetPrimAtPath(f"/Run/{names[1]}").GetAttribute("positions")
    assert static.GetTimeSamples() == [] and len(static.Get()) == frames.gaussians(0, 1).n
    assert main(["export", str(ply_run), "--format", "usd", "-o", str(out)]) == 2   # exists: refused


def test_gasp_export_glb_sequence_holds_every_frame_switched_by_visibility(ply_run, tmp_path):
    import pygltflib
    out = tmp_path / "seq.glb"
    assert main(["export", str(ply_run), "--format", "glb_sequence", "-o", str(out)]) == 0
    doc = pygltflib.GLTF2().load_binary(str(out))
    blob = doc.binary_blob()
    assert doc.extensionsRequired == ["KHR_node_visibility"]
    frames = open_frames(ply_run)
    names = [n.name for n in doc.nodes]
    moving, static = (o["name"] for o in frames.manifest["objects"])
    assert names == [f"{moving}_frame_{f:04d}" for f in range(4)] + [f"{static}_static"]
    assert [n.extensions["KHR_node_visibility"]["visible"] for n in doc.nodes[:4]] == [True, False, False, False]
    (anim,) = doc.animations
    assert len(anim.channels) == 4 and {s.interpolation for s in anim.samplers} == {"STEP"}

    def column(i):
        acc = doc.accessors[i]
        view = doc.bufferViews[acc.bufferView]
        n = {"SCALAR": 1, "VEC3": 3}[acc.type]
        return np.frombuffer(blob, np.float32, acc.count * n, view.byteOffset).reshape(acc.count, n)

    times = column(anim.samplers[0].input)[:, 0]
    np.testing.assert_allclose(times, np.arange(4) * 0.0333333, rtol=1e-6)
    for c in anim.channels:   # 1.0 at its own frame only
        node = int(c.target.extensions["KHR_animation_pointer"]["pointer"].split("/")[2])
        np.testing.assert_array_equal(column(anim.samplers[c.sampler].output)[:, 0], np.arange(4) == node)
    for f in range(4):
        g = frames.gaussians(f, 0)
        pos = column(doc.meshes[doc.nodes[f].mesh].primitives[0].attributes.POSITION)
        np.testing.assert_allclose(pos, g.means @ Z_TO_Y.T, atol=1e-6 * _extent(g))


def test_simulate_format_usd_writes_one_file_beside_ply_frames(ply_run, tmp_path):
    pytest.importorskip("pxr", reason="usd-core (the export extra) is not installed")
    from pxr import Usd
    simulate_scene(load_scene(ply_run.parent / "scene.toml"), tmp_path / "u", quiet=True, fmt="usd")
    usd = list((tmp_path / "u").glob("*.usdc"))
    assert len(usd) == 1
    stage = Usd.Stage.Open(str(usd[0]))
    a = open_frames(ply_run)
    from gasp_core.run.usd_export import prim_name
    name = prim_name(a.manifest["objects"][0]["name"])
    got = np.asarray(stage.GetPrimAtPath(f"/Run/{name}").GetAttribute("positions").Get(Usd.TimeCode(3)))
    np.testing.assert_allclose(got, a.gaussians(3, 0).means, atol=1e-6 * _extent(a.gaussians(3, 0)))


def _splat_transform():
    exe = shutil.which("splat-transform")
    if exe is None:
        pytest.skip("splat-transform not installed (npm install -g @playcanvas/splat-transform)")
    return exe


def test_splat_transform_writes_the_same_glb_values_as_gasp(tmp_path, donut):
    """splat-transform (2.7 and 3.7 write GLB but read none, so it cannot read GASP's back) writes the same source as a
    KHR_gaussian_splatting GLB. Both files hold the same Gaussians: splat-transform turns a PLY 180 degrees about z
    (its -y up becomes glTF's +Y), GASP (up_axis -y) 180 degrees about x; the two differ by a half turn about the
    vertical, so every mean, rotation and SH coefficient of one is the other's turned so (within 1e-6 of the
    extent for means): the attribute names, xyzw order, linear scales, post-sigmoid opacity and SH order agree."""
    exe = _splat_transform()
    g = donut.subset(np.arange(0, donut.n, 40))
    from gasp_core.gs.io import write_gaussians
    write_gaussians(tmp_path / "src.ply", g)
    subprocess.run([exe, str(tmp_path / "src.ply"), str(tmp_path / "st.glb")], check=True, capture_output=True)
    write_glb(tmp_path / "gasp.glb", g, up_axis="-y")
    theirs = turned(read_glb(tmp_path / "st.glb"), Z_TO_Y)     # the files' own (+Y up) values
    ours = turned(read_glb(tmp_path / "gasp.glb"), Z_TO_Y)
    assert theirs.n == ours.n == g.n
    half_turn_about_y = np.diag([-1.0, 1.0, -1.0])
    mine = turned(ours, half_turn_about_y)
    np.testing.assert_allclose(theirs.means, mine.means, atol=1e-6 * _extent(g))
    np.testing.assert_allclose(theirs.means, g.means * [-1, -1, 1], atol=1e-6 * _extent(g))   # 180 deg about z
    np.testing.assert_allclose(theirs.scales, g.scales, rtol=1e-6)
    np.testing.assert_allclose(np.abs((theirs.rotations * mine.rotations).sum(1)), 1.0, atol=1e-5)
    np.testing.assert_allclose(theirs.sh_rest, mine.sh_rest, atol=1e-5)
    np.testing.assert_allclose(theirs.sh_dc, g.sh_dc, atol=1e-6)
    np.testing.assert_allclose(theirs.opacities, g.opacities, atol=1e-3)
