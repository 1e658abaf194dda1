"""Cut a flat slab out of the real guitar (examples/data/guitar.compressed.ply) for the cloth example.

The guitar's thinnest principal axis is nearly the file's x axis; the slab keeps the Gaussians whose
file x lies within 0.06 file units (1.5 cm at the example's scale 0.25 m per unit) of the densest
x, i.e. a thin cross-section through the guitar's face, and writes them unchanged (graphdeco
layout) to examples/data/guitar_slab.ply. Run: python examples/make_guitar_slab.py
"""
from pathlib import Path

import numpy as np

from gasp_core.gs.io import read_gaussians, write_gaussians

HERE = Path(__file__).resolve().parent
HALF_THICKNESS = 0.03  # file units

g = read_gaussians(HERE / "data" / "guitar.compressed.ply")
x = g.means[:, 0]
hist, edges = np.histogram(x, bins=200, range=tuple(np.percentile(x, [1, 99])))
peak = 0.5 * (edges[np.argmax(hist)] + edges[np.argmax(hist) + 1])
keep = np.abs(x - peak) <= HALF_THICKNESS
slab = g.subset(np.flatnonzero(keep))
write_gaussians(HERE / "data" / "guitar_slab.ply", slab, overwrite=True)
print(f"kept {int(keep.sum())} of {g.n} Gaussians within {HALF_THICKNESS} of x = {peak:.4f}")
