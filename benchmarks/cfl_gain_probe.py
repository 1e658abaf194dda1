"""Where the jelly donut's explicit elastic step gains energy at cfl 0.8 (issue 66 item 6; docs/fracture.md "Round 53:
the jelly donut's elastic gain at cfl 0.8"). Read-only: ``benchmarks/energy_ledger.py``'s ledger, per substep, with

- ``elastic`` (the untraced term, J) and its parts: ``Ws`` (the stress's work on the grid), ``dpsi``;
- ``Ws_np``: the same work from a NumPy stress impulse (the corotated Kirchhoff stress of the trial ``F = (I + dt C)
  F`` the engine's P2G forms, scattered as the engine's MLS-MPM does), so a contact impulse misbooked as stress shows;
- the points' local Courant numbers: ``cfl_rest = (c_p + |v|) dt / dx`` with the rest P-wave speed and ``cfl_tan =
  (c(F) + |v|) dt / dx`` with the wave speed of the fixed-corotated tangent at the point's ``F`` (the largest
  acoustic-tensor eigenvalue over 13 lattice and 3 principal directions, spatial: ``rho0 c^2 = eig(A_iJkL m_J m_L)``,
  ``m = F^T n``), their largest over the points and the points over 1;
- the shadow-energy check: ``half = elastic_sum + dpsi_next / 2`` (the ledger pairs the points' velocity half a step
  ahead of ``F``; a symplectic step's bounded energy offset, ``-(dt/2) dpsi/dt``, is taken out by pairing the mean of
  the two ``F`` levels' stored energies with it).

Run: ``python benchmarks/cfl_gain_probe.py --engine taichi_mpm --body donut --n-grid 48 --cfl 0.8 --ms 40``; writes
``benchmarks/results/cfl_gain_probe/<body>_<engine>_<n>_<cfl>.json`` (per-substep rows) and ``..._points.npz`` (the
per-point split, not kept in git); ``--report`` writes ``benchmarks/results/cfl_gain_probe.md`` from them.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_ledger import Ledger, p2g, total   # noqa: E402
from energy_ledger_family import scene   # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "cfl_gain_probe"
DIRS = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0], [1, -1, 0], [1, 0, 1], [1, 0, -1], [0, 1, 1],
                 [0, 1, -1], [1, 1, 1], [1, 1, -1], [1, -1, 1], [-1, 1, 1]], float)
DIRS /= np.linalg.norm(DIRS, axis=1)[:, None]


def corotated_P(F, mu, lam):
    """First Piola stress of fixed corotated, ``2 mu (F - R) + lam (J - 1) J F^-T`` (n, 3, 3)."""
    U, _s, Vt = np.linalg.svd(F)
    R = U @ Vt
    neg = np.linalg.det(R) < 0      # the engines' rotation (det +1)
    if neg.any():
        U2 = U[neg].copy()
        U2[:, :, 2] *= -1
        R[neg] = U2 @ Vt[neg]
    J = np.linalg.det(F)
    return 2 * mu * (F - R) + (lam * (J - 1) * J)[:, None, None] * np.linalg.inv(F).transpose(0, 2, 1)


def tangent_speed(F, mu, lam, rho0, h=1e-6):
    """The largest spatial wave speed (m/s, (n,)) of fixed corotated at ``F`` (module notes)."""
    A = np.zeros((len(F), 3, 3, 3, 3))
    for k in range(3):
        for L in range(3):
            d = np.zeros((3, 3))
            d[k, L] = h
            A[:, :, :, k, L] = (corotated_P(F + d, mu, lam) - corotated_P(F - d, mu, lam)) / (2 * h)
    U = np.linalg.svd(F)[0]
    dirs = np.concatenate([np.broadcast_to(DIRS, (len(F), 13, 3)), U.transpose(0, 2, 1)], axis=1)
    m = np.einsum("njJ,ndj->ndJ", F, dirs)                       # F^T n per direction
    Q = np.einsum("niJkL,ndJ,ndL->ndik", A, m, m)
    ev = np.linalg.eigvalsh(0.5 * (Q + Q.transpose(0, 1, 3, 2)))[..., -1].max(1)
    return np.sqrt(np.maximum(ev, 0.0) / rho0)


def gather_grad(x, grid_v, lo, dx, ng):
    """The APIC gradient ``4 / dx^2 sum_i w_ip v_i (x_i - x_p)^T`` of the node velocities ``grid_v`` (ng^3, 3) at
    the points ``x`` (n, 3): (n, 3, 3), 1/s."""
    from energy_ledger import stencil
    C = np.zeros((len(x), 3, 3))
    for wt, flat, dpos in stencil(x, lo, dx, ng):
        C += (4.0 / dx ** 2) * wt[:, None, None] * np.einsum("ni,nj->nij", grid_v[flat], dpos)
    return C


def point_psi(F, mu, lam, v0):
    """Each point's fixed-corotated energy (J, (n,)), signed (:func:`signed_psi`)."""
    R = F - corotated_P(F, 0.5, 0.0)
    J = np.linalg.det(F)
    return v0 * (mu * ((F - R) ** 2).sum((1, 2)) + 0.5 * lam * (J - 1) ** 2)


