"""Round 87 (issue 67 item 2, a family of neighbours): ``tests/test_rolling.py``'s rigid ball on its 20 degree slope at
other radii and grids than the test's one (R 0.1 m at n_grid 24), each judged by the test's own two-sided check
(``test_rolling.check``: rolling at mu 0.5, ``(5/7) g sin theta`` and ``omega R / v`` within 5 %; slipping at mu
0.05, Coulomb's ``g (sin - mu cos)`` and the spin-up ``omega R = mu g cos t / k`` within 5 %).

The ball is built as the test builds it (a Fibonacci shell of surface points, its Gaussians, carrying the share of the
volume that gives a solid ball's inertia, over a lattice fill at ``dx / 2``; it rests on the shell, ``n_render``), the
shell's count scaled with the radius (3,217 at 0.1 m). ``--flat [N_SHELL ...]`` instead reads the flat-ground spin-up share and rolling resistance (``docs/rigid.md``
"Round 87"). ``python benchmarks/studies/roll_sizes87.py --engine warp_mpm
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


def on_flat(engine: str, radius: float, n_grid: int, n_shell: int | None, v0: float, rolling: bool) -> float:
    """The ball on a flat ground (``test_rolling.body_setup`` at 0 degrees), ``n_shell`` Gaussians (None: the scaled
    count). ``rolling``: started rolling at ``v0`` (m/s) on mu 0.5, its rolling resistance ``c_rr = a (1 + k) / g``
    from its speed at frames 3 and 12; else thrown sliding at ``v0`` with no spin on mu 0.05, its spin-up ``d(w R)/dt``
    over frames 1-3 as a share of ``mu g / k``."""
    import numpy as np
    from dataclasses import replace
    saved = (rl.R, rl.N_GRID, rl.DX, rl.N_SHELL)
    configure(radius, n_grid)
    if n_shell:
        rl.N_SHELL = n_shell
    mu, k = (0.5 if rolling else 0.05), rl.K_SOLID["ball"]
    try:
        s = rl.body_setup("ball", mu, theta=0.0)
        x, m = np.asarray(s.x, float), np.asarray(s.p_vol, float)
        c = (m[:, None] * x).sum(0) / m.sum()
        w0 = np.array([0.0, v0 / radius if rolling else 0.0, 0.0])
        s = replace(s, v=np.array([v0, 0.0, 0.0]) + np.cross(w0, x - c))
        _c, v, w = rl.trace(engine, s, 0.2 if rolling else 0.1)
    finally:
        rl.R, rl.N_GRID, rl.DX, rl.N_SHELL = saved
    if rolling:
        return float(-(v[12, 0] - v[3, 0]) * rl.FPS / 9 * (1.0 + k) / rl.G)
    return float((w[3, 1] - w[1, 1]) * radius * rl.FPS / 2 / (mu * rl.G / k))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--radii", default="0.05,0.1")
    ap.add_argument("--grids", default="24,32,48")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    ap.add_argument("--flat", type=int, nargs="*", default=None, metavar="N_SHELL",
                    help="instead: on a flat ground, the spin-up share (thrown sliding at 0.5 m/s, mu 0.05) and c_rr "
                         "(rolling at 0.3 m/s, mu 0.5) of each radius and grid, at these Gaussian counts (none: scaled)")
    a = ap.parse_args(argv)
    if a.flat is not None:
        for radius in (float(r) for r in a.radii.split(",")):
            for n_grid in (int(n) for n in a.grids.split(",")):
                for ns in a.flat or [None]:
                    print(f"{a.engine} R {radius} n_grid {n_grid} Gaussians {ns or 'scaled'}: spin-up share "
                          f"{on_flat(a.engine, radius, n_grid, ns, 0.5, False):.3f}, c_rr "
                          f"{on_flat(a.engine, radius, n_grid, ns, 0.3, True):.4f}", flush=True)
        return 0
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
