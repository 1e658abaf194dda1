"""Round 49 (issue 67): soft bodies resting on the grid contact against their static sag estimates
(``gasp_core.testing.sag``; docs/contact.md "Round 49: the touched layer shares the column's Coulomb bound").

Usage: ``python benchmarks/sag_family.py [--engines warp_mpm,taichi_mpm] [--cases block:32,donut:32,...]
[--touch-share 0]``; prints one line a case and appends it to ``benchmarks/results/sag_family.md``. ``--touch-share 0``
is round 48's touched layer (its full Coulomb rule), ``--touch-contact 0`` no touched layer at all.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

OUT = Path(__file__).resolve().parent / "results" / "sag_family.md"


def _set(name: str, value) -> None:
    from gasp_taichi_mpm.grid import GridUpdate
    from gasp_warp_mpm.engine import WarpMPMEngine
    for cls in (GridUpdate, WarpMPMEngine):
        setattr(cls, name, value)


def main() -> None:
    from gasp_core.testing.sag import sag_ratio
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="warp_mpm,taichi_mpm")
    ap.add_argument("--cases", default="block:32,block:48,donut:32,donut:48,ball:32")
    ap.add_argument("--touch-share", type=int, default=1)
    ap.add_argument("--touch-contact", type=int, default=1)
    args = ap.parse_args()
    _set("touch_share", bool(args.touch_share))
    _set("touch_contact", bool(args.touch_contact))
    rule = "round 49" if args.touch_share else "round 48"
    rule = rule if args.touch_contact else "no touched layer"
    for engine in args.engines.split(","):
        for case in args.cases.split(","):
            shape, n = case.split(":")
            t = time.time()
            r, m, e = sag_ratio(engine, shape, int(n))
            line = (f"| {engine} | {shape} | n{n} | {rule} | sag {m * 1e3:.3f} mm | estimate {e * 1e3:.3f} mm | "
                    f"ratio {r:.3f} | {time.time() - t:.0f} s |")
            print(line, flush=True)
            with OUT.open("a") as f:
                f.write(line + "\n")


if __name__ == "__main__":
    main()
