"""Round 88 (issue 67 item 2, ``docs/rigid.md`` "Round 88: a ball rests on its sphere"): a family of rigid balls and
solid cylinders rolling and slipping on ``tests/test_rolling.py``'s 20 degree slope, over radii, grids and the ways
their Gaussians sample them, each judged by ``test_rolling``'s two-sided check (5 %) against the closed forms of the
body's own inertia.

Samplings of the body's surface (its Gaussians, ``n_render``: they carry mass), over a lattice fill at ``dx / 2``:

- ``fibonacci``: ``test_rolling``'s own: the ball's Fibonacci shell, its count scaled with the area (3,217 at 0.1 m),
  the cylinder's side on a grid of ``dx / 4``; the volumes set so that ``I = 0.4 M R^2`` (0.5 for the cylinder,
  ``test_rolling._volumes``' rule);
- ``sparse``: the ball with a sixteenth of the Gaussians (round 87: 200 on the 10 cm ball spun up at 0.625 of the
  rate), the cylinder's side on a grid of ``dx``;
- ``scan``: as many Gaussians at random places on the surface (seeded), each with a uniform radial jitter of a
  quarter of their spacing, as a capture leaves them;
- ``fill``: no Gaussians, the lattice alone (each point ``V / N``), its inertia what the lattice gives.

The closed forms take ``k = I / (M R^2)`` from the points (``R`` the declared volume's radius, the shape the engines
meet the ground with, ``gasp_core.mpm.round_ground``): rolling at ``g sin / (1 + k)`` with ``omega R = v`` while
``mu >= k tan / (1 + k)``, else ``g (sin - mu cos)`` with ``omega R = mu g cos t / k``.
``python benchmarks/studies/roll_family88.py --engine warp_mpm --out benchmarks/results/roll_family88_warp.json``
(refused if the file exists).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests"))

import test_rolling as rl  # noqa: E402

SAMPLINGS = ("fibonacci", "sparse", "scan", "fill")
MUS = (rl.ROLL_MU, rl.SLIP_MU)
#: The default family: every radius and grid on the test's sampling, and every sampling on two of them.
RADII, GRIDS = (0.05, 0.1), (24, 32, 48)
SAMPLED_AT = ((0.05, 48), (0.1, 24))


def family(shape: str = "ball") -> list[tuple[float, int, str]]:
    """``(radius m, n_grid, sampling)`` of the default family of ``shape`` (``test_rolling``'s own case, 0.1 m on 24
    with the test's sampling, left out)."""
    out = [(r, n, "fibonacci") for r in RADII for n in GRIDS if (r, n) != (rl.R, rl.N_GRID)]
    return out + [(r, n, s) for r, n in SAMPLED_AT for s in SAMPLINGS if s != "fibonacci"]


def body(shape: str, radius: float, n_grid: int, sampling: str, seed: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """``(x (n, 3) m, p_vol (n,) m^3, n_render)``: the ball (:func:`ball`) or the solid cylinder (:func:`cylinder`)."""
    return (ball if shape == "ball" else cylinder)(radius, n_grid, sampling, seed)


def cylinder(radius: float, n_grid: int, sampling: str, seed: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """``test_rolling``'s solid cylinder (``CYL_LEN`` long, its axis along y, across the slope) of ``radius``: its side's
    Gaussians on a grid of ``dx / 4`` (``fibonacci``, the test's), of ``dx`` (``sparse``), at random angles and
    heights with a quarter spacing's radial jitter (``scan``), or none (``fill``), over a lattice fill at ``dx / 2``,
    the volumes set so that ``I = 0.5 M R^2`` about the axis."""
    dx = rl.SIDE / n_grid
    h = dx / 2
    L = rl.CYL_LEN
    c = np.array([radius + 3 * dx + 0.01, rl.SIDE / 2, rl.GROUND + radius])
    half = np.array([radius, L / 2, radius])
    x, _ = rl.box_points(c - half, c + half, h)
    x = x[np.linalg.norm((x - c)[:, [0, 2]], axis=1) <= radius - h / 2]
    volume = math.pi * radius ** 2 * L
    if sampling == "fill":
        return x, np.full(len(x), volume / len(x)), 0
    s = h / 2 if sampling in ("fibonacci", "scan") else 2 * h
    n_ring, n_len = int(2 * math.pi * radius / s), int(L / s)
    if sampling == "scan":
        rng = np.random.default_rng(seed)
        n = n_ring * n_len
        phi, y = rng.uniform(0, 2 * math.pi, n), rng.uniform(-L / 2, L / 2, n)
        r = radius + rng.uniform(-s / 4, s / 4, n)
    else:
        P, Y = np.meshgrid((np.arange(n_ring) + 0.5) * 2 * math.pi / n_ring, (np.arange(n_len) + 0.5) * L / n_len - L / 2,
                           indexing="ij")
        phi, y, r = P.ravel(), Y.ravel(), np.full(P.size, radius)
    shell = c + np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)
    return _share(x, shell, c, volume, 0.5 * volume * radius * radius)


def _share(x: np.ndarray, shell: np.ndarray, c: np.ndarray, volume: float, second: float):
    """The fill's and the shell's points with the volumes that give ``volume`` and the second moment ``second`` about
    the roll axis (y through ``c``), the shell first."""
    r_fill, r_shell = (((p - c)[:, [0, 2]] ** 2).sum(axis=1) for p in (x, shell))
    A = np.array([[len(r_fill), len(r_shell)], [r_fill.sum(), r_shell.sum()]])
    vf, vs = np.linalg.solve(A, [volume, second])
    return np.concatenate([shell, x]), np.r_[np.full(len(shell), vs), np.full(len(x), vf)], len(shell)


def ball(radius: float, n_grid: int, sampling: str, seed: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """``(x (n, 3) m, p_vol (n,) m^3, n_render)``: the ball centred at ``(R + 3 dx + 0.01, SIDE / 2, GROUND + R)``,
    its Gaussians first (module docstring)."""
    dx = rl.SIDE / n_grid
    h = dx / 2
    c = np.array([radius + 3 * dx + 0.01, rl.SIDE / 2, rl.GROUND + radius])
    x, _ = rl.box_points(c - radius, c + radius, h)
    x = x[np.linalg.norm(x - c, axis=1) <= radius - h / 2]
    volume = 4.0 / 3.0 * math.pi * radius ** 3
    if sampling == "fill":
        return x, np.full(len(x), volume / len(x)), 0
    n = int(round(rl.N_SHELL * (radius / 0.1) ** 2))
    if sampling == "sparse":
        n //= 16
    if sampling == "scan":
        shell = scan_sphere(c, radius, n, seed)
    else:
        shell = c + radius * rl.fibonacci_sphere(n)
    return _share(x, shell, c, volume, 0.4 * volume * radius * radius)


def scan_sphere(c, radius: float, n: int, seed: int = 0) -> np.ndarray:
    """``n`` points (m) on the sphere of ``radius`` about ``c`` as a scan leaves them: at random (seeded), each
    jittered along its normal by up to a quarter of their mean spacing (the "scan" sampling)."""
    rng = np.random.default_rng(seed)
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1)[:, None]
    s = math.sqrt(4.0 * math.pi / n) * radius
    return np.asarray(c) + u * (radius + rng.uniform(-s / 4, s / 4, n))[:, None]


def inertia_share(x: np.ndarray, p_vol: np.ndarray, radius: float) -> float:
    """``k = I / (M R^2)`` about the roll axis (y) through the mass centre, from the points (``R`` the declared
    volume's radius)."""
    c = (p_vol[:, None] * x).sum(0) / p_vol.sum()
    return float((p_vol * ((x - c)[:, [0, 2]] ** 2).sum(axis=1)).sum() / (p_vol.sum() * radius * radius))


def closed_form(k: float, mu: float) -> dict:
    """``test_rolling.closed_form`` for a ball of ``k``."""
    th = math.radians(rl.THETA)
    if mu >= math.tan(th) * k / (1.0 + k):
        return {"rolls": True, "a": rl.G * math.sin(th) / (1.0 + k)}
    return {"rolls": False, "a": rl.G * (math.sin(th) - mu * math.cos(th)), "wR": mu * rl.G * math.cos(th) * rl.T / k}


def problem(want: dict, fig: dict) -> str | None:
    """``test_rolling.check``'s verdict against ``want``: None within ``TOL`` (two-sided), else what is wrong."""
    out = []
    err = fig["a"] / want["a"] - 1.0
    if not abs(err) <= rl.TOL:
        out.append(f"a = {fig['a']:.4f} m/s^2 against {want['a']:.4f} ({100 * err:+.2f} %)")
    if want["rolls"]:
        ratio = fig["wR"] / fig["v"] if fig["v"] != 0.0 else math.inf
        if not abs(ratio - 1.0) <= rl.TOL:
            out.append(f"omega R / v = {ratio:.4f} (rolls: 1)")
    else:
        err = fig["wR"] / want["wR"] - 1.0
        if not abs(err) <= rl.TOL:
            out.append(f"omega R at {rl.T} s = {fig['wR']:.4f} m/s against {want['wR']:.4f} ({100 * err:+.2f} %)")
    return "; ".join(out) or None


def row(engine: str, radius: float, n_grid: int, sampling: str, mu: float, shape: str = "ball", seed: int = 0) -> dict:
    """One case on ``engine``: its figures (``test_rolling.measure``'s), the closed form and the verdict. ``seed``:
    the ``scan`` sampling's draw (round 99; 0 the family's)."""
    from gasp_core.seam.setup import Boundary, Material
    from gasp_core.testing.helpers import make_setup
    x, p_vol, n_render = body(shape, radius, n_grid, sampling, seed)
    t = math.radians(rl.THETA)
    s = make_setup(x, p_vol, Material("jelly", model="rigid", E=1.0e10, nu=0.3, rho=700.0),
                   gravity=(rl.G * math.sin(t), 0.0, -rl.G * math.cos(t)), lo=np.zeros(3), hi=np.full(3, rl.SIDE),
                   n_grid=n_grid, frame_dt=1.0 / rl.FPS, boundaries=[Boundary("ground", height=rl.GROUND, friction=mu)])
    s.n_render = n_render
    t0 = time.time()
    c, v, w = rl.trace(engine, s)
    tt = np.arange(len(c)) / rl.FPS
    sel = tt >= rl.FIT_FROM
    fig = {"a": 2.0 * float(np.polyfit(tt[sel], c[sel, 0], 2)[0]), "wR": float(w[-1, 1]) * radius,
           "v": float(v[-1, 0])}
    return record(engine, shape, radius, n_grid, sampling, n_render, mu, inertia_share(x, p_vol, radius), fig,
                  time.time() - t0)


def record(engine: str, shape: str, radius: float, n_grid: int, sampling: str, n_render: int, mu: float, k: float,
           fig: dict, wall_s: float) -> dict:
    """One case's row: its figures ``fig`` (``a``, ``wR``, ``v``), the closed form of its ``k`` and the verdict."""
    want = closed_form(k, mu)
    out = {"engine": engine, "shape": shape, "R": radius, "n_grid": n_grid, "sampling": sampling, "gaussians": n_render,
           "mu": mu, "k": k, **fig, "a_want": want["a"], "a_err": fig["a"] / want["a"] - 1.0,
           "problem": problem(want, fig), "wall_s": wall_s}
    out["wR_err" if "wR" in want else "wR_over_v"] = (fig["wR"] / want["wR"] - 1.0 if "wR" in want
                                                      else fig["wR"] / fig["v"])
    return out


def report(r: dict) -> str:
    """A row as one printed line."""
    figs = f"a {100 * r['a_err']:+.2f} %, " + (f"wR {100 * r['wR_err']:+.2f} %" if "wR_err" in r
                                              else f"wR/v {r['wR_over_v']:.4f}")
    return (f"{r['engine']} {r['shape']} R {r['R']} n_grid {r['n_grid']} {r['sampling']} ({r['gaussians']} Gaussians, "
            f"k {r['k']:.3f}) mu {r['mu']}: {figs}; {r['problem'] or 'ok'}")


def new_out(ap, path: str | None) -> Path | None:
    """``--out`` as a new file: None without it; ``ap.error`` (exit 2) where it exists (a run never overwrites)."""
    out = Path(path) if path else None
    if out is not None and out.exists():
        ap.error(f"--out {out} exists; give a new file")
    return out


def write_rows(out: Path | None, rows: list[dict]) -> None:
    """The rows as JSON in ``out`` (atomically; nothing without it)."""
    if out is not None:
        tmp = out.with_suffix(".tmp")
        tmp.write_text(json.dumps(rows, indent=1))
        tmp.replace(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--shapes", default="ball,cylinder", help="ball, cylinder or both (comma-separated)")
    ap.add_argument("--seeds", default=None, help="round 99: the scan sampling's draws (comma-separated, e.g. 1,2,3,4); "
                    "with it only the family's scan rows run, once a seed")
    ap.add_argument("--out", default=None, help="a new JSON file for the rows (refused if it exists)")
    a = ap.parse_args(argv)
    out = new_out(ap, a.out)
    seeds = [int(k) for k in a.seeds.split(",")] if a.seeds else [0]
    rows = []
    for shape in a.shapes.split(","):
        for radius, n_grid, sampling in family(shape):
            if a.seeds and sampling != "scan":
                continue
            for seed in seeds:
                for mu in MUS:
                    rows.append({**row(a.engine, radius, n_grid, sampling, mu, shape, seed), "seed": seed})
                    print(report(rows[-1]) + (f" (seed {seed})" if a.seeds else ""), flush=True)
    write_rows(out, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
