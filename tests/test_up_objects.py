"""Issue 68, item 3: ``up = "auto"`` on object captures without a floor. The support plane of the scan
(issue 54) was unsure on the guitar under every rotation; the object's own axes now find its base
(``gasp_core/gs/support.py``, :func:`object_up`): each end of each principal axis moved to the plane of the flat
splats it would stand on, the up-axis cues read in the frame turned to it. Over 6 random rotations each of the
bundled guitar, the donut, the Stanford Bunny (a range scan; Gaussians laid on its faces, one a face) and Spot (Keenan
Crane's cow, a modelled mesh, public domain): within 3 degrees in at least 4 of 6, and never sure and more than 10
degrees off. Spot stays unsure (see the xfail)."""
import dataclasses
import functools
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gasp_core.errors import SceneError
from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.gs.support import estimate_up
from gasp_core.prepare.mesh import laid_gaussians
from gasp_core.prepare.placement import place
from gasp_core.scene.spec import ObjectSpec
from gasp_testing import DONUT, GUITAR, ROOT

SPOT = ROOT / "examples" / "data" / "spot_triangulated.obj"
BUNNY = ROOT / "examples" / "data" / "bun_zipper.ply"
#: Each object's up as its source states it (file frame) and how it is read.
OBJECTS = {"guitar": (lambda: read_gaussians(GUITAR), (0.0, -1.0, 0.0)),
           "donut": (lambda: read_gaussians(DONUT), (0.0, 0.0, 1.0)),
           "bunny": (lambda: laid_gaussians(BUNNY, 1), (0.0, 1.0, 0.0)),    # the scan is Y-up (its README)
           "spot": (lambda: laid_gaussians(SPOT, 4), (0.0, 1.0, 0.0))}      # the OBJ is Y-up (examples/spot_mesh.toml)
ROTATIONS = Rotation.random(6, random_state=68).as_matrix()
WITHIN, NEVER = 3.0, 10.0


def _turned(g, R):
    return dataclasses.replace(g, means=g.means @ R.T, rotations=rotmat_to_quat(R @ quat_to_rotmat(g.rotations)))


def _angle(a, b) -> float:
    return float(np.degrees(np.arccos(np.clip(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b), -1, 1))))


@functools.lru_cache(maxsize=None)
def _answers(name: str) -> list:
    """``(sure, degrees off)`` of ``estimate_up`` on the object turned by each of :data:`ROTATIONS`."""
    load, truth = OBJECTS[name]
    g = load()
    out = []
    for R in ROTATIONS:
        e = estimate_up(_turned(g, R))
        off = _angle(e.up if e.up is not None else (e.lean.normal if e.lean is not None else R @ truth), R @ truth)
        out.append((e.up is not None, off))
    return out


@pytest.mark.parametrize("name", list(OBJECTS))
def test_never_sure_and_more_than_10_degrees_off(name):
    wrong = [(i, round(off, 1)) for i, (sure, off) in enumerate(_answers(name)) if sure and off > NEVER]
    assert not wrong, wrong


@pytest.mark.parametrize("name", ["guitar", "donut", "bunny", pytest.param("spot", marks=pytest.mark.xfail(
    strict=True, reason="Spot stays unsure under every rotation: its hooves' soles are tilted 10-20 degrees and hold "
                        "0.9 % of its splats; in its own frame the flat-area cue (meaningless on a mesh with legs: "
                        "equal splats, no reconstructed base) says -y against the support slab's +y"))])
def test_up_within_3_degrees_in_4_of_6_rotations(name):
    got = _answers(name)
    good = sum(sure and off <= WITHIN for sure, off in got)
    assert good >= 4, [(s, round(o, 2)) for s, o in got]


def test_up_auto_stands_a_turned_guitar_upright():
    """``up = "auto"`` in a scene on the guitar turned by a random rotation: its -y lands on world +z within 3
    degrees (the support plane alone refused it as unsure)."""
    R = ROTATIONS[0]
    pl = place(_turned(read_gaussians(GUITAR), R), ObjectSpec(file=GUITAR, up="auto"))
    assert _angle(pl.R @ (R @ np.array(OBJECTS["guitar"][1])), [0, 0, 1]) < WITHIN


def test_up_auto_takes_the_captures_cameras(tmp_path):
    """Spot turned, unsure from its geometry: ``up = "auto"`` is refused; with a ``cameras.json`` of upright
    cameras beside the file the cameras decide; cameras 90 degrees off a sure answer veto it."""
    R = ROTATIONS[1]
    g = _turned(laid_gaussians(SPOT, 4), R)
    path = write_gaussians(tmp_path / "spot.ply", g)
    with pytest.raises(SceneError, match=r"up = \"auto\" is unsure"):
        place(g, ObjectSpec(file=path, up="auto"))
    up = R @ np.array(OBJECTS["spot"][1])

    def cameras(u):             # every camera upright about u: its y axis (down) is -u
        side = np.cross(u, [0.3, 0.5, 0.1])
        side /= np.linalg.norm(side)
        Rc = np.stack([side, -u, np.cross(side, -u)], axis=1)
        (tmp_path / "cameras.json").write_text(json.dumps([{"rotation": Rc.tolist(), "position": [0, 0, 0]}] * 3))
    cameras(up)
    pl = place(g, ObjectSpec(file=path, up="auto"))
    assert _angle(pl.R @ up, [0, 0, 1]) < 1e-6
    G = _turned(read_gaussians(GUITAR), R)
    gpath = tmp_path / "guitar.ply"
    write_gaussians(gpath, G)
    cameras(np.cross(R @ np.array(OBJECTS["guitar"][1]), [1.0, 0, 0]) / np.linalg.norm(
        np.cross(R @ np.array(OBJECTS["guitar"][1]), [1.0, 0, 0])))
    with pytest.raises(SceneError, match="disagrees"):
        place(G, ObjectSpec(file=gpath, up="auto"))
