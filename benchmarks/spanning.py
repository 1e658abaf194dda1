"""The Gaussians drawn across two pieces, and the specks, frame by frame, with each rendering rule (issue 66, "What a
user sees"; docs/fracture.md, "Pieces that read as pieces"; :mod:`gasp_core.run.sides`).

One ``gasp simulate`` run of a broken scene records each frame's positions and piece labels; the frames are then
rebuilt again with each rule from the same positions (the rule changes what is drawn, not the physics):

* ``map``: each Gaussian where the map and the alpha rule put it (the paper's rule);
* ``hold``: a crumb's and a left-behind Gaussian moved with its piece (round 31, ``gasp_core.run.apart``);
* ``trim``: also each Gaussian kept on its own side of every crack (round 32, the trim rule, :func:`gasp_core.run.sides.keep_to_side`
  without its hosts);
* ``pull``: also a centre that the hold leaves on another piece's side pulled towards its host (the pull rule,
  :func:`gasp_core.run.sides.pull_to_side`);
* ``gap``: the same, but only where the two pieces are apart at that place (the gap rule,
  :class:`gasp_core.run.sides.PieceTree`: what ``gasp simulate`` draws now).

Per frame and rule: ``spanning`` (a Gaussian whose 2-sigma ellipse reaches the side of a piece not its own; with the
rule ``gap`` across a gap: where the pieces are apart), ``spanning_sides`` (the same without the gap: any other
piece's side, the pull rule's count), ``faces_spanning_sides`` (the crack faces so),
``spanning_any`` (the count without an own piece: its samples take two pieces, round 31's definition, 8 points on the
ellipse), ``spanning_split`` (the sub-Gaussians of clamped triangles, ``split_NNNN.ply``, counted as their parents),
``specks``, ``held``, ``trimmed``, ``pulled``, ``faces_spanning`` (the crack faces shown,
:mod:`gasp_core.maps.crack_faces`, whose 2-sigma ellipse reaches another piece's side: before the pull rule the faces were
drawn as made, with the rule ``pull`` they are kept to their side, :func:`gasp_core.run.sides.keep_faces_to_side`),
``faces_shown``, the largest scale over its rest value (the alpha rule's cap must hold) and the
rebuild's time.

Run: ``python benchmarks/spanning.py --scene donut_shatter --engine taichi_mpm --frames 10`` (also ``--scene
biscuit7``, the donut_small biscuit thrown down at 7 m/s, and ``--scene cup``, ``examples/cup_drop.toml``); results in
``benchmarks/results/spanning_<scene>_<engine>.{md,json}``; ``--keep DIR`` keeps the run (its frames drawn with the rule
``gap``) for ``gasp render``.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
RULES = {"map": (False, False, False, False), "hold": (True, False, False, False), "trim": (True, True, False, False),
         "pull": (True, True, True, False), "gap": (True, True, True, True)}


def scene_file(name: str, engine: str, frames: int, work: Path) -> Path:
    """The scene's file in ``work`` on ``engine`` for ``frames`` frames."""
    if name == "donut_shatter":
        text = (ROOT / "examples" / "donut_shatter.toml").read_text()
        text = text.replace('file = "data/', f'file = "{(ROOT / "examples" / "data").as_posix()}/')
    elif name == "cup":
        text = (ROOT / "examples" / "cup_drop.toml").read_text()
        text = text.replace('"data/cup_mesh.ply"', f'"{(ROOT / "examples" / "data" / "cup_mesh.ply").as_posix()}"')
    elif name == "biscuit7":
        from gasp_core.gs.io import read_gaussians, write_gaussians
        from gasp_testing import biscuit_scene_text
        donut = read_gaussians(ROOT / "examples" / "data" / "donut_v3dg.ply")
        ply = work / "donut_small.ply"
        write_gaussians(ply, donut.subset(np.arange(0, donut.n, 16)))
        text = biscuit_scene_text(ply.as_posix(), frames, 7.0)
    else:
        raise SystemExit(f"unknown scene {name}")
    import re
    text = re.sub(r"(?m)^n_frames = \d+", f"n_frames = {frames}", text)
    text = re.sub(r'(?m)^name = "(taichi_mpm|warp_mpm)"', f'name = "{engine}"', text)
    path = work / f"{name}.toml"
    path.write_text(text)
    return path


