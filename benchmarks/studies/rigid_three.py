"""Issue 67 item 4, round 62: rigid bodies among three or more (``gasp_core.mpm.rigid_pairs``, ``docs/rigid.md``
"Round 62: rigid bodies among three or more").

Cases (``gasp_core.testing.scenes_rigid3``): ``rest`` three rigid plates stacked on a ground (sink, creep, gaps,
turn), ``slide`` the top block of three thrown along the middle one on a frictionless ground (slide against
``v^2 / (2 mu g (1 + m0 / (m1 + m2)))``, momentum), ``fall`` three blocks moving apart in the air (v_z against
``v0 - g t``), ``mixed`` a rigid block thrown on a jelly slab with a jelly cube on it (slide, momentum).

Switches (each an engine broken on purpose, for the tests' catches): ``--sweeps N`` (``rigid_pairs.SWEEPS``; 1: the
pairs solved once, no sweeps), ``--before`` (one field for the three: ``colouring.RIGID_PAIRS`` False, the rule before),
``--mu-ignored`` (every pair at 0.5 whatever the bodies say). ``--push``: the slide's top block at rest, pushed by an
``[[impulse]]`` of 1 m/s on its upper nodes (``scenes_rigid3.slide_setup``'s ``push``); ``--models``: the slide's
bodies' models, top first (``rigid,elastic,rigid``: a jelly block between two rigid ones).

    python benchmarks/studies/rigid_three.py --case slide --engine warp_mpm --n-grid 32 [--mu 0.3] [--sweeps 1]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from gasp_core.mpm import colouring, rigid_pairs
from gasp_core.testing import scenes_rigid3 as S


def run(case: str, engine: str, n_grid: int, mu: float | None, half: float, size: float, push: bool = False,
        models=("rigid",) * 3) -> dict:
    """The case's figures (``scenes_rigid3.measure_*``) and its wall time (s)."""
    t0 = time.time()
    if case == "rest":
        out = S.measure_rest(engine, S.stack_setup(n_grid, size, mu))
    elif case == "slide":
        out = S.measure_slide(engine, S.slide_setup(n_grid, mu, half=half, push=push, v0=1.0 if push else 0.5,
                                                    models=models))
    elif case == "mixed":
        out = S.measure_slide(engine, S.mixed_setup(n_grid, mu))
    else:
        out = S.measure_fall(engine, S.fall_setup(n_grid))
    out["seconds"] = time.time() - t0
    return out


def show(case: str, out: dict) -> str:
    """One line of the figures."""
    if case == "rest":
        return (f"sink {np.round(out['sink'] * 1e3, 3).tolist()} mm, creep {np.round(out['creep'] * 1e3, 3).tolist()}"
                f" mm, gap change {np.round(out['gap'] * 1e3, 3).tolist()} mm, turn {np.round(out['turn'], 3).tolist()}"
                f" deg, {out['seconds']:.0f} s")
    if case in ("slide", "mixed"):
        err = 100 * (out["slide"] / out["closed"] - 1)
        return (f"slide {out['slide'] * 1e3:.2f} mm against {out['closed'] * 1e3:.2f} ({err:+.2f} %), momentum "
                f"{100 * out['momentum']:+.3f} %, v {np.round(out['v'], 5).tolist()} m/s, turn "
                f"{np.round(out['turn'], 3).tolist()} deg, {out['seconds']:.0f} s")
    err = 100 * (out["vz"] / out["expect"] - 1)
    return (f"vz {np.round(out['vz'], 4).tolist()} against {np.round(out['expect'], 4).tolist()} "
            f"({np.round(err, 3).tolist()} %), {out['seconds']:.0f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", choices=("rest", "slide", "fall", "mixed"), default="slide")
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n-grid", type=int, default=32)
    ap.add_argument("--mu", type=float, default=None, help="each body's friction (default: the default, 0.5)")
    ap.add_argument("--half", type=float, default=0.03, help="the top block's half-width (slide), m")
    ap.add_argument("--size", type=float, default=0.10, help="the bottom plate's width (rest), m")
    ap.add_argument("--sweeps", type=int, default=None)
    ap.add_argument("--push", action="store_true", help="slide: the top block pushed by an [[impulse]] of 1 m/s")
    ap.add_argument("--models", default="rigid,rigid,rigid", help="slide: the three bodies' models, top first")
    ap.add_argument("--before", action="store_true", help="one field for the three (colouring.RIGID_PAIRS False)")
    ap.add_argument("--mu-ignored", action="store_true", help="every pair at 0.5")
    a = ap.parse_args()
    if a.sweeps is not None:
        rigid_pairs.SWEEPS = a.sweeps
    if a.before:
        colouring.RIGID_PAIRS = False
    if a.mu_ignored:
        rigid_pairs.pair_frictions = lambda setup: np.full(len(setup.materials) ** 2, 0.5)
    out = run(a.case, a.engine, a.n_grid, a.mu, a.half, a.size, a.push, tuple(a.models.split(",")))
    print(f"{a.case} {a.engine} n_grid {a.n_grid} mu {a.mu} sweeps {rigid_pairs.SWEEPS}"
          f"{'' if a.models == 'rigid,rigid,rigid' else ' ' + a.models}{' before' if a.before else ''}"
          f"{' mu-ignored' if a.mu_ignored else ''}{' push' if a.push else ''}: "
          f"{show(a.case, out)}" + (f", v0 {out['v0']:.4f} m/s" if a.push else ""))


if __name__ == "__main__":
    main()
