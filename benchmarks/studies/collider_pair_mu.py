"""Round 65 (issue 67 item 4, ``docs/rigid.md`` "Round 65: the pair's friction in the collider"): the rigid collider's
Coulomb cap per contact pair (rigid body, soft body) instead of one a rigid body.

``--case far``: a rigid block thrown at 0.5 m/s on jelly slab A (``scenes_pair_mu.far_setup``), alone and with a far
jelly B of each ``--far`` friction: the slide against Coulomb's ``v0^2 / (2 mu g (1 + m0 / m_A))``, ``mu`` the
block's pair with A. ``--case bridge``: a block thrown at 1 m/s across slabs B1 / A / B2 (``bridge_setup``): its
deceleration against ``g (mu_A + mu_B) / 2``. ``--set MODULE.NAME=VALUE`` sets a switch first (``PAIR_MU=0``: main's
rule, one ``mu`` a rigid body, the smallest; ``PAIR_SWAP=1``: a broken variant, each pair another soft body's ``mu``).

    python benchmarks/studies/collider_pair_mu.py --case far --engine warp_mpm --n-grid 32 --far none 0.05 0.5 2.0
    python benchmarks/studies/collider_pair_mu.py --case bridge --engine warp_mpm --n-grid 32 --swap-mu
    python benchmarks/studies/collider_pair_mu.py --case loads --n-grid 32 48
"""
from __future__ import annotations

import argparse
import importlib
import time


def _set(items) -> None:
    for item in items or []:
        name, value = item.split("=")
        mod, attr = name.rsplit(".", 1) if "." in name else ("gasp_core.mpm.rigid_collider", name)
        m = importlib.import_module(mod)
        setattr(m, attr, type(getattr(m, attr))(float(value)) if not isinstance(getattr(m, attr), bool)
                else bool(float(value)))


def loads(n_grid: int, mus) -> None:
    """warp_mpm: the bridge's pairs' normal impulses, the last substep's of each frame (``rc_pacc[9 q + 5]``, pairs
    q = the soft bodies' columns of slot 0), averaged over frames 3-6 (0.05-0.1 s): each slab's share and the sum over
    ``M g dt`` (one substep a frame: the jelly's ringing shows in it)."""
    import numpy as np
    from gasp_core.mpm.fields import combine_friction
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.plugins import get_engine
    from gasp_core.testing import scenes_pair_mu as P
    s = P.bridge_setup(n_grid, *mus)
    e = build_engine(get_engine("warp_mpm"), s)
    pm, body = np.asarray(s.p_mass, float), np.asarray(s.body_id)
    N = []
    for f in range(6):
        e.step_frame()
        N.append(e.rc_pacc.numpy().reshape(-1, 9)[1:4, 5] if f >= 2 else None)
    N = np.mean(N[2:], 0)
    share = N / N.sum()
    mu = np.array([combine_friction(mus[0], m) for m in (mus[1], mus[2], mus[2])])
    print(f"warp_mpm n_grid {n_grid} bridge mu {mus}: N shares A/B1/B2 {np.round(share, 4)}, sum N / (M g dt) "
          f"{N.sum() / (pm[body == 0].sum() * 9.81 * float(e.dt)):.4f}, g sum mu_q share_q "
          f"{9.81 * mu @ share:.4f} m/s^2", flush=True)


def main() -> None:
    from gasp_core.testing import scenes_pair_mu as P
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", choices=("far", "bridge", "loads"), default="far")
    ap.add_argument("--engine", default="warp_mpm")
    ap.add_argument("--n-grid", type=int, nargs="+", default=[32])
    ap.add_argument("--far", nargs="+", default=["none", "0.05", "2.0"], help="far jelly B's friction, or none")
    ap.add_argument("--mu", type=float, nargs=3, default=None, help="block, A, B frictions")
    ap.add_argument("--swap-mu", action="store_true", help="bridge: also A and B's frictions swapped")
    ap.add_argument("--set", nargs="*", help="MODULE.NAME=VALUE switches")
    a = ap.parse_args()
    _set(a.set)
    for n in a.n_grid:
        if a.case == "far":
            mb, ma = (a.mu[0], a.mu[1]) if a.mu else (0.5, 0.5)
            for f in a.far:
                t = time.time()
                s = P.far_setup(n, mb, ma, None if f == "none" else float(f))
                r = P.measure_far(a.engine, s)
                print(f"{a.engine} n_grid {n} far {f:>5}: slide {r['slide'] * 1e3:8.3f} mm closed "
                      f"{r['closed'] * 1e3:7.3f} mm ({100 * (r['slide'] / r['closed'] - 1):+7.2f} %) "
                      f"far moved {r['far'] * 1e3:.3f} mm  slide repr {r['slide']!r}  [{time.time() - t:.0f} s]",
                      flush=True)
        elif a.case == "loads":
            for mus in ((1.0, 0.16, 0.64), (1.0, 0.64, 0.16), (1.0, 0.36, 0.36)):
                loads(n, mus)
        else:
            mus = [tuple(a.mu) if a.mu else (1.0, 0.16, 0.64)]
            if a.swap_mu:
                mus.append((mus[0][0], mus[0][2], mus[0][1]))
            for mb, ma, mbb in mus:
                t = time.time()
                r = P.measure_bridge(a.engine, P.bridge_setup(n, mb, ma, mbb))
                print(f"{a.engine} n_grid {n} bridge mu {mb}/{ma}/{mbb}: decel {r['decel']:.4f} m/s^2 expect "
                      f"{r['expect']:.4f} ({100 * (r['decel'] / r['expect'] - 1):+7.2f} %) yaw {r['turn']:.3f} deg "
                      f"v {' '.join(f'{x:.3f}' for x in r['v'])}  [{time.time() - t:.0f} s]", flush=True)


if __name__ == "__main__":
    main()
