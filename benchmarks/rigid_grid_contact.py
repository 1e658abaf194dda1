"""Round 51 (issue 67; docs/contact.md "Round 51: a rigid body on the grid contact"): a rigid body under the engine
option ``contact = "grid"`` (``gasp_core.testing.rigid_grid``): per engine and n_grid the 7.5 cm cube's centroid drop
over 1.1 s on a flat ground and its lowest point over the plane at the end (mm, against the particle contact's skin),
then the slides (30 deg, mu 0.3: the acceleration's error against ``g (sin - mu cos)``) and sticks (30 deg, mu 0.7:
the travel in 1 s after a 0.1 s settle) of a slab, a cube and a disc; one line each on stdout.

    python benchmarks/rigid_grid_contact.py --engines warp_mpm taichi_mpm > benchmarks/results/rigid_grid_contact.txt
"""
import argparse
import math

from gasp_core.testing import rigid_grid as R

G = 9.81


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", nargs="+", default=["warp_mpm", "taichi_mpm"])
    ap.add_argument("--grids", type=int, nargs="+", default=[24, 32])
    a = ap.parse_args()
    for eng in a.engines:
        for n in a.grids:
            drop, low, skin = R.sink(eng, n)
            dx = 1000.0 * R.SIDE / n
            print(f"{eng} n_grid {n} cube on a flat ground: centroid drop {drop * dx:.3f} mm ({drop:+.4f} dx), lowest "
                  f"point {low * dx:+.3f} mm over the plane (skin {skin * dx:.3f} mm)", flush=True)
            for shape in R.SHAPES:
                for theta, mu in ((30.0, 0.7), (30.0, 0.3)):
                    f = R.slope_figure(eng, shape, n, theta, mu)
                    t = math.radians(theta)
                    a0 = G * (math.sin(t) - mu * math.cos(t))
                    fig = f"stick: {f:.3f} mm in 1 s" if a0 <= 0 else f"slide: {100 * (f / a0 - 1):+.3f} %"
                    print(f"{eng} n_grid {n} {shape} {theta:g} deg mu {mu:g}: {fig}", flush=True)


if __name__ == "__main__":
    main()
