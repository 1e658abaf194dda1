"""Where a landing's energy goes, per substep, on both MPM engines (issue 66 item 6; docs/fracture.md "Round 46:
where the landing's energy goes"); the ledger is ``benchmarks/energy_ledger.py``'s.

The family: a jelly ball (R 5 cm) and a jelly block (12 x 12 x 5 cm), E 1e5 Pa, nu 0.3, rho 1000 (the brittle
defaults' E, nu, rho), thrown down at ``--speeds`` (m/s) from 5 mm above a frictionless ground, the default (particle)
contact, n_grid ``--grids`` over ``brittle_drop_family``'s 0.6 m box, for ``--ms`` ms; and the README donut
(``brittle_donut_arrest``'s: jelly and brittle, the scene's ground friction 0.5) at 4.43 m/s. Each run: the energy
brought ``E0`` (kinetic + gravitational over the ground, + stored, J) and, summed over the substeps, each sink
(``p2g``, ``contact``, ``rule``, ``balance``, ``g2p``, ``plastic``; positive: lost) and the untraced terms (``elastic``,
``gravity``), in J; the energy left; ``elastic_paired_worst`` (round 53): the largest elastic term on the way with the
stored energy's rise of the next substep halved in (the points' velocity is half a substep ahead of their ``F``: that
pairing takes out the symplectic step's bounded offset ``-(dt/2) dpsi/dt``, ``benchmarks/cfl_gain_probe.py``), J;
``elastic_own_worst`` (round 70): the scheme's own reading of the elastic step's gain: the half-step paired one under
"start" and "mid", the unpaired one under "trapezoid", whose ledger books ``F``'s owed increment
(``energy_ledger.OWED``; round 69's whole-step pairing without its shift);
the NumPy P2G's node-mass check; the least any sink took in one substep (a
gain is negative). ``--gravity-scale`` / ``--stiffness-scale``: the catches (the engine built with gravity or E
scaled, the ledger kept on the scene's).

Run: ``python benchmarks/energy_ledger_family.py`` (``--engines``, ``--bodies ball,block,donut,donut_brittle``,
``--grids``, ``--speeds``, ``--ms``, ``--cfl``); writes ``benchmarks/results/energy_ledger.{json,md}`` (runs merged by
key). About 10-60 s a run on 2 cores (the donut at n_grid 64: minutes).
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from energy_ledger import SINKS, UNTRACED, Ledger, total   # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "energy_ledger"
E_JELLY, NU, RHO = 1.0e5, 0.3, 1000.0


def jelly():
    from gasp_core.seam.setup import Material
    return Material("jelly", E=E_JELLY, nu=NU, rho=RHO)


#: The ledger books APIC's transfers; since round 56 a step shorter than cfl 0.4's blends AFLIP by default
#: (``transfer_damping = "rate"``, ``gasp_core.mpm.transfer``), whose FLIP part the ledger does not model, so its scenes
#: ask for APIC's damping per substep ("step"): at cfl 0.4 and longer the same run to the bit.
STEP_NOTE = "transfer_damping step"


def simple(body: str, n_grid: int, v: float, cfl: float | None):
    """The ball or the block of the family at ``n_grid``, thrown down at ``v`` (m/s) 5 mm above the ground."""
    from brittle_drop_family import HI, LO, ball_splats, box_splats
    from gasp_core.maps.fill import fill_interior
    from gasp_core.seam.setup import Boundary
    from gasp_core.testing.helpers import make_setup
    splats = (ball_splats((0.0, 0.0, 0.055), 0.05) if body == "ball"
              else box_splats((-0.06, -0.06, 0.005), (0.06, 0.06, 0.055)))
    dx = (HI[0] - LO[0]) / n_grid
    fr = fill_interior(splats.reshape(-1, 3), dx / 4 ** (1 / 3), splats=splats, surface_mass=False)
    opts = {"transfer_damping": "step"} if cfl is None else {"cfl": cfl, "transfer_damping": "step"}   # APIC: STEP_NOTE
    return make_setup(fr.fill_x, fr.p_vol_fill, jelly(), v=(0.0, 0.0, -v), lo=LO, hi=HI, n_grid=n_grid,
                      frame_dt=1 / 30, boundaries=[Boundary("ground", height=0.0, friction=0.0)], options=opts)


def donut(engine: str, n_grid: int, v: float, brittle: bool, cfl: float | None):
    """``brittle_donut_arrest``'s README donut (brittle defaults, or jelly of the same E, nu, rho) at ``v``."""
    import brittle_readme_donut as bd
    from brittle_donut_speed import at_speed
    from gasp_core.seam.setup import Material
    b = bd.brittle("new")
    m = b if brittle else Material("jelly", E=b.E, nu=b.nu, rho=b.rho)
    s = at_speed(bd.donut_setup(engine, n_grid, m), v)
    s.options["transfer_damping"] = "step"   # the ledger's transfers are APIC's (STEP_NOTE)
    if cfl is not None:
        s.options["cfl"] = cfl
    return s