def record(scene: Path, out: Path) -> dict:
    """``gasp simulate`` of ``scene`` into ``out``; each frame's ``(frame, x, labels, pieces)``, the prepared scene."""
    from gasp_core.run import frames as fm
    from gasp_core.run.pipeline import simulate_scene
    from gasp_core.scene.spec import load_scene
    rec, real = {"frames": []}, fm.Rebuilder.__call__

    def recording(self, frame, x, labels=None, pieces=None):
        rec["prep"] = self.prep
        rec["frames"].append((frame, np.array(x), None if labels is None else np.array(labels),
                              None if pieces is None else np.array(pieces)))
        return real(self, frame, x, labels, pieces)
    from gasp_core.run import crack_output as co
    write = co.CrackOutput.write

    def writing(self, folder, frame, x, labels, damage, piece=None):
        rec["cracks"] = self
        rec.setdefault("damage", {})[frame] = None if damage is None else np.array(damage)
        return write(self, folder, frame, x, labels, damage, piece)
    fm.Rebuilder.__call__, co.CrackOutput.write = recording, writing
    try:
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            simulate_scene(load_scene(scene), out, quiet=True, overwrite=True)
        rec["wall_s"] = time.perf_counter() - t0
    finally:
        fm.Rebuilder.__call__, co.CrackOutput.write = real, write
    return rec


def faces_row(rec: dict, frame: int, x, labels, pieces, rule: str) -> dict:
    """The crack faces shown at ``frame`` and how many reach another piece's side, drawn with ``rule`` (module
    notes: only ``pull`` keeps them to their side)."""
    from gasp_core.maps.crack_faces import crack_face_gaussians
    from gasp_core.run.apart import apart_masks
    from gasp_core.run.sides import keep_faces_to_side
    cr = rec.get("cracks")
    if cr is None or not cr.objects or rec["damage"].get(frame) is None:
        return {"faces_spanning": 0, "faces_spanning_sides": 0, "faces_shown": 0}
    faces, lab = cr.objects[0][2], np.asarray(labels)
    means, rot, scales, visible = crack_face_gaussians(faces, x, lab, rec["damage"][frame])
    rows = np.asarray(faces.rows)
    if pieces is not None:
        visible &= np.asarray(pieces, bool)[lab[rows]]
    pts = rows[cr.mass[rows] > 0]
    pts = pts if pieces is None else pts[np.asarray(pieces, bool)[lab[pts]]]
    if len(pts) == 0:
        return {"faces_spanning": 0, "faces_spanning_sides": 0, "faces_shown": int(visible.sum())}
    from gasp_core.run.sides import PieceTree, opening
    tree = PieceTree(x[pts], lab[pts], opening(cr.vol[pts], cr.dx) if rule == "gap" else None)
    if rule in ("pull", "gap"):
        visible, _ = keep_faces_to_side(means, rot, scales, visible, lab[rows], tree, lab[pts], cr.reach, 2.0)
    v = np.flatnonzero(visible)
    span = apart_masks(means[v], rot[v], scales[v], x[pts], lab[pts], cr.reach, lab[rows][v], tree)[0]
    sides = apart_masks(means[v], rot[v], scales[v], x[pts], lab[pts], cr.reach, lab[rows][v])[0]
    return {"faces_spanning": int(span.sum()), "faces_spanning_sides": int(sides.sum()), "faces_shown": len(v)}


def split_spanning(o, g_split, seen: dict) -> int:
    """How many of the sub-Gaussians ``g_split`` (file frame, field ``parent``) span two pieces, each judged with its
    parent's own piece."""
    from gasp_core.gs.gaussians import quat_to_rotmat
    from gasp_core.run.apart import apart_masks
    if g_split is None or "points" not in seen:
        return 0
    pl = o.placement
    rows = np.asarray(g_split.extra["parent"])
    local = rows if o.moving is None else np.searchsorted(np.asarray(o.moving), rows)
    own = None if seen["own"] is None else np.asarray(seen["own"])[local]
    span, _ = apart_masks(pl.to_world(g_split.means), pl.R @ quat_to_rotmat(g_split.rotations),
                          g_split.scales * pl.scale, seen["points"], seen["piece"], seen["reach"], own,
                          seen.get("tree"))
    return int(span.sum())


