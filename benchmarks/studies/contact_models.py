"""Candidate ground contacts for the MPM engines (issue 28), compared in a NumPy MLS-MPM (docs/mpm.md).

The solver is the one of ``benchmarks/studies/ground_spin_reference.py`` (quadratic B-splines, APIC, fixed
corotated jelly), trimmed to what the comparison needs; the contact models (``--model``):

- ``grid``: the old rule, the ground's node layers projected (taichi_elements' "separate" collider).
- ``penalty``: the issue's lead: no ground node within reach of the body (ground nodes are those at
  least two cells below the plane); each point below ``delta = V^(1/3)/2`` above the plane gets
  ``f_n = 16 E V^(1/3) (delta - z)`` scattered in P2G, with a per-point Coulomb friction impulse
  ``min(mu f_n dt, m |v_t|)`` against its tangential velocity.
- ``particle``: no ground node within reach; after G2P, each point whose next position would cross
  the plane (``z + dt v_n < 0``) has its normal velocity raised to ``v_n = max(v_n, -max(z, 0) / dt)``
  (it lands on the plane, never crosses it; a point already below only stops) and its tangential
  velocity reduced by ``mu`` times the normal velocity removed (Coulomb, as the grid rule does).
  ``C`` and ``F`` are left to the grid.
- ``particle_skin``: as ``particle`` but only points with ``z <= 0`` are stopped (``v_n < 0 -> 0``),
  no look-ahead.

Scenes (ball R = 5 cm, E 2e4 Pa, nu 0.3, rho 300, dropped 5 cm, n_grid 16 over 0.3 m, points at dx/2):
``spin`` (mu 0, symmetric ball, 0.02 rad/s seed about y: angular momentum ratio per bounce),
``roll`` (mu 0.5, the ball 0.3 / 0.2 dx off a node column, lattice and jittered: centroid drift
at 40 frames), ``bounce`` (mu 0: restitution from the centroid's vertical velocity, contact duration
against Hertz), ``rest`` (mu 0.5, 60 frames: lowest 1 % of points above the plane, in dx).

Run: ``python benchmarks/studies/contact_models.py [--models grid penalty particle] [--quick]``; the table
goes to stdout and to ``benchmarks/results/contact_models.md``.
"""
from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np

from gasp_core.seam.setup import Material
from gasp_core.testing.helpers import sphere_points
from gasp_core.mpm.points import ground_top_node
from gasp_core.mpm.substeps import mpm_stable_dt, substeps_for

SIDE, R, DROP, E, NU, RHO = 0.3, 0.05, 0.05, 2e4, 0.3, 300.0
G = np.array([0.0, 0.0, -9.81])
OFFS = np.array([(i, j, k) for i in range(3) for j in range(3) for k in range(3)])


def ball(ng, off, jitter, seed=0, drop=DROP):
    dx = SIDE / ng
    lo = np.array([-SIDE / 2, -SIDE / 2, -3 * dx])
    c = np.array([lo[0] + round(-lo[0] / dx) * dx + off[0] * dx, lo[1] + round(-lo[1] / dx) * dx + off[1] * dx, R + drop])
    x, pv = sphere_points(c, R, dx / 2)
    if jitter:
        x = x + np.random.default_rng(seed).uniform(-jitter, jitter, x.shape) * dx / 2
    return x, pv, lo, dx


