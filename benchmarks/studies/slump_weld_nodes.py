"""Round 58 (docs/contact.md "Round 58: the sand's base slips at Coulomb's bound", item 1): what welds the sand
cube's base on the grid contact. The cube of ``gasp_core.testing.sand_slump`` (20 cm, n_grid 32, 26 substeps) on
taichi_mpm: after ``frames`` frames, per node layer ``I_z`` near the ground over the block's outer part
(``|X - 0.5| > 7 cm`` along x, the columns the points there read), the nodes' mass, and their velocity before the
walls' and grounds' rule (after gravity) and after it (the last substep of the frame): mass-weighted means of the
outward tangential velocity ``v_t`` (m/s, along ``sign(X - 0.5)``) and of ``v_z``, and the fraction of the
layer's mass on nodes the rule stopped (``|v_t|`` after under 1e-6 m/s). Then, for the bottom point rows (height
above the ground in quarter cells), each row's quadratic B-spline weights on those layers.

The study wraps ``GridUpdate.touch_keep`` (called with each node's mass and velocity right before
``boundary_rules``) to record them; the engine's code is unchanged.

Run from the repository root: ``python benchmarks/studies/slump_weld_nodes.py [frames] [n_grid] [substeps]
[contact]`` (default 6 32 26 auto; about a minute).
"""
import sys

import numpy as np
import taichi as ti

from gasp_core.seam import build_engine, get_engine
from gasp_core.testing.sand_slump import GROUND, block


def main(frames: int = 6, n: int = 32, k: int = 26, contact: str = "auto") -> None:
    from gasp_taichi_mpm import grid as tgrid
    rec = {}
    orig = tgrid.GridUpdate.touch_keep

    @ti.func
    def touch_keep(self, I, v, m):
        rec["v"][I] = v
        rec["m"][I] = m
        orig(self, I, v, m)

    s = block((0.2, 0.2, 0.2), n, k, contact=contact)
    e = build_engine(get_engine("taichi_mpm"), s)
    sol = e.solver
    rec["v"] = ti.Vector.field(3, sol.real, shape=(n, n, n))
    rec["m"] = ti.field(sol.real, shape=(n, n, n))
    tgrid.GridUpdate.touch_keep = touch_keep
    try:
        for _ in range(frames):
            rec["m"].fill(0.0)
            e.step_frame()
    finally:
        tgrid.GridUpdate.touch_keep = orig
    dx = 1.0 / n
    lo3 = np.asarray(sol.lo.to_numpy(), float)   # the grid's origin (m)
    lo = float(lo3[2])
    vpre, m = rec["v"].to_numpy().astype(float), rec["m"].to_numpy().astype(float)
    vpost = sol.grid_v.to_numpy().astype(float)
    kmax = int(np.asarray(sol.ground_kmax.to_numpy())[0]) if hasattr(sol, "ground_kmax") else None
    X = lo3[0] + np.arange(n) * dx
    side = np.sign(X - 0.5)[:, None, None]
    outer = (np.abs(X - 0.5) > 0.07)[:, None, None] & np.ones((1, n, 1), bool)
    print(f"taichi_mpm, contact {contact}, n_grid {n}, {k} substeps, after {frames} frames; ground at "
          f"{(GROUND - lo) / dx:.2f} dx, ground_kmax {kmax}; grid origin {lo / dx:+.2f} dx; flip {sol.flip}")
    print("I_z  z-ground(dx)  mass(g)  pre v_t  pre v_z   post v_t  post v_z  stopped")
    g = (GROUND - lo) / dx   # the ground's plane in node units
    for kz in range(max(0, int(g) - 2), int(g) + 5):
        sel = outer[:, :, 0] & (m[:, :, kz] > 0)
        mm = m[:, :, kz][sel]
        if mm.sum() <= 0:
            continue
        w = mm / mm.sum()
        vt0 = (side[:, :, 0] * vpre[:, :, kz, 0])[sel]
        vt1 = (side[:, :, 0] * vpost[:, :, kz, 0])[sel]
        st = np.hypot(vpost[:, :, kz, 0], vpost[:, :, kz, 1])[sel] < 1e-6
        print(f"{kz:3d}  {kz - g:+6.2f}  {1e3 * mm.sum():8.3f}  {w @ vt0:+.4f}  {w @ vpre[:, :, kz, 2][sel]:+.4f}"
              f"   {w @ vt1:+.4f}  {w @ vpost[:, :, kz, 2][sel]:+.4f}  {w @ st:.2f}")
    # the outer columns' balance over the substep: the normal impulse the rule took (kg m/s, + up), the friction
    # it gave (the tangential momentum it took), against the columns' weight times dt (their Coulomb bound mu W dt)
    dt = float(sol.dt[None])
    colm = (m * outer[:, :, :1]).sum()
    dvz = (vpost[..., 2] - vpre[..., 2]) * m * outer[:, :, :1]
    ft = (np.hypot(vpre[..., 0], vpre[..., 1]) - np.hypot(vpost[..., 0], vpost[..., 1])) * m * outer[:, :, :1]
    W = colm * 9.81 * dt
    print(f"outer columns: mass {colm:.3f} kg, dt {dt:.3e} s; normal impulse taken {dvz.sum() / W:.2f} W dt "
          f"(by layer: {', '.join(f'{kz}: {dvz[:, :, kz].sum() / W:.2f}' for kz in range(n) if abs(dvz[:, :, kz].sum()) > 1e-3 * W)}); "
          f"friction given {ft.sum() / W:.2f} W dt (Coulomb's bound {0.5:.2f} W dt)")
    x, v = e.positions().astype(float), e.velocities().astype(float)
    zc = (x[:, 2] - GROUND) / dx
    print("point row (height above ground, dx): weights on layers base..base+2 (mean), outward v_p")
    for r0 in np.arange(0.0, 1.5, 0.25):
        sel = (np.abs(x[:, 0] - 0.5) > 0.07) & (zc >= r0) & (zc < r0 + 0.25)
        if not sel.any():
            continue
        u = (x[sel, 2] - lo) / dx
        base = np.floor(u - 0.5).astype(int)
        fx = u - base
        wts = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2], 1)
        bs = np.unique(base)
        print(f"  {r0:.2f}-{r0 + .25:.2f}: {sel.sum():5d} points, base layer(s) {bs.tolist()}, weights "
              f"{np.round(wts.mean(0), 3).tolist()}, v_out {np.mean(np.sign(x[sel, 0] - 0.5) * v[sel, 0]):+.4f}")


if __name__ == "__main__":
    a = sys.argv[1:]
    main(*(int(q) for q in a[:3]), *a[3:4])
