"""Each Gaussian's piece and ``gasp export --split-pieces`` (issue 52, docs/fracture.md).

- :func:`gasp_core.run.pieces.gaussian_pieces` on a known layout: a triangle whose ``v1`` is in one piece and whose
  ``v2, v3`` are in another goes whole to ``v1``'s; pieces are numbered heaviest first; rows not simulated are -1.
  Shown to catch a labelling by ``v2`` (the straddling triangle then goes to the other piece).
- A real broken run (every 16th Gaussian of the README donut as a brittle biscuit landing at 4.43 m/s, warp_mpm,
  n_grid 32, 2 frames: measured 1 piece and 30 crumbs at frame 2, the crumbs that hold Gaussians under one number
  after the pieces) writes ``pieces_NNNN.npy`` per frame;
  exported with ``--split-pieces`` the GLB of each frame has one node per piece of that frame (and one with the piece's
  shown crack faces) and the USD one prim per piece of the last frame, each holding exactly the Gaussians labelled with it (positions equal to the PLY
  frame's, turned to the format's axes), and beside each a prim of its crack faces, time-sampled, hidden at frame 0 and
  shown where the frame's crack-face file shows them. Shown to catch an export that ignores the labels (one node: the count
  check fails). Without the flag the files are byte for byte those of a plain export.
"""
from __future__ import annotations

import json
import types

import numpy as np
import pytest
from gasp_testing import glb_nodes, needs_package

from gasp_core.cli.main import main
from gasp_core.maps.surface import SurfaceMap
from gasp_core.run.pieces import gaussian_pieces, read_pieces

pytest.importorskip("pygltflib", reason="the export extra (pip install -e '.[export]') is not installed")


def _object(n_gaussians: int, moving=None):
    """A stand-in for a PreparedObject: ``n`` unit triangles (the triangles form) and the rows that move."""
    n_sim = n_gaussians if moving is None else len(moving)
    tri = np.zeros((n_sim, 3, 3))
    surface = SurfaceMap(tri, np.broadcast_to(np.eye(3), (n_sim, 3, 3)), np.ones((n_sim, 3)))
    return types.SimpleNamespace(spec=types.SimpleNamespace(static=False), surface=surface,
                                 vertex_slice=slice(0, 3 * n_sim), moving=moving,
                                 gaussians=types.SimpleNamespace(n=n_gaussians))


def test_a_straddling_triangle_goes_to_its_v1s_piece_and_pieces_are_numbered_heaviest_first():
    o = _object(5, moving=np.array([0, 1, 3, 4]))                  # row 2 is not simulated
    # points: 4 triangles x 3 vertices, then 2 fill points; piece 7 is light, piece 2 heavy (the fill)
    labels = np.array([7, 7, 7, 7, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2])  # triangle 1: v1 in 7, v2 and v3 in 2
    mass = np.r_[np.zeros(12), 1.0, 1.0]
    mass[0] = 0.1
    out = gaussian_pieces(o, labels, mass)
    assert out.dtype == np.int32 and out.tolist() == [1, 1, -1, 0, 0]   # piece 2 (2 kg) is 0, piece 7 (0.1 kg) 1

    class ByV2(SurfaceMap):                                         # the mistake the check catches
        def anchors(self):
            return super().anchors() + 1
    o.surface = ByV2(o.surface.tri_rest, o.surface.rot_rest, o.surface.scales_rest)
    assert gaussian_pieces(o, labels, mass).tolist() != [1, 1, -1, 0, 0]


def test_the_crumbs_that_hold_gaussians_share_the_number_after_the_pieces():
    """Issue 66: crumbs are counted apart; their Gaussians go under one number (one debris node), not one a crumb."""
    o = _object(4)
    labels = np.repeat([0, 1, 2, 3], 3)                            # a triangle per label
    mass = np.array([3.0, 0, 0, 0.1, 0, 0, 2.0, 0, 0, 0.2, 0, 0])
    piece = np.array([True, False, True, False])                   # labels 1 and 3 are crumbs
    assert gaussian_pieces(o, labels, mass, piece).tolist() == [0, 2, 1, 2]
    assert gaussian_pieces(o, labels, mass).tolist() == [0, 3, 1, 2]   # without it: a number a crumb (caught)


def _labels(run, frame):
    return read_pieces(run, "donut_small", frame)


