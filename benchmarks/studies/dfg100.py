"""Round 100: damage-field-gradient partitioning (DFG) tried on the pieces family's ball (issue 66 "Pieces": the pieces
of 5 % or more never decrease with speed; ``docs/fracture.md`` "Round 100").

Rounds 82 and 99 tried three classes of damage in the engines, and each missed the row for the same reason: broken
material stays in one velocity field, so nothing throws the fragments apart. DFG (Homel & Herbold 2017,
"Field-gradient partitioning for fracture and frictional contact in the material point method", Int. J. Numer. Meth.
Eng. 109, 1013; in graphics Wolper et al. 2019, "CD-MPM", ACM TOG 38(4)) gives a node two velocity fields and puts
each point, node by node, on the side of the crack it lies on (the sign of its damage gradient against the node's).
Where both sides are broken enough, the fields meet in frictional contact and are free to part.

The engines' two fields are shared out per body, so DFG cannot be laid on them as a patch. This study is a NumPy
MLS-MPM apart from the engines (as ``cube_fem.py`` was for round 80), run twice on the same ball, material, ground,
walls and steps: one velocity field (the engines' class) and DFG. Only the fields differ.

- The ball: ``gasp_core.testing.scenes_pieces.ball_setup`` (radius 0.1 m, points at ``dx / 2``, E 200 kPa, nu 0.25,
  rho 300, f_t 10 kPa, G_f 10 J/m^2), landing at 1, 2, 4, 7 and 10 m/s on a ground of friction 0.5, walls.
- The material: the engines' brittle law (``gasp_core.mpm.materials.brittle_damage``: Hencky principal stresses, the
  largest sets a linear-softening damage over the crack band ``dx``; the tensile principal stresses are scaled by
  ``1 - d``; damage never heals). The band weight of round 33 is left out (the same ``s_f`` everywhere).
- The step: MLS-MPM (Hu et al. 2018), quadratic B-splines, APIC, the ground and walls on the nodes (Coulomb at the
  ground's friction, the walls slip); a substep of 0.3 ``dx / (c_l + v)``.
- DFG: a point's damage gradient is that of the Shepard-smoothed damage on the grid; a node's is its points'
  largest (Homel & Herbold's max rule); a point is in field 0 at a node when the two gradients do not point apart,
  else field 1. A node with both fields is separable when a point there is fully broken and each field's mean damage
  is over ``--d-min`` (0.25, Homel & Herbold's); there the fields meet in Coulomb contact (``--mu``, 0.5) when they
  approach and part freely when they do not; elsewhere they move as one.

The pieces are counted two ways, as the family's test does: the run's tracker (``gasp_core.run.pieces``, geometry and
damage) and the frames alone with the links that opened kept open (``FramePieces(remember=True)``), pieces of 5 %.

    python benchmarks/studies/dfg100.py --frames 30 --out benchmarks/results/dfg100.json
"""
from __future__ import annotations

import argparse
import json
import math
import os
import time

import sys

import numpy as np

from gasp_core.mpm.materials import brittle_damage
from gasp_core.run.pieces import LINK_RADIUS, tracker_for
from gasp_core.testing.pieces_count import FramePieces, tracker_count
from gasp_core.testing.scenes_pieces import SPEEDS, ball_setup

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from fragments99 import inside_jp  # noqa: E402 (round 99's study beside this one)

#: The 27 nodes of a quadratic B-spline stencil, (27, 3) int.
OFFSETS = np.array([(i, j, k) for i in range(3) for j in range(3) for k in range(3)])
#: The walls' reach, in cells from the domain's faces (the nodes they hold).
WALL_CELLS = 3


def stencil(x: np.ndarray, inv_dx: float, n: int):
    """Each point's 27 nodes (N, 27) int, weights (N, 27), weight gradients w.r.t. the point (N, 27, 3) 1/m and
    ``(node - x) / dx`` (N, 27, 3), for points ``x`` (N, 3) m in a grid of ``n`` nodes a side from the origin."""
    X = x * inv_dx
    base = np.floor(X - 0.5).astype(int)
    fx = X - base
    w = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2], 1)    # (N, 3 nodes, 3 axes)
    dw = np.stack([fx - 1.5, -2.0 * (fx - 1), fx - 0.5], 1) * inv_dx
    a, b, c = OFFSETS[:, 0], OFFSETS[:, 1], OFFSETS[:, 2]
    W = w[:, a, 0] * w[:, b, 1] * w[:, c, 2]
    gW = np.stack([dw[:, a, 0] * w[:, b, 1] * w[:, c, 2], w[:, a, 0] * dw[:, b, 1] * w[:, c, 2],
                   w[:, a, 0] * w[:, b, 1] * dw[:, c, 2]], -1)
    idx = base[:, None, :] + OFFSETS[None]
    node = (idx[..., 0] * n + idx[..., 1]) * n + idx[..., 2]
    return node, W, gW, OFFSETS[None] - fx[:, None, :]


