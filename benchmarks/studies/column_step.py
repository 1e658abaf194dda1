"""Round 58 (docs/contact.md "Round 58: the column's step dependence traced"): the conformance sand column's runout at
a short and a long step, with one thing switched at a time, to find the term that makes it spread less at shorter
steps (round 57's "The column's runout is the bulk's").

The column is ``benchmarks/lube_family.py``'s ``column_setup`` (the conformance ``sand_column_collapse``: sand E 3.5e5
Pa, nu 0.3, 32 deg, against the frictionless wall of a channel 6.25 cm wide (2 cells at n_grid 32, 3 at 48), on the ground of friction tan 32 deg),
run ``--frames`` frames of 0.02 s (30: the runout is set by frame 25 at n_grid 32 and 48, a = 2). Read three
ways: ``run`` the deposit's front (``column_deposit``, the conformance scene's; quantised at half a cell) and ``p99``
the 99th percentile of the distance from the wall, each as a runout in % against Lube et al. 2005's
(``scenes_granular.lube_runout``); ``cen`` the travel of the points' mean distance from the wall, in % of its start
``L_i / 2`` (the bulk's spread, continuous); and ``H`` the deposit's height against Lube's, %.

Variants (``--variants``; one switch each, the rest as the scene):

- ``default``: the scene as it is (the grid contact, its touched layer, ``transfer_damping`` "rate");
- ``mu0``: the ground's friction 0;
- ``notouch``: the touched layer off (``GroundTouch.touch_contact = False``, both engines);
- ``tdstep``: ``transfer_damping = "step"`` (APIC at every step: round 55's transfer);
- ``flip``: ``flip = 0.99`` (AFLIP at every step, so the blend does not change with the step);
- ``particle``: ``contact = "particle"`` (the walls kept); ``particle_ground``: the same without the walls;
- ``nowalls``: the grid contact without the walls;
- ``cflmax``: ``cfl_rule = "max"`` (only the rate's reference step changes: the substeps are set);
- ``stiff``: the sand's E times 4 (is the elastic stiffness, E 3.5e5 Pa, part of the limit the step approaches?);
- ``exprate``: a true rate for the transfer's damping: ``transfer_damping = "step"`` with ``flip = exp(-n_ref / n)``
  (``n_ref`` the rate rule's reference substeps), so the non-affine part kept over a time ``t`` is ``exp(-t /
  dt_ref)`` at every step, the reference step included (the rule ``1 - n_ref / n`` keeps none at ``n_ref``);
- ``pic``, ``pic_step``, ``pic_mu0`` (warp_mpm only): PIC, every point's P2G without its affine momentum (the
  ``p_pic`` mark of ``PIC_AT_B`` set for all; ``C`` still moves ``F``), under the rate rule, APIC's "step" and
  friction 0;
- ``share`` (warp_mpm only): the sand's touched columns on round 49's shared bound (``benchmarks/sand_slump_step.py``'s
  probe: the touched node no normal stop, its friction the held layers' unused Coulomb bound);
- ``tdstep_mu0``, ``exprate_notouch``, ``flip_notouch``, ``particle_mu0``: two switches together;
- ``particle_nofloor``: the particle contact with the walls, less the walls' floor face, which lies on the ground's
  plane in this scene (frictionless: it halves the ground's friction budget; ``no_floor``).

The held layers' friction alone (the touched layer's kept) was probed by a temporary edit of warp_mpm's
``grid.build_boundary_rules``, not kept: ``mu_g`` times 0 where ``Ft(k) <= gr[0]`` (docs/contact.md "Round 58").
The runs without walls read the spread both ways from the column's axis (``measures``).

    python benchmarks/studies/column_step.py --engines warp_mpm --grids 32 --substeps 34 136 --variants default mu0

Prints one JSON row per run (n_grid 32: 5 s a run at 34 substeps, 20 s at 136; n_grid 48: 20 and 70 s; plus about
45 s to build the kernels once per process).
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

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import lube_family as lf   # noqa: E402
from gasp_core.seam import build_engine   # noqa: E402
from gasp_core.testing import scenes_granular as sg   # noqa: E402
from gasp_core.testing.helpers import wall_margin   # noqa: E402
from gasp_core.testing.kit import resolve_engine   # noqa: E402

VARIANTS = ("default", "mu0", "notouch", "tdstep", "flip", "particle", "particle_ground", "nowalls", "cflmax",
            "stiff", "exprate", "exprate_notouch", "exprate_mu0", "tdstep_mu0", "flip_notouch",
            "particle_nofloor", "particle_mu0", "pic", "pic_step", "pic_mu0", "share")


def no_floor(planes):
    """``contact_planes`` less the walls' floor face where a ground's plane lies at or above it (its row moved a
    kilometre down, so no point reaches it): the grid contact's ``wall_floor`` rule, for the particle contact."""
    def wrapped(setup, contact=None):
        normals, rows = planes(setup, contact)
        rows = rows.copy()
        grounds = [float(b.height) for b in setup.boundaries if b.kind == "ground"]
        for q in range(len(rows)):
            if normals[q][2] == 1.0 and rows[q][2] != 0.0 and grounds and max(grounds) >= rows[q][0]:
                rows[q][0] = -1e3
        return normals, rows
    return wrapped