def scene(body: str, engine: str, n_grid: int, v: float, cfl: float | None = None):
    if body in ("ball", "block"):
        return simple(body, n_grid, v, cfl)
    return donut(engine, n_grid, v, body == "donut_brittle", cfl)


def run(body: str, engine: str, n_grid: int, v: float, ms: float, cfl: float | None = None,
        gravity_scale: float = 1.0, stiffness_scale: float = 1.0, every_ms: float = 5.0,
        damping: float | None = None, flip: float | None = None, parts: bool = False, rule: str | None = None,
        stress_at: str | None = None, friction: float | None = None, passes: int | None = None,
        owed: str | None = None, gradient: bool = True) -> dict:
    """One landing's ledger (module notes): sums of the sinks, the energy left, and a row every ``every_ms``.
    Prototypes, off by default (None): ``damping``, the particle contact's damping ratio
    (``gasp_core.mpm.contact.DAMPING``, 0.5) for this run; ``flip``, the engines' AFLIP option; ``rule``, the
    engines' ``cfl_rule`` option (``gasp_core.mpm.substeps.CFL_RULES``); ``stress_at``, the engines' option
    (``gasp_core.mpm.stress_at``, round 68); ``friction``, the ground's friction for this run (round 68's split of the
    donut's gain); ``passes``, warp_mpm's trial passes under ``stress_at = "trapezoid"`` (round 69,
    the engines' option ``stress_passes``); ``owed``, the ledger's booking of ``F``'s owed increment under the
    trapezoid (``energy_ledger.OWED``; None: the scheme's, round 70); ``gradient`` False: the trapezoid's
    ``gradient`` sink unbooked (``energy_ledger.Ledger.gradient``; the catch, round 70). ``parts``: also the
    parts of 1 % of the mass or more at the end (``gasp_core.testing.pieces_count.FramePieces``)."""
    import gasp_core.mpm.contact as gc
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = scene(body, engine, n_grid, v, cfl)
    if flip is not None:
        setup.options["flip"] = flip
    if rule is not None:
        setup.options["cfl_rule"] = rule
    if stress_at is not None:
        setup.options["stress_at"] = stress_at
    if friction is not None:
        setup.boundaries = [dataclasses.replace(b, friction=friction) if b.kind == "ground" else b
                            for b in setup.boundaries]
    keep = gc.DAMPING
    gc.DAMPING = keep if damping is None else damping
    if passes is not None:
        setup.options["stress_passes"] = passes
    try:
        r = _run(setup, body, engine, n_grid, v, ms, cfl, gravity_scale, stiffness_scale, every_ms, parts,
                 owed, gradient) | {
            "damping": damping, "flip": flip, "rule": rule, "stress_at": stress_at, "friction": friction,
            "passes": passes}
    finally:
        gc.DAMPING = keep
    log_run(r)
    return r


def log_run(r: dict) -> None:
    """With the environment's ``GASP_LEDGER_LOG`` set to a path, one JSON line of the run's figures (% of ``E0``)
    appended there: the figures of a test run read without running its cases again (round 70)."""
    import os
    path = os.environ.get("GASP_LEDGER_LOG")
    if not path:
        return
    e0, s = r["E0"], r["sums"]
    pct = lambda x: round(100 * x / e0, 3)   # noqa: E731
    row = {k: r.get(k) for k in ("body", "engine", "n_grid", "speed", "ms", "cfl", "rule", "stress_at", "passes",
                                 "owed", "gradient", "gravity_scale")}
    row.update({"untraced_end": pct(s["elastic"] + s["gravity"]), "untraced_worst": pct(r["untraced_worst"]),
                "elastic_end": pct(s["elastic"]), "own_gain": pct(r["elastic_own_worst"]),
                "paired": pct(r["elastic_paired_worst"]), "full": pct(r["elastic_full_worst"]),
                "raw": pct(r["elastic_raw_worst"]), "left": pct(r["E_end"]), "gradient_sink": pct(s["gradient"]),
                "E_max": pct(max(t["E"] for t in r["trace"])), "seconds": round(r["seconds"], 1)})
    with open(path, "a") as f:
        f.write(json.dumps(row) + "\n")


