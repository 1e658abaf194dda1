"""The cup's pieces seen from their crack side (issue 66, the cup's must-show; docs/fracture.md, "Crack faces
against the piece's geometry"), on both grid engines.

The measure (``benchmarks/piece_silhouette.py``): a piece's silhouette is the projection of its geometry, the mesh's
solid where the nearest material point is the piece's, moved by the piece's rigid fit. Checked first on known
answers, whole convex-outlined bodies at rest (the cup, whose outside is a cylinder, a box and a sphere, each
prepared in mesh mode and seen from three sides): the silhouette's area is the area of the convex hull of the mesh's
projected vertices within 1 %, and the rendered body leaves under 2 % of it below alpha 0.9 (measured 0.004-0.83 %).
The footprint of the fill (discs of 0.75 spacing, the measure before round 31) is caught by the first: it reads
7-19 % larger. Then the broken cup (4.43 m/s, n_grid 80, 4 frames): each piece of 5 % of the mass or more, rendered
alone with its crack faces, drawn as ``gasp simulate`` draws them (kept to their side only across a gap,
``gasp_core.run.sides``), has under 2 % of its silhouette below alpha 0.9, and over 2 % without them (the catch: a
piece whose crack faces are removed). Until round 79 the pull rule (kept to their side where the fragments touch too)
was a second catch; the cup's pieces no longer touch at its last frame, so the two rules draw them alike, and that
catch is tests/test_sides.py's on touching pieces. A measure without the pieces' rigid fit reads 63 % on the largest piece (run
by hand).
"""
from __future__ import annotations

import sys
import warnings
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
sys.path.insert(0, str(ROOT / "tests"))

