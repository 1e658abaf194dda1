"""Round 61 (issue 67/66, ``docs/contact.md`` "Round 61: the stacked balls' sink"): a one-off trace of why the pair's
friction lets the stacked jelly balls rest inside each other. NOT runnable on a clean tree: it needs the exploration
patch beside it (``git apply benchmarks/studies/sink_trace.patch``; revert with ``git apply -R``), which adds to
warp_mpm's ``field_contact`` counters in ``pair_acc[7:21]`` (approaching touch nodes, stick count, mass-weighted
``u . n``, ``|u_t|``, ``|n_z|``, ``u_z``, the vertical and horizontal parts of the removed ``q``), a run-time scale of
the pair's friction in ``pair_acc[31]`` and, with ``SINK_SYM=1``, the normal ``grad m_B - grad m_A``.

Usage: ``python benchmarks/studies/sink_trace.py R n_grid mu rule frame scale [frame2 scale2]`` (warp_mpm, the
``stacked_gap`` scene at radius R m and ``n_grid``, the pair's Coulomb coefficient ``mu``; ``rule`` ``curve``
(``gap_touch.CURVATURE``), ``sep0.5`` (round 60's default) or ``sep0``): the friction is multiplied by ``scale`` from
``frame`` on (99: never); prints the gap (dx, ``surface_gap``) every ``EVERY`` (3) frames, the counters over frames
15-30 and a ``TABLE`` line: the mean gap over the last half of ``FRAMES`` (30, the scene's 1 s). ``DROP``: the top
ball's start above the touch, dx (the scene's 1.5; 0: the lattices' surfaces touching at the start, no landing).
"""
import dataclasses
import os
import sys

import numpy as np

import gasp_core.mpm.gap_touch as G
import gasp_core.testing.scenes_pairs as P
import gasp_core.mpm.fields as F, gasp_warp_mpm.fields as WF
from gasp_core.seam.plugins import get_engine
from gasp_core.seam.runner import run_engine
from gasp_core.testing.kit import RunStats
R, ng, mu = float(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
G.CURVATURE = sys.argv[4] == "curve"; G.SEPARATION = 0.5 if sys.argv[4] == "sep0.5" else 0.0
F.field_friction = WF.field_friction = lambda s: mu
P.STACK_R, P.N_GRID, P.DX = R, ng, P.SIDE / ng
P.STACK_DROP = float(os.environ.get("DROP", P.STACK_DROP))
s = dataclasses.replace(P._build_stack(None), options={"threads": 1})
info = get_engine("warp_mpm"); H = {}
rec_info = dataclasses.replace(info, factory=lambda st: H.setdefault("e", info.factory(st)))

prev = None; body = np.asarray(s.body_id); late = []
for rec in run_engine(rec_info, s, int(os.environ.get("FRAMES", "30")), RunStats()):
    if H["e"].pair_acc.shape[0] < 32:
        sys.exit("apply benchmarks/studies/sink_trace.patch first (git apply)")
    if len(sys.argv) > 7 and rec.frame == int(sys.argv[7]):
        a = H["e"].pair_acc.numpy(); a[31] = float(sys.argv[8]); H["e"].pair_acc.assign(a)
    if rec.frame == int(sys.argv[5]):
        a = H["e"].pair_acc.numpy(); a[31] = float(sys.argv[6]); H["e"].pair_acc.assign(a)
    if rec.frame > int(os.environ.get("FRAMES", "30")) // 2:
        late.append(P.surface_gap(rec.x, body, s.p_vol) / P.DX)
    if rec.frame % int(os.environ.get("EVERY", "3")) == 0:
        print(rec.frame, f"{P.surface_gap(rec.x, body, s.p_vol) / P.DX:+.3f}", end=" | ", flush=True)
    if rec.frame in (15, 30):
        a = H["e"].pair_acc.numpy().copy()
        if prev is not None:
            d = a - prev; w = d[9]; ws = max(d[17], 1e-30)
            print(f"R{R} ng{ng} mu{mu} frames15-30: approach-touch nodes {d[7]:.0f} stick {d[8]:.0f} ({d[8]/max(d[7],1):.2f}) "
                  f"| wmean un {d[10]/w:+.2e} |ut| {d[11]/w:+.2e} |nz| {d[12]/w:.3f} u_z {d[13]/w:+.2e} "
                  f"| sum wr q_z {d[14]:+.3e} sum wr |q_h| {d[15]:.3e} | stick |nz| {d[16]/ws:.3f} stick wr q_z {d[18]:+.3e} "
                  f"| touch-separating nodes {d[19]:.0f} sum wr u_z {d[20]:+.3e}")
            print(f"  vf sum/cell mean {d[21]/d[7]:.3f}, >1: {d[22]:.0f}, max-field vf/cell mean {d[23]/d[7]:.3f}")
            gap = P.surface_gap(rec.x, body, s.p_vol) / P.DX
            print(f"  gap now {gap:+.3f} dx")
        prev = a
print(f"TABLE R {R} ng {ng} mu {mu} rule {sys.argv[4]} drop {P.STACK_DROP}: mean gap over the last half {np.mean(late):+.3f} dx (range {min(late):+.3f} to {max(late):+.3f})")