def _run(setup, body, engine, n_grid, v, ms, cfl, gravity_scale, stiffness_scale, every_ms, parts, owed=None,
         gradient=True) -> dict:
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    material = setup.materials[0]
    variant = dataclasses.replace(setup, gravity=np.asarray(setup.gravity) * gravity_scale,
                                  materials=[dataclasses.replace(material, E=material.E * stiffness_scale)])
    t0 = time.time()
    e = build_engine(engines()[engine], variant)
    try:
        ground = next(((b.height, b.friction) for b in setup.boundaries if b.kind == "ground"), None)
        led = Ledger(setup, e, material, ground, owed=owed, gradient=gradient)
        E0 = total(led.E)
        n = int(round(ms * 1e-3 / led.dt))
        every = max(1, int(round(every_ms * 1e-3 / led.dt)))
        sums = {k: 0.0 for k in SINKS + UNTRACED}
        least = {k: 0.0 for k in SINKS}
        trace, worst, paired, psi = [], 0.0, 0.0, led.E["psi"]
        full, raw = 0.0, 0.0   # round 69: paired with a whole step's offset (the trapezoid's), and not paired
        for i in range(n):
            r = led.step()
            paired = max(paired, sums["elastic"] + 0.5 * (r["psi"] - psi))   # the last row's, paired (notes)
            full = max(full, sums["elastic"] + (r["psi"] - psi))
            raw = max(raw, sums["elastic"])
            psi = r["psi"]
            for k in sums:
                sums[k] += r[k]
            for k in SINKS:
                least[k] = min(least[k], r[k])
            worst = max(worst, abs(sums["elastic"] + sums["gravity"]))
            if (i + 1) % every == 0 or i == n - 1:
                trace.append({"t_ms": (i + 1) * led.dt * 1e3, "E": r["total"], "kinetic": r["kinetic"],
                              "Ep": r["Ep"], "psi": r["psi"], "D": r["D"], "U": r["U"],
                              **{k: sums[k] for k in sums}})
        paired, full, raw = (max(q, sums["elastic"]) for q in (paired, full, raw))
        pieces = count_parts(setup, e) if parts else None
    finally:
        e.close()
    return {"body": body, "engine": engine, "n_grid": n_grid, "speed": v, "ms": ms, "cfl": cfl,
            "gravity_scale": gravity_scale, "stiffness_scale": stiffness_scale, "dt": led.dt, "substeps": n,
            "n_points": int(len(led.kc)), "E0": E0, "E_end": trace[-1]["E"], "sums": sums, "least": least,
            "untraced_worst": worst, "elastic_paired_worst": paired, "elastic_full_worst": full,
            "elastic_raw_worst": raw, "owed": led.owed, "gradient": led.trap_gradient,
            "elastic_own_worst": raw if led.owed == "whole" else paired, "mass_err": led.mass_err,
            "seconds": time.time() - t0, "trace": trace,
            "parts": pieces}


def count_parts(setup, e) -> list[float]:
    """The shares of the mass of the parts of 1 % or more at the end (the frames-only count of
    ``brittle_donut_arrest``: rest neighbours within ``LINK_RADIUS`` spacings, cut past ``dx``), from the engine
    ``e``'s positions in the setup's order."""
    from gasp_core.run.pieces import LINK_RADIUS
    from gasp_core.testing.pieces_count import FramePieces
    mat = np.asarray(setup.p_vol) > 0
    x0, m = np.asarray(setup.x)[mat], np.asarray(setup.p_mass)[mat]
    x = np.asarray(e.to_setup_order(e.read_array("x")), np.float64)[mat]
    ref = FramePieces(x0, m, LINK_RADIUS * float(np.cbrt(np.asarray(setup.p_vol)[mat].max())), setup.dx)
    shares = ref.masses(x) / m.sum()
    return [float(q) for q in shares if q >= 0.01]


