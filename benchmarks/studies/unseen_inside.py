"""Issue 66 round 61 ("What a user sees"): the capture's inside Gaussians that a break shows (:mod:`gasp_core.gs.unseen`).

On the README donut (``examples/donut_shatter.toml``'s object, 45 624 Gaussians at rest): how many are unseen at 16, 32
and 64 views (the rule's :data:`VIEWS` 32), the rest PSNR with them hidden at four share limits, the seen share's time
(numba and NumPy); and with ``--run DIR`` (a ``gasp simulate`` run of the example made with ``HIDE_UNSEEN`` off, or
before round 61), per frame how many of those Gaussians the docs' camera then sees (share of its own alpha 0.1 or
more) and the share of the picture's object pixels they paint. Writes ``benchmarks/results/unseen_inside.md``.

    python benchmarks/studies/unseen_inside.py [--run out/donut_shatter_before --frames 2,5,10]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from gasp_core.gs.io import read_gaussians
from gasp_core.gs.camera import Camera
from gasp_core.gs.splat_numpy import Splats, render, shares, splats_from_gaussians
import gasp_core.gs.unseen as unseen

ROOT = Path(__file__).resolve().parents[2]
DONUT = ROOT / "examples" / "data" / "donut_v3dg.ply"
CAMERA = dict(position=[0.35, -0.75, 0.45], look_at=[0.0, 0.0, 0.1], fov=45.0)   # docs/fracture.md's stills


def rest_table(sp: Splats) -> list[str]:
    lines = ["| views | unseen (share < 0.01) | seconds |", "|---|---|---|"]
    shares_by = {}
    for v in (16, 32, 64):
        t = time.perf_counter()
        shares_by[v] = unseen.seen_share(sp, views=v)
        lines.append(f"| {v} | {int((shares_by[v] < unseen.UNSEEN).sum())} of {sp.n} | {time.perf_counter() - t:.1f} |")
    a, b = shares_by[32] < unseen.UNSEEN, shares_by[64] < unseen.UNSEEN
    lines += ["", f"32 against 64 views: {int((a & b).sum())} in both, {int((a & ~b).sum())} at 32 only, "
              f"{int((b & ~a).sum())} at 64 only.", "",
              "| share limit | hidden | rest PSNR over 6 other directions, least / median (dB) |", "|---|---|---|"]
    for lim in (0.003, 0.01, 0.03, 0.1):
        keep = ~(shares_by[32] < lim)
        p = unseen.rest_psnr(sp, keep)
        lines.append(f"| {lim} | {int((~keep).sum())} | {p.min():.1f} / {np.median(p):.1f} |")
    return lines, shares_by[32] < unseen.UNSEEN


def run_table(run_dir: Path, frames: list[int]) -> list[str]:
    """The inside the run draws: the unseen rows of its frame 0 as placed (the run's own rule's mask)."""
    import json
    meta = json.loads((run_dir / "run.json").read_text())
    o = meta["objects"][0]
    pl = o["placement"]
    g0 = read_gaussians(run_dir / o["name"] / "frame_0000.ply")
    hidden = unseen.seen_share(splats_from_gaussians(g0, pl["R"], float(pl["scale"]), pl["t"])) < unseen.UNSEEN
    cam = Camera(np.array(CAMERA["position"]), np.array(CAMERA["look_at"]), CAMERA["fov"], 480, 360, near=1e-3)
    lines = ["| frame | inside Gaussians seen (share >= 0.1) | their share of the object's pixels |", "|---|---|---|"]
    for f in frames:
        g = read_gaussians(run_dir / o["name"] / f"frame_{f:04d}.ply")
        sp = splats_from_gaussians(g, pl["R"], float(pl["scale"]), pl["t"])
        s = shares(sp, cam)
        seen = hidden & (np.nan_to_num(s) >= 0.1)
        _, a_all = render(sp, cam)
        _, a_out = render(sp.subset(~hidden), cam)
        obj = a_all > 0.05
        changed = obj & (np.abs(a_all - a_out) > 0.05)
        lines.append(f"| {f} | {int(seen.sum())} | {changed.sum() / max(obj.sum(), 1):.3f} |")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, help="a run of the example with the inside drawn (HIDE_UNSEEN off)")
    ap.add_argument("--frames", default="2,5,10")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "unseen_inside.md")
    args = ap.parse_args()
    g = read_gaussians(DONUT)
    sp = splats_from_gaussians(g)
    lines, _ = rest_table(sp)
    out = ["# The capture's inside (issue 66 round 61; benchmarks/studies/unseen_inside.py)", "",
           "The README donut at rest, file frame (45 624 Gaussians):", ""] + lines
    if args.run is not None:
        out += ["", f"The run `{args.run.name}` (its inside drawn), the docs' camera, 480 x 360:", ""]
        out += run_table(args.run, [int(f) for f in args.frames.split(",")])
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_suffix(".tmp")
    tmp.write_text("\n".join(out) + "\n")
    tmp.replace(args.out)
    print("\n".join(out))


if __name__ == "__main__":
    main()
