"""Issue 66 round 61 ("What a user sees"): where the donut shatter's beige and pink fans come from.

Runs ``examples/donut_shatter.toml`` in-process (taichi_mpm, its own n_grid 64) and at the frames asked draws, from
the docs' camera, (1) every Gaussian, (2) every Gaussian with those over broken material (at least half of the four
fill points nearest its rest centre at ``d >= 0.9``) clamped to their rest scales, (3) the Gaussians over whole
material alone; counts both kinds. Writes ``docs/fracture_donut_fans.png`` and ``benchmarks/results/donut_fans.md``.

    python benchmarks/studies/donut_fans.py [--frames 2,5]
"""
from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np
from PIL import Image
from scipy.spatial import cKDTree

from gasp_core.gs.splat_numpy import splats_from_gaussians
from gasp_core.prepare.scene import prepare_scene
from gasp_core.render.registry import get_renderer
from gasp_core.render.run import label_image, make_view, to_uint8
from gasp_core.run import pieces
from gasp_core.run.frames import Rebuilder
from gasp_core.scene.spec import load_scene
from gasp_core.seam.runner import EngineRun, RunStats

ROOT = Path(__file__).resolve().parents[2]
BROKEN = 0.9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", default="2,5")
    args = ap.parse_args()
    want = [int(f) for f in args.frames.split(",")]
    prep = prepare_scene(load_scene(ROOT / "examples" / "donut_shatter.toml"))
    o, stats = prep.objects[0], RunStats()
    pl, rb, tracker = o.placement, Rebuilder(prep), pieces.tracker_for(prep.setup)
    rest = rb(0, prep.setup.x)[0][0]
    _, host = cKDTree(np.asarray(prep.setup.x, float)[o.fill_slice]).query(o.surface.tri_rest[:, 0], k=4)
    moving = np.arange(len(rest.means)) if o.moving is None else np.asarray(o.moving)
    view = make_view(np.array([-0.3, -0.3, 0]), np.array([0.3, 0.3, 0.4]), 0.0, 480, 360, 45.0,
                     np.array([0.35, -0.75, 0.45]), np.array([0.0, 0.0, 0.1]))
    rend, rows, lines = get_renderer(), [], ["| frame | fill broken through | Gaussians over broken material | over whole |",
                                              "|---|---|---|---|"]
    with EngineRun(prep.info, prep.setup, stats) as run:
        for rec in run.frames(max(want)):
            d = np.asarray(stats.damage)
            gs, _ = rb(rec.frame, rec.x, tracker.labels(rec.x, d), tracker.pieces)
            if rec.frame not in want:
                continue
            g = gs[0]
            broken = np.zeros(len(g.means), bool)
            broken[moving] = (d[o.fill_slice][host] >= BROKEN).mean(axis=1) >= 0.5
            drawn = np.asarray(g.opacities, float) > -20.0
            sc = np.array(g.scales, copy=True)
            sc[broken, 1:] = np.minimum(sc[broken, 1:], np.asarray(rest.scales)[broken, 1:])
            sp = splats_from_gaussians(g, pl.R, float(pl.scale), pl.t)
            sp_rest = splats_from_gaussians(replace(g, scales=sc), pl.R, float(pl.scale), pl.t)
            tiles = []
            for name, m, s in [("all", drawn, sp), ("broken at rest scale", drawn, sp_rest),
                               ("over whole only", drawn & ~broken, sp)]:
                img, _ = rend(s.subset(m).seen_from(view.camera.position), view.camera, view.background)
                tiles.append(label_image(to_uint8(img), f"frame {rec.frame}: {name}"))
            rows.append(np.concatenate(tiles, 1))
            lines.append(f"| {rec.frame} | {(d[o.fill_slice] >= BROKEN).mean():.3f} | {int((broken & drawn).sum())} | "
                         f"{int((~broken & drawn).sum())} |")
    im = Image.fromarray(np.concatenate(rows, 0))
    im.resize((im.width * 2 // 3, im.height * 2 // 3)).save(ROOT / "docs" / "fracture_donut_fans.png")
    out = ROOT / "benchmarks" / "results" / "donut_fans.md"
    out.write_text("# The donut shatter's fans (issue 66 round 61; benchmarks/studies/donut_fans.py)\n\n"
                   + "\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