def test_every_frame_records_each_gaussians_piece(broken_run):
    rows = json.loads((broken_run / "run.json").read_text())["frames"]
    n = json.loads((broken_run / "frames.json").read_text())["objects"][0]["n_gaussians"]
    for r in rows:
        lab = _labels(broken_run, r["frame"])
        assert lab.shape == (n,) and lab.dtype == np.int32 and lab.min() >= 0
        present = np.unique(lab)
        assert present.tolist() == list(range(len(present)))       # numbered from 0 without a gap
        assert len(present) <= r["pieces"] + (r["debris"] > 0)      # a piece of fill points alone holds no Gaussian
    # the biscuit starts as one piece and crumbs come off (issue 66: what has come apart; 2 at the last frame since
    # round 29's brittle step, 3 or more before); the crumbs that hold a Gaussian share the number after the pieces
    # (one debris node in an export)
    assert rows[0]["pieces"] == 1 and rows[-1]["debris"] >= 1
    assert np.unique(_labels(broken_run, 2)).tolist() == list(range(rows[-1]["pieces"] + 1))


def test_split_glb_has_a_node_per_piece_holding_its_gaussians(broken_run, tmp_path):
    from gasp_core.gs.gltf import UP_TO_Z, Z_TO_Y
    from gasp_core.gs.io import read_gaussians
    from gasp_core.run.crack_output import read_crack_faces
    assert main(["export", str(broken_run), "--format", "glb", "-o", str(tmp_path / "split"), "--split-pieces"]) == 0
    M = (Z_TO_Y @ UP_TO_Z["+z"]).T
    n_faces = []
    for f in range(3):
        lab = _labels(broken_run, f)
        nodes = glb_nodes(tmp_path / "split" / "donut_small" / f"frame_{f:04d}.glb")
        pieces = sorted(n for n in nodes if not n.endswith("_faces"))
        assert pieces == [f"donut_small_piece_{k:03d}" for k in np.unique(lab)]
        means = read_gaussians(broken_run / "donut_small" / f"frame_{f:04d}.ply").means @ M
        for k in np.unique(lab):
            np.testing.assert_allclose(nodes[f"donut_small_piece_{k:03d}"], means[lab == k], atol=1e-6)
        faces = read_crack_faces(broken_run, "donut_small", f)          # each piece's shown crack faces, own node
        for k in np.unique(lab):
            shown = (faces.extra["piece"] == k) & (faces.opacities > 0)
            got = nodes.get(f"donut_small_piece_{k:03d}_faces")
            assert (got is None) == (not shown.any())
            if got is not None:
                np.testing.assert_allclose(got, faces.means[shown] @ M, atol=1e-6)
        n_faces.append(sum(len(v) for n, v in nodes.items() if n.endswith("_faces")))
    assert n_faces[0] == 0 and n_faces[1] > 0, n_faces


def test_the_split_glb_of_a_broken_run_opens_in_babylon_as_a_mesh_per_piece(broken_run, tmp_path):
    """Issue 52's must-show: the pieces of ``gasp export --split-pieces`` open as separate nodes in a real reader,
    Babylon.js's glTF loader in headless Chromium (tests/glb_browser.py): the last frame's GLB gives one
    ``GaussianSplattingMesh`` per node, named as written, each with that node's splats (its piece's Gaussians, or
    its shown crack faces). Skips without Chromium, playwright or Babylon.js (CI installs them)."""
    pytest.importorskip("playwright.sync_api", reason="playwright is not installed: pip install playwright")
    from glb_browser import INSTALL, babylon_dir, chromium, open_in_babylon
    if chromium() is None or babylon_dir() is None:
        pytest.skip(f"needs Chromium (apt-get install -y chromium) and Babylon.js ({INSTALL})")
    assert main(["export", str(broken_run), "--format", "glb", "-o", str(tmp_path / "split"), "--split-pieces"]) == 0
    glb = tmp_path / "split" / "donut_small" / "frame_0002.glb"
    written = {name: len(p) for name, p in glb_nodes(glb).items()}
    assert sum(not n.endswith("_faces") for n in written) >= 2     # the piece and the crumbs' node (issue 66 item 4)
    r = open_in_babylon(glb, tmp_path / "split.png", babylon_dir())
    assert "error" not in r, r
    assert r["classes"].count("GaussianSplattingMesh") == len(written), r
    assert dict(zip(r["names"], r["splats"])) == written, r
    # the plain export: the object's node and its shown crack faces' node, both read as splat meshes
    assert main(["export", str(broken_run), "--format", "glb", "-o", str(tmp_path / "plain")]) == 0
    glb = tmp_path / "plain" / "donut_small" / "frame_0002.glb"
    written = {name: len(p) for name, p in glb_nodes(glb).items()}
    assert sorted(written) == ["donut_small_crack_faces", "frame_0002"], written     # the frame node, then the faces
    r = open_in_babylon(glb, tmp_path / "plain.png", babylon_dir())
    assert "error" not in r and dict(zip(r["names"], r["splats"])) == written, r


