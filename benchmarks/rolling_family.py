"""Issue 67 items 1 and 2 beyond the tests' cases, on both MPM engines: a rigid ball and a solid cylinder on a 20
degree slope over a range of mu on both sides of the rolling threshold (``tests/test_rolling.py``'s scene; the ball
also at n_grid 32, where APIC's inertia is smaller), and the rigid block on a ramp given as a closed mesh collider over
the issue's 3 x 3 grid (``tests/test_ramp_collider.py``), each judged by its test's own two-sided check.

``python benchmarks/rolling_family.py`` writes ``benchmarks/results/rolling_family.json`` (one object a case) and
``rolling_family.md`` (the tables of ``docs/rigid.md`` "Rolling" and "Ramps"); ``--engines`` and ``--parts roll,ramp``
choose.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

import test_ramp_collider as rc  # noqa: E402
import test_rolling as rl  # noqa: E402

ROLL_CASES = [("ball", mu, 24) for mu in (0.5, 0.2, 0.12, 0.1, 0.05)] + [("ball", 0.5, 32), ("ball", 0.05, 32)] \
    + [("cylinder", mu, 24) for mu in (0.3, 0.13, 0.1, 0.05)]


def _grid(n_grid: int) -> None:
    rl.N_GRID, rl.DX = n_grid, rl.SIDE / n_grid


def roll_row(engine: str, shape: str, mu: float, n_grid: int) -> dict:
    _grid(n_grid)
    try:
        t0 = time.time()
        fig = rl.measure(engine, shape, mu)
        want = rl.closed_form(shape, mu)
        th = math.radians(rl.THETA)
        own = rl.G * math.sin(th) / (1.0 + rl.k_engine(shape)) if want["rolls"] else want["a"]
        row = {"part": "roll", "engine": engine, "shape": shape, "mu": mu, "n_grid": n_grid, "rolls": want["rolls"],
               "a": fig["a"], "a_closed": want["a"], "a_err_pct": 100 * (fig["a"] / want["a"] - 1.0),
               "a_own_k": own, "wR_over_v": fig["wR"] / fig["v"], "wR": fig["wR"], "wR_closed": want.get("wR"),
               "ok": rl.check(shape, mu, fig) is None, "seconds": round(time.time() - t0, 1)}
    finally:
        _grid(24)
    return row


def ramp_row(engine: str, theta: float, mu: float) -> dict:
    t0 = time.time()
    fig = rc.measure(engine, theta, mu)
    a0 = rc.closed_form(theta, mu)
    return {"part": "ramp", "engine": engine, "theta": theta, "mu": mu, "slides": rc.slides(theta, mu),
            "figure": fig, "a_closed": a0, "err_pct": 100 * (fig / a0 - 1.0) if a0 > 0 else None,
            "ok": rc.check(theta, mu, fig) is None, "seconds": round(time.time() - t0, 1)}


def markdown(rows: list[dict]) -> str:
    out = ["# rolling_family (issue 67): `python benchmarks/rolling_family.py`", "",
           f"Ball and cylinder on a {rl.THETA:g} deg slope (gravity tilted), R = {rl.R} m; a: fitted from "
           f"{rl.FIT_FROM} to {rl.T} s; closed form: rolling (5/7 or 2/3) g sin theta, slipping g (sin - mu cos); "
           "'own k' the rolling closed form with the inertia the engines hold (the body's own since round 67, "
           "so the closed form's; to round 66 APIC's M dx^2 / 2 added).", "",
           "| engine | shape | n_grid | mu | closed form | a (m/s^2) | error | own k | omega R / v "
           "| omega R (slip: closed) | ok |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in (r for r in rows if r["part"] == "roll"):
        wr = f"{r['wR']:.4f} ({r['wR_closed']:.4f})" if r["wR_closed"] is not None else f"{r['wR']:.4f}"
        out.append(f"| {r['engine']} | {r['shape']} | {r['n_grid']} | {r['mu']} | {'rolls' if r['rolls'] else 'slips'} "
                   f"{r['a_closed']:.4f} | {r['a']:.4f} | {r['a_err_pct']:+.2f} % | {r['a_own_k']:.4f} | "
                   f"{r['wR_over_v']:.4f} | {wr} | {'ok' if r['ok'] else 'FAIL'} |")
    out += ["", "Rigid block on a mesh-collider ramp, gravity straight down (slides: a against g (sin - mu cos) from "
            f"{rc.SLIDE_FROM} to {rc.SLIDE_T} s; sticks: travel in {rc.STICK_T:g} s):", "",
            "| engine | theta | mu | closed form | measured | ok |", "|---|---|---|---|---|---|"]
    for r in (r for r in rows if r["part"] == "ramp"):
        meas = f"{r['figure']:.4f} m/s^2 ({r['err_pct']:+.2f} %)" if r["slides"] else f"{r['figure']:.3f} mm"
        cf = f"{r['a_closed']:.4f} m/s^2" if r["slides"] else "sticks (< 1 mm)"
        out.append(f"| {r['engine']} | {r['theta']} | {r['mu']} | {cf} | {meas} | {'ok' if r['ok'] else 'FAIL'} |")
    return "\n".join(out) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--parts", default="roll,ramp")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "rolling_family"))
    args = ap.parse_args()
    rows = []
    for engine in args.engines.split(","):
        if "roll" in args.parts:
            for shape, mu, ng in ROLL_CASES:
                rows.append(roll_row(engine, shape, mu, ng))
                print(json.dumps(rows[-1]), flush=True)
        if "ramp" in args.parts:
            for theta in rc.THETAS:
                for mu in rc.MUS:
                    rows.append(ramp_row(engine, theta, mu))
                    print(json.dumps(rows[-1]), flush=True)
    Path(args.out + ".json").write_text(json.dumps(rows, indent=1) + "\n")
    Path(args.out + ".md").write_text(markdown(rows))
    print(f"{sum(r['ok'] for r in rows)} of {len(rows)} cases meet their closed forms")


if __name__ == "__main__":
    main()
