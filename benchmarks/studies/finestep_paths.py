"""Finer is never worse (issue 66/67, docs/contact.md "Round 60: finer is never worse"): each contact path's scene
at 1x, 2x, 4x and 8x the default substeps, one frame (1/30 s), its figures per step.

Scenes (n_grid 32 on a 0.6 m grid, gravity -z, a ground at z = 0, friction 0.5; :func:`scene`):
``sand_rigid`` / ``snow_rigid`` / ``sand_jelly`` / ``snow_jelly``: a ball (R 5 cm) at 5 m/s onto a 12 x 12 x 6 cm box
(rigid: ``model="rigid"``, E 1e10, rho 700, the hardwood restitution 0.55; jelly: E 1e5) on the ground
(``benchmarks/studies/finestep_pair.py``'s scene, the ``"mixed"`` two-field contact with the flowing body's touch);
``box_alone``: the rigid box alone; ``*_e0``: the rigid box with ``restitution = 0`` (the traced term switched off);
``jelly_walls``: a jelly ball (R 5 cm, ``Material("jelly")``) thrown at 3 m/s along +x, 2 cm from the domain's
``walls`` (the particle contact), no ground; ``three``: three jelly cubes (8 cm) stacked 10 mm apart, falling freely
with no ground (three bodies on the particle contact, one field: the known answer ``v_z = -g t`` each).
Figures: the box's mean velocity (m/s) and its mean z change (mm), the flowing points below the box's top inside its
footprint, and the total energy (kinetic + gravity's, J) over the start's.
Usage: ``python benchmarks/studies/finestep_paths.py taichi_mpm sand_rigid,box_alone 1,2,4,8``.
"""
import sys, time
import numpy as np
from gasp_core.seam.build import build_engine
from gasp_core.seam.plugins import engines
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing.helpers import box_points

#: The default substeps a frame of the sand scenes at n_grid 32 (taichi_mpm, measured); the study's 1x is each scene's
#: own default (``n_substeps`` unset), its 2x-8x that times k.
N_DEFAULT = {32: 90}


def _other(name, s, opts, n_grid):
    """The scenes ``jelly_walls`` and ``three`` (module notes): ``(setup, n_first)``."""
    if name == "jelly_walls":
        g = np.mgrid[-0.05:0.05:s, -0.05:0.05:s, -0.05:0.05:s].reshape(3, -1).T + s / 2
        parts = [g[np.linalg.norm(g, axis=1) <= 0.05] + np.array([0.3 - 0.07, 0.0, 0.28])]
        bnd, speed = [Boundary("walls", friction=0.5)], 3.0
    else:
        parts = [box_points((-0.04, -0.04, 0.2 + 0.09 * i), (0.04, 0.04, 0.28 + 0.09 * i), s)[0] for i in range(3)]
        bnd, speed = [], 0.0
    x = np.vstack(parts); v = np.zeros_like(x); v[:, 0] = speed
    body = np.concatenate([np.full(len(q), i) for i, q in enumerate(parts)])
    return SimSetup(x=x, v=v, p_vol=np.full(len(x), s ** 3), body_id=body, materials=[Material("jelly")] * len(parts),
                    gravity=np.array([0, 0, -9.81]), domain_lo=np.array([-0.3, -0.3, -0.02]),
                    domain_hi=np.array([0.3, 0.3, 0.58]), n_grid=n_grid, boundaries=bnd, frame_dt=1 / 30,
                    options=opts), len(parts[0])


