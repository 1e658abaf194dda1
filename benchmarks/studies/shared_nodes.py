"""Round 55 (docs/contact.md "Round 55: a node's support in the balance"): scenes whose contact nodes several rows of
the contact's balance share, run two frames on taichi_mpm's cpu and gpu schedules and on warp_mpm (the particle
contact, 34 substeps a frame): the largest position difference between each pair (m).

- ``column a<a> n<n_grid>``: the conformance sand column (``benchmarks/lube_family.py``) in its channel, against the
  ground and three wall faces;
- ``corner``: a jelly block (E 1e5 Pa) pressed into a corner of the walls and the ground by a gravity tilted alike
  along x and y (the nodes on the diagonal pushed alike by two walls).

``PYTHONPATH=<tree>:<tree>/plugins/taichi_mpm:<tree>/plugins/warp_mpm python benchmarks/studies/shared_nodes.py``
on two trees compares their rules (``--balance-off``: the same with ``contact_balance = false``).
"""
import sys
from pathlib import Path

import numpy as np

from gasp_core.seam import build_engine, get_engine
from gasp_core.seam.setup import Boundary, Material
from gasp_core.testing.helpers import box_points, make_setup

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import lube_family as lf  # noqa: E402

SCENES = ("column a2 n48", "column a1 n32", "column a3 n40", "corner")
RUNS = [("taichi_mpm", {}), ("taichi_mpm", {"schedule": "gpu"}), ("warp_mpm", {})]
N_FRAMES, N_SUBSTEPS = 2, 34


def scene(name: str, info, options: dict):
    """The scene ``name`` of :data:`SCENES` on the particle contact with the engine ``options`` added."""
    opts = {"n_substeps": N_SUBSTEPS, "contact": "particle", **options}
    if name.startswith("column"):
        a, n = name.split()[1:]
        return lf.column_setup(info, float(a[1:]), int(n[1:])).replace(options=opts)
    n_grid = 32
    dx = 1.0 / n_grid
    lo = 3 * dx + dx / 8
    x, p_vol = box_points((lo, lo, lo), (lo + 0.12, lo + 0.12, lo + 0.12), dx / 2)
    return make_setup(x, p_vol, Material("jelly", E=1e5, nu=0.3, rho=1000.0), gravity=(-4.0, -4.0, -8.0),
                      n_grid=n_grid, options=opts,
                      boundaries=[Boundary("ground", height=3 * dx, friction=0.5), Boundary("walls", friction=0.3)])


def main() -> None:
    extra = {"contact_balance": False} if "--balance-off" in sys.argv else {}
    for name in SCENES:
        xs = []
        for eng, opt in RUNS:
            info = get_engine(eng)
            e = build_engine(info, scene(name, info, {**opt, **extra}))
            for _ in range(N_FRAMES):
                e.step_frame()
            xs.append(e.positions().astype(np.float64))
        d = [np.abs(xs[i] - xs[j]).max() for i, j in ((0, 1), (0, 2), (1, 2))]
        print(f"{name}: taichi cpu/gpu {d[0]:.2e}, taichi cpu/warp {d[1]:.2e}, taichi gpu/warp {d[2]:.2e} m", flush=True)


if __name__ == "__main__":
    main()