class Probe(Ledger):
    """The ledger with the module notes' extra columns per row."""

    def inverted(self) -> dict:
        """The points with ``det F <= 0`` after the step and the signed energy (:func:`signed_psi`)."""
        p = self.steps.points()
        F = p["F"].reshape(-1, 3, 3)
        J = np.linalg.det(F)
        return {"n_inv": int((J <= 0).sum()), "psi_signed": signed_psi(F, self.stored.mu, self.stored.lam, p["v0"])}

    def step(self) -> dict:
        p0 = self.steps.points()
        mat = self.stored
        Ft = np.einsum("nij,njk->nik", np.eye(3) + self.dt * p0["C"].reshape(-1, 3, 3), p0["F"].reshape(-1, 3, 3))
        tau = np.einsum("nij,nkj->nik", corotated_P(Ft, mat.mu, mat.lam), Ft)
        aff = (-self.dt * 4.0 / self.dx ** 2) * p0["v0"][:, None, None] * tau
        s_mom = p2g(p0["x"], np.zeros((len(Ft), 3)), self.lo, self.dx, self.ng, C=aff, m=np.ones(len(Ft)))
        rho0 = p0["m"] / p0["v0"]
        vmag = np.linalg.norm(p0["v"], axis=1)
        c_tan = tangent_speed(Ft, mat.mu, mat.lam, rho0)
        c_rest = np.sqrt((mat.lam + 2 * mat.mu) / rho0)
        free = p2g(p0["x"], np.c_[p0["m"][:, None] * p0["v"], p0["m"]], self.lo, self.dx, self.ng, C=p0["C"],
                   m=p0["m"])
        mass = free[:, 3]
        ok = mass > 0
        inv = np.where(ok, 1.0 / np.where(ok, mass, 1.0), 0.0)[:, None]
        psi0 = self.E["psi"]
        row = super().step()
        g = self._last
        va = free[:, :3] * inv
        vg = g["mom"] * inv + np.where(ok[:, None], self.dt * self.g, 0.0)
        ws_np = float((s_mom[:, :3] * 0.5 * (va + vg)).sum())
        Cm = gather_grad(p0["x"], 0.5 * (va + vg), self.lo, self.dx, self.ng)
        ws_p = -self.dt * p0["v0"] * np.einsum("nij,nij->n", tau, Cm)     # each point's stress work on the grid
        psi_t = point_psi(Ft, mat.mu, mat.lam, p0["v0"])
        if not hasattr(self, "res_p"):
            self.res_p, self.psi_prev = np.zeros(len(Ft)), point_psi(p0["F"].reshape(-1, 3, 3), mat.mu, mat.lam,
                                                                         p0["v0"])
            self.cfl_p, self.jmin_p = np.zeros(len(Ft)), np.ones(len(Ft))
        self.res_p += ws_p + psi_t - self.psi_prev
        self.psi_prev = psi_t
        self.cfl_p = np.maximum(self.cfl_p, (c_tan + vmag) * self.dt / self.dx)
        self.jmin_p = np.minimum(self.jmin_p, np.linalg.det(Ft))
        self.ws_p_sum = float(ws_p.sum())
        k = self.dt / self.dx
        row.update({"Ws": row["elastic"] - (row["psi"] - psi0) - (row["D"] - 0.0), "dpsi": row["psi"] - psi0,
                    "Ws_np": ws_np, "Ws_p": self.ws_p_sum, "res_sum": float(self.res_p.sum()),
                    "cfl_rest": float(((c_rest + vmag) * k).max()),
                    "cfl_tan": float(((c_tan + vmag) * k).max()), "n_tan_over1": int(((c_tan + vmag) * k > 1).sum()),
                    "c_tan_max": float(c_tan.max()), "c_rest": float(c_rest.max()), "v_max": float(vmag.max()),
                    "J_min": float(np.linalg.det(Ft).min())} | self.inverted())
        return row