def scene(name, n_substeps=None, n_grid=32, speed=5.0, box=(0.12, 0.12, 0.06)):
    """``(setup, n_box)``: the scene ``name`` (module notes); the box's points come first. ``box`` (m): its sides
    (x, y, z), on the ground, centred under the ball (round 76's family)."""
    dx = 0.6 / n_grid; s = dx / 2
    if name in ("jelly_walls", "three"):
        return _other(name, s, {} if n_substeps is None else {"n_substeps": int(n_substeps)}, n_grid)
    bx, by, bz = box
    xb, _ = box_points((-bx / 2, -by / 2, 0.0), (bx / 2, by / 2, bz), s)
    twin = name.endswith("2")   # round 76: two boxes, the halves along x one spacing apart, sharing a field
    if twin:
        name = name[:-1]
        xb2, _ = box_points((s / 2, -by / 2, 0.0), (bx / 2, by / 2, bz), s)
        xb, _ = box_points((-bx / 2, -by / 2, 0.0), (-s / 2, by / 2, bz), s)
        xb = np.vstack([xb, xb2])
    kind = name.split("_")[0]
    rigid = "rigid" in name or kind == "box"
    box = (Material("jelly", E=1e10, rho=700.0, model="rigid", restitution=0.0 if name.endswith("_e0") else None)
           if rigid else Material("jelly", E=1e5, rho=700.0))
    mats, xs = [box, box] if twin else [box], np.zeros((0, 3))
    if kind != "box":
        g = np.mgrid[-0.05:0.05:s, -0.05:0.05:s, -0.05:0.05:s].reshape(3, -1).T + s / 2
        xs = g[np.linalg.norm(g, axis=1) <= 0.05] + np.array([0.0, 0.0, bz + 0.005 + 0.05])
        mats.append(Material(kind))
    x = np.vstack([xb, xs]); v = np.zeros_like(x); v[len(xb):, 2] = -speed
    body = np.r_[np.zeros(len(xb), int), np.ones(len(xs), int)]
    if twin:   # the first half body 0, the second body 1, the flowing ball body 2
        body = np.r_[(xb[:, 0] > 0).astype(int), np.full(len(xs), 2)]
    opts = {} if n_substeps is None else {"n_substeps": int(n_substeps)}
    return SimSetup(x=x, v=v, p_vol=np.full(len(x), s ** 3), body_id=body, materials=mats,
                    gravity=np.array([0, 0, -9.81]), domain_lo=np.array([-0.3, -0.3, -0.02]),
                    domain_hi=np.array([0.3, 0.3, 0.58]), n_grid=n_grid, boundaries=[Boundary("ground", height=0.0,
                    friction=0.5)], frame_dt=1 / 30, options=opts), len(xb)


def energy(x, v, m):
    """Kinetic plus gravity's energy (J) of points ``x``, ``v`` (n, 3) of mass ``m`` (n,), g 9.81 along -z."""
    return float(0.5 * (m * (v ** 2).sum(1)).sum() + 9.81 * (m * x[:, 2]).sum())


def run(eng, name, n_substeps=None, frames=1, n_grid=32, box=(0.12, 0.12, 0.06)):
    """The figures after ``frames`` frames: dict of box_v (3,), box_dz (mm), below (points), e_ratio, n_substeps,
    box_w (rad/s, the box's largest point speed about its mean over its half-diagonal: its spin's size)."""
    st, nb = scene(name, n_substeps, n_grid, box=box)
    rho = np.array([mt.rho for mt in st.materials])
    m = rho[st.body_id] * st.p_vol
    e = build_engine(engines()[eng], st)
    try:
        x0 = np.asarray(e.positions(), float); e0 = energy(x0, np.asarray(e.velocities(), float), m)
        for _ in range(frames):
            e.step_frame()
        x = np.asarray(e.positions(), float); v = np.asarray(e.velocities(), float)
        dz = x[:nb, 2].mean() - x0[:nb, 2].mean()
        xs = x[nb:]
        inside = (np.abs(xs[:, 0]) < box[0] / 2) & (np.abs(xs[:, 1]) < box[1] / 2) & (xs[:, 2] < box[2] + dz)
        bodies = [v[np.asarray(st.body_id) == b].mean(0) for b in range(len(st.materials))]
        box_w = float(np.linalg.norm(v[:nb] - v[:nb].mean(0), axis=1).max() / (0.5 * np.linalg.norm(box)))
        return dict(box_v=v[:nb].mean(0), box_w=box_w, body_v=bodies, x_max=float(x[:, 0].max()), box_dz=1e3 * dz, below=int(inside.sum()),
                    e_ratio=energy(x, v, m) / e0, n_substeps=e.stats()["n_substeps"])
    finally:
        e.close()


if __name__ == "__main__":
    eng, names = sys.argv[1], sys.argv[2].split(",")
    mults = [int(k) for k in (sys.argv[3] if len(sys.argv) > 3 else "1,2,4,8").split(",")]
    print("| engine | scene | substeps | box v (m/s) | box dz (mm) | below | E / E0 | s | bodies' v (m/s) / largest x (m) |")
    for name in names:
        n1 = None
        for k in mults:
            t = time.time()
            r = run(eng, name, None if n1 is None else k * n1)
            n1 = n1 or r["n_substeps"] // max(k, 1)
            print(f"| {eng} | {name} | {r['n_substeps']} ({k}x) | {np.array2string(r['box_v'], precision=4)} | "
                  f"{r['box_dz']:+.2f} | {r['below']} | {r['e_ratio']:.4f} | {time.time() - t:.0f} | "
                  f"{' '.join(np.array2string(b, precision=4) for b in r['body_v'])} / {r['x_max']:.4f} |", flush=True)
