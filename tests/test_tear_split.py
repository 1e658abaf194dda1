"""A tear that stays closed until it parts (issue 52; docs/fracture.md, "Clamped triangles split"): the alpha rule's
clamped triangles of an object that tears are split into sub-triangle Gaussians (:mod:`gasp_core.maps.split`).

- A triangle stretched 4 times along ``e2`` at alpha 1.5 gives ``ceil(4 / 1.5) = 3`` sub-Gaussians at ``a = -2/3,
  0, 2/3`` of ``e2``, scales ``4 s / 3`` and ``s`` (known answer).
- A strip of flat Gaussians on 2 cm tiles, stretched 3 times along its length: the alpha (opacity) along its middle
  line, summed analytically, stays as at rest with the split (0.798 at least, one row at opacity 0.9) and falls
  below 0.5 with the rule alone. Shown failing on a split that makes one cell per edge (the parent again).
- ``rebuild`` on the plasticine T rod prepared (no engine) and stretched 3 times in z over a band of its neck: the
  band's triangles are split, none elsewhere; once the lower part is pulled 6 fill spacings away (parted), no
  sub-Gaussian lies in the gap. Shown failing on a split that ignores the material (``near_material`` always
  true). With the pieces of a broken body, a straddling triangle is not split.
"""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import gasp_core.maps.split as split_mod
from gasp_core.maps.games import alpha_rule, triangles_to_gaussians
from gasp_core.maps.split import split_triangles

S = 0.01   # m, the tiles' half side (the Gaussians' scale)


def test_a_triangle_stretched_four_times_splits_into_three_known_sub_gaussians():
    rest = np.array([[[0, 0, 0], [S, 0, 0], [0, S, 0]]], float)
    moved = np.array([[[0, 0, 0], [4 * S, 0, 0], [0, S, 0]]], float)
    parent, means, rot, scales, centres_rest = split_triangles(rest, moved, np.array([0]), 1.5)
    assert parent.tolist() == [0, 0, 0]
    np.testing.assert_allclose(means[:, 0], [-8 * S / 3, 0, 8 * S / 3], atol=1e-15)
    np.testing.assert_allclose(means[:, 1:], 0, atol=1e-15)
    np.testing.assert_allclose(scales[:, 1:], [[4 * S / 3, S]] * 3, rtol=1e-12)
    np.testing.assert_allclose(np.abs(rot[:, :, 0] @ [0, 0, 1]), 1, atol=1e-12)   # flat in the x-y plane
    np.testing.assert_allclose(centres_rest[:, 0], [-2 * S / 3, 0, 2 * S / 3], atol=1e-15)


def _strip(n=9):
    """Rest GaMeS triangles of ``n`` flat Gaussians on 2 S tiles along x (normal z), and their rest scales."""
    c = np.column_stack([2 * S * np.arange(n), np.zeros(n), np.zeros(n)])
    tri = np.stack([c, c + [S, 0, 0], c + [0, S, 0]], axis=1)
    return tri


def _alpha_on_line(means, rot, scales, xs, opacity=0.9):
    """Alpha ``1 - prod(1 - o G)`` at the points ``(x, 0, 0)`` of flat Gaussians in the x-y plane."""
    d = np.stack([xs, np.zeros_like(xs)], 1)[:, None, :] - means[None, :, :2]
    ax = rot[:, :2, 1:]                                             # in-plane axes, (n, 2, 2)
    loc = np.einsum("pni,nij->pnj", d, ax) / scales[None, :, 1:]
    g = np.exp(-0.5 * np.sum(loc ** 2, axis=2))
    return 1 - np.prod(1 - opacity * g, axis=1)


def _strip_alphas(max_split=split_mod.MAX_SPLIT):
    """Alpha along the middle of the strip stretched 3 times: at rest, with the rule alone, with the split; and
    the count of sub-Gaussians."""
    rest = _strip()
    moved = rest.copy()
    moved[..., 0] *= 3.0                                            # stretched 3 times along x
    _, _, sc_rest, _ = triangles_to_gaussians(rest)
    m, r, sc, _ = triangles_to_gaussians(moved)
    clamped_scales, clamped = alpha_rule(rest, moved, sc, sc_rest, 1.5)
    xs = np.linspace(moved[2, 0, 0], moved[6, 0, 0], 400)          # the middle of the strip
    at_rest = _alpha_on_line(*triangles_to_gaussians(rest)[:3], xs / 3.0)
    alone = _alpha_on_line(m, r, clamped_scales, xs)
    parent, sm, sr, ss, _ = split_triangles(rest, moved, np.flatnonzero(clamped.any(1)), 1.5, max_split)
    split = _alpha_on_line(np.concatenate([m, sm]), np.concatenate([r, sr]), np.concatenate([clamped_scales, ss]), xs)
    return at_rest, alone, split, len(parent)


