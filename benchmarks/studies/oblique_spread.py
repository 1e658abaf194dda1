"""Issue 66, round 40: where the oblique dog-bone's gauge spread comes from (docs/fracture.md "Round 40").

Runs ``tension_oblique.build``'s specimen on one engine for 300 frames (the gauge elastic at 0.57 f_t) and reads each
gauge point's Hencky strain ``log(V)`` from ``F``, turned into the specimen's frame (axial ``a``, ``y'`` in the plane
the specimen turns in, ``z'`` across it). Over the gauge's points (its layers more than half a cell inside its ends),
prints the 5th, 50th and 95th percentile, least and largest of the largest principal strain and of each component
over the gauge's median axial strain (nu 0: the stress is E times it), and writes a PNG of the largest principal
against the axial and ``y'`` coordinates (``--png``).

Run: ``python benchmarks/studies/oblique_spread.py dogbone_2to1 45 [--per 2] [--n-grid 24] [--engine taichi_mpm]
[--grip along|free] [--png /tmp/spread.png]``; ``--per`` lattice points per cell along each axis (2: ``dx / 2``,
the family's; 4: 64 a cell).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tension_family as tf       # noqa: E402
import tension_oblique as to      # noqa: E402


def run(name: str, angle: str, n_grid: int, engine: str, per: int, grip: str, n_frames: int = 300) -> dict:
    """The gauge's strain at ``n_frames``: ``{"xl": (n, 3) rest positions in the specimen's frame (m), "eps": (n, 3,
    3) Hencky strain in that frame, "gauge": (n,) bool, "ref": the gauge's median axial strain, "d": (n,)}``."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    sp = to.SPECIMENS[name]
    orig = to.local_lattice
    to.local_lattice = lambda sp_, s: orig(sp_, tf.SIZE / n_grid / per)
    try:
        st, _, _, R, _, _ = to.build(sp, n_grid, engine, angle, grip=grip)
    finally:
        to.local_lattice = orig
    xl = (np.asarray(st.x, np.float64) - to.CENTRE) @ R + np.array([sp.length / 2, 0, 0])
    e = build_engine(engines()[engine], st)
    try:
        for _ in range(n_frames):
            e.step_frame()
        F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
        d = np.asarray(e.damage(), np.float64)
    finally:
        e.close()
    U, sig, _ = np.linalg.svd(F)
    eps = np.einsum("ji,njk,kl->nil", R, np.einsum("nij,nj,nkj->nik", U, np.log(sig), U), R)
    gl = (sp.length - sp.gauge_l) / 2
    gauge = (xl[:, 0] > gl + 0.5 * st.dx) & (xl[:, 0] < sp.length - gl - 0.5 * st.dx)
    return {"xl": xl, "eps": eps, "gauge": gauge, "ref": float(np.median(eps[gauge, 0, 0])), "d": d}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("name")
    ap.add_argument("angle")
    ap.add_argument("--per", type=int, default=2)
    ap.add_argument("--n-grid", type=int, default=24)
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--grip", default="along", choices=["along", "free"])
    ap.add_argument("--png", default="")
    a = ap.parse_args()
    r = run(a.name, a.angle, a.n_grid, a.engine, a.per, a.grip)
    g, ref = r["gauge"], r["ref"]
    emax = np.linalg.eigvalsh(r["eps"]).max(axis=1) / ref

    def q(v):
        return np.round([*np.percentile(v, [5, 50, 95]), v.min(), v.max()], 3).tolist()
    print(f"{a.name} {a.angle} deg, {a.engine}, n_grid {a.n_grid}, {a.per ** 3} points a cell, grip {a.grip}: "
          f"{int(g.sum())} gauge points; damaged anywhere: {int((r['d'] > 0.01).sum())}")
    print("largest principal / median", q(emax[g]))
    for (i, j, nm) in ((0, 0, "aa"), (1, 1, "yy"), (2, 2, "zz"), (0, 1, "ay"), (0, 2, "az"), (1, 2, "yz")):
        print(f"eps_{nm} / median", q(r["eps"][g, i, j] / ref))
    if a.png:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        xl = r["xl"]
        sel = np.abs(xl[:, 2]) < 0.06
        fig, ax = plt.subplots(figsize=(10, 3))
        sc = ax.scatter(xl[sel, 0], xl[sel, 1], c=emax[sel], s=10, cmap="coolwarm", vmin=0.8, vmax=1.2)
        fig.colorbar(sc, ax=ax)
        ax.set_xlabel("axial (m)")
        ax.set_ylabel("y' (m)")
        fig.tight_layout()
        fig.savefig(a.png, dpi=70)


if __name__ == "__main__":
    main()
