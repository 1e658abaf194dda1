"""``select = { file = "cut.ply" }``: a region chosen in a splat editor, matched to the file by position.

Real data: the V3DG donut. The "edit" is what SuperSplat exports after deleting splats: the kept splats
in another order, positions through float32, plus splats the file does not have.
"""
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from gasp_testing import DONUT

from gasp_core.errors import SceneError
from gasp_core.gs.io import read_gaussians, write_gaussians
from gasp_core.prepare.editor_cut import match_cut
from gasp_core.prepare.placement import prepare_object
from gasp_core.prepare.scene import input_files
from gasp_core.scene.spec import parse_scene

JELLY = '[object.material]\nname = "jelly"\nE = 2.0e4\nnu = 0.3\nrho = 300.0\n'


def _scene(select: str, src: Path):
    text = f"""
n_frames = 1
[engine]
name = "taichi_mpm"
[domain]
n_grid = 24
[[object]]
file = "{DONUT}"
position = [0.0, 0.0, 0.05]
{select}
{JELLY}
"""
    return parse_scene(tomllib.loads(text), src)


@pytest.fixture(scope="module")
def edit(tmp_path_factory):
    """The donut with every splat of file x > 0 deleted, shuffled, 1e-6 jitter, 3 splats added far off."""
    g = read_gaussians(DONUT)
    kept = np.flatnonzero(g.means[:, 0] <= 0.0)
    rng = np.random.default_rng(1)
    cut = g.subset(rng.permutation(kept))
    cut.means = cut.means + rng.normal(0, 1e-6, cut.means.shape)
    foreign = g.subset(np.arange(3))
    foreign.means = foreign.means + [0.0, 0.0, 1.0]
    both = cut.subset(np.arange(cut.n))
    for name in ("means", "scales", "rotations", "opacities", "sh_dc", "sh_rest"):
        setattr(both, name, np.concatenate([getattr(cut, name), getattr(foreign, name)]))
    d = tmp_path_factory.mktemp("cut")
    write_gaussians(d / "cut.ply", both)
    return d, kept, g


def test_kept_splats_are_the_selection_and_unmatched_ones_reported(edit):
    d, kept, g = edit
    with pytest.warns(UserWarning, match=r"3 of its \d+ splats match no Gaussian"):
        o = prepare_object(_scene('select = { file = "cut.ply" }', d / "s.toml").objects[0])
    assert np.array_equal(o.moving, kept)
    assert d / "cut.ply" in input_files(_scene('select = { file = "cut.ply" }', d / "s.toml"))


def test_deleted_splats_are_the_rest(edit):
    d, kept, g = edit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        o = prepare_object(_scene('select = { file = "cut.ply", take = "deleted" }', d / "s.toml").objects[0])
    assert np.array_equal(o.moving, np.flatnonzero(g.means[:, 0] > 0.0))


def test_tolerance_decides_what_matches():
    means = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0]])
    cut = np.array([[1.0004, 0, 0], [2.0, 0.002, 0]])
    rows, unmatched = match_cut(cut, means, 1e-3)
    assert rows.tolist() == [1] and unmatched.tolist() == [1]
    rows, unmatched = match_cut(cut, means, 3e-3)
    assert rows.tolist() == [1, 2] and unmatched.tolist() == []


def test_a_moved_edit_is_one_clear_error(edit, tmp_path):
    d, kept, g = edit
    moved = read_gaussians(d / "cut.ply")
    moved.means = moved.means + [0.01, 0.0, 0.0]      # 1 cm: the editor's transform was saved
    write_gaussians(tmp_path / "moved.ply", moved)
    with pytest.raises(SceneError, match=r"splats are farther than .* from every Gaussian of the object"):
        prepare_object(_scene('select = { file = "moved.ply" }', tmp_path / "s.toml").objects[0])


@pytest.mark.parametrize("select, match", [
    ('select = { file = "nope.ply" }', "is not a file"),
    ('select = { file = "cut.ply", take = "some" }', "take"),
    ('select = { box = { lo = [0, 0, 0], hi = [1, 1, 1] }, take = "kept" }', "applies to select = { file"),
    ('select = { file = "cut.ply", tolerance = -1 }', "tolerance"),
])
def test_bad_file_selection(edit, select, match):
    d, _, _ = edit
    with pytest.raises(SceneError, match=match):
        _scene(select, d / "s.toml")