def node_max(node: np.ndarray, key: np.ndarray, n_nodes: int) -> np.ndarray:
    """Per node, the flat index (into ``node.ravel()``) of its entry with the largest ``key``; -1 where none."""
    flat, k = node.ravel(), np.broadcast_to(key, node.shape).ravel()
    order = np.lexsort((k, flat))
    s = flat[order]
    last = np.r_[s[1:] != s[:-1], True]
    out = np.full(n_nodes, -1)
    out[s[last]] = order[last]
    return out


class Ball:
    """A brittle body on the ground in a NumPy MLS-MPM (module notes); ``dfg`` False: one velocity field."""

    def __init__(self, setup, dfg: bool, mu_c: float = 0.5, d_min: float = 0.25, never=None):
        m = setup.materials[0]
        #: Points that never damage (``--cells``: a Grady fragment's inside), (N,) bool.
        self.never = np.zeros(len(setup.x), bool) if never is None else never
        self.x, self.v = setup.x.astype(np.float64), setup.v.astype(np.float64)
        self.F = np.tile(np.eye(3), (len(self.x), 1, 1))
        self.C = np.zeros_like(self.F)
        self.d = np.zeros(len(self.x))
        self.mass, self.vol = setup.p_mass.astype(np.float64), setup.p_vol.astype(np.float64)
        self.mu, self.lam = m.E / (2 * (1 + m.nu)), m.E * m.nu / ((1 + m.nu) * (1 - 2 * m.nu))
        self.ft = m.tensile_strength
        self.sf = 2 * m.E * m.fracture_energy / (m.tensile_strength * float(setup.crack_band[0]))
        self.n, self.dx = setup.n_grid, setup.dx
        self.ground = setup.boundaries[0].height
        self.mu_g = setup.boundaries[0].friction
        self.g = np.asarray(setup.gravity, np.float64)
        c_l = math.sqrt((self.lam + 2 * self.mu) / m.rho)
        v0 = float(np.max(np.linalg.norm(self.v, axis=1)))
        self.n_sub = math.ceil(setup.frame_dt * (c_l + v0) / (0.3 * self.dx))
        self.dt = setup.frame_dt / self.n_sub
        self.dfg, self.mu_c, self.d_min = dfg, mu_c, d_min
        k = np.arange(self.n)
        i, j, kk = np.meshgrid(k, k, k, indexing="ij")
        self.node_z = (kk.ravel() * self.dx)
        self.node_ijk = np.stack([i.ravel(), j.ravel(), kk.ravel()], 1)

    def stress(self) -> np.ndarray:
        """The Kirchhoff stress (N, 3, 3) Pa; raises the damage (the engines' brittle law)."""
        U, sig, _ = np.linalg.svd(self.F)
        eps = np.log(np.maximum(sig, 1e-4))
        s = 2 * self.mu * eps + self.lam * eps.sum(1, keepdims=True)
        self.d = np.where(self.never, 0.0, np.maximum(self.d, brittle_damage(s.max(1), self.ft, self.sf)))
        s = np.where(s > 0, (1 - self.d)[:, None] * s, s)
        return np.einsum("pij,pj,pkj->pik", U, s, U)

    def fields(self, node, W, gW):
        """DFG: each (point, node)'s field (N, 27) int, and per node whether its fields are separable (bool)."""
        nn = self.n ** 3
        flat = node.ravel()
        wm = (W * self.mass[:, None]).ravel()
        den = np.bincount(flat, wm, nn)
        num = np.bincount(flat, wm * np.repeat(self.d, 27), nn)
        dp, mp = (W * num[node]).sum(1), (W * den[node]).sum(1)
        gd, gm = (gW * num[node][..., None]).sum(1), (gW * den[node][..., None]).sum(1)
        dg = (gd * mp[:, None] - dp[:, None] * gm) / mp[:, None] ** 2      # the Shepard-smoothed damage's gradient
        size = np.linalg.norm(dg, axis=1)
        best = node_max(node, size[:, None], nn)
        node_dg = np.zeros((nn, 3))
        has = best >= 0
        node_dg[has] = dg[best[has] // 27]
        f = (np.einsum("pi,pki->pk", dg, node_dg[node]) < 0).astype(int)
        key = flat * 2 + f.ravel()
        m_f = np.bincount(key, wm, 2 * nn).reshape(nn, 2)
        dmean = np.bincount(key, wm * np.repeat(self.d, 27), 2 * nn).reshape(nn, 2) / np.maximum(m_f, 1e-300)
        dmax = np.zeros(2 * nn)
        np.maximum.at(dmax, key, np.repeat(self.d, 27))
        both = (m_f > 0).all(1)
        sep = both & (dmax.reshape(nn, 2).max(1) >= 1.0) & (dmean.min(1) > self.d_min)
        return f, sep, both

    def boundary(self, v: np.ndarray) -> None:
        """The ground (Coulomb, its friction) and the walls (slip) on node velocities ``v`` (n_nodes, 3), in place."""
        low = (self.node_z <= self.ground) & (v[:, 2] < 0)
        vn = -v[low, 2]
        vt = v[low, :2]
        st = np.linalg.norm(vt, axis=1)
        scale = np.maximum(0.0, 1 - self.mu_g * vn / np.maximum(st, 1e-30))
        v[low, :2] = vt * scale[:, None]
        v[low, 2] = 0.0
        for a in range(3):
            ijk = self.node_ijk[:, a]
            v[(ijk < WALL_CELLS) & (v[:, a] < 0), a] = 0.0
            v[(ijk >= self.n - WALL_CELLS) & (v[:, a] > 0), a] = 0.0

    def contact(self, mom, m, gm, sep, both) -> np.ndarray:
        """Node velocities of the two fields (n_nodes, 2, 3): moving as one where not separable, in Coulomb contact
        where separable and approaching, apart where separating."""
        v = mom / np.maximum(m, 1e-300)[..., None]
        m1, m2 = m[both, 0, None], m[both, 1, None]
        v1, v2 = v[both, 0], v[both, 1]
        vcm = (m1 * v1 + m2 * v2) / (m1 + m2)
        n1 = gm[both, 0] / np.maximum(np.linalg.norm(gm[both, 0], axis=1, keepdims=True), 1e-300)
        n2 = gm[both, 1] / np.maximum(np.linalg.norm(gm[both, 1], axis=1, keepdims=True), 1e-300)
        nrm = n1 - n2
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)   # field 0's outward normal
        u = v1 - vcm
        un = (u * nrm).sum(1, keepdims=True)
        ut = u - un * nrm
        st = np.linalg.norm(ut, axis=1, keepdims=True)
        ut2 = ut * np.maximum(0.0, 1 - self.mu_c * np.maximum(un, 0) / np.maximum(st, 1e-300))
        part = sep[both][:, None] & (((v1 - v2) * nrm).sum(1, keepdims=True) <= 0)    # separable and parting: free
        glue = ~sep[both][:, None]
        new1 = np.where(part, v1, np.where(glue, vcm, vcm + ut2))
        new2 = np.where(part, v2, np.where(glue, vcm, vcm - (m1 / m2) * ut2))
        v[both, 0], v[both, 1] = new1, new2
        return v

    def substep(self) -> None:
        nn, dt, inv_dx = self.n ** 3, self.dt, 1.0 / self.dx
        node, W, gW, off = stencil(self.x, inv_dx, self.n)
        tau = self.stress()
        affine = -dt * 4 * inv_dx * inv_dx * self.vol[:, None, None] * tau + self.mass[:, None, None] * self.C
        dpos = off * self.dx
        p_mom = W[..., None] * (self.mass[:, None, None] * self.v[:, None, :] + np.einsum("pij,pkj->pki", affine, dpos))
        if self.dfg:
            f, sep, both = self.fields(node, W, gW)
        else:
            f, sep, both = np.zeros_like(node), np.zeros(nn, bool), np.zeros(nn, bool)
        key = (node * 2 + f).ravel()
        m = np.bincount(key, (W * self.mass[:, None]).ravel(), 2 * nn).reshape(nn, 2)
        mom = np.stack([np.bincount(key, p_mom[..., a].ravel(), 2 * nn) for a in range(3)], 1).reshape(nn, 2, 3)
        gm = np.stack([np.bincount(key, (gW[..., a] * self.mass[:, None]).ravel(), 2 * nn) for a in range(3)], 1)
        mom += dt * m[..., None] * self.g
        v = self.contact(mom, m, gm.reshape(nn, 2, 3), sep, both)
        v = v.reshape(2 * nn, 3)
        self.boundary_fields(v)
        vp = v[key].reshape(node.shape + (3,))
        self.v = (W[..., None] * vp).sum(1)
        self.C = 4 * inv_dx * np.einsum("pk,pki,pkj->pij", W, vp, off)
        self.x = self.x + dt * self.v
        self.F = (np.eye(3) + dt * self.C) @ self.F

    def boundary_fields(self, v: np.ndarray) -> None:
        """:meth:`boundary` on both fields of ``v`` (2 n_nodes, 3), in place."""
        for f in range(2):
            vf = v[f::2]
            self.boundary(vf)
            v[f::2] = vf

    def step_frame(self) -> None:
        for _ in range(self.n_sub):
            self.substep()
        if not np.isfinite(self.x).all():
            raise FloatingPointError("the study's ball diverged")


