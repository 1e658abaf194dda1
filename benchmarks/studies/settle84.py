"""Round 84 (issue 67 item 3, ``docs/contact.md`` "Round 84: a settled start"): jelly blocks on a 30 degree slope
started settled (the scene key ``settle``, ``gasp_core.seam.settle``) or released unstressed, on either engine and
contact: each block's travel in 1 s from 0.1 s (mm; ``tests/test_elastic_slope.py``'s stick figure) and the settle's
record (its largest displacement from the scene as given, its last frame's motion in cells).

Blocks (``tests/test_settle.py``'s ``BODIES``): the cube 10 cm, the flat block 15 x 15 x 5 cm, the tall block 10 x 10 x
15 cm; jelly E 1e5, nu 0.3, rho 1000; mu 0.6 and 0.7 (``tan 30 / mu`` 0.96, 0.82).

    python benchmarks/studies/settle84.py --engine warp_mpm --grid 24 32 48 --out rows.json
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--engine", nargs="+", default=["warp_mpm"])
    p.add_argument("--grid", nargs="+", type=int, default=[24, 32])
    p.add_argument("--body", nargs="+", default=["cube", "flat", "tall"])
    p.add_argument("--contact", nargs="+", default=["particle", "grid"])
    p.add_argument("--mu", nargs="+", type=float, default=[0.6, 0.7])
    p.add_argument("--released", action="store_true", help="also run each case released unstressed")
    p.add_argument("--out", help="write the rows to this JSON file (refused if it exists)")
    a = p.parse_args(argv)
    if a.out and Path(a.out).exists():
        sys.exit(f"settle84.py: {a.out} exists; give a new file")
    from test_settle import BODIES, settled_figure
    rows = []
    for engine in a.engine:
        for body in a.body:
            for contact in a.contact:
                for n_grid in a.grid:
                    for mu in a.mu:
                        for settle in ((True, False) if a.released else (True,)):
                            with warnings.catch_warnings(record=True) as w:
                                warnings.simplefilter("always", UserWarning)
                                fig, rec = settled_figure(engine, 30, mu, contact, n_grid, BODIES[body],
                                                          settle=settle)
                            row = {"engine": engine, "body": body, "contact": contact, "n_grid": n_grid, "mu": mu,
                                   "settle": settle, "travel_mm": fig, "record": rec,
                                   "warnings": [str(x.message)[:80] for x in w if "settle" in str(x.message)]}
                            rows.append(row)
                            print(json.dumps({k: v for k, v in row.items() if k != "record"}), flush=True)
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
