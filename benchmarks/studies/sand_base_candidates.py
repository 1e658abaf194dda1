"""Round 58 (docs/contact.md "Round 58: the sand's base slips at Coulomb's bound"): the sand's base on the ground
under three rules, on ``tests/test_sand_slump_step.py``'s family and ``sand_slide``'s reference.

- ``grid``: the grid contact as it is (sand's default under ``contact = "auto"``: the held node layers and round
  36's touched layer, each node stopped by ``mu |v_n| >= |v_t|`` on its own velocity);
- ``share``: candidate (b), the grid contact with ``GroundTouch.flow_share`` (both engines): a sand column is marked
  as a solid's, so its touched layer takes no normal stop and only its column's Coulomb bound (the held layers'
  stops, pooled per body: rounds 49-53's rule, ``touch_bound = "body"``);
- ``particle``: candidate (a), the engine option ``contact = "particle"`` (a penalty and Coulomb's friction per
  point; the check's scene as it is, its walls kept: at n_grid 16 the walls' floor plane, 0.1875 m, lies above the
  ground, 0.15 m, docs/contact.md "Round 55: the touched layer as a rate" (2)); ``particle_ground``: the same
  without the walls (on the ground).

Prints one JSON row per case: the slump's drop (cm) at ``N`` and ``2 N`` substeps (``N = 13 n_grid / 16``) and the
change (%, the check's 3 %); ``sand_slide``'s Coulomb ratio (asked tan 30 deg = 0.5774) and travel (mm) at 26 / 52 /
104 substeps.

Run from the repository root: ``python benchmarks/studies/sand_base_candidates.py [--engines ...] [--variants ...]
[--skip-slide]`` (about 2 minutes a variant and engine on a quiet CPU).
"""
import argparse
import json

import numpy as np

from gasp_core.seam import build_engine, get_engine
from gasp_core.testing.sand_slump import BASE_SUBSTEPS, FAMILY, GRIDS, N_FRAMES, block, drop_and_spread

VARIANTS = ("grid", "share", "particle", "particle_ground")


class flow_share:
    """A context: ``GroundTouch.flow_share`` of both engines set to ``on``, restored on exit."""

    def __init__(self, on: bool):
        import gasp_taichi_mpm.touch as tt
        import gasp_warp_mpm.touch as wt
        self.cls = (tt.GroundTouch, wt.GroundTouch)
        self.on = on

    def __enter__(self):
        self.saved = [c.flow_share for c in self.cls]
        for c in self.cls:
            c.flow_share = self.on
        return self

    def __exit__(self, *exc):
        for c, v in zip(self.cls, self.saved):
            c.flow_share = v
        return False


def options(variant: str) -> dict:
    """The engine options of ``variant``."""
    return {"contact": "particle"} if variant.startswith("particle") else {}


def slump(engine: str, variant: str, size, n: int, k: int) -> float:
    """The top's drop (m) after ``N_FRAMES`` frames."""
    s = block(size, n, k, **options(variant))
    if variant == "particle_ground":
        s.boundaries = [b for b in s.boundaries if b.kind != "walls"]
    with flow_share(variant == "share"):
        e = build_engine(get_engine(engine), s)
        for _ in range(N_FRAMES):
            e.step_frame()
    return drop_and_spread(np.asarray(s.x, float), e.positions().astype(float))[0]


def slide(engine: str, variant: str, k: int, v0: float = 0.6) -> tuple[float, float]:
    """``sand_slide``'s reference (``benchmarks/sand_slump_step.py --slide``): Coulomb's ratio over frames 1-3 and
    the travel (mm) after 4 frames."""
    from gasp_core.testing.sand_ball import coulomb_ratio, slide_setup, slide_travel
    s = slide_setup(v0, options={"n_substeps": k, **options(variant)}, ground=True)
    with flow_share(variant == "share"):
        e = build_engine(get_engine(engine), s)
        vs = [np.broadcast_to(np.asarray(s.v, float), s.x.shape)]
        for _ in range(4):
            e.step_frame()
            vs.append(e.velocities().astype(float))
    return coulomb_ratio(np.stack(vs), s, 1, 3), 1000 * slide_travel(np.asarray(s.x, float),
                                                                       e.positions().astype(float), s)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--engines", nargs="+", default=["taichi_mpm", "warp_mpm"])
    ap.add_argument("--variants", nargs="+", default=["grid", "share", "particle"], choices=VARIANTS)
    ap.add_argument("--skip-slide", action="store_true")
    a = ap.parse_args(argv)
    for var in a.variants:
        for eng in a.engines:
            for name, size in FAMILY.items():
                for n in GRIDS:
                    k = BASE_SUBSTEPS * n // 16
                    d1, d2 = slump(eng, var, size, n, k), slump(eng, var, size, n, 2 * k)
                    print(json.dumps(dict(check="slump", variant=var, engine=eng, block=name, n_grid=n, N=k,
                                          drop_cm=[round(100 * d1, 3), round(100 * d2, 3)],
                                          change_pct=round(100 * (d2 / d1 - 1), 2))), flush=True)
            if a.skip_slide or var == "particle_ground":
                continue
            out = [slide(eng, var, k) for k in (26, 52, 104)]
            print(json.dumps(dict(check="slide", variant=var, engine=eng, substeps=[26, 52, 104],
                                  coulomb_ratio=[round(r, 4) for r, _ in out],
                                  travel_mm=[round(t, 2) for _, t in out])), flush=True)


if __name__ == "__main__":
    main()
