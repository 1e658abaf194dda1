"""Round 57 (docs/contact.md "Round 57: the slump's step ladder"): the conformance column (a = 2, n_grid 48) at 34 /
68 / 136 substeps a frame on the grid and the particle contact, its runout read four ways (the deposit's front, the
fixed-thickness front, the 95th and 99th percentiles of x) against Lube et al. 2005, so that a step dependence of the
front grains alone is told from one of the bulk.

Run from the repository root: ``python benchmarks/studies/column_fronts.py warp_mpm``; prints one JSON row per run
(about 1-2 min each on 2 cores).
"""
import json
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import lube_family as lf   # noqa: E402
from gasp_core.seam import build_engine   # noqa: E402
from gasp_core.testing import scenes_granular as sg   # noqa: E402
from gasp_core.testing.helpers import wall_margin   # noqa: E402
from gasp_core.testing.kit import resolve_engine   # noqa: E402


def pct(r: float, ref: float) -> float:
    """``r / ref - 1`` in %, one decimal."""
    return round(100 * (r / ref - 1), 1)


def main(engine: str, a: float = 2.0, n_grid: int = 48) -> None:
    info = resolve_engine(engine)
    ref, L0 = sg.lube_runout(a), sg.COLUMN_L
    for contact in ("auto", "particle"):
        for k in (34, 68, 136):
            s = lf.column_setup(info, a, n_grid).replace(options={"n_substeps": k, "contact": contact})
            e = build_engine(info, s)
            for _ in range(int(math.ceil((0.7 + 2.4 * math.sqrt(2 * a * L0 / 9.81)) / lf.FRAME_DT))):
                e.step_frame()
            x = e.positions().astype(float)
            xw = wall_margin(info, s.dx)
            L, H = sg.column_deposit(x, xw, 3 * s.dx, s.dx / 2)
            F = lf.front_at(x, xw, s.dx / 2, lf.FRONT_THICKNESS * L0)
            p95, p99 = (np.percentile(x[:, 0] - xw, q) for q in (95, 99))
            print(json.dumps(dict(engine=engine, contact=contact, n_substeps=k,
                                  runout_err=pct((L - L0) / L0, ref), front_fixed_err=pct((F - L0) / L0, ref),
                                  p95_err=pct((p95 - L0) / L0, ref), p99_err=pct((p99 - L0) / L0, ref),
                                  height_err=pct(H / L0, sg.lube_height(a)))), flush=True)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "warp_mpm")
