"""The unselected rest of a capture as a collider (issue 54 item 2): only the part within the domain is built, and
as an open surface (a pan, a counter) whose footprints alone are solid, not a volume that fills its cavities.
Real data: the bundled kitchen (examples/kitchen_spinach.toml, the spinach selected in its pan)."""
from __future__ import annotations

import dataclasses
import warnings
from pathlib import Path

import numpy as np
import pytest

from gasp_core.colliders.sdf import SDF_PAD, SHELL_SAMPLES
from gasp_core.errors import SceneError
from gasp_core.prepare.assembly import domain_for
from gasp_core.prepare.colliders import build_colliders
from gasp_core.prepare.placement import prepare_object
from gasp_core.prepare.scene import around_selection
from gasp_core.scene.extras import ColliderSpec
from gasp_core.scene.spec import load_scene

KITCHEN = Path(__file__).resolve().parents[1] / "examples" / "kitchen_spinach.toml"


@pytest.fixture(scope="module")
def kitchen():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(KITCHEN)
        objects = [prepare_object(s) for s in scene.objects]
        scene = around_selection(scene, objects)[0]     # the ground under the selection, the rest a collider
        lo, hi = domain_for(scene, objects)
    dx = float(np.max(hi - lo)) / scene.domain.n_grid
    return scene, objects, lo, hi, dx


def _rest(scene, friction=0.6):
    spec = ColliderSpec(object=1, friction=friction, where="[[collider]] #1")
    return dataclasses.replace(scene, colliders=[spec])


def test_the_rest_of_a_capture_is_built_within_the_domain_and_open(kitchen):
    scene, objects, lo, hi, dx = kitchen
    (c,) = build_colliders(_rest(scene), objects, dx, lo, hi)
    side = np.array(c.phi.shape) * c.h
    # the domain padded by the SDF's own padding on both sides of the clip, not the kitchen (about 6 x 5 x 3 m)
    assert np.all(side <= (hi - lo) + (4 * SDF_PAD + 2) * c.h)
    x = objects[0].surface.points()
    bottom = np.percentile(x[:, 2], 5)
    # a point in the pan's cavity, 3 cm above the spinach's lowest twentieth, over its middle: free space
    probe = np.array([[*np.median(x[:, :2], axis=0), bottom + 0.03]])
    assert c.distance(probe, 0.0)[0] > 0.0
    # the spinach starts within a sample or two of the pan's surface (thickened by SHELL_SAMPLES), not buried in a
    # filled volume
    d = c.distance(x, 0.0)
    assert np.percentile(d, 10) > -(1 + SHELL_SAMPLES) * c.h and d.min() > -(3 + SHELL_SAMPLES) * c.h


def test_the_rest_as_a_solid_would_fill_the_pan(kitchen):
    """The check above against the solid collider (a static object's rule, the space the footprints enclose filled):
    the pan's cavity is inside it, which the open-surface rule avoids."""
    from gasp_core.colliders.sdf import collider_from_splats, SDF_PAD, SDF_SPACING
    from gasp_core.prepare.colliders import _collider_splats, _within
    scene, objects, lo, hi, dx = kitchen
    spec = _rest(scene).colliders[0]
    h = SDF_SPACING * dx
    splats = _within(_collider_splats(spec, objects), lo, hi, SDF_PAD * h, spec.where)
    solid = collider_from_splats(splats, h, shell=False)
    x = objects[0].surface.points()
    assert solid.distance(x, 0.0).min() < -10 * h                  # the spinach buried: the check would refuse it


def test_a_rest_outside_the_domain_is_refused_naming_the_collider(kitchen):
    scene, objects, lo, hi, dx = kitchen
    with pytest.raises(SceneError, match=r"\[\[collider\]\] #1: none of its Gaussians lies within"):
        build_colliders(_rest(scene), objects, dx, lo + 100.0, hi + 100.0)


def test_the_rest_is_carved_free_around_the_selection_so_it_can_start(kitchen):
    """The spinach lies in the pan's footprints (leaves and pan share samples): carved around the simulated points,
    no point starts inside, and the carve takes a small share of the rest's surface (the pan keeps its wall)."""
    from gasp_core.colliders.model import check_start
    scene, objects, lo, hi, dx = kitchen
    x = np.concatenate([objects[0].surface.points()])
    (whole,) = build_colliders(_rest(scene), objects, dx, lo, hi)
    (carved,) = build_colliders(_rest(scene), objects, dx, lo, hi, x)
    with pytest.raises(SceneError, match="start inside it"):
        check_start([whole], x)
    check_start([carved], x)
    solid_whole, solid_carved = int((whole.phi < 0).sum()), int((carved.phi < 0).sum())
    assert 0 < solid_whole - solid_carved < 0.05 * solid_whole


def _donut_with_opaque_selected(tmp_path, append=""):
    """The README donut with every Gaussian of opacity 0.1 or more selected: its unselected rest is its faint halo
    alone (what a click on the donut in the studio selects, its faint Gaussians joined to it)."""
    from scipy.special import expit
    from gasp_core.gs.io import read_gaussians
    data = KITCHEN.parent / "data" / "donut_v3dg.ply"
    opaque = expit(read_gaussians(data).opacities.astype(np.float64)) >= 0.1
    assert 0 < (~opaque).sum() < len(opaque)
    np.save(tmp_path / "opaque.npy", opaque)
    (tmp_path / "donut.toml").write_text(
        f'frame_dt = 0.04\nn_frames = 1\n[[object]]\nfile = "{data}"\nselect = {{ mask = "opaque.npy" }}\n'
        f'[object.material]\nname = "jelly"\n' + append)
    return load_scene(tmp_path / "donut.toml")


def test_a_rest_with_no_opaque_gaussian_is_no_collider_by_default(tmp_path):
    """The studio's click selects the donut with its faint halo joined, leaving a rest of transparent Gaussians only:
    no collider is made of it (CI's studio run failed here with a reshape of an empty array)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = _donut_with_opaque_selected(tmp_path)
        objects = [prepare_object(s) for s in scene.objects]
        scene = around_selection(scene, objects)[0]
        lo, hi = domain_for(scene, objects)
    assert [c.by_default for c in scene.colliders] == [True]
    dx = float(np.max(hi - lo)) / scene.domain.n_grid
    assert build_colliders(scene, objects, dx, lo, hi) == []
    # stated by hand, the same rest is refused, naming the key that would let it be built
    stated = _rest(scene)
    with pytest.raises(SceneError, match=r"\[\[collider\]\] #1: none of its Gaussians has an opacity of min_opacity"):
        build_colliders(stated, objects, dx, lo, hi)