def test_a_stretched_strip_stays_covered_with_the_split_and_not_with_the_rule_alone():
    at_rest, alone, split, n_sub = _strip_alphas()
    assert at_rest.min() > 0.79                                   # one row of tiles at opacity 0.9: 0.798
    assert alone.min() < 0.5, alone.min()                         # the hole the rule leaves
    assert split.min() >= at_rest.min() - 0.01, split.min()       # covered as at rest
    assert n_sub == 9 * 2                                         # ceil(3 / 1.5) = 2 cells along the stretch


def test_the_strip_check_catches_a_split_that_makes_one_cell_per_edge():
    _, _, split, n_sub = _strip_alphas(max_split=1)               # the parent again, clamped
    assert n_sub == 9 and split.min() < 0.5


# ----------------------------------------------------------------------------- the plasticine T rod, prepared
@pytest.fixture(scope="module")
def rod(tmp_path_factory):
    """The T rod of tests/test_brittle.py as plasticine, prepared (no engine is built)."""
    sys.path.insert(0, str(Path(__file__).parent))
    import test_brittle as tb
    from gasp_core.gs.io import write_gaussians
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    tmp = tmp_path_factory.mktemp("tear")
    write_gaussians(tmp / "rod.ply", tb.t_rod())
    text = tb.rod_scene_text("taichi_mpm", tmp / "rod.ply", 1.0).replace('name = "brittle"', 'name = "plasticine"')
    (tmp / "rod.toml").write_text(text.replace("tensile_strength = 1.0\nfracture_energy = 5.0",
                                               "yield_stress = 2700.0\nsoftening = 3.0"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return prepare_scene(load_scene(tmp / "rod.toml"))


Z_LO, Z_HI = 0.605, 0.665   # world z: the band of the neck that is stretched (the neck spans 0.45 to 0.75; tiles
#                             centred at 0.60 and 0.62, vertices 1 cm off them: triangles cross the foot)


def _stretched(x0, gap=0.0):
    """Positions with the band stretched 3 times in z (what is below it moved down with it), the lower part
    pulled a further ``gap`` metres down."""
    x = x0.copy()
    z = x0[:, 2]
    band = (z > Z_LO) & (z < Z_HI)
    x[band, 2] = Z_HI - 3 * (Z_HI - z[band])
    below = z <= Z_LO
    x[below, 2] = z[below] - 2 * (Z_HI - Z_LO) - gap
    return x


def _rebuild(prep, x, labels=None):
    from gasp_core.run.frames import rebuild, split_context
    o = prep.objects[0]
    ctx = split_context(o, prep.setup)
    assert ctx is not None                                        # plasticine with the alpha rule: it splits
    return rebuild(o, x, o.rot_rest, labels=labels, split=ctx)


def test_the_stretched_neck_is_split_and_nothing_else(rod):
    x0 = rod.setup.x
    o = rod.objects[0]
    _, _, c0 = _rebuild(rod, x0)
    assert c0["split"] == 0 and c0["split_gaussians"] is None     # at rest: nothing clamped, nothing written
    g, _, c = _rebuild(rod, _stretched(x0))
    sub = c["split_gaussians"]
    assert c["clamped"] > 0 and sub.n == c["split"] > 0
    vz = x0[o.vertex_slice].reshape(-1, 3, 3)[:, :, 2]
    stretched = (vz.max(1) > Z_LO) & (vz.min(1) < Z_HI)           # a vertex in the band, or across it
    parents = np.unique(sub.extra["parent"])
    assert set(parents) <= set(np.flatnonzero(stretched))        # only triangles of the stretched band split
    np.testing.assert_array_equal(sub.opacities, o.gaussians.opacities[sub.extra["parent"]])
    np.testing.assert_array_equal(sub.sh_dc, o.gaussians.sh_dc[sub.extra["parent"]])
    # each sub-Gaussian within alpha of its rest sub-triangle's scale, so within alpha S
    assert sub.scales[:, 1:].max() <= 1.5 * S * (1 + 1e-9)


def _in_gap(prep, sub, gap):
    """Which sub-Gaussians (file frame) lie inside the opened gap, world z in ``(foot - 0.8 gap, foot - 0.2 gap)``,
    ``foot`` the stretched band's foot (:func:`_stretched`: the lower part's top is ``gap`` under it)."""
    pl = prep.objects[0].placement
    zw = (pl.scale * sub.means @ pl.R.T + pl.t)[:, 2]
    foot = Z_HI - 3 * (Z_HI - Z_LO)
    return (zw < foot - 0.2 * gap) & (zw > foot - 0.8 * gap)


def test_once_the_neck_has_parted_no_sub_gaussian_bridges_the_gap(rod):
    h = float(np.max(rod.setup.p_vol[rod.objects[0].fill_slice])) ** (1 / 3)
    gap = 6 * h
    _, _, c = _rebuild(rod, _stretched(rod.setup.x, gap))
    sub = c["split_gaussians"]
    assert sub is not None and c["split"] > 0                    # the stretched band itself is still split
    assert not _in_gap(rod, sub, gap).any()


def test_the_gap_check_catches_a_split_blind_to_the_material(rod, monkeypatch):
    monkeypatch.setattr(split_mod, "near_material", lambda c, *a: np.ones(len(c), bool))
    h = float(np.max(rod.setup.p_vol[rod.objects[0].fill_slice])) ** (1 / 3)
    gap = 6 * h
    _, _, c = _rebuild(rod, _stretched(rod.setup.x, gap))
    assert _in_gap(rod, c["split_gaussians"], gap).any()


def test_a_triangle_straddling_a_crack_is_not_split(rod):
    x = _stretched(rod.setup.x)
    _, _, c = _rebuild(rod, x)
    labels = np.zeros(len(x), np.int64)
    labels[rod.setup.x[:, 2] <= Z_LO] = 1                          # a crack at the band's foot
    _, _, cl = _rebuild(rod, x, labels)
    assert cl["straddling"] > 0 and cl["split"] < c["split"]
    o = rod.objects[0]
    lab = labels[o.vertex_slice][o.surface.shape_rows()]
    straddle = np.flatnonzero((lab != lab[:, :1]).any(1))
    assert not np.isin(cl["split_gaussians"].extra["parent"], straddle).any()


@pytest.mark.slow
def test_a_tearing_run_writes_the_sub_gaussians_and_gasp_render_draws_them(tmp_path):
    """``gasp simulate``'s pipeline on the plasticine rod, 8 frames (its neck's clamp appears at frame 7, taichi_mpm):
    no ``split_NNNN.ply`` before anything is clamped, one at frame 8 whose rows match ``run.json``'s ``split`` and
    whose parents are rows of the object; ``gasp render``'s reader draws them after the object's rows and renders."""
    sys.path.insert(0, str(Path(__file__).parent))
    import json
    import test_brittle as tb
    from gasp_core.gs.io import write_gaussians
    from gasp_core.render.run import load_run, render_run
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.run.split_output import read_split
    from gasp_core.scene.spec import load_scene
    write_gaussians(tmp_path / "rod.ply", tb.t_rod())
    text = tb.rod_scene_text("taichi_mpm", tmp_path / "rod.ply", 1.0, 8).replace('name = "brittle"',
                                                                                'name = "plasticine"')
    # yield 1200 Pa: since the held region holds by ghost nodes (issue 66) the clamp no longer concentrates stress and
    # the rod at 2700 Pa does not yield in 16 frames; at 1200 its neck's clamp appears at frame 7 (32 sub-Gaussians)
    (tmp_path / "rod.toml").write_text(text.replace("tensile_strength = 1.0\nfracture_energy = 5.0",
                                                    "yield_stress = 1200.0\nsoftening = 3.0"))
    out = tmp_path / "run"
    simulate_scene(load_scene(tmp_path / "rod.toml"), out)
    rows = json.loads((out / "run.json").read_text())["frames"]
    assert read_split(out, "rod", 0) is None and rows[0].get("split", 0) == 0
    sub = read_split(out, "rod", 8)
    assert sub is not None and sub.n == rows[8]["split"] > 0, [r.get("split") for r in rows]
    n = tb.t_rod().n
    assert sub.extra["parent"].min() >= 0 and sub.extra["parent"].max() < n
    r = load_run(out)
    assert r.splats(0).n == n and r.splats(8).n == n + sub.n
    png = render_run(out, tmp_path / "frames", frames=[0, 8], width=96, height=72)
    assert len(list(Path(png).glob("*.png"))) == 2
