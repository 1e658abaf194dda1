"""Round 58: the README donut reference's first bounce, read the same way at every commit of a bisection.

The figures of ``docs/speed_accuracy.md`` ("Round 58: the reference's restitution bisected"): the restitution
of ``bench_trade.py``'s ``full`` donut (every vertex simulated, the scene's fill, taichi_mpm, one thread) moved
from 0.640 (2026-11-23) to 0.854 (2026-11-30); this reads the first impact of ``gasp simulate`` output folders
with :func:`gasp_studies.accuracy.events` exactly as ``benchmarks/bench_accuracy.py`` reads the reference
(the contact gap half the ``n_grid`` 64 reference's cell, 3.27 mm, whatever the run's grid).

Run it with this tree on ``PYTHONPATH`` (the measurement fixed), on folders written by any commit's engine::

    python benchmarks/studies/donut_bounce_bisect.py OUT [OUT ...]

Each folder: ``n_substeps``, the impact time (ms), the restitution by frame differences (``restitution``, what
the reports print), the restitution from the free flights (``restitution_ballistic``), the contact time (ms),
the contact level (mm), and the centroid's height per frame (mm).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from gasp_studies.accuracy import events, track_from_run_dir

#: Half the n_grid 64 reference's cell (m): the gap ``accuracy_report`` uses for every run against that reference.
GAP_M = 0.0032686297661323454


def main(paths: list[str]) -> None:
    for p in paths:
        tr = track_from_run_dir(p)
        ev = events(tr, 0, GAP_M)
        st = json.loads((Path(p) / "run.json").read_text()).get("engine_stats", {})
        cz = tr.object_means(0).mean(axis=1)[:, 2]
        print(f"{p}: n_substeps {st.get('n_substeps')} impact {1e3 * ev['impact_s']:.1f} ms restitution "
              f"{ev['restitution']:.3f} ballistic {ev['restitution_ballistic']:.3f} contact {1e3 * ev['contact_s']:.1f} ms "
              f"level {1e3 * ev['contact_level_m']:.2f} mm")
        print("  cz mm:", " ".join(f"{1e3 * z:.2f}" for z in cz))


if __name__ == "__main__":
    main(sys.argv[1:])
