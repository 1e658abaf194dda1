"""Round 69 (issue 66 item 6; docs/fracture.md "Round 69: the trapezoidal stress"): a known-answer free vibration
for the engine option ``stress_at``. A free jelly bar (0.2 x 0.04 x 0.04 m, E 1e5 Pa, nu 0, rho 1000 kg/m^3: the
bar speed ``c = sqrt(E / rho)`` = 10 m/s), no ground, no gravity, given its first free-free longitudinal mode's
velocity ``v_x = V cos(pi (x + L/2) / L)`` (V 0.1 m/s: a strain of 1 %), run for ``PERIODS`` periods of
``omega = pi c / L``. Energy kept: the mean of (the points' kinetic + fixed corotated stored energy) over the last
period against the first period's.

The prediction for "mid" (round 68: a stiffness-proportional (Rayleigh) damping of coefficient ``beta = dt / 2``):
the energy falls as ``exp(-beta omega^2 t)``; measured against "start" (the transfers' own loss taken out):
``kept_mid / kept_start`` against ``exp(-(dt/2) omega^2 (PERIODS - 1) T)``, ``omega`` the run's own (measured from the
zero crossings of the left half's mean velocity under "start").

``--ledger``: instead, each scheme's offset in ``benchmarks/energy_ledger.py``'s elastic term on the same bar over
two periods: the worst ``|elastic + c dpsi|`` (% of ``E0``; ``dpsi`` the substep's stored energy change) for ``c`` 0,
1/2 (the pairing of ``energy_ledger_family.py``'s "paired gain": the start's half step) and 1 (the trapezoid's whole
step: ``F`` advances by the substep's mean gradient at the next P2G, so the stored energy lags the stress's work by one
increment). Round 70: under the trapezoid the ledger books that owed increment (``energy_ledger.OWED``), so its
``c`` 0 column is round 69's ``c`` 1; ``--owed whole,half,none`` compares the bookings (none: round 69's ledger);
``--no-gradient`` leaves the ledger's ``gradient`` sink unbooked (``energy_ledger.Ledger.gradient``).

Run: ``python benchmarks/studies/free_vibration.py [--engines warp_mpm,taichi_mpm] [--cfl 0.4,0.8]
[--at start,mid,trapezoid] [--n-grid 32] [--passes 1,3] [--ledger]`` (one JSON line a run, then a markdown table).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

L, H, E, RHO, V = 0.2, 0.04, 1.0e5, 1000.0, 0.1
PERIODS = 4


def bar_setup(n_grid: int, cfl: float, at: str, passes: int = 1):
    from gasp_core.seam.setup import Material
    from gasp_core.testing.helpers import make_setup
    lo, hi = (-0.15, -0.15, -0.15), (0.15, 0.15, 0.15)
    dx = (hi[0] - lo[0]) / n_grid
    s = dx / 2
    g = np.mgrid[-L / 2:L / 2 - 1e-9:s, -H / 2:H / 2 - 1e-9:s, -H / 2:H / 2 - 1e-9:s].reshape(3, -1).T + s / 2
    v = np.zeros_like(g)
    v[:, 0] = V * np.cos(math.pi * (g[:, 0] + L / 2) / L)
    return make_setup(g, np.full(len(g), s ** 3), Material("jelly", E=E, nu=0.0, rho=RHO), v=v, gravity=(0, 0, 0),
                      lo=lo, hi=hi, n_grid=n_grid, frame_dt=1 / 30,
                      options={"cfl": cfl, "transfer_damping": "step", "stress_at": at,
                               **({"stress_passes": passes} if at == "trapezoid" else {})})


def energy(pts: dict, mu: float) -> float:
    """Kinetic + fixed corotated stored energy (nu 0: lambda 0) of the points, J."""
    ke = 0.5 * float(np.sum(pts["m"] * np.sum(pts["v"] ** 2, axis=1)))
    s = np.linalg.svd(pts["F"], compute_uv=False)
    return ke + float(np.sum(pts["v0"] * mu * np.sum((s - 1.0) ** 2, axis=1)))


def run(engine: str, n_grid: int, cfl: float, at: str, passes: int) -> dict:
    from energy_ledger import steps_of
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = bar_setup(n_grid, cfl, at, passes)
    cls = engines()[engine]
    t0 = time.time()
    e = build_engine(cls, setup)
    try:
        st = steps_of(e)
        dt = float(e.dt)
        omega = math.pi * math.sqrt(E / RHO) / L
        n = int(round(PERIODS * 2 * math.pi / omega / dt))
        Es, vl, left = [], [], None
        mu = E / 2.0
        for i in range(n + 1):
            p = st.points()
            if left is None:
                left = p["x"][:, 0] < 0.0
            Es.append(energy(p, mu))
            vl.append(float(np.mean(p["v"][left, 0])))
            if i < n:
                st.substep()
    finally:
        e.close()
    Es, vl = np.array(Es), np.array(vl)
    sgn = np.sign(vl)
    cross = np.nonzero(sgn[1:] * sgn[:-1] < 0)[0]
    # linear interpolation of the crossings; half a period between two
    tc = [(i + vl[i] / (vl[i] - vl[i + 1])) * dt for i in cross]
    T_meas = 2 * float(np.mean(np.diff(tc))) if len(tc) > 2 else float("nan")
    per = int(round(2 * math.pi / omega / dt))
    kept = float(np.mean(Es[-per:]) / np.mean(Es[:per]))
    return {"engine": engine, "n_grid": n_grid, "cfl": cfl, "stress_at": at,
            "passes": passes if at == "trapezoid" else None, "dt": dt, "substeps": n, "n_points": len(setup.x),
            "omega_bar": omega, "omega_meas": 2 * math.pi / T_meas if T_meas == T_meas else None,
            "kept": kept, "E0": float(Es[0]), "seconds": round(time.time() - t0, 1)}


def offsets(engine: str, n_grid: int, cfl: float, at: str, passes: int, owed: str | None = None,
            gradient: bool = True) -> dict:
    """The worst ``|elastic + c dpsi|`` of the ledger over two periods (module notes), % of ``E0``; ``owed``: the
    ledger's booking of ``F``'s owed increment under the trapezoid (``energy_ledger.OWED``; None: the scheme's)."""
    from energy_ledger import Ledger, total
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = bar_setup(n_grid, cfl, at, passes)
    e = build_engine(engines()[engine], setup)
    try:
        led = Ledger(setup, e, setup.materials[0], None, owed=owed, gradient=gradient)
        E0, psi, el = total(led.E), led.E["psi"], 0.0
        worst = {0.0: 0.0, 0.5: 0.0, 1.0: 0.0}
        for _ in range(2 * int(round(2 * L / math.sqrt(E / RHO) / led.dt))):
            r = led.step()
            for c in worst:
                worst[c] = max(worst[c], abs(el + c * (r["psi"] - psi)))
            psi, el = r["psi"], el + r["elastic"]
    finally:
        e.close()
    return {"engine": engine, "cfl": cfl, "stress_at": at, "passes": passes if at == "trapezoid" else None,
            "owed": led.owed, **{f"c={c:g}": round(100 * w / E0, 3) for c, w in worst.items()}, "elastic_end": round(100 * el / E0, 3)}


def cases(a):
    """``(engine, cfl, stress_at, passes)`` of the command line ``a``: the trapezoid at each pass count (taichi_mpm:
    one pass alone, round 69), the other schemes once (passes 0)."""
    for engine in a.engines.split(","):
        for cfl in (float(c) for c in a.cfl.split(",")):
            for at in a.at.split(","):
                for passes in ([int(q) for q in a.passes.split(",")] if at == "trapezoid" else [0]):
                    if not (engine == "taichi_mpm" and passes > 1):
                        yield engine, cfl, at, passes


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engines", default="warp_mpm")
    ap.add_argument("--cfl", default="0.4,0.8")
    ap.add_argument("--at", default="start,mid,trapezoid")
    ap.add_argument("--n-grid", type=int, default=32)
    ap.add_argument("--passes", default="1,3", help="the trapezoid's passes a substep (comma list)")
    ap.add_argument("--ledger", action="store_true", help="the ledger's offsets instead (module notes)")
    ap.add_argument("--owed", default=None, help="with --ledger: the ledger's booking of F's owed increment under "
                    "the trapezoid, a comma list of whole, half, none (default: the scheme's, whole; round 70)")
    ap.add_argument("--no-gradient", dest="gradient", action="store_false", help="with --ledger: the trapezoid's "
                    "gradient sink left unbooked (energy_ledger.Ledger.gradient; round 69's ledger)")
    a = ap.parse_args(argv)
    if a.ledger:
        print("| engine | cfl | stress_at | owed booked | worst, c 0 | c 1/2 | c 1 | elastic term at the end |")
        print("|---|---|---|---|---|---|---|---|")
        for engine, cfl, at, passes in cases(a):
            for owed in (a.owed.split(",") if a.owed and at == "trapezoid" else [None]):
                r = offsets(engine, a.n_grid, cfl, at, passes, owed, a.gradient)
                name = at + (f" ({passes} passes)" if r["passes"] else "")
                print(f"| {engine} | {cfl} | {name} | {r['owed']} | {r['c=0']} | {r['c=0.5']} | {r['c=1']} | "
                      f"{r['elastic_end']} |", flush=True)
        return 0
    rows = []
    for engine, cfl, at, passes in cases(a):
        r = run(engine, a.n_grid, cfl, at, passes)
        print(json.dumps(r), flush=True)
        rows.append(r)
    print("| engine | cfl | dt (ms) | stress_at | omega (rad/s) | energy kept over 3 periods | against start | "
          "Rayleigh dt/2 predicts |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        base = next((q for q in rows if q["engine"] == r["engine"] and q["cfl"] == r["cfl"]
                     and q["stress_at"] == "start"), None)
        w = (base or r)["omega_meas"] or r["omega_bar"]
        pred = math.exp(-(r["dt"] / 2) * w * w * (PERIODS - 1) * 2 * math.pi / r["omega_bar"])
        rel = r["kept"] / base["kept"] if base else float("nan")
        at = r["stress_at"] + (f" ({r['passes']} passes)" if r["passes"] else "")
        print(f"| {r['engine']} | {r['cfl']} | {r['dt'] * 1e3:.3f} | {at} | {w:.1f} | {r['kept']:.4f} | {rel:.4f} | "
              f"{pred:.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