def test_without_the_flag_and_the_crack_faces_the_glb_export_is_unchanged(broken_run, tmp_path):
    """Without ``--split-pieces`` (and with ``--no-crack-faces``: the plain export carries the crack faces,
    ``tests/test_export_crack_faces.py``) every frame is byte for byte ``write_glb`` of the frame."""
    from gasp_core.gs.gltf import write_glb
    from gasp_core.run.layout import open_frames
    assert main(["export", str(broken_run), "--format", "glb", "-o", str(tmp_path / "plain"), "--no-crack-faces"]) == 0
    frames = open_frames(broken_run)
    for f in range(3):
        write_glb(tmp_path / "ref.glb", frames.gaussians(f, 0), up_axis="+z", overwrite=True)
        got = (tmp_path / "plain" / "donut_small" / f"frame_{f:04d}.glb").read_bytes()
        assert got == (tmp_path / "ref.glb").read_bytes()
    assert "split_pieces" not in json.loads((tmp_path / "plain" / "export.json").read_text())


def test_split_usd_has_a_prim_per_piece_of_the_last_frame(broken_run, tmp_path):
    pytest.importorskip("pxr", reason="usd-core (the export extra) is not installed")
    from pxr import Usd
    from gasp_core.gs.io import read_gaussians
    out = tmp_path / "split.usdc"
    assert main(["export", str(broken_run), "--format", "usd", "-o", str(out), "--split-pieces"]) == 0
    stage = Usd.Stage.Open(str(out))
    obj = stage.GetPrimAtPath("/Run/donut_small")
    assert obj.GetTypeName() == "Xform"
    lab = _labels(broken_run, 2)
    prims = {p.GetName(): p for p in obj.GetChildren()}
    faces = read_gaussians(broken_run / "donut_small" / "crack_faces_0002.ply")
    with_faces = np.unique(faces.extra["piece"][faces.extra["piece"] >= 0])
    assert sorted(prims) == sorted([f"piece_{k:03d}" for k in np.unique(lab)]
                                   + [f"piece_{k:03d}_faces" for k in with_faces])
    for f in range(3):
        means = read_gaussians(broken_run / "donut_small" / f"frame_{f:04d}.ply").means   # +z up: USD's own
        for k in np.unique(lab):
            got = np.asarray(prims[f"piece_{k:03d}"].GetAttribute("positions").Get(Usd.TimeCode(f)))
            np.testing.assert_allclose(got, means[lab == k], atol=1e-6)
    # each piece's crack faces (those of the last frame), drawn from the frame their crack opens: none at frame 0
    for k in with_faces:
        rows = faces.extra["piece"] == k
        prim = prims[f"piece_{k:03d}_faces"]
        for f in range(3):
            ff = read_gaussians(broken_run / "donut_small" / f"crack_faces_{f:04d}.ply")
            np.testing.assert_allclose(np.asarray(prim.GetAttribute("positions").Get(Usd.TimeCode(f))),
                                       ff.means[rows], atol=1e-6)
            alpha = np.asarray(prim.GetAttribute("opacities").Get(Usd.TimeCode(f)))
            np.testing.assert_array_equal(alpha > 0.5, ff.opacities[rows] > 0)
            assert f > 0 or not (alpha > 0.5).any()
    assert sum((np.asarray(prims[f"piece_{k:03d}_faces"].GetAttribute("opacities").Get(Usd.TimeCode(2))) > 0.5).sum()
               for k in with_faces) > 0, "no face shown at the last frame of a broken run"


def test_split_pieces_is_refused_for_other_formats_and_runs_without_pieces(broken_run, tmp_path, capsys):
    assert main(["export", str(broken_run), "--format", "ply", "-o", str(tmp_path / "p"), "--split-pieces"]) == 2
    assert "--split-pieces writes --format glb or usd, not ply" in capsys.readouterr().err
    assert not (tmp_path / "p").exists()
    import shutil
    bare = tmp_path / "bare"
    shutil.copytree(broken_run, bare)
    for f in bare.glob("donut_small/pieces_*.npy"):
        f.unlink()
    assert main(["export", str(bare), "--format", "glb", "-o", str(tmp_path / "g"), "--split-pieces"]) == 2
    assert "the run has no pieces" in capsys.readouterr().err


