"""Issue 39 item 5: how far PhysGaussian's ``F`` (estimated at each centre from its neighbours' motion,
``gasp_core.maps.centres``) rebuilds a Gaussian from its own triangle's ``F`` (the vertex layout), on one engine run.

One run of the vertex layout (``surface_points = "vertices"``); at every frame each Gaussian is rebuilt two ways
with the covariance rule (``F Sigma F^T``): from its moved triangle (the triangle's own ``F``), and from its moved
centre ``v1`` with ``F`` fitted to the motion of its 16 nearest rest neighbours among the other centres and the
fill (the centres layout's estimate, fed the same motion). The means are the same point; the covariances differ by
the estimate alone, as ``||S_centres - S_vertices||_F / ||S_vertices||_F`` per Gaussian. On a passive surface the
centres layout has this very motion (the same fill, the same gather); on a material one its physics differs too
(measured in U by ``benchmarks/bench_accuracy.py``, ``docs/speed_accuracy.md``).

    python benchmarks/studies/centres_vs_vertices.py --scene guitar --frames 12   # passive (the default level's)
    python benchmarks/studies/centres_vs_vertices.py --scene donut --frames 12    # material

Writes ``benchmarks/results/centres_vs_vertices_<scene>.md``.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import time
from pathlib import Path

import numpy as np

from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.maps.centres import build_centre_frame
from gasp_core.prepare.scene import prepare_scene
from gasp_core.run.frames import rebuild
from gasp_core.scene.spec import load_scene
from gasp_core.seam.runner import run_engine

ROOT = Path(__file__).resolve().parents[2]
SCENES = {"guitar": (ROOT / "examples" / "guitar_sand.toml", "passive"),
          "donut": (ROOT / "examples" / "donut_jelly.toml", "material")}


def covariances(rot: np.ndarray, scales_w: np.ndarray) -> np.ndarray:
    """In-plane ``R diag(s^2) R^T`` (world frame, m^2), shape (n, 3, 3), from world rotations and scales."""
    return np.einsum("nij,nj,nkj->nik", rot[:, :, 1:], scales_w[:, 1:] ** 2, rot[:, :, 1:])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", choices=sorted(SCENES), default="guitar")
    ap.add_argument("--frames", type=int, default=12)
    args = ap.parse_args()
    path, surface = SCENES[args.scene]
    scene = load_scene(path)
    scene.objects = [dataclasses.replace(o, surface=surface, surface_points="vertices", rebuild="covariance",
                                         core_fraction=1.0) for o in scene.objects]
    t0 = time.perf_counter()
    prep = prepare_scene(scene)
    (o,) = prep.objects
    vs = np.arange(o.vertex_slice.start, o.vertex_slice.stop, 3)          # every triangle's v1 = its centre
    fill = np.arange(o.fill_slice.start, o.fill_slice.stop)
    frame = build_centre_frame(prep.setup.x, vs, np.r_[vs, fill])
    est = dataclasses.replace(o, centres=frame)
    prev = {"v": o.rot_rest, "c": o.rot_rest}
    rows = []
    for rec in run_engine(prep.info, prep.setup, args.frames):
        out = {}
        for k, obj in (("v", o), ("c", est)):
            g, prev[k], _ = rebuild(obj, rec.x, prev[k])
            R = obj.placement.R @ quat_to_rotmat(g.rotations)
            out[k] = (g.means, covariances(R, g.scales * obj.placement.scale))
        assert np.array_equal(out["v"][0], out["c"][0])
        cv, cc = out["v"][1], out["c"][1]
        rel = np.linalg.norm(cc - cv, axis=(1, 2)) / np.maximum(np.linalg.norm(cv, axis=(1, 2)), 1e-30)
        rows.append((rec.frame, float(np.median(rel)), float(np.percentile(rel, 95)), float(np.percentile(rel, 99)),
                     float(rel.max()), float((rel > 0.10).mean())))
        print(f"frame {rec.frame}: median {rows[-1][1]:.2%}, p95 {rows[-1][2]:.2%}, > 10 %: {rows[-1][5]:.1%}",
              flush=True)
    wall = time.perf_counter() - t0
    lines = [f"# PhysGaussian's F from the neighbours against the triangle's own F: {args.scene}", "",
             f"`python benchmarks/studies/centres_vs_vertices.py --scene {args.scene} --frames {args.frames}` "
             f"(engine `{prep.info.name}`, surface `{surface}`, {len(o.tri_rest):,} Gaussians, {len(fill):,} fill "
             f"points, {frame.n_degenerate} degenerate neighbourhoods, {int((frame.rank == 2).sum())} planar; "
             f"{wall:.0f} s; 1-min load average at the end {os.getloadavg()[0]:.1f}).", "",
             "Per Gaussian, `||S_centres - S_vertices||_F / ||S_vertices||_F` of the in-plane covariance rebuilt "
             "by `F Sigma F^T` from the same engine run (same means).", "",
             "| frame | median | p95 | p99 | max | share > 10 % |", "|---|---|---|---|---|---|"]
    lines += [f"| {f} | {a:.2%} | {b:.2%} | {c:.2%} | {d:.1%} | {e:.1%} |" for f, a, b, c, d, e in rows]
    out_path = ROOT / "benchmarks" / "results" / f"centres_vs_vertices_{args.scene}.md"
    out_path.write_text("\n".join(lines) + "\n")
    print(f"wrote {out_path}")


if __name__ == "__main__":
    main()
