"""Thin parts by local thickness (issue 54, item 5): the jelly guitar at n_grid 64 is warned about its neck, named by
where it is, with the n_grid that would put 2 cells across it; a well-resolved donut is not; a slab of known
thickness beside a thick block is found at its thickness, and the block's trimmed edges are not a part."""
import dataclasses
import re
import warnings

import numpy as np
import pytest

from gasp_core.prepare.assembly import build_setup
from gasp_core.prepare.checks import check_resolution
from gasp_core.prepare.placement import prepare_object
from gasp_core.prepare.thickness import MIN_PART_CELLS, thin_parts
from gasp_core.scene.spec import load_scene
from gasp_testing import ROOT

EXAMPLES = ROOT / "examples"


def _lattice(lo, hi, h):
    axes = [np.arange(a, b + 1e-9, h) for a, b in zip(lo, hi)]
    return np.array(np.meshgrid(*axes, indexing="ij")).reshape(3, -1).T


@pytest.mark.parametrize("layers, thin", [(2, True), (3, True), (4, True), (6, False)])
def test_a_slab_beside_a_block_is_found_at_its_thickness(layers, thin):
    """Points on a lattice of h = 1 cm (as a fill lays them): a 40 x 40 cm slab of ``layers`` point layers beside a
    20 cm block, dx = 2 cm, so parts under 4 cm are thin. The slab measures its layers within half a voxel; 6 layers
    (6 cm) are not thin; the block's edges are never a part. The bounding box of the whole (40 x 60 x 20 cm) says
    nothing: 10 cells across its smallest side."""
    h, dx = 0.01, 0.02
    slab = _lattice((0, 0, 0), (0.4, 0.4, (layers - 1) * h), h)
    block = _lattice((0.41, 0, 0), (0.6, 0.4, 0.2), h)
    parts = thin_parts(np.vstack([slab, block]), h, dx)
    if not thin:
        assert parts == []
        return
    assert len(parts) == 1, parts
    (p,) = parts
    assert abs(p["thickness"] - layers * h) <= 0.5 * h + 1e-9, p
    assert p["hi"][0] <= 0.42 and p["side"] == "-x" and p["length"] >= 0.38


def _guitar(n_grid: int):
    src = (EXAMPLES / "guitar_sand.toml").read_text()
    src = (src.replace('name = "sand"', 'name = "jelly"').replace("friction_angle = 35.0", "")
           .replace("rho = 1600.0", "rho = 1000.0").replace("n_grid = 64", f"n_grid = {n_grid}")
           .replace('"data/guitar.compressed.ply"', f'"{EXAMPLES / "data" / "guitar.compressed.ply"}"'))
    return src


def _thin_warnings(scene):
    objs = [prepare_object(s) for s in scene.objects]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        build_setup(scene, objs)
    return [str(m.message) for m in w if "thin part" in str(m.message)]


@pytest.mark.slow
def test_the_jelly_guitar_at_n_grid_64_is_warned_about_its_neck(tmp_path):
    """The guitar stands 1.11 m tall: its first (longest) thin part lies at its +z end, in its top half (the neck
    and head, measured z 0.585-1.111 m, 1.6 grid cells across), and the warning names the n_grid for 2 cells
    (measured 136, from its thinnest part). The bounding-box rule of check_resolution says nothing of it."""
    p = tmp_path / "guitar_jelly.toml"
    p.write_text(_guitar(64))
    msgs = _thin_warnings(load_scene(p))
    assert len(msgs) == 1, msgs
    first = re.search(r"at its \+z end, ([\d.]+) m long, ([\d.]+) grid cells across .*?within \[[^\]]*\] to "
                      r"\[[^\]]*\] m\)", msgs[0])
    assert first and msgs[0].split("of the fill): ")[1].startswith("at its +z end"), msgs[0]
    lo_z, hi_z = (float(v) for v in re.findall(r"within \[[^,]+, [^,]+, ([-\d.]+)\] to \[[^,]+, [^,]+, ([-\d.]+)\]",
                                                 msgs[0])[0])
    assert lo_z >= 0.5 and hi_z >= 1.05 and float(first.group(2)) < MIN_PART_CELLS
    need = int(re.search(r"n_grid >= (\d+)", msgs[0]).group(1))
    assert need > 64
    dx = float(re.search(r"dx = ([\d.]+) m", msgs[0]).group(1))
    assert check_resolution("guitar", np.array([0.37, 0.37, 1.11]), dx, 64, None) == []


def test_a_well_resolved_donut_has_no_thin_part():
    assert _thin_warnings(load_scene(EXAMPLES / "donut_jelly.toml")) == []


def test_a_solid_is_not_warned_by_its_bounding_box():
    """The README donut at n_grid 32 is 7.3 cells across its smallest axis (the tube) and has no part under 2
    cells: no resolution line (the bounding-box rule warned "7.3 grid cells across its smallest", issue 54)."""
    scene = load_scene(EXAMPLES / "donut_jelly.toml")
    scene = dataclasses.replace(scene, domain=dataclasses.replace(scene.domain, n_grid=32))
    objs = [prepare_object(s) for s in scene.objects]
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        build_setup(scene, objs)
    assert not [str(m.message) for m in w if "grid cells across" in str(m.message)]