def parts_run(engine: str, n_grid: int, v: float, frames: int = 5, damping: float | None = None,
              flip: float | None = None) -> dict:
    """The brittle README donut at ``v`` stepped ``frames`` frames of 1/30 s by the engine alone (no ledger), with the
    prototypes of :func:`run`: the parts of 1 % of the mass or more at the end, and the share broken through."""
    import gasp_core.mpm.contact as gc
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import engines
    setup = scene("donut_brittle", engine, n_grid, v)
    if flip is not None:
        setup.options["flip"] = flip
    keep, t0 = gc.DAMPING, time.time()
    gc.DAMPING = keep if damping is None else damping
    try:
        e = build_engine(engines()[engine], setup)
        try:
            for _ in range(frames):
                e.step_frame()
            mat = np.asarray(setup.p_vol) > 0
            d = np.asarray(e.to_setup_order(e.read_array("Jp")), np.float64)[mat]
            m = np.asarray(setup.p_mass)[mat]
            out = {"parts": count_parts(setup, e), "broken": float(m @ (d >= 1.0) / m.sum())}
        finally:
            e.close()
    finally:
        gc.DAMPING = keep
    return {"engine": engine, "n_grid": n_grid, "speed": v, "frames": frames, "damping": damping, "flip": flip,
            "seconds": time.time() - t0, **out}


def key(r: dict) -> tuple:
    return (r["body"], r["engine"], r["n_grid"], r["speed"], r["ms"], r.get("cfl"), r["gravity_scale"],
            r["stiffness_scale"], r.get("damping"), r.get("flip"), r.get("rule"), r.get("stress_at"), r.get("friction"),
            r.get("passes"))


def report(runs: list[dict]) -> list[str]:
    """The Markdown table of the runs: each sink's share of the energy brought (%), and in J."""
    lines = ["# Where a landing's energy goes (`benchmarks/energy_ledger_family.py`)", "",
             "Per run: the energy brought `E0` (kinetic + gravitational over the ground + stored, J), each sink summed "
             "over the substeps as a % of `E0` (positive: lost; `benchmarks/energy_ledger.py`'s notes), the energy "
             "left, and `untraced`: the elastic + gravity terms at the end and their largest size on the way "
             "(% of `E0`); `gain`: the largest energy over `E0` at any substep (%).", "",
             "| body | engine | n_grid | v (m/s) | ms | dt (ms) | points | E0 (J) | p2g | contact | friction | rule | "
             "balance | g2p | plastic | damage | untraced end; worst | left | gain | mass err | s |",
             "|" + "---|" * 21]
    for r in sorted(runs, key=lambda r: tuple(str(x) for x in key(r))):
        s, e0 = r["sums"], r["E0"]
        pct = lambda x: f"{100 * x / e0:.1f}"   # noqa: E731
        tag = "" if r["gravity_scale"] == 1 and r["stiffness_scale"] == 1 else \
            f" (catch: g x{r['gravity_scale']}, E x{r['stiffness_scale']})"
        tag += "".join(f" ({k} {r[k]})" for k in ("damping", "flip", "rule", "stress_at", "passes", "friction")
                       if r.get(k) is not None)
        tag += f" (parts {', '.join(f'{q:.3f}' for q in r['parts'])})" if r.get("parts") else ""
        lines.append(f"| {r['body']}{tag} | {r['engine']} | {r['n_grid']} | {r['speed']} | {r['ms']:g} | "
                     f"{r['dt'] * 1e3:.3f} | {r['n_points']} | {e0:.3f} | {pct(s['p2g'])} | {pct(s['contact'])} | "
                     f"{pct(s['friction']) if 'friction' in s else '-'} | {pct(s['rule'])} | {pct(s['balance'])} | "
                     f"{pct(s['g2p'])} | {pct(s['plastic']) if 'plastic' in s else '-'} | {pct(r['trace'][-1]['D'])} | "
                     f"{pct(s['elastic'] + s['gravity'])}; {pct(r['untraced_worst'])} | {pct(r['E_end'])} | "
                     f"{r['gain'] * 100:.2f} | {r['mass_err']:.1e} | {r['seconds']:.0f} |")
    return lines + [""]


