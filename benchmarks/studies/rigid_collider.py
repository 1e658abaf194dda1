"""Round 63 (docs/rigid.md "Round 63: the rigid body as a moving collider of the soft field"): the rest scenes of
``tests/test_soft_on_rigid_rest.py`` (and its neighbours not tuned on: a jelly ball on the rigid slab, a rigid plate on
jelly) and the mixed slides of ``tests/test_block_on_block.py``, with the rule on or off.

    python benchmarks/studies/rigid_collider.py --engine warp_mpm --rule on --cases jelly_on_slab,block_on_jelly \
        --grids 32,48 --E 1e5,1e6 [--slides] [--set REACT=0 ...]

Prints per case the gap at 0.3 s and 1.0 s (mm), the drift from 0.3 to 1.0 s and the settle from the start to
0.3 s in dx; per slide its error against the closed form.
``--set NAME=VALUE`` sets a constant of the engine's ``rigid_collider`` module (a broken variant, an experiment).
"""
from __future__ import annotations

import argparse
import importlib
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))



def scene(case: str, n_grid: int, E: float):
    """A rest scene of ``tests/test_soft_on_rigid_rest.py`` (its three and its neighbours ``ball_on_slab``,
    ``plate_on_jelly``)."""
    from test_soft_on_rigid_rest import rest_setup
    return rest_setup(case, n_grid, E=E)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--rule", default="on")
    ap.add_argument("--cases", default="jelly_on_slab,block_on_jelly")
    ap.add_argument("--grids", default="32")
    ap.add_argument("--E", default="1e5")
    ap.add_argument("--slides", action="store_true")
    ap.add_argument("--set", nargs="*", default=[])
    ap.add_argument("--points", type=int, default=0, help="round 66: gasp_core.mpm.rigid_sdf.POINT_CONTACT")
    a = ap.parse_args()
    import gasp_core.mpm.rigid_sdf as SDF
    SDF.POINT_CONTACT = bool(a.points)
    import gasp_core.mpm.rigid_collider as RC
    RC.RIGID_COLLIDER = a.rule == "on"
    mod = importlib.import_module(f"gasp_{a.engine}.rigid_collider")
    for kv in a.set:
        k, v = kv.split("=")
        setattr(mod, k, type(getattr(mod, k))(float(v)))
    from test_soft_on_rigid_rest import gap_drift
    for case in [c for c in a.cases.split(",") if c]:
        for ng in map(int, a.grids.split(",")):
            for E in map(float, a.E.split(",")):
                t = time.time()
                s = scene(case, ng, E)
                g0, g1, d = gap_drift(a.engine, s)
                print(f"{a.engine} rule {a.rule} {' '.join(a.set)} | {case} n{ng} E {E:g} | gap {1e3 * g0:.2f} -> "
                      f"{1e3 * g1:.2f} mm | drift {d / s.dx:+.3f} dx | settle {(g0 - s.start_gap) / s.dx:+.3f} dx | "
                      f"{time.time() - t:.0f} s", flush=True)
    if a.slides:
        from test_block_on_block import MIXED_FAMILY, check, closed_form, measure, mixed_setup
        for upper, ng, mu in MIXED_FAMILY:
            s = mixed_setup(upper, friction=mu, n_grid=ng)
            d, v2 = measure(a.engine, s)
            d0, vf = closed_form(s)
            print(f"{a.engine} rule {a.rule} {' '.join(a.set)} | slide {upper} on top n{ng} mu {mu} | "
                  f"{100 * (d / d0 - 1):+.2f} % | lower {100 * (v2 / vf - 1):+.2f} % | {check(s, (d, v2)) or 'pass'}",
                  flush=True)


if __name__ == "__main__":
    main()
