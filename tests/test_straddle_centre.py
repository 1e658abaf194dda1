"""A Gaussian straddling a crack between pieces that move rigidly sits where its anchor piece's motion takes it
(issue 66 item 5: the rigid fragments of a stiff brittle body; ``gasp_core.run.frames.turn_with_pieces``).

The cup of examples/cup_drop.toml in mesh mode (its Gaussians bound to the mesh's faces; no engine is built), cut by
the plane x = 0.003 m into two pieces: the piece with x below turns 20 degrees about x through the cup's centre and
moves 5 cm away, a gap opening at the cut. Every straddling Gaussian (its face's vertices in both pieces) anchored
there must be at ``R (m_rest - c) + c + shift`` within 1e-6 m, one anchored in the other piece at its rest centre.
The face's map centre, which the old rule kept, lies in the gap, centimetres off (run here by leaving the centres out:
it fails). A piece that deforms (stretched 10 % along z: its fit's residual is millimetres) keeps the map's centres,
off the rigid prediction by more than 1e-4 m.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import gasp_core.run.frames as frames_mod

ROOT = Path(__file__).resolve().parents[1]
X_CUT = 0.003
SHIFT = np.array([-0.05, 0.0, 0.01])


def rot_x(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


@pytest.fixture(scope="module")
def cup(tmp_path_factory):
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    tmp = tmp_path_factory.mktemp("cup")
    text = (ROOT / "examples" / "cup_drop.toml").read_text().replace(
        '"data/cup_mesh.ply"', f'"{(ROOT / "examples" / "data" / "cup_mesh.ply").as_posix()}"')
    (tmp / "cup.toml").write_text(text.replace("n_grid = 96", "n_grid = 80"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return prepare_scene(load_scene(tmp / "cup.toml"), "warp_mpm")


def moved(cup, stretch: float = 1.0):
    """The straddling rows' anchors' pieces, their rebuilt world centres and the rigid prediction."""
    o, x0 = cup.objects[0], cup.setup.x
    labels = (x0[:, 0] < X_CUT).astype(np.int64)                # 1: the moved piece
    lab = labels[o.vertex_slice][o.surface.shape_rows()]
    straddle = np.flatnonzero((lab != lab[:, :1]).any(1))
    centre = x0.mean(0)
    R = rot_x(np.radians(20.0))
    x, low = x0.copy(), labels == 1
    rel = x0[low] - centre
    rel[:, 2] *= stretch
    x[low] = rel @ R.T + centre + SHIFT
    g = frames_mod.rebuild(o, x, o.rot_rest, labels=labels)[0]
    got = o.placement.to_world(g.means)[straddle]
    m_rest = o.surface.tri_rest[straddle, 0]
    want = np.where((lab[straddle, 0] == 1)[:, None], (m_rest - centre) @ R.T + centre + SHIFT, m_rest)
    return lab[straddle, 0], got, want


def test_a_straddler_of_a_rigid_piece_moves_with_it(cup):
    anchor, got, want = moved(cup)
    assert (anchor == 1).sum() > 10 and (anchor == 0).sum() > 10
    err = np.linalg.norm(got - want, axis=1)
    assert err.max() < 1e-6, err.max()


def test_the_centre_check_catches_the_map_centre_and_spares_a_deforming_piece(cup, monkeypatch):
    anchor, got, want = moved(cup, stretch=1.1)
    assert np.linalg.norm(got - want, axis=1)[anchor == 1].max() > 1e-4   # deforming: the map's centres kept
    real = frames_mod.turn_with_pieces
    monkeypatch.setattr(frames_mod, "turn_with_pieces", lambda o, x, sr, lab, st, rot, means=None:
                        real(o, x, sr, lab, st, rot))                     # the old rule: the face's map centre
    anchor, got, want = moved(cup)
    assert np.linalg.norm(got - want, axis=1).max() > 1e-3
