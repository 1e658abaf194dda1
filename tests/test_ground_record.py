"""``run.json`` states the ground in each object's file frame, where the output frames are."""
import json

import numpy as np

from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.gs.io import read_gaussians
from gasp_core.prepare.placed import Placement
from gasp_core.run.record import ground_in_file_frame


def test_ground_plane_maps_back_to_world_height():
    rng = np.random.default_rng(3)
    for R in (np.eye(3), np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]), quat_to_rotmat(rng.normal(size=4))):
        pl = Placement(R, 2.5, np.array([0.3, -0.2, 0.7]))
        g = ground_in_file_frame(pl, 0.1)
        x = rng.normal(size=(50, 3))
        z_world = pl.to_world(x)[:, 2]
        # n . x - offset is the height above the ground in file units
        np.testing.assert_allclose((x @ np.array(g["normal"]) - g["offset"]) * pl.scale, z_world - 0.1, atol=1e-12)
    # a -y-up file placed z up (R maps file -y to world +z): the ground is a plane y = const in the file
    g = ground_in_file_frame(Placement(np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]), 2.0, np.array([0, 0, 1.0])), 0.0)
    assert g["axis"] == "y" and g["at"] == 0.5


def test_run_json_ground_meets_the_landed_donut(donut_run):
    meta = json.loads((donut_run / "run.json").read_text())
    o = meta["objects"][0]
    (gr,) = o["ground_in_file_frame"]
    assert gr["axis"] == "z"
    lowest = min(read_gaussians(f).means[:, 2].min() for f in sorted((donut_run / o["name"]).glob("frame_*.ply")))
    # in the file frame of the written frames the falling donut reaches the ground and does not sink into it by
    # more than the contact band of issue 28 (0.25 dx: the particle contact is a penalty, its impact dips the lowest
    # Gaussians about 0.1 dx below the plane; the grid contact held them above it), nor float a cell above it
    dx = meta["domain"]["dx"]
    assert o["placement"]["scale"] == 1.0
    assert gr["at"] - 0.25 * dx <= lowest <= gr["at"] + 1.5 * dx
