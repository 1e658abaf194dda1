"""Sand's and snow's plastic work in the energy ledger, both MPM engines (round 56; issue 66 item 6 "No energy is
gained"; docs/fracture.md "Round 56: sand and snow in the ledger"); the ledger is ``benchmarks/energy_ledger.py``'s.

The family (:data:`BODIES`): a sand column (R 5 cm, 15 cm tall) collapsing on the ground, a sand cube (12 cm)
slumping, a sand ball (R 5 cm) and a snow ball (R 5 cm) thrown down at 2 m/s from 5 mm above the ground, and a snow
block (12 x 12 x 5 cm) at 2 m/s; sand ``E 3.5e5 Pa, nu 0.3, rho 1600, friction_angle 30`` (``gasp_core.testing.
sand_ball``'s), snow the schema's defaults (``gasp_core.testing.snow``'s: E 1e5, nu 0.3, rho 1000, xi 10, theta_c
2.5e-2, theta_s 4.5e-3); 2 x 2 x 2 points a cell (``box_points`` lattice), the ground at z = 0 with friction 0.5 and
the default contact (``"auto"``: the grid contact for sand and snow), ``brittle_drop_family``'s 0.6 m box at n_grid
``--grids``. Each run books, per substep, the round 56 ledger (Hencky's energy for sand, the hardened fixed corotated
energy for snow; the plastic work of every point's return; snow's hardening term) and, alongside, the ledger before
it (fixed corotated, no return booked: :class:`BothLedgers`), and reports, as % of the energy brought ``E0`` (kinetic
+ gravitational over the ground + stored): each sink summed, the untraced term (``elastic + gravity``) at the end and
its largest size on the way, before and after. ``--stiffness-scale``: the catch (the engine built with E scaled, the
ledger kept on the scene's E). The ledger steps the engine's substeps frame by frame as its clock says (round 57:
snow's step from its state, ``gasp_core.mpm.state_step``; ``frames`` in the results: each frame's substeps).

Run: ``python benchmarks/energy_ledger_plastic.py`` (``--engines``, ``--bodies``, ``--grids``,
``--stiffness-scale``); writes ``benchmarks/results/energy_ledger_plastic.{json,md}`` (runs merged by key). About
1-6 min a run on 2 cores.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_ledger import SINKS, Ledger, Stored, total   # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "energy_ledger_plastic"
LO, HI = (-0.3, -0.3, -0.02), (0.3, 0.3, 0.58)   # brittle_drop_family's box
#: body: (material, shape, size (m), speed down (m/s), simulated time (ms)); shapes sit on the ground (z = 0) or,
#: thrown, 5 mm above it.
BODIES = {"sand_column": ("sand", "cylinder", (0.05, 0.15), 0.0, 200.0),
          "sand_block": ("sand", "box", (0.12, 0.12, 0.12), 0.0, 200.0),
          "sand_ball": ("sand", "ball", (0.05,), 2.0, 100.0),
          "snow_ball": ("snow", "ball", (0.05,), 2.0, 100.0),
          "snow_block": ("snow", "box", (0.12, 0.12, 0.05), 2.0, 100.0),
          # round 58: the snow step's neighbours (shapes, sizes and landings it was not built on)
          "snow_column": ("snow", "cylinder", (0.04, 0.10), 4.0, 100.0),
          "snow_ball_fast": ("snow", "ball", (0.05,), 5.0, 100.0),
          "snow_slab": ("snow", "box", (0.20, 0.20, 0.03), 3.0, 100.0)}


def material(name: str):
    from gasp_core.seam.setup import Material
    if name == "sand":
        return Material("sand", E=3.5e5, nu=0.3, rho=1600.0, friction_angle=30.0)
    return Material("snow")


def points(shape: str, size, dx: float, lift: float) -> tuple[np.ndarray, float]:
    """The lattice points (n, 3) of ``shape`` (m) at ``dx / 2`` and their volume (m^3): a cylinder ``(R, H)``, a box
    ``(a, b, c)`` or a ball ``(R,)`` standing on ``z = lift``, centred on the z axis."""
    from gasp_core.testing.helpers import box_points
    h = dx / 2
    if shape == "box":
        a, b, c = size
        return box_points((-a / 2, -b / 2, lift), (a / 2, b / 2, lift + c), h)
    r = size[0]
    top = lift + (size[1] if shape == "cylinder" else 2 * r)
    x, vol = box_points((-r, -r, lift), (r, r, top), h)
    keep = (x[:, :2] ** 2).sum(1) <= r * r if shape == "cylinder" else \
        ((x - np.array([0.0, 0.0, lift + r])) ** 2).sum(1) <= r * r
    return x[keep], vol


def scene(body: str, n_grid: int, cfl: float | None = None):
    """The body of :data:`BODIES` on ``n_grid`` (module notes), at the engines' ``cfl`` option (None: their
    default)."""
    from gasp_core.seam.setup import Boundary
    from gasp_core.testing.helpers import make_setup
    name, shape, size, v, _ms = BODIES[body]
    dx = (HI[0] - LO[0]) / n_grid
    x, vol = points(shape, size, dx, 0.005 if v > 0 else 0.0)
    return make_setup(x, np.full(len(x), vol), material(name), v=(0.0, 0.0, -v), lo=LO, hi=HI, n_grid=n_grid,
                      frame_dt=1 / 30, boundaries=[Boundary("ground", height=0.0, friction=0.5)],
                      options={"transfer_damping": "step"} if cfl is None else {"cfl": cfl, "transfer_damping": "step"})
    # APIC's transfers, which the ledger books (energy_ledger_family.STEP_NOTE)


class BothLedgers(Ledger):
    """The round 56 ledger with the one before it alongside: each row also has ``elastic_before``, the elastic term
    with the stored energy before round 56 (``Stored(plastic=False)``: fixed corotated) and no plastic work."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.old = Stored(self.stored.mat, self.setup, plastic=False)
        self.psi_old = self.old_psi(self.steps.points())

    def old_psi(self, p) -> float:
        return self.old(p["F"].reshape(-1, 3, 3), p["Jp"], p["v0"], p["x"])[0]

    def step(self) -> dict:
        psi0 = self.E["psi"]
        row = super().step()
        psi1 = self.old_psi(self.steps.points())
        row["elastic_before"] = (row["elastic"] - (row["psi"] - psi0) - row["plastic"] - row["hardening"]
                                 + psi1 - self.psi_old)
        row["psi_before"], self.psi_old = psi1, psi1
        return row