def counted(setup, dfg: bool, frames: int, mu_c: float, d_min: float, never=None) -> dict:
    """Pieces of 5 % per frame (0 .. ``frames``): the tracker's and the frames-only count with links kept open."""
    ball = Ball(setup, dfg, mu_c, d_min, never)
    t = tracker_for(setup)
    spacing = float(np.cbrt(np.max(setup.p_vol)))
    kept = FramePieces(setup.x, setup.p_mass, LINK_RADIUS * spacing, setup.dx, remember=True)
    total = float(setup.p_mass.sum())
    out = {"tracker_5": [], "frames_kept_5": [], "broken": []}
    for i in range(frames + 1):
        if i:
            ball.step_frame()
        out["tracker_5"].append(tracker_count(t.row(ball.x, ball.d if i else None)[0], total, 0.05))
        out["frames_kept_5"].append(kept.count(ball.x, 0.05))
        out["broken"].append(round(float(np.mean(ball.d >= 0.9)), 3))
    out["n_substeps"] = ball.n_sub
    return out


def bar_check(dfg: bool, sign: float, n_grid: int = 32, speed: float = 0.5, t_end: float = 0.1) -> dict:
    """The fields' own check: a bar (0.3 x 0.06 x 0.06 m, the ball's material, no gravity, no ground in reach) broken
    through at its middle (a band one cell wide at ``d`` 1), its halves set moving apart (``sign`` 1) or together
    (-1) at ``speed`` m/s each. Returns the growth of their centres' distance over ``t_end`` s (parting freely:
    ``2 speed t_end``), the gap between them and their mean x velocities."""
    from types import SimpleNamespace
    from gasp_core.seam.setup import Material
    from gasp_core.testing.scenes_pieces import BALL
    dx = 1 / n_grid
    sp = dx / 2
    g, h = np.arange(0.35 + sp / 2, 0.65, sp), np.arange(0.47 + sp / 2, 0.53, sp)
    x = np.array(np.meshgrid(g, h, h, indexing="ij")).reshape(3, -1).T
    left = x[:, 0] < 0.5
    v = np.zeros_like(x)
    v[:, 0] = np.where(left, -sign, sign) * speed
    vol = np.full(len(x), sp ** 3)
    setup = SimpleNamespace(materials=[Material("brittle", **BALL)], x=x, v=v, p_mass=vol * BALL["rho"], p_vol=vol,
                            crack_band=[dx], n_grid=n_grid, dx=dx, gravity=[0.0, 0.0, 0.0], frame_dt=0.01,
                            boundaries=[SimpleNamespace(height=-1.0, friction=0.5)])
    bar = Ball(setup, dfg)
    bar.d[np.abs(x[:, 0] - 0.5) < dx / 2] = 1.0
    for _ in range(round(t_end / setup.frame_dt)):
        bar.step_frame()
    grow = (bar.x[~left, 0].mean() - bar.x[left, 0].mean()) - (x[~left, 0].mean() - x[left, 0].mean())
    return {"fields": "dfg" if dfg else "one", "halves": "parting" if sign > 0 else "meeting",
            "centres_grow_m": round(float(grow), 4), "free_m": 2 * speed * t_end,
            "gap_m": round(float(bar.x[~left, 0].min() - bar.x[left, 0].max()), 4),
            "v_left": round(float(bar.v[left, 0].mean()), 3), "v_right": round(float(bar.v[~left, 0].mean()), 3)}


