"""Issue 66 round 44: the energy budget of an oblique dog-bone built through the scene (``benchmarks/user_oblique.py``)
on a grip free across its pull (``constrain = "along"``): why its "work to separate" read +47 to +52 % of G_f at 30
deg while the damage's own account read 21.5-22.9 J/m^2 (docs/fracture.md "Round 44").

Steps the case as ``user_oblique.run_case`` does (same scene, frames and stop rule) and records, each frame, from the
engine's ``F``, ``d``, ``x``, ``v`` of its material points (nu 0, the brittle model's Hencky energy):

- ``psi``: the elastic energy ``V E/2 sum_i eps_i^2`` (``eps_i = log sigma_i``, a tensile one's times ``1 - d``);
- ``kin``: ``m |v|^2 / 2`` (the affine part of APIC's velocity field left out);
- ``diss``: the damage's dissipation summed frame by frame, ``V E/2 sum_(eps_i > 0) eps_i^2 delta d`` (the energy
  the damage releases at the strain it happens at; mean of the strains at the frame's two ends);
- ``flux``: through each axial layer, the power ``(P a) . v`` (volume mean times the layer's section, W), and its
  part along the axis ``(a . P a)(a . v)``;
- the work measure's own series (``force``, ``pos``, ``dmean``), so ``user_oblique``'s figure is rebuilt here.

The budget of a zone of layers ``[i, j]``: the energy in through its two end layers' fluxes, ``int flux_j - flux_i
dt``, against ``psi + kin + diss`` in it (the end layers half counted). Run: ``python
benchmarks/studies/work_budget.py --engine warp_mpm --angles 30,45 --n-grid 24``; writes ``/tmp/work_budget_*.npz``
and prints the table rows (JSON).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import tension_family as tf      # noqa: E402
import tension_oblique as to     # noqa: E402
import user_oblique as uo        # noqa: E402
import user_tension as ut        # noqa: E402


def point_energies(F: np.ndarray, d: np.ndarray, pv: np.ndarray):
    """``(psi (n,), tensile eps^2 sum (n,))``: a point's elastic energy (J) and ``sum_(eps_i > 0) eps_i^2``."""
    eps = np.log(np.clip(np.linalg.svd(F, compute_uv=False), 1e-12, None))
    ten = np.where(eps > 0, eps * eps, 0.0).sum(axis=1)
    com = np.where(eps > 0, 0.0, eps * eps).sum(axis=1)
    return pv * tf.E / 2 * ((1 - d) * ten + com), ten


def record(e, pv, layer, a, area, vol, n):
    """Step ``e`` up to ``n`` frames (``user_oblique.record``'s stop rule): per frame and layer the series of the
    module's docstring."""
    nl, li, mat = len(vol), np.maximum(layer, 0), layer >= 0
    pw, m = np.where(mat, pv, 0.0), tf.RHO * np.where(mat, pv, 0.0)
    keys = ("force", "pos", "dmean", "flux", "flux_a", "psi", "kin", "diss", "thru", "opened")
    out = {k: [] for k in keys}
    d_prev, ten_prev, diss = np.zeros(len(pv)), np.zeros(len(pv)), np.zeros(len(pv))
    for _ in range(n):
        e.step_frame()
        F = np.asarray(e.to_setup_order(e.get_state()["F"]), np.float64)
        d = np.asarray(e.damage(), np.float64)
        xs, v = (np.asarray(q, np.float64) for q in (e.positions(), e.velocities()))
        P = np.zeros((len(pv), 3, 3))
        P[mat] = to.nominal(F[mat], d[mat])
        Pa = P @ a
        psi, ten = point_energies(F, d, pw)
        diss += pw * tf.E / 2 * 0.5 * (ten + ten_prev) * np.maximum(d - d_prev, 0.0)
        d_prev, ten_prev = d.copy(), ten
        lay = lambda q: np.bincount(li, q * pw, nl) / vol                        # noqa: E731
        out["force"].append(lay(Pa @ a) * area)
        out["pos"].append(lay(xs @ a))
        out["dmean"].append(lay(d))
        out["flux"].append(lay(np.einsum("ni,ni->n", Pa, v)) * area)
        out["flux_a"].append(lay((Pa @ a) * (v @ a)) * area)
        out["psi"].append(np.bincount(li, psi, nl))
        out["kin"].append(np.bincount(li, 0.5 * m * np.einsum("ni,ni->n", v, v), nl))
        out["diss"].append(np.bincount(li, diss, nl))
        out["thru"].append(bool(np.any(np.bincount(li, (d >= 0.9) * pw, nl) >= vol * (1 - 1e-9))))
        out["opened"].append(bool(np.any(np.bincount(li, (d >= 1.0) * pw, nl) >= vol * (1 - 1e-9))))
        if len(out["opened"]) > tf.AFTER and out["opened"][-tf.AFTER]:
            break
    res = {k: np.array(v) for k, v in out.items()}
    res.update(d=d, xs=xs)
    return res


