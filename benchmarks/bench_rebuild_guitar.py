"""The two ``T^-1`` rebuild rules side by side on the sand guitar (``examples/guitar_sand.toml``).

One engine run; every frame's moved triangles are rebuilt both ways (``rebuild = "games"``, the
paper's Gram-Schmidt, and ``rebuild = "covariance"``, PhysGaussian's ``F Sigma F^T`` with the
triangle's own ``F``), each with the scene's alpha rule, and the two Gaussians of every face are
compared: the relative Frobenius distance of their covariances ``||S_games - S_cov|| / ||S_cov||``
(median, 95th percentile, max), the share of Gaussians more than 10 % apart, and the largest in-plane
standard deviation of each rule relative to the rest one (how much the alpha rule had to hold).
Means are the same by construction (``m = v1``). Writes ``benchmarks/results/rebuild_guitar.md``.

Run: ``python benchmarks/bench_rebuild_guitar.py [--frames 12] [--engine warp_mpm]`` (about 10 s a frame
on 2 CPU cores at the scene's n_grid 64, plus the build).
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from gasp_core.gs.gaussians import quat_to_rotmat
from gasp_core.prepare.scene import prepare_scene
from gasp_core.run.frames import rebuild
from gasp_core.scene.spec import load_scene
from gasp_core.seam.runner import run_engine

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "rebuild_guitar.md"


def covariances(g) -> np.ndarray:
    """``R diag(s^2) R^T`` per Gaussian of a :class:`~gasp_core.gs.gaussians.Gaussians`, file frame."""
    R = quat_to_rotmat(g.rotations)
    return np.einsum("nij,nj,nkj->nik", R, g.scales ** 2, R)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=12)
    ap.add_argument("--engine", default=None, help="override the scene's engine")
    args = ap.parse_args()
    t0 = time.perf_counter()
    scene = load_scene(ROOT / "examples" / "guitar_sand.toml")
    prep = prepare_scene(scene, engine=args.engine)
    (o,) = prep.objects
    rules = {r: dataclasses.replace(o, spec=dataclasses.replace(o.spec, rebuild=r)) for r in ("games", "covariance")}
    prev = {r: o.rot_rest for r in rules}
    rows = []
    for rec in run_engine(prep.info, prep.setup, args.frames):
        out = {}
        for r, obj in rules.items():
            out[r], prev[r], _ = rebuild(obj, rec.x, prev[r])
        assert np.array_equal(out["games"].means, out["covariance"].means)
        cg, cc = covariances(out["games"]), covariances(out["covariance"])
        rel = np.linalg.norm(cg - cc, axis=(1, 2)) / np.maximum(np.linalg.norm(cc, axis=(1, 2)), 1e-30)
        grow = {r: float(np.percentile(out[r].scales[:, 1:].max(axis=1), 99)) for r in rules}
        rows.append((rec.frame, float(np.median(rel)), float(np.percentile(rel, 95)), float(rel.max()),
                     float((rel > 0.10).mean()), grow["games"], grow["covariance"]))
        print(f"frame {rec.frame}: median {rows[-1][1]:.2%}, p95 {rows[-1][2]:.2%}, max {rows[-1][3]:.2%}, "
              f"> 10 %: {rows[-1][4]:.1%}", flush=True)
    wall = time.perf_counter() - t0
    lines = ["# Rebuild rules side by side: the sand guitar", "",
             f"`python benchmarks/bench_rebuild_guitar.py --frames {args.frames}"
             + (f" --engine {args.engine}" if args.engine else "") + f"` on engine `{prep.info.name}`, "
             f"{len(o.tri_rest)} Gaussians, {len(prep.setup.x)} simulated points, {wall:.0f} s end to end "
             f"(build and both rebuilds included).", "",
             "Covariance distance per Gaussian, `||S_games - S_cov||_F / ||S_cov||_F` (the same engine run; "
             "`docs/rebuild.md`), and the 99th percentile of the largest in-plane scale of each rule "
             "(file units; the alpha rule 1.5 bounds both).", "",
             "| frame | median | p95 | max | share > 10 % | games s_max p99 | covariance s_max p99 |",
             "|---|---|---|---|---|---|---|"]
    for f, med, p95, mx, share, sg, sc in rows:
        lines.append(f"| {f} | {med:.2%} | {p95:.2%} | {mx:.1%} | {share:.1%} | {sg:.4g} | {sc:.4g} |")
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
