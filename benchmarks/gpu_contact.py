"""Issue 67's sliding contact on a lent GPU, in one device call: the Coulomb ratios of rounds 38-41 on taichi_mpm's
CUDA path (the GPU schedule: atomic P2G, tree sums; f32, the default, on both devices), against the same cases on
the same machine's CPU.

The figure is round 38's (``gasp_core.testing.sand_ball.coulomb_ratio``): the sand block's horizontal momentum lost
over the normal impulse its support gave it, from the throw to frame 3, over the pair's ``mu``, less 1; each case's
tolerance is the tests' ``RATIO_TOL`` (2.5 %), either side. The cases are those of the tests that hold each rule:

- ``slab45``: the 4.5 cm jelly slab at n_grid 32 (``sand_slide_coulomb``, round 38; the two-field contact);
- ``thin2_stiff``: the slab 2 cells thick at E 2e6 Pa (``tests/test_thin_support.py``; ``GROUND_MIRROR`` and
  ``B_FRICTION``, round 41);
- ``rigid_face``: a rigid slab, its face 3/4 of a cell above a node layer, at 0.7 m/s (``tests/test_sand_on_rigid.py``;
  ``PIC_AT_B``, round 41);
- ``ground64``: the block on the ground at n_grid 64 (``tests/test_ground_slide_coulomb.py``; round 36's touched
  layer);
- ``key_mu1``: the slab's scene ``friction`` 1.0, the pair ``sqrt(tan phi 1.0)`` (``tests/test_body_friction_key.py``);
- ``thin1``: the jelly slab 1 cell thick (``tests/test_thin_support.py``; ``TOP_FREE`` and ``B_OWN_FRICTION``, round
  42);
- ``two_slabs``: two slabs side by side in field B, friction 0.3 and 1.0, a block on each, each read against its own
  pair (``tests/test_field_b_frictions.py``; the per-node friction, round 42).

Each case also gives its wall time (the first case's includes the kernels' compile). Writes
``gpu_contact_<device>.json`` (``gpu_contact_warp_mpm_<device>.json`` with ``--engine warp_mpm``) to ``--out``.
Usage on the device (``../shared/device``), both devices in one call::

    bash .device/setup.sh && export PYTHONPATH=/tmp/site && python3 benchmarks/gpu_contact.py --device cuda \
        --out $OUT && python3 benchmarks/gpu_contact.py --device cpu --out $OUT
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPEEDS = (1.2, 1.6)
FRAMES = 3
TOL = 0.025


def _setup(case: str, v0: float, options: dict):
    """``(setup, [(body, mu), ...])`` of ``case`` (module notes) at throw speed ``v0`` (m/s): the blocks to read and
    each one's pair friction."""
    from gasp_core.mpm import fields as F
    from gasp_core.testing import sand_ball as S
    S.N_GRID = 64 if case == "ground64" else 32
    if case == "ground64":
        setup = S.slide_setup(v0, options, ground=True)
        return setup, [(0, float(setup.boundaries[0].friction))]
    if case == "two_slabs":
        setup = S.two_slab_setup(v0, (0.3, 1.0), options)
        pair = F.pair_frictions(setup)
        return setup, [(0, float(pair[1])), (2, float(pair[3]))]
    if case in ("thin2_stiff", "thin1"):
        cells = 2 if case == "thin2_stiff" else 1
        S.SLAB = dataclasses.replace(S.SLAB, E=2e6) if case == "thin2_stiff" else S.SLAB
        setup = S.slide_setup(v0, options, slab_h=cells * S.SIDE / S.N_GRID)
    elif case == "rigid_face":
        setup = S.slide_setup(v0, options, slab_h=S.COULOMB_SLAB_H)
        setup.materials = [setup.materials[0], dataclasses.replace(setup.materials[1], model="rigid")]
    elif case == "key_mu1":
        setup = S.slide_setup(v0, options, slab_h=S.COULOMB_SLAB_H)
        setup.materials = [setup.materials[0], dataclasses.replace(setup.materials[1], friction=1.0)]
    else:
        setup = S.slide_setup(v0, options, slab_h=S.COULOMB_SLAB_H)
    return setup, [(0, F.field_friction(setup))]


CASES = {"slab45": SPEEDS, "thin2_stiff": SPEEDS, "rigid_face": (0.7,), "ground64": SPEEDS, "key_mu1": (1.2,),
         "thin1": SPEEDS, "two_slabs": SPEEDS}


def run_case(case: str, device: str, engine: str = "taichi_mpm") -> dict:
    """Coulomb's ratio over ``mu`` less 1 at each speed of ``case`` on ``engine`` and ``device``, the check, the wall
    time."""
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import sand_ball as S
    from gasp_core.testing.kit import run_trace
    slab0 = S.SLAB
    info = get_engine(engine)
    out = {}
    t0 = time.perf_counter()
    try:
        for v0 in CASES[case]:
            setup, reads = _setup(case, v0, {"device": device})
            tr = run_trace(info, setup, FRAMES)
            for body, mu in reads:
                err = S.coulomb_ratio(tr.v, setup, 0, FRAMES, body=body) / mu - 1.0
                key = str(v0) if len(reads) == 1 else f"{v0}_body{body}"
                out[key] = {"ratio_error": float(err), "mu": float(mu), "n_points": int(len(setup.x))}
    finally:
        S.SLAB = slab0
    errs = [r["ratio_error"] for r in out.values()]
    return {"speeds": out, "passes": all(math.isfinite(e) and abs(e) <= TOL for e in errs),
            "wall_s": round(time.perf_counter() - t0, 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cuda", choices=("cuda", "cpu"))
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    ap.add_argument("--engine", default="taichi_mpm", choices=("taichi_mpm", "warp_mpm"))
    ap.add_argument("--only", default=None, help="comma-separated cases (default all)")
    args = ap.parse_args(argv)
    names = args.only.split(",") if args.only else list(CASES)
    doc = {"engine": args.engine, "device": args.device, "tol": TOL, "cases": {}}
    args.out.mkdir(parents=True, exist_ok=True)
    tag = "" if args.engine == "taichi_mpm" else f"{args.engine}_"
    path = args.out / f"gpu_contact_{tag}{args.device}.json"
    for name in names:
        try:
            doc["cases"][name] = run_case(name, args.device, args.engine)
        except Exception as exc:   # one case's failure leaves the others' figures
            doc["cases"][name] = {"error": f"{type(exc).__name__}: {exc}"}
        print(name, json.dumps(doc["cases"][name]), flush=True)
        path.write_text(json.dumps(doc, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