FRAMES = 4
MARK = 0.02          # the issue's: under 2 % of the silhouette below alpha 0.9
SIDES = ([1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [1.0, 1.0, 1.0])


def hull_area(cam, points: np.ndarray) -> float:
    """Area (pixels) of the convex hull of ``points`` (k, 3) projected by ``cam``."""
    from scipy.spatial import ConvexHull
    return float(ConvexHull(cam.project_points(points)[0]).volume)


def shape_scene(tmp_path: Path, shape: str):
    """The cup's scene (n_grid 80, taichi_mpm) with its mesh, or a box (6 x 4 x 3 cm) or a sphere (R 3 cm) subdivided
    to 5 mm edges and turned (30, 20, 10) degrees, in its place."""
    import trimesh
    from test_cup_drop import cup_scene
    from gasp_core.scene.spec import load_scene
    if shape == "cup":
        return cup_scene(tmp_path, "taichi_mpm", 4.43)
    m = trimesh.creation.box([0.06, 0.04, 0.03]) if shape == "box" else trimesh.creation.icosphere(3, 0.03)
    v, f = trimesh.remesh.subdivide_to_size(m.vertices, m.faces, 0.005)
    trimesh.Trimesh(v - [0.0, 0.0, v[:, 2].min()], f).export(tmp_path / f"{shape}.ply")
    cup_scene(tmp_path, "taichi_mpm", 4.43)
    text = (tmp_path / "cup_taichi_mpm_4.43.toml").read_text()
    cup_ply = (ROOT / "examples" / "data" / "cup_mesh.ply").as_posix()
    text = text.replace(cup_ply, (tmp_path / f"{shape}.ply").as_posix())
    text = text.replace("rotation = [90.0, 0.0, 0.0]", "rotation = [30.0, 20.0, 10.0]")
    (tmp_path / f"{shape}.toml").write_text(text)
    return load_scene(tmp_path / f"{shape}.toml")


@pytest.mark.slow
@pytest.mark.parametrize("shape", ["cup", "box", "sphere"])
def test_the_measure_reads_known_answers_on_whole_bodies(tmp_path, shape):
    import crack_faces as cf
    import piece_silhouette as ps
    from gasp_core.prepare.mesh import read_mesh
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.render.builtin import CpuRenderer
    from gasp_core.run.pieces import PieceTracker
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(shape_scene(tmp_path, shape), "taichi_mpm")
    s, o = prep.setup, prep.objects[0]
    geo = ps.object_geometry(s, o)
    render = CpuRenderer(jit=True)
    verts = o.placement.to_world(np.asarray(read_mesh(o.spec.mesh.path)[0].vertices, np.float64))
    whole = parts_at(prep, s.x, PieceTracker(s.x, s.body_id, s.p_mass, s.p_vol))
    fill = s.x[o.fill_slice]
    for side in SIDES:
        cam = cf.crack_camera(fill.mean(0), np.array(side), fill.min(0), fill.max(0), 480)
        sil = geo.silhouette(cam, s.x, np.zeros(len(s.x), np.int64), 0)
        hull = hull_area(cam, verts)
        assert sil.sum() == pytest.approx(hull, rel=0.01), f"from {side}: {sil.sum()} pixels, hull {hull:.0f}"
        foot = cf.silhouette(cam, fill, whole["h"])
        assert foot.sum() > 1.03 * hull                              # the footprint's bias, caught
        alpha = render(whole["surf"], cam)[1]
        assert np.mean(alpha[sil] < 0.9) < MARK


def run_cup(tmp_path: Path, engine: str):
    """The cup of tests/test_cup_drop.py at 4.43 m/s: ``(prep, x_rest, x_last, tracker)``."""
    from test_cup_drop import cup_scene
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.run import fragment_run
    from gasp_core.run.pieces import PieceTracker
    from gasp_core.seam.runner import RunStats
    scene = cup_scene(tmp_path, engine, 4.43)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        prep = prepare_scene(scene, engine)
    s = prep.setup
    tracker = PieceTracker(s.x, s.body_id, s.p_mass, s.p_vol)
    x = s.x.copy()
    with closing(fragment_run.frames(prep.info, s, RunStats(), FRAMES, tracker=tracker)) as recs:
        for r in recs:
            x = r.x.copy()
    return prep, x, tracker


def parts_at(prep, x, tracker, rule: str | None = "gap"):
    """``benchmarks/crack_faces.py``'s parts at ``x``, the pieces the run's tracker's (the fragments), the Gaussians
    and crack faces drawn with ``rule`` (``crack_faces.RULE``; default "gap", what ``gasp simulate`` draws)."""
    import crack_faces as cf
    import gasp_core.run.pieces as pieces_mod
    real, real_rule = pieces_mod.PieceTracker, cf.RULE
    pieces_mod.PieceTracker = lambda *a, **k: tracker
    cf.RULE = rule
    try:
        return cf.scene_parts(prep, x, np.zeros(len(x)))
    finally:
        pieces_mod.PieceTracker, cf.RULE = real, real_rule


@pytest.mark.slow
@pytest.mark.parametrize("engine", ["taichi_mpm", "warp_mpm"])
def test_the_cups_pieces_close_from_their_crack_side(tmp_path, engine):
    import crack_faces as cf
    import piece_silhouette as ps
    from gasp_core.render.builtin import CpuRenderer
    prep, x, tracker = run_cup(tmp_path, engine)
    geo = ps.object_geometry(prep.setup, prep.objects[0])
    render = CpuRenderer(jit=True)
    # the broken cup
    parts = parts_at(prep, x, tracker)
    rows = cf.measure_pieces(parts, x, np.zeros(len(x)), render, faces="fill", geometry=geo)
    assert len(rows) >= 2
    for r in rows:
        assert r["geo_fill"] < MARK, f"piece {r['piece']}: {100 * r['geo_fill']:.2f} % below alpha 0.9"
        assert r["geo_without"] > MARK                               # the catch: no crack faces
    # Round 79: the second catch, the pull rule (which trims faces and Gaussians where two fragments touch too),
    # no longer applies here: at the last frame the cup's pieces of 5 % or more lie 28-227 mm apart (3.7-30 dx,
    # taichi_mpm), none touching, and both rules draw them alike (0.111, 0.226, 0.593 % below alpha 0.9 each). The
    # gap rule against the pull rule on touching pieces is checked by tests/test_sides.py.
