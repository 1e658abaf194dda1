"""How much softer in bending an MPM part is when it is few grid cells and few points across (issue 38, item 6).

The conformance cantilever (``gasp_core.testing.scenes_materials``: a bar clamped by ``fixed_region`` on a grid
node, L 0.5 m, n_grid 32, dx 3.125 cm) with its square section ``h`` set to 1-4 cells and its points ``dx / ppa``
apart (ppa points per cell along an axis: 1, 4^(1/3) for 4 per cell, 2 for 8), E scaled as ``(0.1 / h)^2`` so
that every bar sags about 20 mm (Euler-Bernoulli). The softness is the time-averaged tip deflection over 1 s
(gravity switched on at t = 0, ~4 periods of the first mode) divided by Timoshenko's static deflection
(:func:`gasp_core.testing.scenes_analytic.timoshenko_cantilever`); the peak is the largest deflection over the
static one (2 for an undamped step response). ``gasp_core.prepare.stand.THIN_SOFTNESS`` is calibrated on it.

Run: ``python benchmarks/thin_softness.py [ENGINE]`` (default warp_mpm); writes
``benchmarks/results/thin_softness_ENGINE.md``.
"""
import pathlib
import sys
import time

import numpy as np

from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup
from gasp_core.testing.kit import resolve_engine, run_trace
from gasp_core.testing.scenes_analytic import timoshenko_cantilever

N_GRID, L, X0, NU, RHO = 32, 0.5, 6 / 32, 0.3, 1000.0


def measure(info, cells: float, ppa: float) -> dict:
    dx = 1.0 / N_GRID
    h = cells * dx
    E = 4.6e6 * (0.1 / h) ** 2
    x, p_vol = box_points((X0 - 0.1, 0.5 - h / 2, 0.55), (X0 + L, 0.5 + h / 2, 0.55 + h), dx / ppa)
    across = int(np.round(h / (dx / ppa)))
    setup = make_setup(x, p_vol, Material("jelly", E=E, nu=NU, rho=RHO), n_grid=N_GRID,
                       boundaries=[Boundary("fixed_region", lo=(0.0, 0.0, 0.0), hi=(X0, 1.0, 1.0))], frame_dt=0.02)
    t0 = time.perf_counter()
    tr = run_trace(info, setup, 50)
    x0 = tr.x[0]
    tip = x0[:, 0] > x0[:, 0].max() - 1e-9
    w = -(tr.x[:, tip, 2].mean(axis=1) - x0[tip, 2].mean())
    static, _ = timoshenko_cantilever(E, NU, RHO, L, h)
    return dict(cells=cells, ppa=ppa, across=max(across, 1), soft=float(w[1:].mean() / static),
                peak=float(w.max() / static), secs=time.perf_counter() - t0)


def main() -> None:
    engine = sys.argv[1] if len(sys.argv) > 1 else "warp_mpm"
    info = resolve_engine(engine)
    rows = []
    for ppa in (1.0, 4 ** (1 / 3), 2.0):
        for cells in (1.0, 1.5, 2.0, 3.0, 4.0):
            r = measure(info, cells, ppa)
            rows.append(r)
            print(r, flush=True)
    load = pathlib.Path("/proc/loadavg").read_text().split()[:3]
    out = pathlib.Path(__file__).parent / "results" / f"thin_softness_{engine}.md"
    lines = [f"# Bending softness of thin parts, {engine} (`python benchmarks/thin_softness.py {engine}`)", "",
             "Cantilever L 0.5 m, n_grid 32, nu 0.3, section h x h; softness = time-averaged tip deflection / "
             "Timoshenko static; peak = largest deflection / Timoshenko static (gravity on at once).", "",
             f"load average at the end: {' '.join(load)}", "",
             "| cells across (h/dx) | points per cell per axis | points across | softness | peak / static | s |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {r['cells']:g} | {r['ppa']:.3g} | {r['across']} | {r['soft']:.3f} | {r['peak']:.3f} | "
              f"{r['secs']:.1f} |" for r in rows]
    out.write_text("\n".join(lines) + "\n")
    print(out)


if __name__ == "__main__":
    main()
