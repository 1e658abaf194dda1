"""``gasp export`` without ``--split-pieces`` carries a brittle body's crack faces (issue 52 item 3, docs/fracture.md).

On the broken donut_small biscuit (``broken_run``, tests/conftest.py: its crack-face files show none at frame 0 and
some at frames 1 and 2), the known answer is the run's own ``<object>/crack_faces_NNNN.ply``:

- ``glb``: each frame's file holds the object's node (named ``frame_NNNN`` as a plain GLB frame's, the frame's
  Gaussians, positions equal to the PLY frame's) and, where faces are shown, ``<object>_crack_faces`` with exactly
  the shown ones (hidden ones left out); frame 0 (none shown) is byte for byte the plain frame; ``export.json``
  records the shown count per frame;
- ``ply``: the object's rows first and unchanged, then exactly the shown faces (colour kept, SH padded with 0);
- ``usd``: ``/Run/<object>`` as before and ``/Run/<object>_crack_faces`` with every face, positions time-sampled
  equal to the crack-face file's, opacity above 0.5 exactly where the file shows the face (none at frame 0);
- ``glb_sequence``: each frame's node holds its rows, then the faces shown at that frame;
- ``--no-crack-faces`` leaves them out.

Shown failing (by hand) on the export before the change (no faces: all four fail), on an
export that writes every face, hidden ones too (frame 0 then holds a faces node, and the row counts differ), and
on one that puts the faces before the object's rows (the row check fails).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from gasp_core.cli.main import main
from gasp_testing import glb_nodes

pytest.importorskip("pygltflib", reason="the export extra (pip install -e '.[export]') is not installed")

NAME = "donut_small"


def _faces(run, f):
    from gasp_core.run.crack_output import read_crack_faces
    return read_crack_faces(run, NAME, f)


def test_the_glb_export_has_a_node_with_the_shown_crack_faces(broken_run, tmp_path):
    from gasp_core.gs.gltf import UP_TO_Z, Z_TO_Y, write_glb
    from gasp_core.gs.io import read_gaussians
    from gasp_core.run.layout import open_frames
    assert main(["export", str(broken_run), "--format", "glb", "-o", str(tmp_path / "g")]) == 0
    M = (Z_TO_Y @ UP_TO_Z["+z"]).T
    counts = []
    for f in range(3):
        nodes = glb_nodes(tmp_path / "g" / NAME / f"frame_{f:04d}.glb")
        faces = _faces(broken_run, f)
        shown = faces.opacities > 0
        counts.append(int(shown.sum()))
        means = read_gaussians(broken_run / NAME / f"frame_{f:04d}.ply").means @ M
        own = f"frame_{f:04d}"                                   # the node's name as write_glb gives it
        np.testing.assert_allclose(nodes[own], means, atol=1e-6)
        if shown.any():
            assert list(nodes) == [own, f"{NAME}_crack_faces"]
            np.testing.assert_allclose(nodes[f"{NAME}_crack_faces"], faces.means[shown] @ M, atol=1e-6)
        else:
            assert list(nodes) == [own]
    assert counts[0] == 0 and counts[1] > 0 and counts[2] > 0, counts
    write_glb(tmp_path / "ref.glb", open_frames(broken_run).gaussians(0, 0), up_axis="+z")
    assert (tmp_path / "g" / NAME / "frame_0000.glb").read_bytes() == (tmp_path / "ref.glb").read_bytes()
    assert json.loads((tmp_path / "g" / "export.json").read_text())["crack_faces"] == {NAME: counts}
    # --no-crack-faces: the object's node alone at every frame
    assert main(["export", str(broken_run), "--format", "glb", "-o", str(tmp_path / "bare"), "--no-crack-faces"]) == 0
    assert all(list(glb_nodes(tmp_path / "bare" / NAME / f"frame_{f:04d}.glb")) == [f"frame_{f:04d}"]
               for f in range(3))
    assert "crack_faces" not in json.loads((tmp_path / "bare" / "export.json").read_text())


def test_the_ply_export_puts_the_shown_crack_faces_after_the_objects_rows(broken_run, tmp_path):
    from gasp_core.gs.io import read_gaussians
    assert main(["export", str(broken_run), "--format", "ply", "-o", str(tmp_path / "p")]) == 0
    for f in range(3):
        got = read_gaussians(tmp_path / "p" / NAME / f"frame_{f:04d}.ply")
        own = read_gaussians(broken_run / NAME / f"frame_{f:04d}.ply")
        faces = _faces(broken_run, f)
        shown = faces.subset(np.flatnonzero(faces.opacities > 0))
        assert got.n == own.n + shown.n
        for field in ("means", "scales", "opacities", "sh_dc", "sh_rest"):
            np.testing.assert_array_equal(getattr(got, field)[:own.n], getattr(own, field))
        np.testing.assert_allclose(got.means[own.n:], shown.means, atol=1e-12)
        np.testing.assert_array_equal(got.opacities[own.n:], shown.opacities)
        np.testing.assert_array_equal(got.sh_dc[own.n:], shown.sh_dc)
        assert not got.sh_rest[own.n:].any()
    assert shown.n > 0


def test_the_usd_export_has_a_time_sampled_prim_with_every_crack_face(broken_run, tmp_path):
    pytest.importorskip("pxr", reason="usd-core (the export extra) is not installed")
    from pxr import Usd
    from gasp_core.gs.io import read_gaussians
    out = tmp_path / "run.usdc"
    assert main(["export", str(broken_run), "--format", "usd", "-o", str(out)]) == 0
    stage = Usd.Stage.Open(str(out))
    assert sorted(p.GetName() for p in stage.GetPrimAtPath("/Run").GetChildren()) == [NAME, f"{NAME}_crack_faces"]
    prim, obj = stage.GetPrimAtPath(f"/Run/{NAME}_crack_faces"), stage.GetPrimAtPath(f"/Run/{NAME}")
    shown_at = []
    for f in range(3):
        faces = _faces(broken_run, f)
        np.testing.assert_allclose(np.asarray(prim.GetAttribute("positions").Get(Usd.TimeCode(f))), faces.means,
                                   atol=1e-6)
        alpha = np.asarray(prim.GetAttribute("opacities").Get(Usd.TimeCode(f)))
        np.testing.assert_array_equal(alpha > 0.5, faces.opacities > 0)
        shown_at.append(int((alpha > 0.5).sum()))
        means = read_gaussians(broken_run / NAME / f"frame_{f:04d}.ply").means
        np.testing.assert_allclose(np.asarray(obj.GetAttribute("positions").Get(Usd.TimeCode(f))), means, atol=1e-6)
    assert shown_at[0] == 0 and shown_at[1] > 0, shown_at
    out2 = tmp_path / "bare.usdc"
    assert main(["export", str(broken_run), "--format", "usd", "-o", str(out2), "--no-crack-faces"]) == 0
    bare = Usd.Stage.Open(str(out2))
    assert [p.GetName() for p in bare.GetPrimAtPath("/Run").GetChildren()] == [NAME]


def test_the_glb_sequence_draws_each_frames_shown_faces_with_it(broken_run, tmp_path):
    from gasp_core.gs.gltf import UP_TO_Z, Z_TO_Y
    from gasp_core.gs.io import read_gaussians
    out = tmp_path / "run.glb"
    assert main(["export", str(broken_run), "--format", "glb_sequence", "-o", str(out)]) == 0
    nodes = glb_nodes(out)
    M = (Z_TO_Y @ UP_TO_Z["+z"]).T
    for f in range(3):
        faces = _faces(broken_run, f)
        means = read_gaussians(broken_run / NAME / f"frame_{f:04d}.ply").means @ M
        want = np.concatenate([means, faces.means[faces.opacities > 0] @ M])
        np.testing.assert_allclose(nodes[f"{NAME}_frame_{f:04d}"], want, atol=1e-6)