def run(body: str, engine: str, n_grid: int, ms: float | None = None, stiffness_scale: float = 1.0,
        every_ms: float = 10.0, cfl: float | None = None) -> dict:
    """One run's ledger, before and after (module notes): the sums (J), the untraced term at the end and its
    largest size on the way (J), the least any sink took in a substep (J, a gain negative), a row every
    ``every_ms``."""
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = scene(body, n_grid, cfl)
    ms = BODIES[body][4] if ms is None else ms
    mat = setup.materials[0]
    t0 = time.time()
    e = build_engine(engines()[engine], dataclasses.replace(setup, materials=[
        dataclasses.replace(mat, E=mat.E * stiffness_scale)]))
    try:
        led = BothLedgers(setup, e, mat, None)
        E0 = total(led.E)
        n_frames = max(1, math.ceil(ms * 1e-3 / setup.frame_dt - 1e-6))   # the last one cut at ms
        every = every_ms * 1e-3
        keys = SINKS + ("elastic", "gravity", "elastic_before")
        sums, least = {k: 0.0 for k in keys}, {k: 0.0 for k in SINKS}
        trace, worst, worst_before, top = [], 0.0, 0.0, E0
        t, n, clock = 0.0, 0, e.clock   # the engine's substeps, frame by frame (round 57: from the state)
        for f in range(n_frames):
            clock.begin()
            done = False
            while not done:
                led.dt = float(e.dt)
                r = led.step()
                t, n, done = t + led.dt, n + 1, clock.after()
                done = done or (f == n_frames - 1 and t >= ms * 1e-3 - 1e-9)
                for k in keys:
                    sums[k] += r[k]
                for k in SINKS:
                    least[k] = min(least[k], r[k])
                worst = max(worst, abs(sums["elastic"] + sums["gravity"]))
                worst_before = max(worst_before, abs(sums["elastic_before"] + sums["gravity"]))
                top = max(top, r["total"])
                if t >= every * (len(trace) + 1) - 1e-9 or (done and f == n_frames - 1):
                    trace.append({"t_ms": t * 1e3, "E": r["total"], "kinetic": r["kinetic"], "psi": r["psi"],
                                  "psi_before": r["psi_before"], "PE": r["PE"], **sums})
    finally:
        e.close()
    return {"body": body, "engine": engine, "n_grid": n_grid, "ms": ms, "stiffness_scale": stiffness_scale, "cfl": cfl,
            "dt": setup.frame_dt / clock.n_setup, "substeps": n, "frames": list(clock.frames),
            "n_points": int(len(led.kc)), "E0": E0, "E_end": trace[-1]["E"],
            "gain": max(0.0, top / E0 - 1.0), "sums": sums, "least": least, "untraced_end": sums["elastic"] +
            sums["gravity"], "untraced_worst": worst, "before_end": sums["elastic_before"] + sums["gravity"],
            "before_worst": worst_before, "mass_err": led.mass_err, "seconds": time.time() - t0, "trace": trace}