class switched:
    """A context: the engines' class switches of ``variant`` set on entry, restored on exit."""

    def __init__(self, variant: str):
        self.variant = variant
        self.saved = []

    def _set(self, obj, name, value):
        self.saved.append((obj, name, getattr(obj, name)))
        setattr(obj, name, value)

    def __enter__(self):
        if self.variant in ("notouch", "exprate_notouch", "flip_notouch"):
            import gasp_taichi_mpm.touch as tt
            import gasp_warp_mpm.touch as wt
            self._set(tt.GroundTouch, "touch_contact", False)
            self._set(wt.GroundTouch, "touch_contact", False)
        elif self.variant == "share":
            import gasp_warp_mpm.touch as wt
            self._set(wt, "FLOWING", ())   # the sand's columns marked as a solid's: round 49's shared bound
            self._set(wt.GroundTouch, "touch_bound", "credit")   # no dashpot for sand: round 49's plain bound
        elif self.variant == "particle_nofloor":
            import gasp_taichi_mpm.engine as te
            import gasp_warp_mpm.engine as we
            self._set(te, "contact_planes", no_floor(te.contact_planes))
            self._set(we, "contact_planes", no_floor(we.contact_planes))
        return self

    def __exit__(self, *exc):
        for obj, name, value in reversed(self.saved):
            setattr(obj, name, value)
        return False


def n_ref_of(s, opts: dict) -> int:
    """The reference step's substeps a frame of ``transfer_damping = "rate"`` (``grid_engine.transfer_alpha``'s)."""
    from gasp_core.mpm.grid_engine import choose_dt
    from gasp_core.mpm.substeps import CFL
    return choose_dt(s, {**opts, "cfl": CFL, "dt": None, "n_substeps": None}, "")[0]


def setup_of(info, a: float, n_grid: int, n_substeps: int, variant: str):
    """The column of ``lube_family.column_setup`` with ``n_substeps`` substeps a frame and ``variant``'s change."""
    s = lf.column_setup(info, a, n_grid)
    opts = dict(s.options, n_substeps=n_substeps)
    opts.update({"tdstep": {"transfer_damping": "step"}, "tdstep_mu0": {"transfer_damping": "step"},
                 "pic_step": {"transfer_damping": "step"},
                 "flip": {"flip": 0.99}, "flip_notouch": {"flip": 0.99}, "particle": {"contact": "particle"},
                 "particle_nofloor": {"contact": "particle"}, "particle_mu0": {"contact": "particle"},
                 "particle_ground": {"contact": "particle"}, "cflmax": {"cfl_rule": "max"}}.get(variant, {}))
    s = s.replace(options=opts)
    if variant in ("particle_ground", "nowalls"):
        s.boundaries = [b for b in s.boundaries if b.kind != "walls"]
    if variant.startswith("exprate"):   # a true rate: exp(-dt / dt_ref) of the non-affine part kept a substep
        n_ref = n_ref_of(s, opts)
        s = s.replace(options=dict(opts, transfer_damping="step", flip=math.exp(-n_ref / n_substeps)))
    if variant in ("mu0", "exprate_mu0", "tdstep_mu0", "particle_mu0", "pic_mu0"):
        s.boundaries = [dataclasses.replace(b, friction=0.0) if b.kind == "ground" else b for b in s.boundaries]
    if variant == "stiff":
        s.materials = [dataclasses.replace(m, E=4 * m.E) for m in s.materials]
    return s