def replay(rec: dict, rule: str) -> list[dict]:
    """The frames of ``rec`` rebuilt with ``rule`` (module notes); one row per frame."""
    from scipy.spatial import cKDTree
    from gasp_core.run import frames as fm
    from gasp_core.run.apart import apart_row
    seen = {}

    def watching(means, rot, scales, x_fill, lab_fill, mass_fill, pieces, reach, tree=None, own=None):
        keep = np.asarray(mass_fill) > 0
        if pieces is not None:
            keep &= np.asarray(pieces, bool)[np.asarray(lab_fill)]
        seen.update(points=np.asarray(x_fill)[keep], piece=np.asarray(lab_fill)[keep], reach=reach, own=own)
        seen["spanning_any"] = apart_row(means, rot, scales, x_fill, lab_fill, mass_fill, pieces, reach,
                                         cKDTree(seen["points"]))["spanning"]
        seen["spanning_sides"] = apart_row(means, rot, scales, x_fill, lab_fill, mass_fill, pieces, reach,
                                           cKDTree(seen["points"]), own)["spanning"]
        seen["tree"] = tree
        return apart_row(means, rot, scales, x_fill, lab_fill, mass_fill, pieces, reach, tree, own)
    rb = fm.Rebuilder(rec["prep"])
    rb.hold, rb.trim, rb.pull, rb.gap = RULES[rule]
    real, fm.apart_row = fm.apart_row, watching
    rows, rest = [], None
    try:
        for frame, x, labels, pieces in rec["frames"]:
            seen.clear()
            t0 = time.perf_counter()
            gs, row = rb(frame, x, labels, pieces)
            ms = 1e3 * (time.perf_counter() - t0)
            o = rec["prep"].objects[0]
            big = gs[0].scales.max(axis=1)
            rest = big if rest is None else rest
            rows.append({"frame": frame, "pieces": 0 if pieces is None else int(np.sum(pieces)),
                         **{k: row.get(k, 0) for k in ("straddling", "held", "trimmed", "pulled", "spanning",
                                                       "specks", "clamped")},
                         **faces_row(rec, frame, x, labels, pieces, rule),
                         "spanning_any": seen.get("spanning_any", 0),
                         "spanning_sides": seen.get("spanning_sides", 0),
                         "spanning_split": split_spanning(o, rb.last_split[0], seen), "split": row.get("split", 0),
                         "grown_max": float((big / rest).max()), "rebuild_ms": ms})
    finally:
        fm.apart_row = real
    return rows


def table(name: str, engine: str, rec: dict, res: dict) -> list[str]:
    """The markdown of one scene's figures."""
    frames = [r["frame"] for r in next(iter(res.values()))]
    out = [f"# Spanning and specks: {name}, {engine}, {len(frames) - 1} frames (load {os.getloadavg()[0]:.1f})", "",
           f"gasp simulate {rec['wall_s']:.1f} s; {res[list(res)[-1]][-1]['pieces']} pieces at the last frame.", "",
           "| rule | figure | " + " | ".join(str(f) for f in frames) + " |", "|---|---|" + "---|" * len(frames)]
    for rule in res:
        for key in ("spanning", "spanning_sides", "spanning_any", "spanning_split", "faces_spanning",
                    "faces_spanning_sides", "faces_shown", "specks", "held",
                    "trimmed", "pulled", "grown_max"):
            vals = [r[key] for r in res[rule]]
            cells = [f"{v:.3f}" if isinstance(v, float) else str(v) for v in vals]
            out.append(f"| {rule} | {key} | " + " | ".join(cells) + " |")
        ms = np.median([r["rebuild_ms"] for r in res[rule][1:]]) if len(frames) > 1 else 0.0
        out.append(f"| {rule} | rebuild ms (median) | {ms:.0f} |" + " |" * (len(frames) - 1))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="donut_shatter", choices=["donut_shatter", "biscuit7", "cup"])
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--keep", type=Path, default=None, help="keep the run here (drawn with the rule gap)")
    ap.add_argument("--rules", default=",".join(RULES), help="the rules replayed, comma-separated")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        rec = record(scene_file(a.scene, a.engine, a.frames, work), a.keep or work / "out")
        res = {rule: replay(rec, rule) for rule in a.rules.split(",")}
    stem = ROOT / "benchmarks" / "results" / f"spanning_{a.scene}_{a.engine}"
    Path(f"{stem}.json").write_text(json.dumps({"scene": a.scene, "engine": a.engine, "wall_s": rec["wall_s"],
                                                "rules": res}, indent=1, default=float))
    lines = table(a.scene, a.engine, rec, res)
    Path(f"{stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
