"""A dynamic model's released part starts with the velocity the model gives it (issue 31, item 2): the finite
difference of psi over one frame, on the real splaTV kitchen (examples/kitchen_spinach.toml)."""
from pathlib import Path

import numpy as np
import pytest

from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.prepare.scene import prepare_scene
from gasp_core.scene.spec import load_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _kitchen(extra: str = "", tmp_path: Path | None = None):
    src = EXAMPLES / "kitchen_spinach.toml"
    if not extra:
        return load_scene(src)
    text = src.read_text().replace('dynamic_time = 0.5', f'dynamic_time = 0.5\n{extra}')
    text = text.replace('"data/spinach_4.splatv"', f'"{EXAMPLES / "data" / "spinach_4.splatv"}"')
    path = tmp_path / "kitchen.toml"
    path.write_text(text)
    return load_scene(path)


def test_spinach_starts_with_the_models_velocity():
    """The spinach's triangle vertices v1 (its means) start with (psi(V, s + frame_dt) - psi(V, s)) / frame_dt,
    placed in the world (m/s); the model really moves it (a median speed above 1 mm/s)."""
    scene = _kitchen()
    prep = prepare_scene(scene)
    o = prep.objects[0]
    assert o.spec.velocity_from_model and o.surface.form != "cores"
    base, motion = read_splatv(o.spec.file)
    s, dt = o.spec.dynamic_time, scene.frame_dt
    m0 = o.placement.to_world(splatv_at(base, motion, s).means[o.moving])
    m1 = o.placement.to_world(splatv_at(base, motion, s + dt).means[o.moving])
    expect = (m1 - m0) / dt
    got = prep.setup.v[o.vertex_slice].reshape(-1, 3, 3)[:, 0]
    assert np.allclose(got, expect, rtol=1e-9, atol=1e-12)
    assert np.median(np.linalg.norm(expect, axis=1)) > 1e-3
    # every simulated point of the spinach has the velocity of its own vertex or of its nearest one
    assert np.isfinite(prep.setup.v).all()


def test_a_velocity_in_the_scene_replaces_the_models(tmp_path):
    scene = _kitchen("velocity = [0.0, 0.0, 0.0]", tmp_path)
    prep = prepare_scene(scene)
    assert not prep.objects[0].spec.velocity_from_model
    assert not prep.setup.v.any()


def test_a_static_file_has_no_model_velocity():
    scene = load_scene(EXAMPLES / "donut_jelly.toml")
    assert not scene.objects[0].velocity_from_model


def test_background_key(tmp_path):
    """``background`` (dynamic models only): "model" (default) plays the unselected rows on, "frozen" keeps them."""
    from gasp_core.errors import SceneError
    from gasp_core.prepare.dynamic import follows_model
    from gasp_core.prepare.placement import prepare_object
    frozen = _kitchen('background = "frozen"', tmp_path)
    o = prepare_object(frozen.objects[0])
    assert o.moving is not None and not follows_model(o)
    assert follows_model(prepare_object(_kitchen().objects[0]))
    text = (EXAMPLES / "donut_jelly.toml").read_text().replace('up_axis = "+z"', 'up_axis = "+z"\nbackground = "model"')
    text = text.replace('"data/donut_v3dg.ply"', f'"{EXAMPLES / "data" / "donut_v3dg.ply"}"')
    (tmp_path / "d.toml").write_text(text)
    with pytest.raises(SceneError, match="background is only for dynamic models"):
        load_scene(tmp_path / "d.toml")
