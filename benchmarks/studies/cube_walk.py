"""Round 78 (docs/contact.md "Round 78"): the 10 cm jelly cube (E 1e5 Pa, nu 0.3, rho 1000) of
``tests/test_elastic_slope.py`` on a 30 degree slope: its landing (the first frame from 0.1 s on whose centroid moves
under 1 mm/s, and its travel to there) and its travel from 0.5 s to 1.5 s, with the probes that traced the particle
contact's walk. Prints one line a case.

    python benchmarks/studies/cube_walk.py --engine warp_mpm --n 24 32 48 --contact particle grid
    python benchmarks/studies/cube_walk.py --n 32 --damping 1.0 2.0        # the contact's DAMPING (a probe)
    python benchmarks/studies/cube_walk.py --n 32 --torque-reach 0              # the balance's TORQUE_REACH (warp_mpm)
    python benchmarks/studies/cube_walk.py --n 32 --no-balance
    python benchmarks/studies/cube_walk.py --n 24 32 48 --viscosity 5 30
    python benchmarks/studies/cube_walk.py --n 24 32 48 64 --mu 0.6 0.7 0.8 10   # round 79: the ring against mu

Round 79 added the ring: the centroid's height along the ground's normal, peak to peak over 1.0-1.6 s (sampled at
the frames), the cube's axial ring whose normal-force swing the walk rides (docs/contact.md "Round 79").
"""
import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
from slopes import centroids, landing_end  # noqa: E402
from test_elastic_slope import CUBE, block_setup  # noqa: E402
from test_rigid_slope import FPS  # noqa: E402

import gasp_core.mpm.contact as contact  # noqa: E402


def case(engine: str, n_grid: int, kind: str, mu: float, viscosity: float, balance: bool) -> str:
    s = block_setup(30, mu, kind, CUBE, n_grid)
    if viscosity:
        s.materials = [dataclasses.replace(s.materials[0], viscosity=viscosity)]
    if not balance:
        s.options = {**s.options, "contact_balance": False}
    c = centroids(engine, s, round(1.6 * FPS))
    if c is None:
        return "left the box"
    end = landing_end(c, FPS, round(0.1 * FPS))
    x = 1000.0 * (c[:, 0] - c[0, 0])
    land = f"landing {x[end]:.2f} mm, frame {end}" if end is not None else "not landed"
    z = 1000.0 * c[round(1.0 * FPS):, 2]   # the height along the ground's normal over the last 0.6 s (round 79)
    return (f"{land}; travel 0.5-1.5 s {x[round(1.5 * FPS)] - x[round(0.5 * FPS)]:.3f} mm; "
            f"ring 1.0-1.6 s {float(np.ptp(z)):.4f} mm peak to peak")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm", choices=("warp_mpm", "taichi_mpm"))
    ap.add_argument("--n", type=int, nargs="+", default=[32])
    ap.add_argument("--contact", nargs="+", default=["particle"], choices=("particle", "grid"))
    ap.add_argument("--mu", type=float, nargs="+", default=[0.6])
    ap.add_argument("--viscosity", type=float, nargs="+", default=[0.0], help="Kelvin-Voigt eta, Pa s")
    ap.add_argument("--damping", type=float, nargs="+", default=[contact.DAMPING],
                    help="gasp_core.mpm.contact.DAMPING for the probe (the shipped value by default)")
    ap.add_argument("--kappa", type=float, default=None,
                    help="gasp_core.mpm.contact.KAPPA for the probe (round 79; the shipped value by default)")
    ap.add_argument("--torque-reach", type=float, default=None,
                    help="the balance's TORQUE_REACH, warp_mpm only (its kernels read it when they compile)")
    ap.add_argument("--no-balance", action="store_true", help="contact_balance = false")
    a = ap.parse_args()
    reach = a.torque_reach
    if reach is not None:   # one value a process: the balance's kernels read it when they compile
        if a.engine != "warp_mpm":
            ap.error("--torque-reach: warp_mpm only")
        import warp as wp
        import gasp_warp_mpm.balance as bal
        bal.TORQUE_CLIP = wp.constant(float(reach))
    if a.kappa is not None:
        contact.KAPPA = a.kappa   # read per point by contact.contact_coefficients, as DAMPING
    for damping in a.damping:
        contact.DAMPING = damping   # read per point by contact.contact_coefficients
        for n in a.n:
            for kind in a.contact:
                for eta, mu in ((e, m) for e in a.viscosity for m in a.mu):
                    out = case(a.engine, n, kind, mu, eta, not a.no_balance)
                    print(f"{a.engine} n_grid {n} {kind} mu {mu} viscosity {eta:g} DAMPING {damping:g}"
                          f"{'' if reach is None else f' TORQUE_REACH {reach:g}'}"
                          f"{'' if a.kappa is None else f' KAPPA {a.kappa:g}'}"
                          f"{' no balance' if a.no_balance else ''}: {out}", flush=True)


if __name__ == "__main__":
    main()
