"""Issue 66 round 104: how the pieces of 5 % of one run move with the draw of its Grady's cells, under three rules for
the seeds: ``run`` (the code as it stands since round 103: drawn once, weighted to the impact), ``flaws`` (each point's
uniform drawn once, ordered by ``-ln(1 - u) / w``, Efraimidis & Spirakis 2006: a faster landing keeps the slower one's
seeds) and ``uniform`` (no weight to the impact). ``docs/fracture.md`` "Round 104". The rows of
``results/cell_draws104.jsonl`` labelled ``uniform_beside_parts`` came from a one-off patch of
``gasp_core.run.grady_cells.lay`` (the probe run first, and Grady's seeds drawn with no weight to the impact where it
found two parts or more; not kept: on the example's n_grid 64 it fell from 6 to 5 pieces at 7 m/s).

    python benchmarks/studies/cell_draws104.py --scheme run|flaws|uniform --case ball28|ball32|ring48|SHAPE@N
        [--draws 5] [--first 0] --out F

``ball28``/``ball32``: the pieces family's ball (``scenes_pieces.ball_setup``) at 4, 7, 10 m/s, pieces of 5 % at
frame 30 (``counted_run``); ``SHAPE@N``: ``scenes_pieces.shape_setup``'s ``SHAPE`` (``cube:0.16``, ``ball:0.14``)
on n_grid ``N``, the same way; ``ring48``: ``examples/donut_shatter.toml`` on n_grid 48 at 5.5 and 7 m/s, pieces of 5 %
at frame 8 (the run's tracker read at that frame). warp_mpm; cells laid as a run lays them (probed). Appends one JSON
line per draw to ``--out``. About 1 minute a draw for a ball, 2.5 for the ring (2 cores).
"""
from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.run import fragments, grady_cells
from gasp_core.run.pieces import tracker_for
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.testing.pieces_count import tracker_count
from gasp_core.testing.scenes_pieces import counted_run, shape_setup

SCENE = Path(__file__).resolve().parents[2] / "examples" / "donut_shatter.toml"


def split_flaws(x, material, spacing, impact, count, size, seed=0):
    """``fragments.split_body`` with its seeds the first ``count`` of the body's flaws (module docstring)."""
    x = np.asarray(x, np.float64)
    mat = np.flatnonzero(material)
    d = np.linalg.norm(x[mat] - np.asarray(impact, np.float64), axis=1)
    w = 1.0 / (d + size) ** 2
    u = np.random.default_rng(seed).random(len(w))
    seeds = np.argsort(-np.log1p(-u) / w, kind="stable")[:count]
    out = np.zeros(len(x), np.int64)
    out[mat] = cKDTree(x[mat][seeds]).query(x[mat])[1]
    return fragments.connected_cells(x, material, spacing, out)


def split_uniform(x, material, spacing, impact, count, size, seed=0):
    """``fragments.split_body`` with its seeds drawn uniformly over the body's points (no weight to the impact)."""
    x = np.asarray(x, np.float64)
    mat = np.flatnonzero(material)
    seeds = np.random.default_rng(seed).choice(len(mat), size=min(count, len(mat)), replace=False)
    out = np.zeros(len(x), np.int64)
    out[mat] = cKDTree(x[mat][seeds]).query(x[mat])[1]
    return fragments.connected_cells(x, material, spacing, out)


def ring_setups(speeds, n_grid: int):
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.scene.spec import load_scene
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for v in speeds:
            text = SCENE.read_text().replace("velocity = [0.0, 0.0, -4.43]", f"velocity = [0.0, 0.0, {-v}]")
            text = text.replace('file = "data/', f'file = "{SCENE.parent / "data"}/')
            path = Path(tmp) / f"ring_{v}.toml"
            path.write_text(text.replace("n_grid = 64 ", f"n_grid = {n_grid} "))
            out.append(prepare_scene(load_scene(path), "warp_mpm").setup)
    return out


def pieces_at(info, s, frames: int) -> int:
    t, e = tracker_for(s), build_engine(info, s)
    try:
        for _ in range(frames):
            e.step_frame()
        row = t.row(np.asarray(e.positions(), np.float64), np.asarray(e.damage(), np.float64))[0]
    finally:
        e.close()
    return tracker_count(row, float(s.p_mass.sum()), 0.05)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scheme", choices=("run", "flaws", "uniform"), required=True)
    ap.add_argument("--case", required=True, help="ball28, ball32, ring48 or SHAPE@N (module docstring)")
    ap.add_argument("--draws", type=int, default=5)
    ap.add_argument("--first", type=int, default=0, help="the first draw")
    ap.add_argument("--out", required=True, help="a JSON-lines file (appended to)")
    a = ap.parse_args(argv)
    if a.scheme != "run":
        grady_cells.split_body = split_flaws if a.scheme == "flaws" else split_uniform
    info = engines()["warp_mpm"]
    if a.case == "ring48":
        speeds, frames = (5.5, 7.0), 8
        setups = ring_setups(speeds, 48)
    else:
        speeds, frames = (4.0, 7.0, 10.0), 30
        shape, grid = a.case.split("@") if "@" in a.case else ("ball", a.case[4:])
        setups = [shape_setup(shape, v, int(grid)) for v in speeds]
    for k in range(a.first, a.first + a.draws):
        row = []
        for s0 in setups:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                s, _ = grady_cells.laid(s0, seed=k, info=info)
            row.append(pieces_at(info, s, frames) if a.case == "ring48"
                       else counted_run("warp_mpm", s, frames)["tracker_5"][-1])
        with open(a.out, "a") as f:
            f.write(json.dumps({"scheme": a.scheme, "case": a.case, "draw": k, "speeds": list(speeds),
                                "pieces5": row}) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
