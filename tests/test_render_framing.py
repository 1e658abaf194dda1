"""The render frames what moves (issue 54, item 4): the default camera of ``gasp render`` and ``gasp view`` looks
at the simulated part of a run; ``--camera scene`` frames the whole scene. Measured on the kitchen's spinach (351
of 62,442 Gaussians): the projected bounding box of the moving rows' centres against the picture."""
import subprocess
import sys

import numpy as np
import pytest

from gasp_core.prepare.placement import prepare_object
from gasp_core.render import commands as render_cli
from gasp_core.render.run import FRAMINGS, Run, load_run, moving_mask, run_view
from gasp_core.gs.splat_numpy import splats_from_gaussians
from gasp_core.run.record import ranges_rows, row_ranges
from gasp_core.scene.spec import load_scene
from gasp_testing import ROOT

KITCHEN = ROOT / "examples" / "kitchen_spinach.toml"
#: The moving rows' projected box must cover at least this share of the picture's area (640 x 480).
MIN_SHARE = 0.35


def box_share(cam, x) -> float:
    """Share of the picture covered by the bounding box of the points ``x`` (n, 3) projected by ``cam``,
    clipped to the picture."""
    uv, z = cam.project_points(x[z_front(cam, x)])
    lo = np.clip(uv.min(axis=0), 0, [cam.width, cam.height])
    hi = np.clip(uv.max(axis=0), 0, [cam.width, cam.height])
    return float(np.prod(hi - lo) / (cam.width * cam.height))


def z_front(cam, x):
    return cam.project_points(x)[1] > cam.near


def test_row_ranges_round_trip():
    rows = np.array([0, 1, 2, 5, 7, 8, 100])
    assert row_ranges(rows) == [[0, 3], [5, 6], [7, 9], [100, 101]]
    assert np.array_equal(ranges_rows(row_ranges(rows)), rows)
    assert row_ranges(None) is None and row_ranges(np.zeros(0, int)) == []


def test_the_default_camera_frames_the_kitchens_spinach():
    """The kitchen at its model time 0.5, placed as its example places it: the default framing puts the 351
    moving Gaussians' box over at least 35 % of the picture (measured 0.47); framing the whole scene (the old
    default, ``--camera scene``) leaves them under 1 % (measured 0.001), so the check catches it."""
    scene = load_scene(KITCHEN)
    o = prepare_object(scene.objects[0])
    run = Run(KITCHEN.parent, [{"n_gaussians": o.gaussians.n, "moving_rows": row_ranges(o.moving)}], None,
              None, scene.frame_dt, "")
    mask = moving_mask(run)
    assert mask.sum() == len(o.moving) == 351
    pl = o.placement
    splats = splats_from_gaussians(o.gaussians, pl.R, pl.scale, pl.t)
    shares = {}
    for framing in FRAMINGS:
        shares[framing] = box_share(run_view([run], [splats], framing)[0].camera, splats.means[mask])
    assert shares["moving"] >= MIN_SHARE, shares
    assert shares["scene"] < 0.01, shares
    assert render_cli.FRAMINGS == FRAMINGS


def test_everything_moves_frames_the_whole_scene():
    """No selection (``moving_rows`` null) or a run recorded before the field: no mask, the whole sequence."""
    assert moving_mask(Run(ROOT, [{"n_gaussians": 5, "moving_rows": None}], None, None, 0.03, "")) is None
    assert moving_mask(Run(ROOT, [{"n_gaussians": 5}], None, None, 0.03, "")) is None
    static = [{"n_gaussians": 3, "static": True}, {"n_gaussians": 2, "moving_rows": None}]
    assert moving_mask(Run(ROOT, static, None, None, 0.03, "")).tolist() == [False] * 3 + [True] * 2


def test_a_brittle_objects_crack_faces_are_framed_with_it(tmp_path):
    """A run with a static object and a brittle one (examples/donut_shatter_on_guitar.toml) draws the brittle
    object's crack faces after its rows (Run.splats): the mask holds them, as moving (before, a mask one row per
    Gaussian made ``gasp render`` of that example fail: a boolean index of 136,478 on 153,595 splats)."""
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    from gasp_core.run.crack_output import CRACK_FILE
    (tmp_path / "biscuit").mkdir()
    write_gaussians(tmp_path / "biscuit" / CRACK_FILE.format(0), Gaussians(
        means=np.zeros((4, 3)), scales=np.full((4, 3), 0.01), rotations=np.tile([1.0, 0, 0, 0], (4, 1)),
        opacities=np.full(4, -30.0, np.float32), sh_dc=np.zeros((4, 3), np.float32)))
    objects = [{"name": "guitar", "n_gaussians": 3, "static": True},
               {"name": "biscuit", "n_gaussians": 2, "moving_rows": None}]
    assert moving_mask(Run(tmp_path, objects, None, None, 0.03, "")).tolist() == [False] * 3 + [True] * 6


@pytest.mark.slow
def test_gasp_render_of_the_kitchen_frames_the_spinach(tmp_path):
    """End to end: 2 frames of the kitchen example, then the camera ``gasp render`` uses by default."""
    out = tmp_path / "kitchen"
    subprocess.run([sys.executable, "-m", "gasp_core.cli.main", "simulate", str(KITCHEN), "-o", str(out),
                    "--frames", "2", "-q"], check=True, cwd=ROOT)
    run = load_run(out)
    mask = moving_mask(run)
    assert mask is not None and mask.sum() == 351
    frames = [run.splats(f) for f in range(run.n_frames)]
    cam = run_view([run], frames)[0].camera
    assert min(box_share(cam, s.means[mask]) for s in frames) >= MIN_SHARE
