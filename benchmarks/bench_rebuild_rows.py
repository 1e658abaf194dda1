"""The host's rebuild at 2M Gaussians, on one core against all of them (issue 65 item 3; :mod:`gasp_core.maps.rows`).

The README donut's Gaussians (``examples/data/donut_v3dg.ply``, 45,624) 44 times side by side (2,007,456 rows), moved
by a shear and a stretch past alpha 1.5; timed: ``SurfaceMap.gaussians`` (``T^-1`` and the control rule) and the
quaternions, as ``gasp_core.run.frames.rebuild`` runs them, with ``GASP_REBUILD_THREADS`` = 1 and then the cores
this process may use, ``--rounds`` times each in turn; the medians and their ratio, measured in one run, and whether
the two give the same bits. Writes ``benchmarks/results/bench_rebuild_rows.json``::

    python benchmarks/bench_rebuild_rows.py --rounds 3
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from gasp_core.gs.gaussians import quat_to_rotmat, rotmat_to_quat
from gasp_core.gs.io import read_gaussians
from gasp_core.maps import rows
from gasp_core.maps.games import flatten, gaussians_to_triangles
from gasp_core.maps.surface import surface_map

ROOT = Path(__file__).resolve().parents[1]


def scene(copies: int):
    g = read_gaussians(ROOT / "examples" / "data" / "donut_v3dg.ply")
    scales, rot, _ = flatten(g.scales, quat_to_rotmat(g.rotations))
    tri = gaussians_to_triangles(g.means, rot, scales)
    shift = np.arange(copies)[:, None, None, None] * np.array([0.3, 0.0, 0.0])
    tri = (tri[None] + shift).reshape(-1, 3, 3)
    rot, scales = np.tile(rot, (copies, 1, 1)), np.tile(scales, (copies, 1))
    F = np.array([[1.0, 0.4, 0.0], [0.0, 2.2, 0.0], [0.0, 0.1, 0.9]])
    return surface_map(tri, rot, scales, surface_points="triangles", rebuild="games", alpha=1.5), tri @ F.T, rot


def rebuild(m, x, rot):
    means, r, scales, counts = m.gaussians(x, np.zeros((0, 3)), rot)
    quats, = rows.by_rows(lambda a: (rotmat_to_quat(a),), len(r), r)
    return means, quats, scales


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--copies", type=int, default=44)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "bench_rebuild_rows.json")
    a = ap.parse_args()
    m, tri_t, rot = scene(a.copies)
    x = tri_t.reshape(-1, 3)
    cores = rows.host_threads()
    times = {"1": [], str(cores): []}
    outs = {}
    for _ in range(a.rounds):
        for t in times:
            os.environ["GASP_REBUILD_THREADS"] = t
            t0 = time.perf_counter()
            outs[t] = rebuild(m, x, rot)
            times[t].append(time.perf_counter() - t0)
    same = all(np.array_equal(p, q) for p, q in zip(outs["1"], outs[str(cores)]))
    med = {t: float(np.median(v)) for t, v in times.items()}
    doc = {"rows": len(tri_t), "threads": cores, "seconds": times, "median_s": med,
           "ratio_one_over_all": med["1"] / med[str(cores)], "same_bits": same,
           "load_before": os.getloadavg()[0]}
    a.out.write_text(json.dumps(doc, indent=1))
    print(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
