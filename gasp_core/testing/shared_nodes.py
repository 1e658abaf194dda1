"""Scenes whose contact nodes several rows of the contact's balance share (round 55, docs/contact.md "Round 55: a
node's support"; ``gasp_core.mpm.contact_mark``): a node's support must not hang on the order of the points, so the
two MLS-MPM engines and taichi_mpm's two schedules give the same motion to float rounding.

- ``column a<a> n<n_grid>``: the conformance sand column (``benchmarks/lube_family.py``) of aspect ``a`` on ``n_grid``
  cells in its channel, against the ground and three wall faces;
- ``corner``: a jelly block (E 1e5 Pa) pressed into a corner of the walls and the ground by a tilted gravity, the
  same along x and y (the nodes on the diagonal pushed alike by two walls).

Each on the particle contact at a fixed number of substeps a frame. Used by ``tests/test_contact_mark.py``.
"""
from __future__ import annotations

from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points, make_setup

#: The scenes' names (:func:`shared_scene`).
SCENES = ("column a2 n48", "column a1 n32", "column a3 n40", "corner")
#: Frames each scene runs, and substeps a frame.
N_FRAMES, N_SUBSTEPS = 2, 34


def shared_scene(name: str, column_setup=None) -> SimSetup:
    """The scene ``name`` of :data:`SCENES` on the particle contact (``column_setup``: ``benchmarks/lube_family``'s
    builder for ``column``, ``(info, a, n_grid) -> SimSetup``, with its engine info bound)."""
    opts = {"n_substeps": N_SUBSTEPS, "contact": "particle"}
    if name.startswith("column"):
        a, n = name.split()[1:]
        return column_setup(float(a[1:]), int(n[1:])).replace(options=opts)
    n_grid = 32
    dx = 1.0 / n_grid
    jelly = Material("jelly", E=1e5, nu=0.3, rho=1000.0)
    walls = [Boundary("ground", height=3 * dx, friction=0.5), Boundary("walls", friction=0.3)]
    if name == "corner":
        lo = 3 * dx + dx / 8
        x, p_vol = box_points((lo, lo, lo), (lo + 0.12, lo + 0.12, lo + 0.12), dx / 2)
        return make_setup(x, p_vol, jelly, gravity=(-4.0, -4.0, -8.0), n_grid=n_grid, boundaries=walls, options=opts)
    raise ValueError(f"shared_scene: unknown scene {name!r}, expected one of {SCENES}")
