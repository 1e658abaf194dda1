"""Rounds 46-48 (issue 67 item 3): the grid contact's hold near the stick limit, a block on a slope (``contact =
"grid"``; docs/contact.md "Round 46: the grid contact's hold near the limit", "Round 47: the touch test tied to the
point's extent").

    python benchmarks/grid_hold.py --engines warp_mpm,taichi_mpm --cases jelly:release:48:30:0.6,jelly:settled:48:30:0.6
    python benchmarks/grid_hold.py --ring --engines warp_mpm --grids 24,48

The block is ``gasp_core.testing.snow.slope_setup``'s (15 x 15 x 5 cm whatever ``n_grid``, a ground of friction
``mu``, gravity 9.81 m/s^2 tilted ``theta`` degrees), of jelly (E 1e5 Pa, nu 0.3, rho 1000, ``model = "elastic"``)
or the schema's default snow, on the grid contact. Each case ``material:variant:n_grid:theta:mu[:key=value...]``
(engine options: ``cfl=0.2``, ``contact=particle``) gives the
centroid's travel (mm) over 1 s from 0.1 s after the start of the measured part:

* ``release``: the tests' scene (the block put on the ground undeformed and let go; ``tests/test_elastic_slope.py``,
  ``tests/test_snow_contact.py``);
* ``settled``: the same block first held for ``SETTLE_S`` s on the ground's friction 5.0, then the ground's friction
  set to ``mu`` (the engine's ground table written between frames);
* ``slide`` (``tan theta / mu`` over 1): the released block's acceleration against Coulomb's, as the tests read it
  (``dslide``: the damped jelly's);
* ``damped``: ``release`` with the jelly given ``viscosity`` ``DAMPED_ETA`` Pa s (a damping ratio about 0.4 of the
  block's first compression mode, ``eta omega / (2 E)`` with ``omega = pi c_p / (2 h)``, 365 rad/s).

``--ring`` (warp_mpm: it steps single substeps): the block released on the ground's friction 5.0 (its base held) and
the ground's normal and tangential loads read from the block's momentum each substep over the first 0.12 s: the
normal load over ``M g cos theta`` (2 ms means: min, max) and the share of that time where the tangential load over
the normal exceeds ``tan theta / 0.96`` (the friction a 0.96 case has). Lines are printed and appended to
``benchmarks/results/grid_hold.md`` (``--out``); ``--section TITLE`` first appends a heading ``## TITLE``;
``--touch-damping D`` sets both engines' ``touch_damping`` (round 48's dashpot above the held layers; 0: off, the
rule before, docs/contact.md "Round 48: a dashpot above the held layers"); ``--touch-credit 0`` round 49's touched
layers (the dashpot's push gives no friction, docs/contact.md "Round 50"); ``--viscous-conserve 0`` the viscous step's
rule before round 49 (the CG's iterate ``m u``, without the uniform correction ``du = sum r / sum m``),
``--viscous-tol T`` its CG tolerance (``TOL``, 1e-2) on both engines (docs/contact.md "Round 49: the viscous step's
momentum, a uniform correction").
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def set_ground_mu(e, mu: float) -> None:
    """Write ground 0's friction into a built engine between frames (warp_mpm's ``ground`` table, taichi_mpm's
    ``ground_fric`` field)."""
    if hasattr(e, "ground") and hasattr(e.ground, "numpy"):
        g = e.ground.numpy()
        g[:, 1] = mu
        e.ground.assign(g)
    else:
        e.solver.ground_fric[0] = mu


def ring(engine: str, n: int, theta: float) -> str:
    """The ground's loads on the jelly block released on friction ``HOLD_MU`` (its base held), read from the block's
    mean velocity each substep over the first 0.12 s (warp_mpm only: it steps single substeps through its
    ``_substeps``): a markdown line with the normal load over ``M g cos theta`` (2 ms means, min and max) and the
    share of the time where the tangential load over the normal exceeds ``tan theta / 0.96``."""
    from gasp_core.seam import build_engine, get_engine
    from gasp_core.testing.grid_hold import HOLD_MU, block_material
    from gasp_core.testing.snow import slope_setup
    import numpy as np
    s = slope_setup(theta, HOLD_MU, n, block_material("jelly"), {"contact": "grid"})
    e = build_engine(get_engine(engine), s)
    t, g, dt = math.radians(theta), 9.81, e.dt
    v0, nn, tt = e.velocities().astype(np.float64).mean(0), [], []
    for _ in range(int(0.12 / dt)):
        ns, e.n_substeps = e.n_substeps, 1
        e._substeps()
        e.n_substeps = ns
        v = e.velocities().astype(np.float64).mean(0)
        a, v0 = (v - v0) / dt, v
        nn.append((a[2] + g * math.cos(t)) / (g * math.cos(t)))
        tt.append((g * math.sin(t) - a[0]) / (g * math.cos(t)))
    w = max(1, int(0.002 / dt))
    mean = lambda a: np.convolve(np.asarray(a), np.ones(w) / w, mode="valid")   # noqa: E731
    nm, tm = mean(nn), mean(tt)
    over = float(np.mean(tm / np.maximum(nm, 1e-9) > math.tan(t) / 0.96))
    return (f"| ring | {engine} | n{n} | {theta:g} deg | normal load / M g cos: {nm.min():.3f} .. {nm.max():.3f} | "
            f"tangential / normal over tan theta / 0.96: {100 * over:.0f} % of 0.12 s | dt {dt:.3g} s |")



def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--engines", default="warp_mpm,taichi_mpm")
    p.add_argument("--cases", default="jelly:release:48:30:0.6,jelly:settled:48:30:0.6,jelly:damped:48:30:0.6")
    p.add_argument("--ring", action="store_true")
    p.add_argument("--grids", default="24,48")
    p.add_argument("--thetas", default="30,45")
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/grid_hold.md"))
    p.add_argument("--section", default=None)
    p.add_argument("--touch-damping", type=float, default=None)
    p.add_argument("--touch-credit", type=int, default=None)
    p.add_argument("--viscous-conserve", type=int, default=None)
    p.add_argument("--viscous-tol", type=float, default=None)
    a = p.parse_args()
    if a.section:
        with open(a.out, "a") as fh:
            fh.write(f"\n## {a.section}\n\n")
    if a.touch_damping is not None:
        _set_damping(a.touch_damping)
    if a.touch_credit is not None:   # round 50: 0 is round 49's rule (the dashpot's push gives no friction)
        from gasp_taichi_mpm.grid import GridUpdate
        from gasp_warp_mpm.engine import WarpMPMEngine
        GridUpdate.touch_credit = WarpMPMEngine.touch_credit = bool(a.touch_credit)
        GridUpdate.touch_bound = WarpMPMEngine.touch_bound = "credit"   # round 51: touch_credit read only there
    _set_viscous(a.viscous_conserve, a.viscous_tol)
    for eng in a.engines.split(","):
        if a.ring:
            lines = (ring(eng, int(n), float(th)) for n in a.grids.split(",") for th in a.thetas.split(","))
        else:
            lines = (_case(eng, c) for c in a.cases.split(","))
        for line in lines:
            print(line, flush=True)
            with open(a.out, "a") as fh:
                fh.write(line + "\n")


def _set_damping(d: float) -> None:
    """Both engines' ``touch_damping`` set to ``d`` (round 48's dashpot; 0: off)."""
    from gasp_taichi_mpm.grid import GridUpdate
    from gasp_warp_mpm.engine import WarpMPMEngine
    GridUpdate.touch_damping = WarpMPMEngine.touch_damping = float(d)


def _set_viscous(conserve, tol) -> None:
    """Both engines' viscous step: ``conserve`` (None: as is) and the CG's ``TOL`` (None: as is; set before any
    kernel is built: taichi reads it when it compiles)."""
    import gasp_taichi_mpm.viscosity as tv
    import gasp_warp_mpm.schedule.gpu as wg
    import gasp_warp_mpm.schedule.ordered as wo
    import gasp_warp_mpm.viscosity as wv
    if conserve is not None:
        tv.ImplicitViscosity.conserve = wv.ImplicitViscosity.conserve = bool(conserve)
    if tol is not None:
        for mod in (tv, wv, wg, wo):
            mod.TOL = float(tol)


def _case(engine: str, case: str) -> str:
    from gasp_core.testing.grid_hold import hold_travel, slide_error
    mat, variant, n, th, mu, *opt = case.split(":")
    options = dict(o.split("=") for o in opt)
    options = {k: (v if k == "contact" else float(v)) for k, v in options.items()}
    t0 = time.time()
    ratio = math.tan(math.radians(float(th))) / float(mu)
    if variant in ("slide", "dslide"):
        err = slide_error(engine, mat, int(n), float(th), float(mu), damped=variant == "dslide")
        return (f"| slide | {engine} | {mat} | {'damped' if variant == 'dslide' else 'release'} | n{n} | {th} deg, mu {mu} (tan/mu {ratio:.3f}) | "
                f"a {100 * err:+.2f} % off Coulomb | {time.time() - t0:.0f} s |")
    f = hold_travel(engine, mat, variant, int(n), float(th), float(mu), options=options, set_mu=set_ground_mu)
    return (f"| hold | {engine} | {mat} | {variant} {options or ''} | n{n} | {th} deg, mu {mu} "
            f"(tan/mu {ratio:.3f}) | travel {f:.4f} mm in 1 s | {'holds' if f < 1.0 else 'CREEPS'} | {time.time() - t0:.0f} s |")


if __name__ == "__main__":
    main()
