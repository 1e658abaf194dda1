"""Round 87 (issue 67 item 2, a family of neighbours): ``tests/test_rolling.py``'s rigid ball on its 20 degree slope at
other radii and grids than the test's one (R 0.1 m at n_grid 24), each judged by the test's own two-sided check
(``test_rolling.check``: rolling at mu 0.5, ``(5/7) g sin theta`` and ``omega R / v`` within 5 %; slipping at mu
0.05, Coulomb's ``g (sin - mu cos)`` and the spin-up ``omega R = mu g cos t / k`` within 5 %).

The ball is built as the test builds it (a Fibonacci shell of surface points, its Gaussians, carrying the share of the
volume that gives a solid ball's inertia, over a lattice fill at ``dx / 2``; it rests on the shell, ``n_render``), the
shell's count scaled with the radius (3,217 at 0.1 m). ``python benchmarks/studies/roll_sizes87.py --engine warp_mpm
--radii 0.05,0.1 --grids 24,32,48 --out benchmarks/results/roll_sizes87.json`` (refused if the file exists).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

import test_rolling as rl  # noqa: E402

MUS = (rl.ROLL_MU, rl.SLIP_MU)
#: The test's own ball (radius m, Gaussians): the shell's density every radius keeps.
REF_R, REF_SHELL = rl.R, rl.N_SHELL


def configure(radius: float, n_grid: int) -> None:
    """Set ``test_rolling``'s module constants to a ball of ``radius`` (m) on ``n_grid``."""
    rl.R, rl.N_GRID, rl.DX = radius, n_grid, rl.SIDE / n_grid
    rl.N_SHELL = int(round(REF_SHELL * (radius / REF_R) ** 2))


def row(engine: str, radius: float, n_grid: int, mu: float) -> dict:
    """One case: the figures ``test_rolling.measure`` reads, the closed form and the check's verdict
    (``test_rolling``'s module constants are restored after it)."""
    saved = (rl.R, rl.N_GRID, rl.DX, rl.N_SHELL)
    configure(radius, n_grid)
    t0 = time.time()
    try:
        fig = rl.measure(engine, "ball", mu)
    finally:
        rl.R, rl.N_GRID, rl.DX, rl.N_SHELL = saved
    want = rl.closed_form("ball", mu)
    out = {"engine": engine, "R": radius, "n_grid": n_grid, "mu": mu,
           **{k: float(v) for k, v in fig.items()}, "a_want": want["a"],
           "a_err": fig["a"] / want["a"] - 1.0, "problem": rl.check("ball", mu, fig), "wall_s": time.time() - t0,
           "R_over_dx": radius * n_grid / rl.SIDE}
    if "wR" in want:
        out["wR_want"] = want["wR"]
        out["wR_err"] = fig["wR"] / want["wR"] - 1.0
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--radii", default="0.05,0.1")
    ap.add_argument("--grids", default="24,32,48")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = Path(a.out) if a.out else None
    if out is not None and out.exists():
        ap.error(f"--out {out} exists; give a new file")
    rows = []
    for radius in (float(r) for r in a.radii.split(",")):
        for n_grid in (int(n) for n in a.grids.split(",")):
            for mu in MUS:
                r = row(a.engine, radius, n_grid, mu)
                rows.append(r)
                err = f"a {100 * r['a_err']:+.2f} %" + (f", wR {100 * r['wR_err']:+.2f} %" if "wR_err" in r else
                                                        f", wR/v {r['wR'] / r['v']:.4f}")
                print(f"{a.engine} R {radius} n_grid {n_grid} (R/dx {r['R_over_dx']:.1f}) mu {mu}: {err}; "
                      f"{r['problem'] or 'ok'}", flush=True)
    if out is not None:
        tmp = out.with_suffix(".tmp")
        tmp.write_text(json.dumps(rows, indent=1))
        tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
