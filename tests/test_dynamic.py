"""Dynamic scenes: G_t = T^-1(phi(psi(V, s), t)) with the real splaTV model as psi."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.errors import SceneError
from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.prepare.placement import prepare_object
from gasp_core.scene.spec import parse_scene

SPLATV = Path(__file__).resolve().parents[1] / "examples" / "data" / "spinach_4.splatv"


def scene(extra: str, file=SPLATV):
    import tomllib
    return parse_scene(tomllib.loads(f'[[object]]\nfile = "{file}"\nrecentre = false\n{extra}'), Path("/tmp/x.toml"))


def test_psi_at_s_is_what_physics_starts_from():
    base, motion = read_splatv(SPLATV)
    s = 0.6
    obj = prepare_object(scene(f"dynamic_time = {s}").objects[0])
    expect = splatv_at(base, motion, s)
    assert obj.gaussians.n == base.n == 62442
    assert np.array_equal(obj.gaussians.means, expect.means)
    # the model really moves between s = 0 and s = 0.6, so s matters
    assert np.median(np.linalg.norm(expect.means - splatv_at(base, motion, 0.0).means, axis=1)) > 1e-3
    # triangles start at psi(V, s): v1 = the means in world frame (identity placement here), for the simulated
    # rows (the room's detached floaters are written unchanged, issue 19)
    assert np.allclose(obj.tri_rest[:, 0], obj.simulated_rows(expect.means))


def test_dynamic_time_only_for_dynamic_models():
    donut = Path(__file__).resolve().parents[1] / "examples" / "data" / "donut_v3dg.ply"
    with pytest.raises(SceneError, match="dynamic_time"):
        scene("dynamic_time = 0.5", file=donut)
