"""Round 61 (``docs/contact.md`` "Round 61: a touch that reads the curvature"): where the touch by geometry's NumPy
reference (``gasp_core.mpm.gap_touch.gap_marks``) first marks two lattices brought together, per rule and pair of
shapes, without dynamics: the static part of the gap at rest (the rest is the sink after the first touch).

Two lattices at spacing dx / 2 on a grid of 24 cells (dx 1): the lower body B (a cube 8 cells wide or a ball), the
upper body A (a cube 5 cells wide, a ball, or a cylinder on its side) lowered along z; the face gap bisected (12
steps) to the largest at which any node is marked, reported as ``tests/test_stacked_balls.py``'s measure
(``surface_gap``: nearest points less half of each one's spacing), in dx, at four places of the bodies in their cells.
Rules: ``curve`` (``CURVATURE``), ``sep0.5`` (round 60), ``sep0`` (round 60 at SEPARATION 0).

``--shift``: the smoothing's shift itself. Points 0.05-0.6 dx outside a lattice ball of radius R (400 random
directions, four places of the ball in its cell): the distance the half-space level reads from the other field's
gathered fraction less the true distance to the lattice's surface (``surface_gap``'s), against ``SIGMA2 k`` (``k`` the
least principal curvature of the field's level surface at the point, ``gap_touch.least_curvature``) and the mean
curvature's ``SIGMA2 (k1 + k2) / 2``.

Usage: ``python benchmarks/studies/gap_first_mark.py [--shift]`` (about a minute).
"""
import numpy as np
from scipy.spatial import cKDTree

from gasp_core.mpm import gap_touch as G
from gasp_core.mpm.fields_reference import flow_touch_level
from gasp_core.testing.scenes_pairs import surface_gap

NG, S = 24, 0.5


def scatter(x):
    """P2G's quadratic B-spline scatter of points ``x`` (n, 3) each of volume ``S^3``: (NG, NG, NG)."""
    out = np.zeros((NG,) * 3)
    base = np.floor(x - 0.5).astype(int)
    fx = x - base
    w = [0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1.0) ** 2, 0.5 * (fx - 0.5) ** 2]
    for i in range(3):
        for j in range(3):
            for k in range(3):
                np.add.at(out, (base[:, 0] + i, base[:, 1] + j, base[:, 2] + k),
                          S ** 3 * w[i][:, 0] * w[j][:, 1] * w[k][:, 2])
    return out


def lattice(kind, size, c):
    """The points of a ``kind`` ("cube": half-width ``size``; "ball", "cyl": radius ``size``) centred at ``c``."""
    g = np.arange(-NG / 2, NG / 2, S) + S / 2
    p = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    if kind == "ball":
        p = p[np.linalg.norm(p, axis=1) <= size]
    elif kind == "cyl":
        p = p[(np.hypot(p[:, 0], p[:, 2]) <= size) & (np.abs(p[:, 1]) < 3.0)]
    else:
        p = p[(np.abs(p) < size).all(1)]
    return p + c


def marked(xa, xb, rule):
    x = np.vstack([xa, xb])
    in_a = np.r_[np.ones(len(xa), bool), np.zeros(len(xb), bool)]
    vf = np.stack([scatter(xa), scatter(xb)])
    near = np.r_[cKDTree(xb).query(xa)[0], cKDTree(xa).query(xb)[0]] < 2.0   # no other point marks
    x, in_a = x[near], in_a[near]
    if rule == "curve":
        return G.gap_marks(x, in_a, vf, np.zeros(3), 1.0, None, np.full(len(x), 0.25), G.half_space_table()).any()
    lv = flow_touch_level(0.5 * (0.5 + (0.5 if rule == "sep0.5" else 0.0)))
    return G.gap_marks(x, in_a, vf, np.zeros(3), 1.0, np.full(len(x), lv)).any()


def first_mark(a, b, rule, off):
    xb = lattice(b[0], b[1], np.array([NG / 2, NG / 2, 6.0]) + off)
    top = xb[:, 2].max() + S / 2
    xa = lattice(a[0], a[1], np.array([NG / 2 + 0.03 + 0.37 * off[0], NG / 2 + 0.07 + 0.37 * off[1], 0.0]))
    xa[:, 2] -= xa[:, 2].min() - S / 2
    lo, hi = -0.6, 0.8
    for _ in range(12):
        m = 0.5 * (lo + hi)
        lo, hi = (m, hi) if marked(xa + [0, 0, top + m], xb, rule) else (lo, m)
    x = np.vstack([xa + [0, 0, top + lo], xb])
    return surface_gap(x, np.r_[np.zeros(len(xa), int), np.ones(len(xb), int)], S ** 3)


def shift_check():
    rng = np.random.default_rng(0)
    table = G.half_space_table()
    for r in (2.0, 2.67, 4.0, 8.0):
        excess, shift, mean = [], [], []
        for _ in range(4):
            c = np.full(3, NG / 2) + rng.random(3)
            p = lattice("ball", r, c)
            vf = scatter(p)
            d = rng.normal(size=(400, 3))
            x = c + d / np.linalg.norm(d, axis=1)[:, None] * (r + rng.uniform(-0.2, 1.0, (400, 1)))
            dist = cKDTree(p).query(x)[0] - S / 2
            x = x[(dist > 0.05) & (dist < 0.6)]
            dist = dist[(dist > 0.05) & (dist < 0.6)]
            base = np.floor(x - 0.5).astype(int)
            for q in range(len(x)):
                b = base[q]
                phi, g, h = G.gather_derivatives(vf[b[0]:b[0] + 3, b[1]:b[1] + 3, b[2]:b[2] + 3], x[q] - b)
                excess.append(np.interp(-phi, -table, np.arange(G.TABLE_N) * G.TABLE_STEP) - dist[q])
                shift.append(G.SIGMA2 * G.least_curvature(g[None], h[None])[0])
                mean.append(G.SIGMA2 / 2 * (g @ h @ g - (g @ g) * np.trace(h)) / np.linalg.norm(g) ** 3)
        print(f"ball R {r:g} dx: the half-space reading's excess distance {np.mean(excess):+.3f} dx (sd "
              f"{np.std(excess):.3f}), SIGMA2 k {np.mean(shift):+.3f} dx (the mean curvature's SIGMA2 (k1 + k2) / 2 "
              f"{np.mean(mean):+.3f})", flush=True)


def main():
    import sys
    if "--shift" in sys.argv:
        shift_check()
        return
    pairs = [(("cube", 2.5), ("cube", 4.0)), (("ball", 2.67), ("cube", 4.0)), (("cyl", 2.67), ("cube", 4.0)),
             (("ball", 2.0), ("ball", 2.0)), (("ball", 3.0), ("ball", 3.0))]
    for rule in ("curve", "sep0.5", "sep0"):
        for a, b in pairs:
            gs = [first_mark(a, b, rule, np.array([o, 0.5 * o, 0.3 * o])) for o in (0.0, 0.25, 0.5, 0.75)]
            print(f"{rule:7s} {a[0]} {a[1]:g} on {b[0]} {b[1]:g}: first mark at {np.mean(gs):+.3f} dx (range "
                  f"{min(gs):+.3f} to {max(gs):+.3f})", flush=True)


if __name__ == "__main__":
    main()
