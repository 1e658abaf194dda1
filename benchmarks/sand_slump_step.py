"""Round 55: the sand's slump against the step (docs/contact.md "Round 55: the sand's slump against the step").

A sand block (``gasp_core.testing.sand_slump.block``: ``Material("sand", E=2e4, nu=0.3, friction_angle=30)``, 2 x 2
x 2 points a cell) on the ground at z = 0.15 m (friction ``--mu``, 0.5), frictionless walls, released at rest under
gravity for ``--frames`` frames of 1/30 s (15: 0.5 s); the top's drop (its 95th percentile of z, cm) and the spread
(the growth of the ptp of x, cm) at several substep counts a frame, on both engines and several grids. ``--size 0.2
0.2 0.2`` (the default) is the block of ``plugins/taichi_mpm/tests/test_taichi_mpm.py::test_sand_and_liquid_spread``.

``--variant`` switches one thing (the probes of docs/contact.md "Round 55"):

- ``default``: the engines as they are (the grid contact, its touched layer, APIC);
- ``notouch``: the touched layer off (``GroundTouch.touch_contact = False`` on both engines);
- ``particle``: the engine option ``contact = "particle"`` (the penalty contact at the points);
- ``flip``: the engine option ``flip = 0.99`` (AFLIP);
- ``particle_ground``: the particle contact with the walls taken away (round 55 found the particle contact's sand at
  n_grid 16 resting on the walls' floor plane, above this scene's ground; without the walls it is on the ground);
- ``share``: warp_mpm only, a probe: the sand's touched columns take round 49's shared bound (the touched node no
  normal stop, its friction the held layers' unused Coulomb bound; ``touch_bound = "credit"``, no dashpot).

``--family`` runs the check of ``tests/test_sand_slump_step.py`` instead (``gasp_core.testing.sand_slump``: each
block of ``FAMILY`` on each of ``GRIDS`` at ``N`` and ``2 N`` substeps) and prints ``d(2N) / d(N) - 1``.

    python benchmarks/sand_slump_step.py --grids 16 32 --substeps 7 13 26 52 104 208 --json out.json
    python benchmarks/sand_slump_step.py --family --variants default particle --json family.json
    python benchmarks/sand_slump_step.py --slide --lube --engines warp_mpm --json more.json

``--ladder`` (round 57, docs/contact.md "Round 57: the slump's step ladder under the transfer rule") runs each block of
``FAMILY`` on each of ``--grids`` at ``N``, ``2 N``, ``4 N`` and ``8 N`` substeps (``--rungs``) (``N = 13 n_grid / 16``) and prints
each halving's change, to read whether the drop converges and at what order.

    python benchmarks/sand_slump_step.py --ladder --variants default particle_ground --json ladder.json

``--slide`` (``sand_slide``'s reference on the ground) and ``--lube`` (the conformance column, a = 2, n_grid 48) read
what the touched layer is there for, on the grid and the particle contact, at several substeps.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from gasp_core.seam import build_engine
from gasp_core.testing.sand_slump import BASE_SUBSTEPS, FAMILY, GRIDS, block, drop_and_spread

VARIANTS = ("default", "notouch", "particle", "particle_ground", "flip", "share")


def engine_info(name: str):
    """The registered engine ``name`` (``"taichi_mpm"`` or ``"warp_mpm"``)."""
    if name == "taichi_mpm":
        from gasp_taichi_mpm import gasp_engines
    else:
        from gasp_warp_mpm import gasp_engines
    return gasp_engines()[0]


class switched:
    """A context: the engines' class switches of ``variant`` set on entry, restored on exit."""

    def __init__(self, variant: str):
        self.variant = variant
        self.saved = []

    def _set(self, obj, name, value):
        self.saved.append((obj, name, getattr(obj, name)))
        setattr(obj, name, value)

    def __enter__(self):
        if self.variant == "notouch":
            import gasp_taichi_mpm.touch as tt
            import gasp_warp_mpm.touch as wt
            self._set(tt.GroundTouch, "touch_contact", False)
            self._set(wt.GroundTouch, "touch_contact", False)
        elif self.variant == "share":
            import gasp_warp_mpm.touch as wt
            self._set(wt, "FLOWING", ())   # the sand's columns marked as a solid's: round 49's share
            self._set(wt.GroundTouch, "touch_bound", "credit")   # no dashpot for sand: round 49's plain bound
        return self

    def __exit__(self, *exc):
        for obj, name, value in reversed(self.saved):
            setattr(obj, name, value)
        return False


