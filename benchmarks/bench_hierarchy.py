"""Core-Gaussian hierarchy build: wall time, peak memory and binding coefficients, 45k to 1M Gaussians.

Inputs (real data): the donut (``examples/data/donut_v3dg.ply``, 45,624 Gaussians) and the guitar
(``examples/data/guitar.compressed.ply``, 90,854) tiled side by side 11 times (999,394 Gaussians,
each copy shifted by 1.1 times the guitar's extent along x so the copies do not touch).

Each case runs :func:`gasp_core.maps.hierarchy.build_hierarchy` in its own subprocess so that the peak
resident memory (``ru_maxrss``) is that build's alone (reading and flattening the file included);
the wall time is the build only. ``--baseline`` also runs the former BIRCH build (the parent
commit's ``gasp_core/maps/hierarchy.py``, from git) on the donut for the coefficient comparison.

Usage::

    python benchmarks/bench_hierarchy.py                  # all cases
    python benchmarks/bench_hierarchy.py --baseline       # plus the BIRCH build on the donut

Writes ``benchmarks/results/bench_hierarchy.json`` and ``benchmarks/results/bench_hierarchy.md``.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

CHILD = r"""
import json, resource, sys, time, importlib.util
import numpy as np
from gasp_core.gs.io import read_gaussians
from gasp_core.maps.games import flatten, gaussians_to_triangles
src, tiles, frac, module = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
g = read_gaussians(src)
s, R, _ = flatten(g.scales, g.rotmats())
means = g.means.astype(np.float64)
tri = gaussians_to_triangles(means, R, s)
if tiles > 1:
    shift = np.array([1.1 * np.ptp(means[:, 0]), 0.0, 0.0])
    tri = np.concatenate([tri + i * shift for i in range(tiles)])
    means = np.concatenate([means + i * shift for i in range(tiles)])
if module == "new":
    from gasp_core.maps.hierarchy import build_hierarchy
else:
    spec = importlib.util.spec_from_file_location("hierarchy_old", module)
    mod = importlib.util.module_from_spec(spec); spec.loader.exec_module(mod)
    build_hierarchy = mod.build_hierarchy
t0 = time.perf_counter()
h = build_hierarchy(means, tri, frac)
wall = time.perf_counter() - t0
a = np.abs(h.local).ravel()
print(json.dumps({"n": len(means), "core_fraction": frac, "n_cores": int(h.core_of.max() + 1),
                  "build_s": wall, "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "coef_max": float(a.max()), "coef_p99": float(np.quantile(a, 0.99))}))
"""


def run_case(src: Path, tiles: int, frac: float, module: str = "new") -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, str(src), str(tiles), str(frac), module],
                         capture_output=True, text=True, cwd=ROOT, check=True)
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res.update(input=src.name, tiles=tiles, method="grid" if module == "new" else "birch (former)")
    return res


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--baseline", action="store_true", help="also run the former BIRCH build on the donut")
    args = p.parse_args(argv)
    donut = ROOT / "examples" / "data" / "donut_v3dg.ply"
    guitar = ROOT / "examples" / "data" / "guitar.compressed.ply"
    cases = [(donut, 1, 0.001), (donut, 1, 0.05), (donut, 1, 0.5), (guitar, 11, 0.05), (guitar, 11, 0.5)]
    rows = []
    for src, tiles, frac in cases:
        rows.append(run_case(src, tiles, frac))
        print(rows[-1], flush=True)
    if args.baseline:
        old = subprocess.run(["git", "show", "e7eb22b~1:gasp_core/maps/hierarchy.py"], capture_output=True,
                             text=True, cwd=ROOT, check=True).stdout.replace("from .games import EPS", "EPS = 1e-8")
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / "hierarchy_old.py"
            path.write_text(old)
            for frac in (0.05,):
                rows.append(run_case(donut, 1, frac, str(path)))
                print(rows[-1], flush=True)
    meta = {"machine": platform.platform(), "cpus": os.cpu_count(), "python": platform.python_version()}
    RESULTS.mkdir(parents=True, exist_ok=True)
    (RESULTS / "bench_hierarchy.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=2))
    lines = ["# Hierarchy build (benchmarks/bench_hierarchy.py)", "",
             f"{meta['machine']}, {meta['cpus']} CPUs, Python {meta['python']}. Peak RSS includes reading "
             "and flattening the input; build time is `build_hierarchy` alone.", "",
             "| input | Gaussians | core_fraction | method | cores | build s | peak RSS MB | max abs(a) | p99 abs(a) |",
             "|---|---:|---:|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        name = r["input"] + (f" x{r['tiles']}" if r["tiles"] > 1 else "")
        lines.append(f"| {name} | {r['n']:,} | {r['core_fraction']} | {r['method']} | {r['n_cores']:,} | "
                     f"{r['build_s']:.2f} | {r['peak_rss_mb']:.0f} | {r['coef_max']:.3g} | {r['coef_p99']:.3g} |")
    (RESULTS / "bench_hierarchy.md").write_text("\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