def measures(info, s, x: np.ndarray, a: float) -> dict:
    """The runout read three ways and the height, % against Lube et al. 2005 (module notes)."""
    L0, ref = sg.COLUMN_L, sg.lube_runout(a)
    xw = wall_margin(info, s.dx)
    if not any(b.kind == "walls" for b in s.boundaries):   # no wall: the spread either way from the column's axis
        xc = xw + L0 / 2
        L, H = sg.column_deposit(np.abs(x - [xc, 0, 0]) + [xw, 0, 0], xw, 3 * s.dx, s.dx / 2)
        L, p99 = 2 * L, 2 * np.percentile(np.abs(x[:, 0] - xc), 99)
        cen = 2 * np.mean(np.abs(x[:, 0] - xc)) / L0 - 0.5
    else:
        L, H = sg.column_deposit(x, xw, 3 * s.dx, s.dx / 2)
        p99 = np.percentile(x[:, 0] - xw, 99)
        cen = np.mean(x[:, 0] - xw) / L0 - 0.5
    return dict(run=round(100 * ((L - L0) / L0 / ref - 1), 1), p99=round(100 * ((p99 - L0) / L0 / ref - 1), 2),
                cen=round(100 * cen / 0.5, 2), H=round(100 * (H / L0 / sg.lube_height(a) - 1), 1))


def run(engine: str, a: float, n_grid: int, n_substeps: int, variant: str, frames: int) -> dict:
    """One run: the row of ``measures`` after ``frames`` frames, with the AFLIP blend the run took and its seconds."""
    info = resolve_engine(engine)
    s = setup_of(info, a, n_grid, n_substeps, variant)
    with switched(variant):
        e = build_engine(info, s)
        if variant.startswith("pic"):   # warp_mpm: every point's P2G without its affine momentum (p_pic's one entry)
            if engine != "warp_mpm" or e.p_pic.shape[0] != 1:
                raise ValueError("the pic probe is warp_mpm's, on a scene without field A's marks")
            e.p_pic.assign(np.ones(1, np.int32))
        t0 = time.perf_counter()
        for _ in range(frames):
            e.step_frame()
        x = e.positions().astype(float)
    from gasp_core.mpm.grid_engine import transfer_alpha
    alpha = transfer_alpha(s, dict(s.options), n_substeps)
    return dict(engine=engine, a=a, n_grid=n_grid, n_substeps=n_substeps, variant=variant, frames=frames,
                alpha=round(alpha, 3), **measures(info, s, x, a), seconds=round(time.perf_counter() - t0, 1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["warp_mpm"])
    ap.add_argument("--grids", nargs="+", type=int, default=[32])
    ap.add_argument("--aspects", nargs="+", type=float, default=[2.0])
    ap.add_argument("--substeps", nargs="+", type=int, default=[34, 136])
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--variants", nargs="+", default=["default"], choices=VARIANTS)
    ap.add_argument("--json", help="append the rows to this file (a JSON list)")
    args = ap.parse_args(argv)
    rows = []
    for eng in args.engines:
        for var in args.variants:
            for a in args.aspects:
                for n in args.grids:
                    for k in args.substeps:
                        rows.append(run(eng, a, n, k, var, args.frames))
                        print(json.dumps(rows[-1]), flush=True)
    if args.json:
        try:
            with open(args.json) as f:
                old = json.load(f)
        except FileNotFoundError:
            old = []
        with open(args.json, "w") as f:
            json.dump(old + rows, f, indent=1)


if __name__ == "__main__":
    main()