def parts_report(data: dict) -> list[str]:
    """The brittle donut's parts with and without the prototypes (``--parts-only``)."""
    pr = data.get("parts_runs", [])
    if not pr:
        return []
    lines = ["## The brittle README donut's parts (engine alone, `--parts-only`)", "",
             "| engine | n_grid | v (m/s) | frames | contact damping | flip | parts of 1 % or more | broken through |",
             "|---|---|---|---|---|---|---|---|"]
    for r in sorted(pr, key=lambda r: tuple(str(r[k]) for k in ("engine", "n_grid", "damping", "flip"))):
        lines.append(f"| {r['engine']} | {r['n_grid']} | {r['speed']} | {r['frames']} | "
                     f"{'0.5 (default)' if r['damping'] is None else r['damping']} | "
                     f"{'0 (default)' if r['flip'] is None else r['flip']} | "
                     f"{len(r['parts'])}: {', '.join(f'{q:.3f}' for q in r['parts'])} | {r['broken']:.3f} |")
    return lines + [""]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", default="taichi_mpm,warp_mpm")
    ap.add_argument("--bodies", default="ball,block")
    ap.add_argument("--grids", default="32,48,64")
    ap.add_argument("--speeds", default="1,2,4.43")
    ap.add_argument("--ms", type=float, default=60.0, help="simulated time (ms)")
    ap.add_argument("--cfl", type=float, default=None)
    ap.add_argument("--gravity-scale", type=float, default=1.0)
    ap.add_argument("--stiffness-scale", type=float, default=1.0)
    ap.add_argument("--damping", type=float, default=None, help="prototype: the contact's damping ratio (0.5)")
    ap.add_argument("--flip", type=float, default=None, help="prototype: the engines' AFLIP blend")
    ap.add_argument("--rule", default=None, help="the engines' cfl_rule option ('max', 'sum')")
    ap.add_argument("--stress-at", default=None, help="the engines' stress_at option ('start', 'mid'; round 68)")
    ap.add_argument("--passes", type=int, default=None, help="the engines' stress_passes option (round 69)")
    ap.add_argument("--out", default=None, help="the results' path without suffix (default benchmarks/results/"
                    "energy_ledger)")
    ap.add_argument("--friction", type=float, default=None, help="the ground's friction (default: the scene's)")
    ap.add_argument("--parts", action="store_true", help="count the parts of 1 %% or more at the end")
    ap.add_argument("--parts-only", type=int, default=0, help="the brittle donut's parts after this many frames, "
                    "engine alone (printed and kept under 'parts_runs')")
    a = ap.parse_args(argv)
    out = OUT if a.out is None else Path(a.out)
    path = out.with_suffix(".json")
    data = json.loads(path.read_text()) if path.exists() else {}
    runs = data.get("runs", [])
    if a.parts_only:
        pr = data.get("parts_runs", [])
        for engine in a.engines.split(","):
            for ng in (int(g) for g in a.grids.split(",")):
                r = parts_run(engine, ng, float(a.speeds.split(",")[0]), a.parts_only, a.damping, a.flip)
                print(json.dumps(r), flush=True)
                pr = [q for q in pr if [q[k] for k in ("engine", "n_grid", "speed", "frames", "damping", "flip")]
                      != [r[k] for k in ("engine", "n_grid", "speed", "frames", "damping", "flip")]] + [r]
                data = json.loads(path.read_text()) if path.exists() else {}
                path.write_text(json.dumps({**data, "parts_runs": pr}, indent=0))
                data = {**data, "parts_runs": pr}
                OUT.with_suffix(".md").write_text("\n".join(report(data.get("runs", [])) + parts_report(data)) + "\n")
        return 0
    for body in a.bodies.split(","):
        for ng in (int(g) for g in a.grids.split(",")):
            for v in (float(s) for s in a.speeds.split(",")):
                for engine in a.engines.split(","):
                    r = run(body, engine, ng, v, a.ms, a.cfl, a.gravity_scale, a.stiffness_scale, damping=a.damping,
                            flip=a.flip, parts=a.parts, rule=a.rule, stress_at=a.stress_at, friction=a.friction,
                            passes=a.passes)
                    r["gain"] = max(0.0, max(t["E"] for t in r["trace"]) / r["E0"] - 1.0)
                    runs = [q for q in runs if key(q) != key(r)] + [r]
                    print(json.dumps({k: r[k] for k in ("body", "engine", "n_grid", "speed", "E0", "E_end",
                                                         "sums", "untraced_worst", "elastic_paired_worst", "dt",
                                                         "elastic_full_worst", "elastic_raw_worst",
                                                         "stress_at", "passes", "seconds")}), flush=True)
                    data = json.loads(path.read_text()) if path.exists() else {}
                    path.write_text(json.dumps({**data, "runs": runs}, indent=0))
                    out.with_suffix(".md").write_text("\n".join(report(runs) + parts_report(data)) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
