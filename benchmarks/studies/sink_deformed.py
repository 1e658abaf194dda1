"""Round 61 (issue 67/66, ``docs/contact.md`` "Round 61: the stacked balls' sink"): the stacked balls' gap at rest
with the nearest pair's half-spacings taken deformed (``|F d| h / 2`` along the pair's direction ``d``, ``F`` the
points' deformation gradient) beside the undeformed measure (``scenes_pairs.surface_gap``), warp_mpm, ``CURVATURE``,
n_grid 24, R 5 and 7.5 cm, the pair's friction 0 and 0.5, dropped 1.5 dx and from touch; the mean of the last 0.5 s.

Usage: ``python benchmarks/studies/sink_deformed.py`` (8 rows, about 35 s).
"""
import dataclasses

import numpy as np
from scipy.spatial import cKDTree

import gasp_core.mpm.fields as F_, gasp_warp_mpm.fields as WF
import gasp_core.mpm.gap_touch as G
import gasp_core.testing.scenes_pairs as P
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.runner import run_engine
from gasp_core.testing.kit import RunStats
G.CURVATURE = True; G.SEPARATION = 0.0
for R in (0.05, 0.075):
    for mu in (0.0, 0.5):
        for drop in (1.5, 0.0):
            F_.field_friction = WF.field_friction = lambda s, mu=mu: mu
            P.STACK_R, P.N_GRID, P.DX, P.STACK_DROP = R, 24, P.SIDE / 24, drop
            s = dataclasses.replace(P._build_stack(None), options={"threads": 1})
            info = get_engine("warp_mpm"); H = {}
            ri = dataclasses.replace(info, factory=lambda st: H.setdefault("e", info.factory(st)))
            body = np.asarray(s.body_id); h = np.cbrt(np.asarray(s.p_vol, float)) * np.ones(len(body))
            und, dfm, strain = [], [], []
            for rec in run_engine(ri, s, 30, RunStats()):
                if rec.frame < 15:
                    continue
                x = rec.x; Fd = H["e"].F.numpy()
                a, b = np.where(body == 0)[0], np.where(body == 1)[0]
                dd, k = cKDTree(x[a]).query(x[b]); i = int(np.argmin(dd)); pb, pa = b[i], a[k[i]]
                d = (x[pb] - x[pa]) / dd[i]
                la, lb = np.linalg.norm(Fd[pa] @ d), np.linalg.norm(Fd[pb] @ d)
                und.append((dd[i] - 0.5 * (h[pa] + h[pb])) / P.DX)
                dfm.append((dd[i] - 0.5 * (h[pa] * la + h[pb] * lb)) / P.DX)
                strain.append(1 - 0.5 * (la + lb))
            print(f"R {R} mu {mu} drop {drop}: undeformed {np.mean(und):+.3f} dx, deformed {np.mean(dfm):+.3f} dx, "
                  f"the pair's strain along d {np.mean(strain):.3f}", flush=True)
