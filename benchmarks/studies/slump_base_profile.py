"""Round 57 (docs/contact.md "Round 57: the slump's step ladder", "The welded layer, seen"): the sand cube of
``gasp_core.testing.sand_slump`` (20 cm, n_grid 32) on the grid contact and on the particle contact on the ground (its
walls taken away), warp_mpm: after ``frames`` frames, the mean outward speed (m/s) of the points more than 7 cm from
the axis, binned by height above the ground in quarter cells (the point count in brackets).

Run from the repository root: ``python benchmarks/studies/slump_base_profile.py [n_grid] [substeps] [frames]``
(default 32 26 6; seconds).
"""
import sys

import numpy as np

from gasp_core.seam import build_engine, get_engine
from gasp_core.testing.sand_slump import GROUND, block


def main(n: int = 32, k: int = 26, frames: int = 6) -> None:
    for contact in ("auto", "particle"):
        s = block((0.2, 0.2, 0.2), n, k, contact=contact)
        if contact == "particle":
            s.boundaries = [b for b in s.boundaries if b.kind != "walls"]
        e = build_engine(get_engine("warp_mpm"), s)
        for _ in range(frames):
            e.step_frame()
        x, v = e.positions().astype(float), e.velocities().astype(float)
        outer = np.abs(x[:, 0] - 0.5) > 0.07
        z = (x[:, 2] - GROUND) * n
        rows = []
        for lo in np.arange(0.0, 2.5, 0.25):
            m = outer & (z >= lo) & (z < lo + 0.25)
            if m.sum():
                rows.append(f"{lo:.2f}: {np.mean(np.sign(x[m, 0] - 0.5) * v[m, 0]):.3f} ({m.sum()})")
        print(contact, f"lowest point {z.min():.3f} dx;", "  ".join(rows))


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:4]))