def variant_options(variant: str) -> dict:
    """The engine options of ``variant``."""
    return {"particle": {"contact": "particle"}, "particle_ground": {"contact": "particle"},
            "flip": {"flip": 0.99}}.get(variant, {})


def slump(engine: str, n_grid: int, n_substeps: int, size=(0.2, 0.2, 0.2), mu=0.5, n_frames=15,
          variant="default", **options) -> tuple[float, float, float]:
    """``(drop, spread, seconds)``: the top's drop and the sideways growth (m) after ``n_frames`` frames, and the
    frames' wall time (s). Raises ``ValueError`` for the ``share`` probe on taichi_mpm (warp_mpm only)."""
    if variant == "share" and engine != "warp_mpm":
        raise ValueError("the share probe is warp_mpm's only")
    s = block(size, n_grid, n_substeps, mu, **variant_options(variant), **options)
    if variant == "particle_ground":
        s.boundaries = [b for b in s.boundaries if b.kind != "walls"]
    with switched(variant):
        e = build_engine(engine_info(engine), s)
        t0 = time.perf_counter()
        for _ in range(n_frames):
            e.step_frame()
        x = e.positions()
    drop, spread = drop_and_spread(np.asarray(s.x, np.float64), x.astype(np.float64))
    return drop, spread, time.perf_counter() - t0


def family_rows(engines, variants) -> list[dict]:
    """The check's family (``--family``): one row per variant, engine, block and grid with the drops at ``N`` and
    ``2 N`` substeps (cm) and their relative change (%)."""
    rows = []
    for var in variants:
        for eng in engines:
            if var == "share" and eng != "warp_mpm":
                continue
            for name, size in FAMILY.items():
                for n in GRIDS:
                    k = BASE_SUBSTEPS * n // 16
                    d1 = slump(eng, n, k, size, variant=var)[0]
                    d2 = slump(eng, n, 2 * k, size, variant=var)[0]
                    rows.append(dict(check="family", variant=var, engine=eng, block=name, size=list(size), n_grid=n,
                                     N=k, drop_N_cm=round(100 * d1, 3), drop_2N_cm=round(100 * d2, 3),
                                     change_pct=round(100 * (d2 / d1 - 1.0), 2)))
                    print(json.dumps(rows[-1]), flush=True)
    return rows


def ladder_rows(engines, variants, grids, rungs=4) -> list[dict]:
    """``--ladder``: each block of ``FAMILY`` on each grid at ``N 2^k`` substeps (``k < rungs``, ``N = 13 n_grid /
    16``), one row per variant, engine, block and grid: the drops (cm) and each halving's change (%)."""
    rows = []
    for var in variants:
        for eng in engines:
            for name, size in FAMILY.items():
                for n in grids:
                    k = BASE_SUBSTEPS * n // 16
                    d = [slump(eng, n, k * 2 ** i, size, variant=var)[0] for i in range(rungs)]
                    rows.append(dict(check="ladder", variant=var, engine=eng, block=name, n_grid=n,
                                     substeps=[k * 2 ** i for i in range(rungs)],
                                     drop_cm=[round(100 * x, 3) for x in d],
                                     change_pct=[round(100 * (b / a - 1.0), 2) for a, b in zip(d, d[1:])]))
                    print(json.dumps(rows[-1]), flush=True)
    return rows