def test_the_run_writes_crack_faces_hidden_while_whole_and_render_draws_them(broken_run):
    """``<object>/crack_faces_NNNN.ply`` (gasp_core.run.crack_output): one Gaussian per fill point of the brittle
    donut, every one hidden at frame 0 (whole), some shown once it has broken (measured 670 and 559 of 3 487 at frames
    1 and 2), and ``gasp render``'s run reader draws them with the object."""
    from gasp_core.render.run import load_run
    from gasp_core.run.crack_output import HIDDEN, SHOWN, read_crack_faces
    run = json.loads((broken_run / "run.json").read_text())
    n_fill = run["objects"][0]["n_fill_points"]
    shown = []
    for f in range(3):
        g = read_crack_faces(broken_run, "donut_small", f)
        assert g.n == n_fill and set(np.unique(g.opacities)) <= {np.float32(SHOWN), np.float32(HIDDEN)}
        shown.append(int((g.opacities > 0).sum()))
    assert shown[0] == 0 and 0.05 * n_fill < shown[1] < 0.5 * n_fill and shown[2] > 0, shown
    n_gauss = json.loads((broken_run / "frames.json").read_text())["objects"][0]["n_gaussians"]
    r = load_run(broken_run)
    from gasp_core.run.split_output import read_split   # the sub-triangle Gaussians of clamped triangles, drawn last
    sub = read_split(broken_run, "donut_small", 2)
    assert r.splats(2).n == n_gauss + n_fill + (0 if sub is None else sub.n)
    # hidden faces draw nothing: frame 0 renders as the object alone (the renderer's own rounding)
    from gasp_core.render.builtin import CpuRenderer
    from gasp_core.gs.camera import auto_camera
    from gasp_core.gs.splat_numpy import splats_from_gaussians
    alone = r.objects[0]["placement"]
    bare = splats_from_gaussians(r.read(0, 0), alone["R"], float(alone["scale"]), alone["t"],
                                 rest_rotmats=r.read(0, 0).rotmats())
    cam = auto_camera(bare.means.min(0), bare.means.max(0), 160, 120)
    with_faces, _ = CpuRenderer()(r.splats(0), cam)
    without, _ = CpuRenderer()(bare, cam)
    assert np.abs(with_faces - without).max() < 1e-4


def test_a_gaussian_straddling_a_crack_keeps_its_rest_shape_and_the_others_stretch(broken_run):
    """``rebuild(..., labels)``: the donut_small biscuit at rest with the ``v1-v2`` edge of ten Gaussians doubled; five of those ``v2`` are labelled with another piece (the triangle straddles a crack). The five keep
    their rest rotation and scales exactly (they belong to ``v1``'s piece, not stretched across the gap), the five
    others stretch (largest scale above rest, to the alpha cap), the untouched ones are as at rest; without the labels
    the straddling five stretch too (what the check catches)."""
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.run.frames import rebuild
    from gasp_core.scene.spec import load_scene
    prep = prepare_scene(load_scene(broken_run.parent / "scene.toml"))
    o, x0 = prep.objects[0], prep.setup.x
    rest = rebuild(o, x0, o.rot_rest)[0]
    rows = np.arange(len(x0))[o.vertex_slice][o.surface.shape_rows()]      # (n, 3) setup rows of v1, v2, v3
    x = x0.copy()
    x[rows[:10, 1]] += x0[rows[:10, 1]] - x0[rows[:10, 0]]          # the v1-v2 edge doubled
    labels = np.zeros(len(x0), np.int64)
    labels[rows[:5, 1]] = 1
    g, _, counts = rebuild(o, x, o.rot_rest, labels=labels)
    assert counts["straddling"] == 5
    np.testing.assert_allclose(g.scales[:5], rest.scales[:5], rtol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(g.rotations[:5] * rest.rotations[:5], 1)), 1.0, atol=1e-12)
    assert (g.scales[5:10].max(1) > 1.2 * rest.scales[5:10].max(1)).all()
    np.testing.assert_allclose(g.scales[10:], rest.scales[10:], rtol=1e-9)
    blind = rebuild(o, x, o.rot_rest)[0]
    assert (blind.scales[:5].max(1) > 1.2 * rest.scales[:5].max(1)).all()
