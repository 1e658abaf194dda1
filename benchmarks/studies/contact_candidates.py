"""Candidate particle contacts (``gasp_core.mpm.contact``: stiffness ``KAPPA``, damping ratio ``DAMPING``,
skin ``SKIN``) against the grid contact, on the conformance scenes that decide them, in one engine.

Each candidate sets the module's constants before the engine is built (``contact_coefficients`` reads them
then); ``grid`` is the engine option ``contact = "grid"``. Scenes: ``spun_ball_bounce`` (angular momentum
growth per bounce), ``jittered_ball_rest`` (drift, mm), ``rest_gap`` (dx), ``rest_on_tilted_ground`` (dx),
``bounce_hertz`` (restitution and contact duration against Hertz, the scene's own figures).

Run: ``python benchmarks/studies/contact_candidates.py [--engine warp_mpm]``; the table goes to stdout and to
``benchmarks/results/contact_candidates.md``.
"""
from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import gasp_core.mpm.contact as contact
from gasp_core.testing import scene_by_name
from gasp_core.testing.kit import evaluate_scene, resolve_engine

#: (label, KAPPA, DAMPING, SKIN); None: the grid contact.
CANDIDATES = [("grid (old)", None, None, None),
              ("penalty 16, undamped, no skin (the issue's lead)", 16.0, 0.0, 0.0),
              ("penalty 16, damped 0.5, skin 0.5", 16.0, 0.5, 0.5),
              ("penalty 8, damped 0.5, skin 0.5", 8.0, 0.5, 0.5),
              ("penalty 4, damped 0.5, no skin", 4.0, 0.5, 0.0),
              ("penalty 4, damped 0.25, skin 0.5", 4.0, 0.25, 0.5),
              ("penalty 4, damped 0.5, skin 0.5 (default)", 4.0, 0.5, 0.5),
              ("penalty 4, damped 1, skin 0.5", 4.0, 1.0, 0.5),
              ("penalty 1, damped 1, skin 0.5", 1.0, 1.0, 0.5)]
SCENES = ("spun_ball_bounce", "jittered_ball_rest", "rest_gap", "rest_on_tilted_ground", "bounce_hertz")


def figures(info, name: str) -> str:
    r = evaluate_scene(info, scene_by_name(name), {})
    if not r.checks:
        return f"{r.status}: {r.message[:60]}"
    out = [f"{c.figures.get('signed', c.figures.get('value', float('nan'))):.3g}" for c in r.checks]
    return ("" if r.status == "pass" else "**") + " / ".join(out) + ("" if r.status == "pass" else "**")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    a = ap.parse_args()
    info = resolve_engine(a.engine)
    saved = contact.KAPPA, contact.DAMPING, contact.SKIN
    rows = ["| candidate | " + " | ".join(SCENES) + " | CPU s |", "|---" * (len(SCENES) + 2) + "|"]
    for label, kappa, damping, skin in CANDIDATES:
        c0 = time.process_time()
        if kappa is None:
            opts = {"contact": "grid"}
            run = dataclasses.replace(info, factory=lambda s, f=info.factory: f(s.replace(options={**s.options, **opts})))
        else:
            contact.KAPPA, contact.DAMPING, contact.SKIN = kappa, damping, skin
            run = info
        cells = [figures(run, s) for s in SCENES]
        contact.KAPPA, contact.DAMPING, contact.SKIN = saved
        rows.append(f"| {label} | " + " | ".join(cells) + f" | {time.process_time() - c0:.0f} |")
        print(rows[-1], flush=True)
    text = "\n".join(rows)
    res = Path(__file__).resolve().parents[1] / "results"
    res.mkdir(exist_ok=True)
    (res / "contact_candidates.md").write_text(f"`python benchmarks/studies/contact_candidates.py --engine {a.engine}` "
                                               f"(bold: the scene's check fails)\n\n{text}\n")
    print(text)


if __name__ == "__main__":
    main()
