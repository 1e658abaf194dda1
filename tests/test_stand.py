"""Can a body carry itself (issue 28, item 6): gasp_core.prepare.stand's E_crit and the warning `gasp simulate` gives.

Known answers: a uniform column of height L and section second moment I under its weight W needs
``E >= 0.97^3 W L^2 / (6 I)`` in the estimate's model (from the top of its 3 % footprint; Greenhill's exact
buckling load gives ``W L^2 / (7.84 I)``); a body
whose centre of mass lies beyond its footprint tips whatever its E. The slender figure is a box on two thin legs
made of flat Gaussians on its faces (what a scan gives), filled by the pipeline.
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from gasp_core.prepare.stand import stand_estimate, stand_warning
from gasp_core.testing.helpers import box_points

#: Torso (x, y, z sizes) and legs (side, height), metres: a 0.25 m figure standing on two 2 cm legs.
TORSO = (0.08, 0.05, 0.12)
LEG, LEG_H, LEG_GAP = 0.03, 0.13, 0.02


def test_uniform_column_matches_the_closed_form():
    a, L, rho = 0.02, 0.2, 300.0
    x, pv = box_points((0, 0, 0), (a, a, L), 0.002)
    est = stand_estimate(x, np.full(len(x), pv), rho)
    W, I = rho * 9.81 * a * a * L, a ** 4 / 12
    assert abs(est.E_crit / (0.97 ** 3 * W * L * L / (6 * I)) - 1) < 0.05, est     # from the footprint's top
    assert est.com_over_footprint


def test_a_leaning_column_tips_over():
    x, pv = box_points((0, 0, 0), (0.02, 0.02, 0.2), 0.002)
    x[:, 0] += 0.2 * x[:, 2]                       # sheared: the top is 2 widths over
    est = stand_estimate(x, np.full(len(x), pv), 300.0)
    assert not est.com_over_footprint
    assert "tips over" in stand_warning("col", est, 1e9)


def _figure(path):
    """Flat Gaussians (5 mm apart, thin axis along the face normal) on the faces of a box on two legs."""
    from scipy.spatial.transform import Rotation
    from gasp_core.gs.gaussians import Gaussians
    from gasp_core.gs.io import write_gaussians
    boxes = [((-LEG_GAP / 2 - LEG, -LEG / 2, 0.0), (-LEG_GAP / 2, LEG / 2, LEG_H)),
             ((LEG_GAP / 2, -LEG / 2, 0.0), (LEG_GAP / 2 + LEG, LEG / 2, LEG_H)),
             ((-TORSO[0] / 2, -TORSO[1] / 2, LEG_H), (TORSO[0] / 2, TORSO[1] / 2, LEG_H + TORSO[2]))]
    means, normals = [], []
    step = 0.005
    for lo, hi in boxes:
        lo, hi = np.array(lo), np.array(hi)
        for d in range(3):
            e1, e2 = [k for k in range(3) if k != d]
            u = np.arange(lo[e1] + step / 2, hi[e1], step)
            w = np.arange(lo[e2] + step / 2, hi[e2], step)
            U, Wg = np.meshgrid(u, w, indexing="ij")
            for side, sign in ((lo[d], -1.0), (hi[d], 1.0)):
                p = np.zeros((U.size, 3))
                p[:, e1], p[:, e2], p[:, d] = U.ravel(), Wg.ravel(), side
                n = np.zeros(3)
                n[d] = sign
                means.append(p)
                normals.append(np.tile(n, (len(p), 1)))
    means, normals = np.concatenate(means), np.concatenate(normals)
    quats = np.array([Rotation.align_vectors([n], [[1.0, 0.0, 0.0]])[0].as_quat() for n in normals])
    g = Gaussians(means=means, scales=np.tile([1e-8, step / 2, step / 2], (len(means), 1)),
                  rotations=quats[:, [3, 0, 1, 2]], opacities=np.full(len(means), 3.0, np.float32),
                  sh_dc=np.full((len(means), 3), 0.5, np.float32))
    return write_gaussians(path, g)


def _scene(ply, E: float, tmp_path, name: str) -> str:
    text = f"""
frame_dt = 0.0333333
n_frames = 30
[engine]
name = "warp_mpm"
[domain]
n_grid = 32
[[boundary]]
kind = "ground"
height = 0.0
friction = 0.8
[[object]]
file = "{ply}"
up_axis = "+z"
position = [0.0, 0.0, 0.0]
[object.material]
name = "jelly"
E = {E}
nu = 0.3
rho = 1000.0
"""
    p = tmp_path / f"{name}.toml"
    p.write_text(text)
    return p


def _warnings(ply, E: float, tmp_path) -> list[str]:
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        prepare_scene(load_scene(_scene(ply, E, tmp_path, f"E{E:.0f}")))
    return [str(w.message) for w in got if "carry its own weight" in str(w.message)]


def test_slender_figure_is_warned_below_its_E_crit(tmp_path):
    """The warning names the E it needs; at 5x that E there is none. `gasp info --rho` reports an E_crit too (its up
    axis is unsure, no cue gives the sign of its longest axis z, so it is judged standing along +z, the default)."""
    from gasp_core.cli.info import info
    ply = _figure(tmp_path / "figure.ply")
    lines = _warnings(ply, 1e4, tmp_path)
    assert len(lines) == 1 and "needs E of about" in lines[0], lines
    E_crit = float(lines[0].split("needs E of about ")[1].split(" Pa")[0])
    assert 1e5 < E_crit < 1e6, lines                  # measured 2.3e5 Pa at n_grid 32
    assert _warnings(ply, 0.5 * E_crit, tmp_path)
    assert not _warnings(ply, 5 * E_crit, tmp_path)
    d = info(ply, rho=1000.0, n_grid=32)
    assert d["stand_E_crit_Pa"] > 0 and d["stand_com_inside"] is True, d
    assert d["up_axis_guess"] == "unknown" and "+z" in d["stand_note"]


def test_a_dropped_donut_gets_no_stand_warning(tmp_path):
    """The README's donut (examples/donut_jelly.toml) falls onto the ground from 5 cm: not standing, no warning."""
    from pathlib import Path
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        prepare_scene(load_scene(Path(__file__).parents[1] / "examples" / "donut_jelly.toml"))
    assert not [str(w.message) for w in got if "own weight" in str(w.message) or "tips over" in str(w.message)]



def test_a_donut_lying_on_the_ground_does_not_tip_over():
    """examples/donut_wind.toml: the donut rests on its rounded underside, which touches the ground all round
    within a cell; its lowest 3 % alone (one side of the ring) said "tips over whatever its stiffness" (issue 38)."""
    from pathlib import Path
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        ps = prepare_scene(load_scene(Path(__file__).parents[1] / "examples" / "donut_wind.toml"))
    assert not [str(w.message) for w in got if "tips over" in str(w.message)]
    s = ps.setup
    assert not stand_estimate(s.x, s.p_vol, 300.0).com_over_footprint     # the lowest 3 % alone: one side
    assert stand_estimate(s.x, s.p_vol, 300.0, foot_depth=s.dx).com_over_footprint