def slide_rows(engines, substeps=(26, 52, 104), contacts=("auto", "particle"), v0=0.6) -> list[dict]:
    """``--slide``: ``sand_slide``'s reference (``gasp_core.testing.sand_ball.slide_setup(ground=True)``: a 6 x 6 x 3
    cm sand block thrown at ``v0`` m/s along the ground of friction tan 30 deg, n_grid 32), 4 frames: Coulomb's ratio
    over frames 1-3 (``coulomb_ratio``) and the travel (mm), per contact and substeps a frame."""
    from gasp_core.testing.sand_ball import coulomb_ratio, slide_setup, slide_travel
    rows = []
    for eng in engines:
        for contact in contacts:
            for k in substeps:
                s = slide_setup(v0, options={"n_substeps": k, "contact": contact}, ground=True)
                e = build_engine(engine_info(eng), s)
                vs = [np.broadcast_to(np.asarray(s.v, float), s.x.shape)]
                for _ in range(4):
                    e.step_frame()
                    vs.append(e.velocities().astype(float))
                travel = slide_travel(np.asarray(s.x, float), e.positions().astype(float), s)
                rows.append(dict(check="slide", engine=eng, contact=contact, n_substeps=k, v0=v0,
                                 coulomb_ratio=round(coulomb_ratio(np.stack(vs), s, 1, 3), 4),
                                 travel_mm=round(1000 * travel, 2)))
                print(json.dumps(rows[-1]), flush=True)
    return rows


def lube_rows(engines, substeps=(34, 68, 136), contacts=("auto", "particle"), a=2.0, n_grid=48) -> list[dict]:
    """``--lube``: the conformance column (``benchmarks/lube_family.py``'s ``column_setup``, a = 2, n_grid 48) per
    contact and substeps a frame (34 is about the default ``cfl``'s): runout and height against Lube et al. 2005."""
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import lube_family as lf
    from gasp_core.testing import scenes_granular as sg
    rows = []
    for eng in engines:
        info = engine_info(eng)
        for contact in contacts:
            for k in substeps:
                r, h = lf.column_end(info, a, n_grid, {"n_substeps": k, "contact": contact})
                rows.append(dict(check="lube", engine=eng, contact=contact, n_substeps=k, a=a, n_grid=n_grid,
                                 runout=round(r, 4), runout_err_pct=round(100 * (r / sg.lube_runout(a) - 1), 1),
                                 height=round(h, 4), height_err_pct=round(100 * (h / sg.lube_height(a) - 1), 1)))
                print(json.dumps(rows[-1]), flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["taichi_mpm", "warp_mpm"])
    ap.add_argument("--grids", nargs="+", type=int, default=[16, 32])
    ap.add_argument("--substeps", nargs="+", type=int, default=[7, 13, 26, 52])
    ap.add_argument("--size", nargs=3, type=float, default=[0.2, 0.2, 0.2])
    ap.add_argument("--mu", type=float, default=0.5)
    ap.add_argument("--frames", type=int, default=15)
    ap.add_argument("--variants", nargs="+", default=["default"], choices=VARIANTS)
    ap.add_argument("--json", help="append the rows to this file (a JSON list)")
    ap.add_argument("--family", action="store_true", help="the check's family at N and 2N substeps")
    ap.add_argument("--ladder", action="store_true", help="the family at N, 2N, 4N, 8N substeps on --grids")
    ap.add_argument("--rungs", type=int, default=4, help="--ladder's substep counts: N 2^k, k < rungs")
    ap.add_argument("--slide", action="store_true", help="sand_slide's reference, grid and particle contact")
    ap.add_argument("--lube", action="store_true", help="the conformance column a = 2, grid and particle contact")
    a = ap.parse_args(argv)
    other = a.family or a.slide or a.lube or a.ladder
    rows = family_rows(a.engines, a.variants) if a.family else []
    rows += ladder_rows(a.engines, a.variants, a.grids, a.rungs) if a.ladder else []
    rows += slide_rows(a.engines) if a.slide else []
    rows += lube_rows(a.engines) if a.lube else []
    for var in ([] if other else a.variants):
        for eng in a.engines:
            if var == "share" and eng != "warp_mpm":
                continue
            for n in a.grids:
                for k in a.substeps:
                    d, w, t = slump(eng, n, k, tuple(a.size), a.mu, a.frames, var)
                    rows.append(dict(variant=var, engine=eng, n_grid=n, n_substeps=k, size=a.size, mu=a.mu,
                                     drop_cm=round(100 * d, 3), spread_cm=round(100 * w, 3), seconds=round(t, 1)))
                    print(json.dumps(rows[-1]), flush=True)
    if a.json:
        try:
            with open(a.json) as f:
                old = json.load(f)
        except FileNotFoundError:
            old = []
        with open(a.json, "w") as f:
            json.dump(old + rows, f, indent=1)


if __name__ == "__main__":
    main()