def signed_psi(F, mu, lam, v0):
    """The fixed-corotated energy the engines' stress derives from, ``mu |F - R|^2 + lam (J - 1)^2 / 2`` with ``R``
    the proper rotation and ``J`` the signed determinant (J): equal to the unsigned SVD's where ``det F > 0``."""
    R = corotated_P(F, 0.5, 0.0) * -1 + F        # 2 * 0.5 * (F - R) = F - R  ->  R = F - (F - R)
    J = np.linalg.det(F)
    return float(v0 @ (mu * ((F - R) ** 2).sum((1, 2)) + 0.5 * lam * (J - 1) ** 2))


def summary(path: Path) -> dict:
    """One probe run's figures (J unless named): the elastic term at the end and its largest, the paired one
    (``half``) at the end and its largest, the Courant numbers' largest, the inverted points, the per-point split."""
    d = json.loads(path.read_text())
    rows, cum, half = d["rows"], 0.0, []
    el = np.cumsum([r["elastic"] for r in rows])
    for i, r in enumerate(rows):
        cum = el[i]
        half.append(cum + (rows[i + 1]["dpsi"] if i + 1 < len(rows) else 0.0) / 2)
    out = {"run": path.stem, "E0": d["E0"], "dt_ms": d["dt"] * 1e3, "end": float(el[-1]), "worst": float(el.max()),
           "half_end": half[-1], "half_worst": float(max(half)), "cfl_rest": max(r["cfl_rest"] for r in rows),
           "cfl_tan": max(r["cfl_tan"] for r in rows), "n_inv": rows[-1].get("n_inv", 0)}
    pts = path.with_name(path.stem + "_points.npz")
    if pts.exists():
        z = np.load(pts)
        res, jmin = z["res"], z["jmin"]
        out |= {"res_inverted": float(res[jmin <= 0].sum()), "res_J_over_half": float(res[jmin >= 0.5].sum()),
                "res_top10": float(np.sort(res)[::-1][: len(res) // 10].sum()), "res_total": float(res.sum())}
    return out


def report() -> list[str]:
    """The Markdown table of every probe run under :data:`OUT` (% of ``E0`` where named)."""
    lines = ["# The elastic term's gain per run (`benchmarks/cfl_gain_probe.py`)", "",
             "`end`, `worst`: the ledger's elastic term summed to the end and its largest on the way (% of E0); "
             "`paired`: the same with the stored energy of the two `F` levels' mean paired with the points' "
             "velocity (the half-step offset taken out); the largest local Courant numbers over points and substeps "
             "(rest `c_p` and the tangent `c(F)`, each `+ |v|`); points inverted at the end; the per-point split of "
             "the paired sum (J): inverted points, points whose `J` stayed over 0.5, the top 10 % of the points.", "",
             "| run | E0 (J) | dt (ms) | end % | worst % | paired end % | paired worst % | (c_p+v)dt/dx | "
             "(c(F)+v)dt/dx | "
             "inverted | split: inverted; J>0.5; top 10 %; all (J) |", "|" + "---|" * 11]
    for p in sorted(OUT.glob("*.json")):
        s = summary(p)
        pc = lambda x: f"{100 * x / s['E0']:.2f}"   # noqa: E731
        split = (f"{s['res_inverted']:.2f}; {s['res_J_over_half']:.2f}; {s['res_top10']:.2f}; {s['res_total']:.2f}"
                 if "res_total" in s else "-")
        lines.append(f"| {s['run']} | {s['E0']:.2f} | {s['dt_ms']:.3f} | {pc(s['end'])} | {pc(s['worst'])} | "
                     f"{pc(s['half_end'])} | {pc(s['half_worst'])} | {s['cfl_rest']:.2f} | {s['cfl_tan']:.2f} | "
                     f"{s['n_inv']} | {split} |")
    return lines + [""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="taichi_mpm")
    ap.add_argument("--body", default="donut")
    ap.add_argument("--n-grid", type=int, default=48)
    ap.add_argument("--speed", type=float, default=4.43)
    ap.add_argument("--cfl", type=float, default=0.8)
    ap.add_argument("--ms", type=float, default=40.0)
    ap.add_argument("--friction", type=float, default=None, help="the ground's friction (default: the scene's)")
    ap.add_argument("--rule", default=None, help="the engine option cfl_rule ('max', 'sum'; default: unset)")
    ap.add_argument("--report", action="store_true", help="only write the table of the runs kept")
    a = ap.parse_args(argv)
    if a.report:
        (OUT.parent / "cfl_gain_probe.md").write_text("\n".join(report()))
        return 0
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = scene(a.body, a.engine, a.n_grid, a.speed, a.cfl)
    if a.rule is not None:
        setup.options["cfl_rule"] = a.rule
    if a.friction is not None:
        import dataclasses
        setup.boundaries = [dataclasses.replace(b, friction=a.friction) if b.kind == "ground" else b
                            for b in setup.boundaries]
    material = setup.materials[0]
    t0 = time.time()
    e = build_engine(engines()[a.engine], setup)
    steps_sub = type(e)
    try:
        ground = next(((b.height, b.friction) for b in setup.boundaries if b.kind == "ground"), None)
        led = Probe(setup, e, material, ground)
        inner = led.steps.substep

        def keep():
            led._last = inner()
            return led._last
        led.steps.substep = keep
        E0 = total(led.E)
        n = int(round(a.ms * 1e-3 / led.dt))
        rows = []
        for i in range(n):
            r = led.step()
            rows.append({k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in r.items()
                         if not isinstance(v, (np.ndarray, dict))} | {"t_ms": (i + 1) * led.dt * 1e3})
    finally:
        e.close()
    del steps_sub
    OUT.mkdir(parents=True, exist_ok=True)
    tag = ("" if a.friction is None else f"_mu{a.friction:g}") + ("" if a.rule is None else f"_{a.rule}")
    np.savez(OUT / f"{a.body}_{a.engine}_{a.n_grid}_{a.cfl:g}{tag}_points.npz", res=led.res_p, cfl=led.cfl_p,
             jmin=led.jmin_p, x0=np.asarray(setup.x)[np.asarray(setup.p_vol) > 0])
    path = OUT / f"{a.body}_{a.engine}_{a.n_grid}_{a.cfl:g}{tag}.json"
    path.write_text(json.dumps({"E0": E0, "dt": led.dt, "dx": led.dx, "n": n, "seconds": time.time() - t0,
                                "rows": rows}, indent=0))
    print(path, time.time() - t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