def run(sp, n_grid: int, engine: str, angle: str, extra: int = 0) -> dict:
    """One case (``user_oblique.run_case``'s scene and frames, plus ``extra`` frames); the recorded series and the
    geometry."""
    from gasp_core.seam.build import build_engine
    ps, mesh = uo.prepare(sp, n_grid, engine, angle)
    st, geo = ps.setup, uo.geometry(ps, mesh, sp, angle)
    lx, area, free, w = geo["lx"], geo["area"], geo["free"], geo["w"]
    free_len = float(np.ptp(lx[free])) + w
    t_peak = (tf.FT / tf.E) * free_len * (sp.gauge_w ** 2 / area[free]).max() / tf.PULL + ut.RAMP_S / 2
    n_frames = int(np.ceil((t_peak + 1.5 * 2 * tf.GF / tf.FT / tf.PULL) / tf.FRAME_DT)) + extra
    e = build_engine(ps.info, st)
    t0 = time.time()
    try:
        out = record(e, geo["pv"], geo["layer"], geo["a"], area, geo["vol"], n_frames)
    finally:
        e.close()
    out["seconds"] = time.time() - t0
    out["sf"] = to.point_sf(st, out["xs"], engine, geo["a"])
    return {**out, **{k: geo[k] for k in ("lx", "area", "free", "gauge", "reach", "layer", "pv", "w")}}


def work_measure(o: dict, dx: float, stop: int | None = None) -> dict:
    """``user_oblique.run_case``'s work to separate (J/m^2) rebuilt from the series (over frames ``[:stop]``), its
    crack layer and span, and the cumulative series."""
    a_gauge = float(uo.SPECIMENS["dogbone_2to1"].gauge_w ** 2)
    force, pos, lx, area, free = o["force"][:stop], o["pos"][:stop], o["lx"], o["area"], o["free"]
    crack = int(np.argmax(np.where(free, o["dmean"][-1], -1.0)))
    span = np.flatnonzero(free & (np.abs(lx - lx[crack]) <= 2 * dx + 1e-9))
    elastic = (force[:, span[:-1]] / area[span[:-1]] / tf.E * np.diff(lx[span])).sum(axis=1)
    wo = pos[:, span[-1]] - pos[:, span[0]] - (lx[span[-1]] - lx[span[0]]) - elastic
    sig_c = force[:, crack] / a_gauge
    dw = 0.5 * (sig_c[1:] + sig_c[:-1]) * np.diff(wo)
    return {"crack": crack, "span": span, "work": float(dw.sum()), "cum": np.concatenate([[0.0], np.cumsum(dw)]),
            "sig_c": sig_c, "wo": wo}


def budget(o: dict, lo: int, hi: int) -> dict:
    """The zone of layers ``lo..hi`` (the end layers half counted): energy in through its ends' fluxes (all
    components, and along the axis only), against its ``psi``, ``kin`` and ``diss`` at each frame (J/m^2: over the
    gauge's section)."""
    a_gauge = float(uo.SPECIMENS["dogbone_2to1"].gauge_w ** 2)
    wgt = np.zeros(len(o["lx"]))
    wgt[lo:hi + 1] = 1.0
    wgt[[lo, hi]] = 0.5
    dt = tf.FRAME_DT
    cum = lambda f: np.concatenate([[0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * dt)])   # noqa: E731
    into = cum(o["flux"][:, hi] - o["flux"][:, lo]) / a_gauge
    into_a = cum(o["flux_a"][:, hi] - o["flux_a"][:, lo]) / a_gauge
    psi, kin, diss = ((o[k] * wgt).sum(axis=1) / a_gauge for k in ("psi", "kin", "diss"))
    return {"in": into, "in_axial": into_a, "psi": psi, "kin": kin, "diss": diss}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--only", default="dogbone_2to1")
    ap.add_argument("--angles", default="30,45")
    ap.add_argument("--n-grid", default="24")
    ap.add_argument("--constrain", default="along")
    ap.add_argument("--extra", type=int, default=0, help="frames past user_oblique's")
    a = ap.parse_args()
    uo.CONSTRAIN = a.constrain
    for name in a.only.split(","):
        for angle in a.angles.split(","):
            for n in (int(q) for q in a.n_grid.split(",")):
                o = run(uo.SPECIMENS[name], n, a.engine, angle, a.extra)
                path = Path(f"/tmp/work_budget_{name}_{angle}_{n}_{a.engine}_{a.constrain}.npz")
                np.savez(path, **{k: v for k, v in o.items()})
                wm = work_measure(o, tf.SIZE / n)
                print(json.dumps({"case": path.name, "frames": len(o["force"]), "s": round(o["seconds"], 1),
                                  "work": round(wm["work"], 3), "crack": int(wm["crack"]),
                                  "span": [int(wm["span"][0]), int(wm["span"][-1])]}), flush=True)


if __name__ == "__main__":
    main()
