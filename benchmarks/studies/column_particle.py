"""Round 59 (docs/contact.md "Round 59: ..."): why the sand column runs out short on the particle contact.

Issue 67 item 5. After round 58's walls' floor fix the conformance column (``lube_family.column_setup``, a = 2) on
``contact = "particle"`` with the ground's whole friction runs out -54.9 % (n_grid 32) / -43.3 % (48) against Lube et
al. 2005, the grid contact -33 / -20 %, while the particle contact slides a sand block at Coulomb's ratio to four
digits. This study switches one thing at a time on the particle contact's column and reads it as
``column_step.measures`` does (``run`` the deposit's front, ``p99`` the 99th percentile of the distance from the
wall, ``cen`` the bulk's travel, ``H`` the height; %, against Lube's fit).

Variants are ``+``-joined switches on top of ``particle`` (``contact = "particle"``, the channel's walls kept):

- ``grid``: the grid contact (the scene as it is; no other switch applies);
- ``nobal``: ``contact_balance = false`` (no contact balance at all);
- ``notorque``: the balance without its torque take-back (``contact_reach`` 0: the force's fix alone; with
  ``oldbal``, on the sand);
- ``mu0``: the ground's friction 0;
- ``skin<f>``, ``kappa<f>``, ``damp<f>``: the contact's ``SKIN``, ``KAPPA``, ``DAMPING`` times ``f``;
- ``nowalls``: the channel's walls removed (the spread read both ways from the axis; a 3-D slump then);
- ``oldbal``: the rule before round 59, the contact's balance on the flowing sand too
  (``gasp_core.mpm.contact.BALANCE_FLOWING`` True); ``particle`` is round 59's rule (the balance leaves a flowing body
  alone), which equals ``nobal`` on this one-body scene.

    python benchmarks/studies/column_particle.py --engine warp_mpm --grids 32 --substeps 34 \
        --variants grid particle oldbal oldbal+notorque nobal particle+mu0

One JSON row a run (n_grid 32, 34 substeps: 2-5 s a run on warp_mpm after its kernel builds).
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
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import column_step as cs   # noqa: E402
import lube_family as lf   # noqa: E402
import gasp_core.mpm.contact as gc   # noqa: E402
from gasp_core.seam import build_engine   # noqa: E402
from gasp_core.testing.kit import resolve_engine   # noqa: E402


class patched:
    """Module attributes set on entry, restored on exit."""

    def __init__(self, items):
        self.items, self.saved = items, []

    def __enter__(self):
        for obj, name, value in self.items:
            self.saved.append((obj, name, getattr(obj, name)))
            setattr(obj, name, value)
        return self

    def __exit__(self, *exc):
        for obj, name, value in reversed(self.saved):
            setattr(obj, name, value)
        return False


def setup_and_patches(info, a, n_grid, n_sub, variant):
    """The column with ``variant``'s switches: (setup, list of (module, name, value) to patch while it is built)."""
    sw = variant.split("+")
    if sw == ["grid"]:
        return cs.setup_of(info, a, n_grid, n_sub, "default"), []
    s = cs.setup_of(info, a, n_grid, n_sub, "particle")
    opts, pat = dict(s.options), []
    for w in sw:
        if w == "particle":
            continue
        if w == "oldbal":
            pat.append((gc, "BALANCE_FLOWING", True))
        elif w == "nobal":
            opts["contact_balance"] = False
        elif w == "notorque":
            import gasp_taichi_mpm.engine as te
            zero = lambda setup: np.zeros(len(setup.materials))   # noqa: E731
            pat += [(gc, "contact_reach", zero), (te, "contact_reach", zero)]
        elif w == "mu0":
            s.boundaries = [dataclasses.replace(b, friction=0.0) if b.kind == "ground" else b for b in s.boundaries]
        elif w == "nowalls":
            s.boundaries = [b for b in s.boundaries if b.kind != "walls"]
        elif w.startswith(("skin", "kappa", "damp")):
            name = {"skin": "SKIN", "kappa": "KAPPA", "damp": "DAMPING"}[w.rstrip("0123456789.")]
            f = float(w[len(w.rstrip("0123456789.")):])
            pat.append((gc, name, getattr(gc, name) * f))
        else:
            raise ValueError(f"unknown switch {w!r}")
    return s.replace(options=opts), pat


def run(engine, a, n_grid, n_sub, variant, frames):
    info = resolve_engine(engine)
    s, pat = setup_and_patches(info, a, n_grid, n_sub, variant)
    with patched(pat):
        e = build_engine(info, s)
        t0 = time.perf_counter()
        for _ in range(frames):
            e.step_frame()
        x = e.positions().astype(float)
    return dict(engine=engine, a=a, n_grid=n_grid, n_substeps=n_sub, variant=variant, frames=frames,
                **cs.measures(info, s, x, a), seconds=round(time.perf_counter() - t0, 1))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--grids", nargs="+", type=int, default=[32])
    ap.add_argument("--aspects", nargs="+", type=float, default=[2.0])
    ap.add_argument("--substeps", nargs="+", type=int, default=[34])
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--variants", nargs="+", default=["particle"])
    ap.add_argument("--json", help="append the rows to this JSON-lines file")
    args = ap.parse_args(argv)
    for var in args.variants:
        for a in args.aspects:
            for n in args.grids:
                for k in args.substeps:
                    row = run(args.engine, a, n, k, var, args.frames)
                    print(json.dumps(row), flush=True)
                    if args.json:
                        with open(args.json, "a") as f:
                            f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