def simulate(model, mu, frames, ng=16, off=(0.0, 0.0), jitter=0.0, spin=0.0, kappa=16.0, drop=DROP):
    """Run one drop; returns per-substep arrays t, centroid z, centroid vz, contact flag, and per frame
    the centroid (m), angular momentum about the centroid (kg m^2/s) and the lowest-1 % height (m)."""
    x, pv, lo, dx = ball(ng, off, jitter, drop=drop)
    inv_dx = 1 / dx
    n = len(x)
    mat = Material("jelly", E=E, nu=NU, rho=RHO)
    pm = np.full(n, pv * RHO)
    dtm = mpm_stable_dt([mat], dx, G, height=SIDE, v0_max=1.0, cfl=0.4)
    nsub, dt = substeps_for(1 / 30, dtm)
    ktop = ground_top_node(0.0, lo[2], dx) - (0 if model == "grid" else 2)
    c0 = x.mean(0)
    v = np.zeros((n, 3))
    if spin:
        v = np.cross(np.array([0.0, spin, 0.0]), x - c0)
    F = np.tile(np.eye(3), (n, 1, 1)); C = np.zeros((n, 3, 3))
    delta = 0.5 * pv ** (1 / 3)
    sub, per_frame = [], []
    for f in range(frames):
        for s in range(nsub):
            X = (x - lo) * inv_dx
            base = np.floor(X - 0.5).astype(int)
            if base.min() < 0 or base.max() > ng - 3:
                raise RuntimeError(f"left the grid at frame {f}")
            fx = X - base
            w = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2], 1)
            W = w[:, OFFS[:, 0], 0] * w[:, OFFS[:, 1], 1] * w[:, OFFS[:, 2], 2]
            dpos = (OFFS[None] - fx[:, None]) * dx
            F = np.einsum("nij,njk->nik", np.eye(3) + dt * C, F)
            U, S, Vt = np.linalg.svd(F)
            J = np.prod(S, 1)
            tau = 2 * mat.mu * np.einsum("nij,nkj->nik", F - U @ Vt, F) + (mat.lam * J * (J - 1))[:, None, None] * np.eye(3)
            aff = -dt * pv * 4 * inv_dx ** 2 * tau + pm[:, None, None] * C
            pmom = pm[:, None] * v
            contact = False
            if model.startswith("penalty") or model.startswith("pstep"):
                pen = (delta if model.endswith("d") else 0.0) - x[:, 2]
                k = (float(model[7:].split("s")[0].rstrip("d") or kappa) * E * pv ** (1 / 3) if model.startswith("penalty")
                     else float(model[5:]) * pm / dt ** 2)
                if "s" in model:   # smoothed onset over +-w: k (d + w)^2 / (4 w) for |d| < w
                    wsm = float(model.split("s")[1]) * dx
                    fn = np.where(pen > wsm, k * pen, np.where(pen > -wsm, k * (pen + wsm) ** 2 / (4 * wsm), 0.0))
                else:
                    fn = np.where(pen > 0, k * pen, 0.0)
                vt = v[:, :2]; lt = np.linalg.norm(vt, axis=1)
                jt = np.minimum(mu * fn * dt, pm * lt)
                pmom = pmom.copy()
                pmom[:, 2] += dt * fn
                pmom[:, :2] -= (jt / np.maximum(lt, 1e-30))[:, None] * vt
                contact = bool((fn > 0).any())
            if model == "pimpulse":   # the point's own velocity projected, the impulse fed to the grid through P2G
                dp, hitp = _impulse(x[:, 2], v, pm, mu, dt)
                pmom = pmom + dp
                contact = bool(hitp.any())
            mom = pmom[:, None, :] + np.einsum("nij,nkj->nki", aff, dpos)
            idx = base[:, None, :] + OFFS[None]
            flat = ((idx[..., 0] * ng + idx[..., 1]) * ng + idx[..., 2]).ravel()
            gm = np.bincount(flat, (W * pm[:, None]).ravel(), ng ** 3)
            gp = np.stack([np.bincount(flat, (W * mom[..., d]).ravel(), ng ** 3) for d in range(3)], 1)
            has = gm > 0
            gv = np.zeros_like(gp); gv[has] = gp[has] / gm[has, None] + dt * G
            gnd = has & (np.arange(ng ** 3) % ng <= ktop)
            hit = gnd & (gv[:, 2] < 0)
            if model == "grid":
                contact = bool(hit.any())
            vt = gv[hit].copy(); vt[:, 2] = 0
            lt = np.linalg.norm(vt, axis=1)
            gv[hit] = vt * np.where(lt > 1e-30, np.maximum(0, 1 + mu * gv[hit, 2] / np.maximum(lt, 1e-300)), 0.0)[:, None]
            if model.startswith("gimpulse"):   # the point's velocity from the new grid, its impulse scattered back
                for _ in range(int(model[8:] or 1)):
                    vp = np.einsum("nk,nki->ni", W, gv[flat.reshape(n, 27)])
                    dp, hitp = _impulse(x[:, 2], vp, pm, mu, dt)
                    gi = np.stack([np.bincount(flat, (W * dp[:, d:d + 1]).ravel(), ng ** 3) for d in range(3)], 1)
                    gv[has] += gi[has] / gm[has, None]
                contact = bool(hitp.any())
            vg = gv[flat.reshape(n, 27)]
            v = np.einsum("nk,nki->ni", W, vg)
            C = 4 * inv_dx ** 2 * np.einsum("nk,nki,nkj->nij", W, vg, dpos)
            if model.startswith("particle"):
                z = x[:, 2]
                if model == "particle":
                    vmin = -np.maximum(z, 0.0) / dt
                    hitp = v[:, 2] < vmin
                else:
                    vmin = np.zeros(n)
                    hitp = (z <= 0.0) & (v[:, 2] < 0)
                dvn = np.where(hitp, vmin - v[:, 2], 0.0)
                v[:, 2] += dvn
                vt = v[:, :2]; lt = np.linalg.norm(vt, axis=1)
                sc = np.where(lt > 1e-30, np.maximum(0.0, 1 - mu * dvn / np.maximum(lt, 1e-300)), 0.0)
                v[hitp, :2] = vt[hitp] * sc[hitp, None]
                contact = bool(hitp.any())
            x = x + dt * v
            cm = x.mean(0)
            sub.append((f * nsub + s + 1, cm[2], v[:, 2].mean(), contact))
        cm = x.mean(0)
        L = (np.cross(x - cm, pm[:, None] * v)).sum(0)
        per_frame.append((*cm, *L, np.quantile(x[:, 2], 0.01), x[:, 2].min()))
    sub = np.array(sub, float); sub[:, 0] *= dt
    return sub, np.array(per_frame), dx, nsub