def cell_trace(speed: float, n_grid: int, mu_c: float, d_min: float, frames: int) -> list:
    """Grady's cells on the ball with DFG (``--cells 0``): every third frame, the nodes with both fields and the
    separable ones, the cells' mean distance from their common centre (m) and their mean speed relative to it (m/s),
    and the ball's lowest and highest points (m; the top wall holds the nodes from ``1 - 3 dx``)."""
    from fragments99 import lay_cells
    setup = ball_setup(speed, n_grid)
    jp, _ = inside_jp(setup, speed, 0.0)
    cell = lay_cells(setup, speed)[0]
    ball, rows = Ball(setup, True, mu_c, d_min, jp < 0), []
    for fr in range(1, frames + 1):
        ball.step_frame()
        if fr % 3 == 0:
            rows.append(motion_row(ball, cell, fr))
    return rows


def motion_row(ball: Ball, cell: np.ndarray, frame: int) -> dict:
    """A traced frame of a ball laid in cells ``cell`` (per point, int): the nodes with both fields and the separable
    ones, the cells' mean distance from their common centre (m) and their mean speed relative to it (m/s), and the
    ball's lowest and highest points (m)."""
    _, sep, both = ball.fields(*stencil(ball.x, 1 / ball.dx, ball.n)[:3])
    ids = range(cell.max() + 1)
    cen = np.array([ball.x[cell == c].mean(0) for c in ids])
    vel = np.array([ball.v[cell == c].mean(0) for c in ids])
    return {"frame": frame, "both": int(both.sum()), "separable": int(sep.sum()),
            "spread_m": round(float(np.linalg.norm(cen - cen.mean(0), axis=1).mean()), 4),
            "v_rel": round(float(np.linalg.norm(vel - vel.mean(0), axis=1).mean()), 3),
            "z_min": round(float(ball.x[:, 2].min()), 3), "z_max": round(float(ball.x[:, 2].max()), 3)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fields", default="one,dfg", help="one (a single velocity field), dfg, or both")
    ap.add_argument("--grids", default="28,32")
    ap.add_argument("--speeds", default=",".join(str(s) for s in SPEEDS))
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--mu", type=float, default=0.5, help="DFG: the crack faces' Coulomb coefficient")
    ap.add_argument("--d-min", type=float, default=0.25, help="DFG: each field's mean damage to part")
    ap.add_argument("--cells", type=float, default=-1.0,
                    help="0 or more: Grady's cells laid on the ball first, none under this many grid cells across "
                         "(round 99's inside probe, fragments99.inside_jp: their insides never damage); -1: none")
    ap.add_argument("--check", choices=("family", "bar", "trace"), default="family",
                    help="bar: the fields' own check (bar_check); trace: Grady's cells' motion (cell_trace) at the "
                         "first of --speeds and --grids")
    ap.add_argument("--out", required=True, help="a new JSON file (refused if it exists)")
    a = ap.parse_args()
    if os.path.exists(a.out):
        raise SystemExit(f"--out {a.out} exists; give a new file")
    if a.check != "family":
        if a.check == "bar":
            rows = [bar_check(dfg, sign) for sign in (1.0, -1.0) for dfg in (False, True)]
        else:
            rows = cell_trace(float(a.speeds.split(",")[0]), int(a.grids.split(",")[0]), a.mu, a.d_min, a.frames)
        for r in rows:
            print(r)
        with open(a.out, "x") as f:
            json.dump(rows, f, indent=1)
        return
    rows = []
    for kind in a.fields.split(","):
        for g in (int(s) for s in a.grids.split(",")):
            five = []
            for v in (float(s) for s in a.speeds.split(",")):
                t0 = time.perf_counter()
                setup = ball_setup(v, g)
                never, split = None, {}
                if a.cells >= 0:
                    jp, split = inside_jp(setup, v, a.cells)
                    never = None if jp is None else jp < 0
                r = counted(setup, kind == "dfg", a.frames, a.mu, a.d_min, never)
                rows.append({"fields": kind, "n_grid": g, "speed": v, "mu": a.mu, "d_min": a.d_min, "split": split,
                             "seconds": round(time.perf_counter() - t0, 1), **r})
                five.append((r["tracker_5"][12], r["tracker_5"][-1], r["frames_kept_5"][-1]))
                print(f"{kind} n_grid {g} v {v}: tracker 5 % at 12 / {a.frames}, kept frames {five[-1]}, "
                      f"broken {r['broken'][-1]}, {rows[-1]['seconds']} s", flush=True)
    with open(a.out, "x") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
