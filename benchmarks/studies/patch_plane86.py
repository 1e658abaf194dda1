"""How flat a contact patch is: the figures behind ``gasp_core.mpm.take_back`` (round 86, ``docs/contact.md``
"Round 86: the take-back where the patch is not flat").

For each frame of a scene run on an engine: the points within the ground contact's skin (``depth > 0``, weighted
by their depth, as the penalty weights their impulses), their count, ``n_eff = (sum d)^2 / sum d^2``, ``rho`` (the
rms departure of their heights from their best plane, in point spacings ``h``) and ``f``
(:func:`gasp_core.mpm.take_back.unresolved_fraction`, the fraction of the take-back's bound kept). Scenes: the
conformance suite's jittered ball at rest (``jittered``), its lattice ball spun on a frictionless ground (``spun``),
and the tall jelly block settled on 30 degrees at mu 0.7 (``tall``, n_grid 24).

    python benchmarks/studies/patch_plane86.py --scene jittered spun tall --out patch.json
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parents[2] / "tests"))


def patch_row(x: np.ndarray, h: np.ndarray, ground: float) -> dict:
    """The patch figures of positions ``x`` (m) with spacings ``h`` (m) on a ground at ``ground`` (m)."""
    from gasp_core.mpm.contact import SKIN
    from gasp_core.mpm.take_back import plane_departure, unresolved_fraction
    d = ground + SKIN * h - x[:, 2]
    m = d > 0
    if m.sum() == 0:
        return {"n": 0}
    w, X, hm, up = d[m], x[m], float(np.median(h)), np.array([0.0, 0.0, 1.0])
    J = w.sum()
    rho2 = plane_departure(np.cov(X.T, aweights=w, bias=True), up)
    return {"n": int(m.sum()), "n_eff": round(float(J * J / (w * w).sum()), 1),
            "rho_h": round(float(np.sqrt(rho2 or 0.0)) / hm, 4), "f": round(unresolved_fraction(w, X, up, hm), 4)}


def ball_rows(engine: str, which: str) -> list[dict]:
    from gasp_core.testing import scenes_contact as sc
    from gasp_core.testing.kit import resolve_engine, run_trace
    info = resolve_engine(engine)
    s = (sc._build_jittered if which == "jittered" else sc._build_spun)(info)
    n = sc.DRIFT_FRAMES if which == "jittered" else sc.SPIN_FRAMES
    tr = run_trace(info, s, n)
    h = np.cbrt(np.asarray(s.p_vol, float) * np.ones(len(s.x)))
    return [{"scene": which, "frame": f, **patch_row(np.asarray(tr.x[f], float), h, sc.GROUND_H)}
            for f in range(0, n + 1, 2)]


def tall_rows(engine: str) -> list[dict]:
    from test_elastic_slope import FPS, SETTLE_T, STICK_T, block_setup
    from gasp_core.seam.plugins import get_engine
    from gasp_core.seam.runner import EngineRun, RunStats
    s = block_setup(30.0, 0.7, "particle", (0.1, 0.1, 0.15), 24)
    ground = next(b for b in s.boundaries if b.kind == "ground").height
    h = np.cbrt(np.asarray(s.p_vol, float) * np.ones(len(s.x)))
    rows = []
    with EngineRun(get_engine(engine), s, RunStats(), settle=True) as run:
        for f, rec in enumerate(run.frames(round((SETTLE_T + STICK_T) * FPS))):
            if f % 3 == 0:
                rows.append({"scene": "tall", "frame": f, **patch_row(np.asarray(rec.x, float), h, ground)})
    return rows


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", nargs="+", default=["jittered", "spun", "tall"], choices=["jittered", "spun", "tall"])
    p.add_argument("--engine", default="warp_mpm")
    p.add_argument("--out", help="write the rows to this JSON file (refused if it exists)")
    a = p.parse_args(argv)
    if a.out and Path(a.out).exists():
        sys.exit(f"patch_plane86.py: {a.out} exists; give a new file")
    rows = []
    for which in a.scene:
        new = tall_rows(a.engine) if which == "tall" else ball_rows(a.engine, which)
        for r in new:
            print(json.dumps(r), flush=True)
        rows += new
    if a.out:
        Path(a.out).write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()
