"""The crack band across the grid at an angle (issue 66 item 2, round 31; docs/fracture.md "The crack band").

A free bar (0.6 x 0.1 x 0.1 m, points at dx / 2 in its own frame, E 1 MPa, nu 0, rho 1000, f_t 3 kPa, G_f 5 J/m^2)
lies in the xy plane at ``theta`` to the grid's x axis, notched at mid-length (the middle layer keeps the middle half
of its section both ways: a ligament of a quarter of the section), and is given the velocity of a uniform stretch
along its axis (0.6 /s: its ends at 0.18 m/s, the middle's dynamic stress about twice f_t at the ligament). It breaks
at the notch and its halves fly apart; the damage's dissipation (each point's ``V f_t s d / (2 E)`` through the
engine's softening law, as ``benchmarks/tension_family.py``'s ``dissipated``) is summed over the points within 2 cells
of the notch and divided by the bar's section. What it measures is the ratio between angles at one grid (the crack's
area, the ligament or more, is the same at every angle), not ``G_f`` itself: a finite element's crack band across
its elements at an angle is wider by the projection of the element on the crack's normal (Oliver 1989, "A consistent
characteristic length for smeared cracking models", IJNME 28), up to sqrt(2) at 45 deg.

Run: ``python benchmarks/oblique_band.py [--engine warp_mpm] [--grids 32,48] [--angles 0,30,45]``; writes
``benchmarks/results/oblique_band.{json,md}`` (the other engines' rows kept).
"""
import argparse
import json
from pathlib import Path

import numpy as np
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import make_setup
from gasp_core.mpm.materials import softening_stress

E, NU, RHO, FT, GF = 1e6, 0.0, 1000.0, 3e3, 5.0
L, A = 0.6, 0.1


def run(engine: str, theta_deg: float, n_grid: int, frames: int = 120, rate: float = 0.6):
    """``(dissipated within 2 cells of the notch, over the whole body, per bar section (J/m^2); the layers broken
    through; the largest d there)`` after ``frames`` frames of 2.5 ms."""
    dx = 1.0 / n_grid
    s = dx / 2
    nx, ny = int(round(L / s)), int(round(A / s))
    u = (np.arange(nx) + 0.5) * s - L / 2
    w = (np.arange(ny) + 0.5) * s - A / 2
    U, V, W = np.meshgrid(u, w, w, indexing="ij")
    k = np.abs(U) == np.abs(U).min()       # the layer(s) nearest the middle
    mid = np.abs(u).min()
    notch = (np.abs(U - U[k].min()) < 1e-12) & ((np.abs(V) > A / 4) | (np.abs(W) > A / 4))
    U, V, W = U[~notch], V[~notch], W[~notch]
    th = np.radians(theta_deg)
    t = np.array([np.cos(th), np.sin(th), 0.0])
    n = np.array([-np.sin(th), np.cos(th), 0.0])
    c = np.array([0.5, 0.5, 0.5])
    x = c + U[:, None] * t + V[:, None] * n + W[:, None] * np.array([0, 0, 1.0])
    v = rate * U[:, None] * t
    m = Material("brittle", E=E, nu=NU, rho=RHO, tensile_strength=FT, fracture_energy=GF)
    st = make_setup(x, np.full(len(x), s ** 3), m, v=v, gravity=(0, 0, 0), n_grid=n_grid, frame_dt=0.0025,
                    options={"precision": "f64", **({"threads": 1} if engine == "taichi_mpm" else {})})
    sf = softening_stress(m, float(st.crack_band[0]))
    e = build_engine(engines()[engine], st)
    try:
        for _ in range(frames):
            e.step_frame()
        d = np.asarray(e.damage(), np.float64)
    finally:
        e.close()
    D = FT ** 2 * sf * d / (2 * E * ((1 - d) * (sf - FT) + FT))
    zone = np.abs(U) < 2 * dx + s
    layers = np.round(U / s).astype(int)
    thru = [kk for kk in np.unique(layers) if (d[layers == kk] >= 0.9).all()]
    return float((D[zone] * s ** 3).sum() / A ** 2), float((D * s ** 3).sum() / A ** 2), thru, float(d[zone].max())




def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--grids", default="32,48")
    ap.add_argument("--angles", default="0,30,45")
    a = ap.parse_args()
    out = Path(__file__).parent / "results" / "oblique_band"
    old = json.loads(out.with_suffix(".json").read_text())["rows"] if out.with_suffix(".json").exists() else []
    rows = [r for r in old if r["engine"] != a.engine]      # the other engines' rows are kept
    for n in [int(g) for g in a.grids.split(",")]:
        for th in [float(t) for t in a.angles.split(",")]:
            zone, whole, thru, _ = run(a.engine, th, n)
            rows.append({"engine": a.engine, "n_grid": n, "theta_deg": th, "zone_J_m2": zone, "whole_J_m2": whole,
                         "layers_through": [int(k) for k in thru]})
            print(json.dumps(rows[-1]), flush=True)
    out.with_suffix(".json").write_text(json.dumps({"G_f": GF, "rows": rows}, indent=1))
    lines = ["# The crack band at an angle to the grid (issue 66, round 31)", "",
             "`python benchmarks/oblique_band.py` (docstring: the notched free bar). Dissipation within 2 cells of the "
             "notch per bar section (J/m^2; G_f 5 over the ligament, a quarter of it), and its ratio to theta 0 at "
             "the same grid.", "", "| engine | n_grid | theta (deg) | dissipated (J/m^2) | / theta 0 | whole body |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        ref = next((q for q in rows if q["engine"] == r["engine"] and q["n_grid"] == r["n_grid"]
                    and q["theta_deg"] == 0.0), None)
        ratio = f"{r['zone_J_m2'] / ref['zone_J_m2']:.2f}" if ref else ""
        lines.append(f"| {r['engine']} | {r['n_grid']} | {r['theta_deg']:g} | {r['zone_J_m2']:.3f} | {ratio} | "
                     f"{r['whole_J_m2']:.3f} |")
    out.with_suffix(".md").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
