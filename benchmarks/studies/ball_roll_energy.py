"""Round 69 (issue 67 items 2 and 4, diagnosis): where a rolling ball's energy goes on a soft slab.

``ball_roll_soft.py``'s scene (a rigid ball, radius ``R``, rolling without slip at 0.5 m/s along a 32 x 16 x 3 cm slab
lying on a frictionless ground; its measure from the first frame to ``T``), with an energy budget by body, read from
the engine's points (warp_mpm; the rigid ball's points move as one body):

- ``ball``: its translation ``M V^2 / 2``, its spin (the points' kinetic energy less the translation's) and its
  height's ``M g z``;
- ``slab``: its points' kinetic energy with APIC's affine part ``m dx^2 / 4 |C|^2 / 2``, its stored energy (jelly's
  fixed corotated of the engine's ``F``, ``benchmarks/energy_ledger.py``'s :class:`Stored`), ``m g z``, and the ground
  contact's springs ``k depth^2 / 2`` (the engine's own ``(k, c, skin)`` per point);
- ``p2g``: the slab's own P2G loss summed over the substeps, ``Ep - K0`` (its points' energy less its free P2G's
  grid kinetic energy, NumPy: ``energy_ledger.p2g``; the slab alone on the grid: the ball's field is its own);
- ``lost``: the drop of the sum of both bodies' energies; ``lost - p2g`` the rest of the dissipation (the slab's G2P,
  the contact's projections, the ground's rule);
- ``c_rr``: the rolling resistance coefficient the ball's loss is, ``F / (M g)`` with ``F`` its mechanical energy's
  drop over the distance its centre went.

Cases: ``--contact default`` (the rigid collider, the slab's normals), ``point0`` (``rigid_sdf.POINT_CONTACT``, round
66's contact per point) and ``point4`` (``GRID_PASSES 4``: round 67's constraint of the grid), each with ``+NAME=VALUE``
constants of ``rigid_sdf`` (``point4+PATCH=0.25``: round 67's patches; ``+EXACT_SPHERE=1`` the probe
:func:`exact_sphere`); round 70: ``roll``, the engine option ``roll_contact`` (``gasp_core.mpm.roll_contact``), with
``+NAME=VALUE`` its constants or warp_mpm's ``rigid_collider.FRICTION`` (``roll+EXACT=0``, ``roll+FRICTION=0``: broken
variants); ``--E`` the slab's Young's modulus
(``rigid``: the same slab rigid, the control); round 71: ``--engine taichi_mpm`` (the same budget read from taichi_mpm's
points, without the slab's P2G column); ``--mu``; ``--n-grid``; ``--ppc`` the slab's points per cell along an
axis (2: the scene's); ``--v0`` the ball's speed; ``--radius``; ``--seat`` the ball set on the slab's top points.

    python benchmarks/studies/ball_roll_energy.py --contact default point4 --E rigid 1e5 1e6 1e7 --mu 0 0.5

Figures: ``docs/rigid.md`` ("Round 69: where a rolling ball's energy goes on a soft slab").
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from ball_roll_soft import roll_setup  # noqa: E402

G = 9.81


def with_ppc(s, ppc: int):
    """The scene ``s`` with its slab (body 1) refilled at ``ppc`` points per cell along an axis (the same box and
    mass: ``box_points`` at ``dx / ppc``)."""
    from gasp_core.testing.helpers import box_points
    if ppc == 2:
        return s
    body = np.asarray(s.body_id)
    xs, pvs = box_points([-0.12, -0.08, 0.0], [0.20, 0.08, 0.03], s.dx / ppc)
    keep = body != 1
    return s.replace(x=np.concatenate([np.asarray(s.x)[keep], xs]),
                     v=np.concatenate([np.asarray(s.v)[keep], np.zeros_like(xs)]),
                     C=np.concatenate([np.asarray(s.C)[keep], np.zeros((len(xs), 3, 3))]),
                     p_vol=np.concatenate([np.asarray(s.p_vol)[keep], np.full(len(xs), pvs)]),
                     body_id=np.concatenate([body[keep], np.ones(len(xs), int)]))


def exact_sphere(body_sdf):
    """A probe (round 69): ``rigid_sdf.body_sdf`` with its field replaced by an exact sphere's, centred on the body's
    points, of radius their farthest plus half their spacing (the lattice's own grid kept)."""
    def sdf(X0, dx):
        from gasp_core.mpm.rigid_sdf import point_spacing
        out = body_sdf(X0, dx)
        X0 = np.asarray(X0, float)
        R = float(np.linalg.norm(X0, axis=1).max()) + 0.5 * point_spacing(X0)
        dims = out["phi"].shape
        axes = [out["origin"][a] + out["h"] * np.arange(dims[a]) for a in range(3)]
        g = np.stack(np.meshgrid(*axes, indexing="ij"), -1)
        r = np.maximum(np.linalg.norm(g, axis=-1), 1e-12)
        return {**out, "phi": r - R, "grad": g / r[..., None]}
    return sdf


class Budget:
    """The energies of the ball (body 0) and the slab (body 1) of a built warp_mpm engine ``e`` of setup ``s``, and
    the slab's P2G loss summed over the substeps (module notes)."""

    def __init__(self, s, e, slab_material):
        from energy_ledger import Stored
        from gasp_core.mpm.grid_origin import ground_on_node
        self.s, self.e = s, e
        g = ground_on_node(s)
        self.lo, self.dx, self.ng = np.asarray(g.domain_lo, float), float(s.dx), int(s.n_grid)
        self.stored = Stored(slab_material, s) if slab_material.model != "rigid" else None
        self.p2g = 0.0
        self.points()

    def points(self):
        """The engine's points now (its internal order, which a CPU engine re-sorts every frame)."""
        e = self.e
        self.body = e.read_array("body")
        self.m = e.read_array("p_mass").astype(float)
        self.v0 = e.read_array("p_vol").astype(float)
        kc = e.read_array("p_contact").astype(float)   # round 71: either engine's (k, c, skin) per point
        self.kc = kc if len(kc) == len(self.m) else np.zeros((len(self.m), 3))
        return {k: e.read_array(k).astype(float) for k in ("x", "v", "C", "F")}

    def slab_ep(self, p, k):
        m = self.m[k]
        aff = 0.5 * float(m @ (p["C"][k] ** 2).sum((1, 2))) * self.dx ** 2 / 4
        return 0.5 * float(m @ (p["v"][k] ** 2).sum(1)) + aff

    def energies(self) -> dict:
        p = self.points()
        b, k = self.body == 0, self.body == 1
        mb, xb, vb = self.m[b], p["x"][b], p["v"][b]
        M = float(mb.sum())
        V = (mb @ vb) / M
        c = (mb @ xb) / M
        trans = 0.5 * M * float(V @ V)
        spin = 0.5 * float(mb @ ((vb - V) ** 2).sum(1))
        out = {"trans": trans, "spin": spin, "ball_pe": M * G * float(c[2]), "x": float(c[0]), "z": float(c[2]),
               "v": float(V[0]), "M": M}
        ms = self.m[k]
        out["slab_ke"] = self.slab_ep(p, k)
        out["slab_psi"] = self.stored(p["F"][k].reshape(-1, 3, 3), np.ones(int(k.sum())), self.v0[k], p["x"][k])[0] \
            if self.stored is not None else 0.0
        out["slab_pe"] = G * float(ms @ p["x"][k][:, 2])
        kk, _c, skin = self.kc[k].T
        depth = np.maximum(skin - p["x"][k][:, 2], 0.0)
        out["ground_U"] = 0.5 * float((kk * depth ** 2).sum())
        out["ball"] = trans + spin + out["ball_pe"]
        out["slab"] = out["slab_ke"] + out["slab_psi"] + out["slab_pe"] + out["ground_U"]
        return out

    def before_substep(self) -> None:
        """Adds the slab's P2G loss of the coming substep (its points now, their free P2G's grid energy)."""
        from energy_ledger import grid_ke, p2g
        p = self.points()
        k = self.body == 1
        x, v, C, m = p["x"][k], p["v"][k], p["C"][k], self.m[k]
        acc = p2g(x, np.c_[m[:, None] * v, m], self.lo, self.dx, self.ng, C=C, m=m)
        ep = 0.5 * float(m @ (v ** 2).sum(1)) + 0.5 * float(m @ (C ** 2).sum((1, 2))) * self.dx ** 2 / 4
        self.p2g += ep - grid_ke(acc[:, :3], acc[:, 3])


def run(contact: str, E, mu: float, n_grid: int = 32, R: float = 0.03, T: float = 0.2, ppc: int = 2,
        p2g: bool = True, v0: float = 0.5, seat: bool = False, spin: float = 1.0, engine: str = "warp_mpm") -> dict:
    """One case's budget (module notes): energies at the first frame and the last (J), the sums, ``c_rr``."""
    import gasp_core.mpm.rigid_sdf as sdf
    import gasp_core.mpm.roll_contact as roll
    import gasp_warp_mpm.rigid_collider as wrc
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    name, *sets = contact.split("+")
    point = name.startswith("point")
    consts = {"POINT_CONTACT": point} | ({"GRID_PASSES": int(name[5:])} if point else {})
    mods = {k: sdf for k in consts}
    for k, v in (kv.split("=") for kv in sets):   # a constant of rigid_sdf, roll_contact or the collider (FRICTION)
        mod = next(m for m in ((roll, sdf, wrc) if name == "roll" else (sdf, roll, wrc)) if hasattr(m, k))
        mods[k], consts[k] = mod, type(getattr(mod, k, 0))(float(v))
    exact = consts.pop("EXACT_SPHERE", 0)   # the probe: the ball's shape an exact sphere (exact_sphere)
    keep = {k: getattr(mods[k], k) for k in consts} | {"body_sdf": sdf.body_sdf}
    mods["body_sdf"] = sdf
    if exact:
        sdf.body_sdf = exact_sphere(sdf.body_sdf)
    for k, v in consts.items():
        setattr(mods[k], k, v)
    try:
        slab = "rigid" if E == "rigid" else "elastic"
        s = with_ppc(roll_setup(n_grid, R, v0, mu, slab, spin, seat=seat, E=1.0e5 if E == "rigid" else float(E)), ppc)
        # round 70: the engine option roll_contact; round 71: on by default, so the band and the point contact set it off
        s = s.replace(options={**s.options, "roll_contact": name == "roll"})
        t0 = time.time()
        e = build_engine(get_engine(engine), s)
        bud = Budget(s, e, s.materials[1])
        if p2g and slab != "rigid" and engine == "warp_mpm":   # round 71: taichi_mpm's substeps are not hooked
            inner = e._substep

            def hooked(i, capturing=False):
                bud.before_substep()
                inner(i, capturing)
            e._substep = hooked
        rows = [{**bud.energies(), "p2g": 0.0, "t": 0.0}]   # the state given, before any step
        for _ in range(round(T / s.frame_dt)):
            e.step_frame()
            rows.append({**bud.energies(), "p2g": bud.p2g, "t": getattr(e, "sim_time", e.frame * s.frame_dt)})
        dt = float(e.dt)
        e.close()
    finally:
        for k, v in keep.items():
            setattr(mods[k], k, v)
    return {"contact": contact if engine == "warp_mpm" else f"{engine}:{contact}", "engine": engine, "E": E, "mu": mu, "n_grid": n_grid, "R": R, "T": T, "ppc": ppc, "dt": dt, "v0": v0,
            "seat": seat, "spin": spin,
            "rows": rows, "seconds": time.time() - t0}


def budget(r: dict, t0: float | None = None) -> dict:
    """The budget of run ``r`` from its frame at ``t0`` s (None: its first frame, the measure's; 0: the state given)
    to its last: the
    changes ``d`` (J), ``lost``, the slab's ``p2g``, ``K0`` (the ball's kinetic energy at the start), the ball's
    speed then and at the end, ``c_rr`` (module notes)."""
    rows = r["rows"]
    first = rows[1] if t0 is None else min(rows, key=lambda q: abs(q["t"] - t0))
    last = rows[-1]
    K0 = first["trans"] + first["spin"]
    d = {k: last[k] - first[k] for k in ("trans", "spin", "ball_pe", "slab_ke", "slab_psi", "slab_pe", "ground_U",
                                         "ball", "slab")}
    dist = last["x"] - first["x"]
    return {"t0": first["t"], "K0": K0, "d": d, "lost": -(d["ball"] + d["slab"]), "p2g": last["p2g"] - first["p2g"],
            "c_rr": -d["ball"] / dist / (first["M"] * G), "v": (first["v"], last["v"]), "dist": dist}


def row(r: dict, t0: float | None = None) -> str:
    b = budget(r, t0)
    K0, d = b["K0"], b["d"]
    pct = lambda x: f"{100 * x / K0:+.1f}"   # noqa: E731
    E = "rigid" if r["E"] == "rigid" else f"{float(r['E']):.0e}"
    return (f"| {r['contact']} | {r['n_grid']} | {r['ppc']} | {100 * r['R']:g} | {E} | {r['mu']:g} | {b['t0']:.3f} | "
            f"{b['v'][0]:.3f} -> {b['v'][1]:.3f} | {1e3 * K0:.2f} | {pct(d['trans'])} | {pct(d['spin'])} | "
            f"{pct(d['ball_pe'])} | {pct(d['slab_ke'])} | {pct(d['slab_psi'])} | {pct(d['slab_pe'] + d['ground_U'])} | "
            f"{pct(b['lost'])} | {pct(b['p2g'])} | {b['c_rr']:.4f} | {r['seconds']:.0f} |")


def summary(runs: list[dict]) -> list[str]:
    """The docs' table: per run, the whole (from the state given to ``T``) and the steady window (0.1 s to ``T``):
    the ball's speed, what was lost and the slab's P2G share (% of the ball's kinetic energy at the window's start),
    the ball's drop in height (% likewise) and ``c_rr``."""
    out = ["| contact | n_grid | ppc | R (cm) | slab E (Pa) | mu | v0 | seat | whole: v end, lost, of it slab P2G, ball "
           "mgz | steady (0.1-0.2 s): v, lost, of it slab P2G, c_rr |", "|" + "---|" * 10]
    for r in runs:
        w, s = budget(r, 0.0), budget(r, 0.1)
        pc = lambda b, x: f"{100 * x / b['K0']:.1f}"   # noqa: E731
        E = "rigid" if r["E"] == "rigid" else f"{float(r['E']):.0e}"
        out.append(f"| {r['contact']} | {r['n_grid']} | {r['ppc']} | {100 * r['R']:g} | {E} | {r['mu']:g} | "
                   f"{r.get('v0', 0.5):g} | {'yes' if r.get('seat') else ''} | {w['v'][1]:.3f}, {pc(w, w['lost'])} %, "
                   f"{pc(w, w['p2g'])} %, {pc(w, w['d']['ball_pe'])} % | {s['v'][0]:.3f} -> {s['v'][1]:.3f}, "
                   f"{pc(s, s['lost'])} %, {pc(s, s['p2g'])} %, {s['c_rr']:.4f} |")
    return out


HEAD = ("| contact | n_grid | ppc | R (cm) | slab E (Pa) | mu | from (s) | v (m/s) | K0 (mJ) | ball trans | "
        "ball spin | "
        "ball mgz | slab kinetic | slab stored | slab mgz + ground springs | lost | of it slab P2G | c_rr | s |\n"
        "|" + "---|" * 19)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm", help="round 71: warp_mpm or taichi_mpm (taichi_mpm: no P2G "
                    "column, its substeps are not hooked; its contact column prefixed)")
    ap.add_argument("--contact", nargs="+", default=["default", "point4"])
    ap.add_argument("--E", nargs="+", default=["rigid", "1e5"])
    ap.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.5])
    ap.add_argument("--n-grid", type=int, nargs="+", default=[32])
    ap.add_argument("--radius", type=float, nargs="+", default=[0.03])
    ap.add_argument("--ppc", type=int, nargs="+", default=[2])
    ap.add_argument("--T", type=float, default=0.2)
    ap.add_argument("--v0", type=float, nargs="+", default=[0.5], help="the ball's rolling speed at the start (m/s)")
    ap.add_argument("--windows", type=float, nargs="*", default=[0.0, 0.1],
                    help="budgets also from these times (s) to T (the start's settle left out)")
    ap.add_argument("--seat", action="store_true", help="the ball set with its point contact's skin on the slab's top "
                    "points (ball_roll_soft's --seat: no drop at the start)")
    ap.add_argument("--no-p2g", action="store_true", help="skip the slab's P2G loss (faster at high E)")
    ap.add_argument("--json", default=None, help="append each case's budget to this JSON-lines file")
    ap.add_argument("--report", default=None, help="print the docs' table of the runs in this JSON-lines file and stop")
    a = ap.parse_args(argv)
    if a.report:
        print("\n".join(summary([json.loads(q) for q in Path(a.report).read_text().splitlines() if q.strip()])))
        return 0
    print("Changes from the first frame to the last, % of the ball's kinetic energy K0 at the first frame "
          "(lost: the drop of both bodies' sum; c_rr: the ball's loss as a rolling resistance)\n")
    print(HEAD)
    for contact in a.contact:
        for n in a.n_grid:
            for ppc in a.ppc:
                for R in a.radius:
                    for E in a.E:
                        for mu in a.mu:
                            for v0 in a.v0:
                                r = run(contact, E, mu, n, R, a.T, ppc, not a.no_p2g, v0, a.seat, engine=a.engine)
                                for t0 in [None] + a.windows:
                                    print(row(r, t0), flush=True)
                                if a.json:
                                    with open(a.json, "a") as f:
                                        f.write(json.dumps(r) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