def _impulse(z, v, pm, mu, dt):
    """Per point, the momentum (kg m/s, shape (n, 3)) that keeps it from crossing the plane z = 0 in the
    next step (``v_n >= -max(z, 0) / dt``) with Coulomb friction: ``mu`` times the normal momentum,
    at most what stops the tangential motion. Also the mask of points in contact."""
    vmin = -np.maximum(z, 0.0) / dt
    hitp = v[:, 2] < vmin
    dpn = np.where(hitp, pm * (vmin - v[:, 2]), 0.0)
    vt = v[:, :2]
    lt = np.linalg.norm(vt, axis=1)
    dpt = -(np.minimum(mu * dpn, pm * lt) / np.maximum(lt, 1e-30))[:, None] * vt
    return np.column_stack([dpt, dpn]), hitp


def hertz_duration():
    """Hertz's contact time of the ball on a rigid plane at the drop's impact speed, s."""
    m = RHO * 4 / 3 * math.pi * R ** 3
    v = math.sqrt(2 * 9.81 * DROP)
    Es = E / (1 - NU ** 2)
    return 2.87 * (m * m / (R * Es * Es * v)) ** 0.2


def _pushed(sub):
    """Per substep: the ground pushes (the centroid's vertical acceleration exceeds -0.99 g; in flight
    it is -g exactly, P2G and G2P conserving momentum)."""
    t, vz = sub[:, 0], sub[:, 2]
    a = np.diff(vz, prepend=vz[0] + 9.81 * (t[1] - t[0])) / (t[1] - t[0])
    return a > -0.99 * 9.81


def bounce_figures(sub):
    """Restitution (largest upward centroid speed after the first impact over the impact speed) and
    the first contact's duration (s: from the first push to that largest upward speed)."""
    t, vz = sub[:, 0], sub[:, 2]
    first = int(np.argmax(_pushed(sub)))
    up = first + int(np.argmax(vz[first:] > 0))
    down = up + int(np.argmax(vz[up:] < 0))
    top = up + int(np.argmax(vz[up:down]))
    return float(vz[top]) / -float(vz[first - 1]), t[top] - t[first - 1]


def spin_ratios(sub, pf):
    """|L_y| (about the centroid) in the middle of each flight (a run of at least half a frame with no
    push from the ground) over the one before; the first flight holds the seed."""
    nsub = len(sub) // len(pf)
    on = _pushed(sub)
    mids, i = [], 0
    while i < len(on):
        j = i
        while j < len(on) and not on[j]:
            j += 1
        if j - i >= nsub // 2:
            mids.append(min(len(pf) - 1, ((i + j) // 2) // nsub))
        i = j + 1
    Ly = np.abs(pf[:, 4])
    return [Ly[mids[k + 1]] / Ly[mids[k]] for k in range(len(mids) - 1)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--models", nargs="+", default=["grid", "penalty", "particle", "particle_skin"])
    ap.add_argument("--quick", action="store_true")
    a = ap.parse_args()
    rows = ["| model | spin growth per bounce (mu 0, 0.02 rad/s seed) | roll at 40 frames, lattice / jittered (mm, mu 0.5) "
            "| restitution | contact (ms; Hertz %.1f) | rest: lowest 1 %% / lowest point above the plane (dx) | CPU s |"
            % (1e3 * hertz_duration()), "|---|---|---|---|---|---|---|"]
    frames = 20 if a.quick else 40
    for model in a.models:
        c0 = time.process_time()
        sub, pf, dx, nsub = simulate(model, 0.0, frames, spin=0.02)
        ratios = spin_ratios(sub, pf)
        e, tc = bounce_figures(sub)
        drifts = []
        for jit in (0.0, 0.5):
            _, pfr, _, _ = simulate(model, 0.5, frames, off=(0.3, 0.2), jitter=jit)
            drifts.append(1e3 * math.hypot(*(pfr[-1, :2] - pfr[0, :2])))
        gap = pfr[-1, 6] / dx, pfr[-1, 7] / dx
        rows.append(f"| {model} | {' / '.join(f'{r:.2f}' for r in ratios)} | {drifts[0]:.2f} / {drifts[1]:.2f} | {e:.3f} "
                    f"| {1e3 * tc:.1f} | {gap[0]:+.3f} / {gap[1]:+.3f} | {time.process_time() - c0:.0f} |")
        print(rows[-1], flush=True)
    text = "\n".join(rows)
    print(text)
    os.makedirs(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results"), exist_ok=True)
    with open(os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results", "contact_models.md"), "w") as fh:
        fh.write(f"`python benchmarks/studies/contact_models.py{' --quick' if a.quick else ''}` ({frames} frames)\n\n{text}\n")


if __name__ == "__main__":
    main()
