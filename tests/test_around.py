"""The scene around a selection (issue 54 item 2, :mod:`gasp_core.prepare.around`): the unselected rest is a collider
by default, a ground comes from the support under the selection, and the domain is set around what moves and where
it can reach; an explicit ``[domain]``, ``[[boundary]]`` or ``[[collider]]`` wins. Real data: the bundled kitchen."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.prepare.around import (REACH_LIMIT, STENCIL_CELLS, flight_reach, reach_domain, with_rest_colliders,
                                      with_support_ground)
from gasp_core.prepare.assembly import footprints
from gasp_core.prepare.placement import prepare_object
from gasp_core.scene.spec import load_scene
from gasp_testing import ROOT

KITCHEN = ROOT / "examples" / "kitchen_spinach.toml"
G = 9.81


def _kitchen(tmp_path: Path, replace=(), append: str = ""):
    text = KITCHEN.read_text().replace('"data/spinach_4.splatv"', f'"{KITCHEN.parent / "data" / "spinach_4.splatv"}"')
    for old, new in replace:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "kitchen.toml"
    path.write_text(text + append)
    return load_scene(path)


@pytest.fixture(scope="module")
def spinach():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        scene = load_scene(KITCHEN)
        return scene, [prepare_object(s) for s in scene.objects]


def test_the_rest_is_a_collider_by_default_and_a_key_turns_it_off(tmp_path):
    scene, lines = with_rest_colliders(load_scene(KITCHEN))
    (c,) = scene.colliders
    assert c.object == 1 and "rest_collider = false" in lines[0]
    off = _kitchen(tmp_path, [("\nselect = ", "\nrest_collider = false\nselect = ")])
    assert off.objects[0].rest_collider is False and with_rest_colliders(off) == (off, [])
    # an engine without static colliders, or one that makes a convex hull of their field (no grid): none, and the
    # line says why
    for features in ({"grid"}, {"static_colliders", "passive_points"}):
        same, (line,) = with_rest_colliders(load_scene(KITCHEN), features=frozenset(features))
        assert not same.colliders and "distance field on a grid" in line
    assert len(with_rest_colliders(load_scene(KITCHEN), features={"grid", "static_colliders"})[0].colliders) == 1


def test_an_explicit_collider_naming_the_object_wins(tmp_path):
    scene = _kitchen(tmp_path, append="\n[[collider]]\nobject = \"spinach_4\"\nfriction = 0.9\n")
    out, lines = with_rest_colliders(scene)
    assert [c.friction for c in out.colliders] == [0.9] and lines == []


def test_rest_collider_needs_a_selection(tmp_path):
    with pytest.raises(SceneError, match=r"rest_collider applies to an object with 'select'"):
        _kitchen(tmp_path, [("\nselect = { box = { lo = [-3.2, 6.1, 12.7], hi = [-0.4, 6.95, 14.8] } }",
                             "\nrest_collider = true")])


def test_the_ground_is_the_support_under_the_selection_unless_stated(tmp_path, spinach):
    scene, objects = spinach
    out, line = with_support_ground(scene, objects)
    (g,) = out.boundaries
    # the example measured the pan's bottom by hand at -0.565 m
    assert g.kind == "ground" and abs(g.height - (-0.565)) < 0.01 and "beneath the selection" in line
    stated = _kitchen(tmp_path, append="\n[[boundary]]\nkind = \"ground\"\nheight = -0.6\n")
    assert with_support_ground(stated, objects) == (stated, "")
    boxed = _kitchen(tmp_path, [("[domain]", "[domain]\nlo = [-0.41, 0.84, -0.66]\nhi = [0.14, 1.39, -0.11]")])
    assert with_support_ground(boxed, objects) == (boxed, "")


def test_free_flight_reach_is_ballistic_and_stops_at_the_ground():
    x = np.array([[0.0, 0.0, 1.0]])
    v = np.array([[1.0, 0.0, 2.0]])
    end, apex = flight_reach(x, v, (0, 0, -G), 10.0, 0.0)
    t = (2.0 + np.sqrt(4.0 + 2 * G)) / G                 # z = 1 + 2 t - g t^2 / 2 = 0
    assert end[0] == pytest.approx(t, rel=1e-9) and end[2] == pytest.approx(0.0, abs=1e-12)
    assert apex[2] == pytest.approx(1.0 + 4.0 / (2 * G), rel=1e-9) and apex[0] == pytest.approx(2.0 / G, rel=1e-9)
    end, _ = flight_reach(x, v, (0, 0, -G), 0.5, None)   # no ground: the run's duration
    assert end[2] == pytest.approx(1.0 + 1.0 - G / 8, rel=1e-9) and end[0] == pytest.approx(0.5)


def test_the_kitchens_domain_is_around_the_spinach_bounded_by_the_pan(spinach):
    scene, objects = spinach
    scene, _ = with_support_ground(scene, objects)
    fp = footprints(objects[0])
    lo, hi = reach_domain(scene, objects, fp)
    side = hi - lo
    assert np.allclose(side, side[0]) and np.all(fp >= lo) and np.all(fp <= hi)
    ext = float(np.max(np.ptp(fp, axis=0)))
    assert side[0] < 2.0 * ext                     # 0.538 m on the spinach's 0.317 m: the pan bounds the 1 s fall
    lowest = min(scene.boundaries[0].height, float(fp[:, 2].min()))
    assert lowest - lo[2] == pytest.approx(STENCIL_CELLS * side[0] / scene.domain.n_grid, rel=1e-9)


def test_a_fall_with_nothing_beneath_is_cut_at_the_limit(spinach):
    """No ground (the support not added): 1 s of free fall would reach 4.9 m below; the domain stops at
    REACH_LIMIT times the moving extent, keeps what moves inside, and says so."""
    scene, objects = spinach
    fp = footprints(objects[0])
    ext = float(np.max(np.ptp(fp, axis=0)))
    with pytest.warns(UserWarning, match="the domain is cut"):
        lo, hi = reach_domain(scene, objects, fp)
    assert np.allclose(hi - lo, REACH_LIMIT * ext) and np.all(fp >= lo) and np.all(fp <= hi)
    assert lo[2] < fp[:, 2].min() - 0.5 * ext          # grown downwards, the way it falls