def key(r: dict) -> tuple:
    return (r["body"], r["engine"], r["n_grid"], r["ms"], r["stiffness_scale"], r.get("cfl"))


def report(runs: list[dict]) -> list[str]:
    """The Markdown table of the runs (% of the energy brought ``E0``)."""
    lines = ["# Sand's and snow's plastic work in the energy ledger (`benchmarks/energy_ledger_plastic.py`)", "",
             "Per run: the energy brought `E0` (kinetic + gravitational over the ground + stored, J); the untraced "
             "term (`elastic + gravity`) at the end and its largest size on the way, before round 56 (fixed "
             "corotated energy, no return booked) and after (the model's energy, the plastic work booked), % of "
             "`E0`; each sink summed (% of `E0`, positive: lost); `gain`: the largest energy over `E0` (%). The "
             "gates (`tests/test_energy_ledger.py`): untraced at the end within 2 %, on the way within 6 %.", "",
             "`substeps`: each frame's (round 57: snow's from its state, `gasp_core.mpm.state_step`; runs before it: "
             "blank); `dt`: the setup's.", "",
             "| body | engine | n_grid | ms | dt (ms) | substeps | points | E0 (J) | before: end; worst | after: end; "
             "worst | p2g | rule | balance | g2p | plastic | hardening | left | gain | s |", "|" + "---|" * 19]
    for r in sorted(runs, key=lambda r: tuple(str(x) for x in key(r))):
        s, e0 = r["sums"], r["E0"]
        pct = lambda x: f"{100 * x / e0:+.2f}"   # noqa: E731
        tag = "" if r["stiffness_scale"] == 1 else f" (catch: engine E x{r['stiffness_scale']})"
        tag += "" if r.get("cfl") is None else f" (cfl {r['cfl']})"
        lines.append(f"| {r['body']}{tag} | {r['engine']} | {r['n_grid']} | {r['ms']:g} | {r['dt'] * 1e3:.3f} | "
                     f"{', '.join(str(n) for n in r.get('frames', []))} | {r['n_points']} | {e0:.4f} | "
                     f"{pct(r['before_end'])}; {pct(r['before_worst'])} | "
                     f"{pct(r['untraced_end'])}; {pct(r['untraced_worst'])} | {pct(s['p2g'])} | {pct(s['rule'])} | "
                     f"{pct(s['balance'])} | {pct(s['g2p'])} | {pct(s['plastic'])} | {pct(s['hardening'])} | "
                     f"{100 * r['E_end'] / e0:.1f} | {100 * r['gain']:.2f} | {r['seconds']:.0f} |")
    return lines + [""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--bodies", default=",".join(list(BODIES)[:5]))
    ap.add_argument("--grids", default="32,48")
    ap.add_argument("--ms", type=float, default=None, help="simulated time (ms; default the body's)")
    ap.add_argument("--stiffness-scale", type=float, default=1.0)
    ap.add_argument("--cfl", type=float, default=None, help="the engines' cfl option (default theirs, 0.4)")
    a = ap.parse_args(argv)
    path = OUT.with_suffix(".json")
    for body in a.bodies.split(","):
        for ng in (int(g) for g in a.grids.split(",")):
            for engine in a.engines.split(","):
                r = run(body, engine, ng, a.ms, a.stiffness_scale, cfl=a.cfl)
                print(json.dumps({k: r[k] for k in ("body", "engine", "n_grid", "E0", "untraced_end",
                                                     "untraced_worst", "before_end", "before_worst", "sums",
                                                     "seconds")}), flush=True)
                runs = json.loads(path.read_text())["runs"] if path.exists() else []
                runs = [q for q in runs if key(q) != key(r)] + [r]
                path.write_text(json.dumps({"runs": runs}, indent=0))
                OUT.with_suffix(".md").write_text("\n".join(report(runs)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
