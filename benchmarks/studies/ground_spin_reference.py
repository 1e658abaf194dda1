"""numpy MLS-MPM (docs/mpm.md) of the issue-17 ball drop, bit-close to warp_mpm/taichi_mpm (drift to 1e-3 mm), with experiment switches (--variant pic2 | cunproj | gafter | v1 | v4 | bilat | partc) and per-substep contact logs (see tests/test_ground_spin.py).

More switches (branch spin2, the leads of the second investigation; figures in its report):
cfun (F advanced with C from the unprojected grid velocity, APIC momentum with the projected one),
capicun (the reverse), below (ground nodes strictly below the plane), gradf (stress force
-V tau grad N_i instead of MLS's 4/dx^2 w dpos), gradc (F advanced with sum v_i grad N_i^T),
sfirst (ground nodes projected before this substep's stress force is added), pen<kappa>
(e.g. pen16: no grid ground within reach (nodes k <= top - 2 only); a particle-level penalty
f_z = kappa E V^(1/3) (V^(1/3)/2 - z) scattered in P2G; friction not modelled).
torque_split(log, nsub) splits the ground's torque into node momentum, APIC, tau_zz, other stress, gravity."""
import math, argparse
import numpy as np
from gasp_core.testing.helpers import sphere_points
from gasp_core.mpm.points import ground_top_node
from gasp_core.mpm.substeps import mpm_stable_dt, substeps_for
from gasp_core.seam.setup import Material

def run(mu_b=0.5, frames=40, ng=16, drop=0.05, off=(0.3, 0.2), cfl=0.4, ppc=2.0, E=2e4, variant="base",
        log=None, every=5, verbose=True):
    SIDE = 0.3; dx = SIDE / ng; inv_dx = 1 / dx
    LO = np.array([-SIDE / 2, -SIDE / 2, -3 * (0.3 / 16)])
    R = 0.05
    c = np.array([LO[0] + round(-LO[0] / dx) * dx + off[0] * dx, LO[1] + round(-LO[1] / dx) * dx + off[1] * dx, R + drop])
    x, pv = sphere_points(c, R, dx / ppc)
    mat = Material("jelly", E=E, nu=0.3, rho=300.0)
    n = len(x); pm = np.full(n, pv * 300.0); muL, lam = mat.mu, mat.lam
    g = np.array([0, 0, -9.81])
    dtm = mpm_stable_dt([mat], dx, g, height=SIDE, v0_max=0.0, cfl=cfl)
    nsub, dt = substeps_for(1 / 30, dtm)
    ktop = ground_top_node(0.0, LO[2], dx) - (1 if variant=='below' else 0) - (2 if variant.startswith('pen') else 0)
    kap = float(variant[3:]) if variant.startswith('pen') else 0.0
    delta = 0.5 * pv ** (1 / 3)
    v = np.zeros((n, 3)); F = np.tile(np.eye(3), (n, 1, 1)); C = np.zeros((n, 3, 3)); CA = np.zeros((n, 3, 3)); CG = np.zeros((n, 3, 3))
    m = pm / pm.sum(); x0 = x.copy(); c0 = m @ x0
    offs = np.array([(i, j, k) for i in range(3) for j in range(3) for k in range(3)])
    out = []
    for f in range(1, frames + 1):
        for s in range(nsub):
            X = (x - LO) * inv_dx
            base = np.floor(X - 0.5).astype(int)
            fx = X - base
            w = np.stack([0.5 * (1.5 - fx) ** 2, 0.75 - (fx - 1) ** 2, 0.5 * (fx - 0.5) ** 2], 1)  # n,3(i),3(axis)
            W = w[:, offs[:, 0], 0] * w[:, offs[:, 1], 1] * w[:, offs[:, 2], 2]  # n,27
            dpos = (offs[None] - fx[:, None]) * dx  # n,27,3
            dw = np.stack([-(1.5 - fx), -2 * (fx - 1), (fx - 0.5)], 1) * inv_dx  # n,3(i),3(axis)
            GW = np.stack([dw[:, offs[:, 0], 0] * w[:, offs[:, 1], 1] * w[:, offs[:, 2], 2],
                           w[:, offs[:, 0], 0] * dw[:, offs[:, 1], 1] * w[:, offs[:, 2], 2],
                           w[:, offs[:, 0], 0] * w[:, offs[:, 1], 1] * dw[:, offs[:, 2], 2]], -1)  # n,27,3 grad N_i(x_p)
            F = np.einsum('nij,njk->nik', np.eye(3) + dt * (CA if variant=='cfun' else (CG if variant in ('gradc','gradboth') else C)), F)
            U, S, Vt = np.linalg.svd(F)
            Rr = U @ Vt
            J = np.linalg.det(F)
            tau = 2 * muL * np.einsum('nij,nkj->nik', F - Rr, F) + (lam * J * (J - 1))[:, None, None] * np.eye(3)
            aff = -dt * pv * 4 * inv_dx ** 2 * tau + (0 if variant == 'pic2' else pm[:, None, None] * (CA if variant=='capicun' else C))
            affS = -dt * pv * 4 * inv_dx ** 2 * tau
            if variant in ('gradf', 'gradboth'):
                aff = aff - affS
                mom = pm[:, None, None] * v[:, None, :] + np.einsum('nij,nkj->nki', aff, dpos) + np.einsum('nij,nkj->nki', -dt * pv * tau, GW / np.maximum(W, 1e-300)[..., None])
            else:
                mom = pm[:, None, None] * v[:, None, :] + np.einsum('nij,nkj->nki', aff, dpos)  # n,27,3
            if kap > 0:
                pen = delta - x[:, 2]
                fn = np.where(pen > 0, kap * E * pv ** (1 / 3) * pen, 0.0)
                mom = mom + (dt * fn)[:, None, None] * np.array([0, 0, 1.0])[None, None, :]
            idx = base[:, None, :] + offs[None]
            flat = (idx[..., 0] * ng + idx[..., 1]) * ng + idx[..., 2]
            gm = np.zeros(ng ** 3); gp = np.zeros((ng ** 3, 3))
            np.add.at(gm, flat.ravel(), (W * pm[:, None]).ravel())
            np.add.at(gp, flat.ravel(), (W[..., None] * mom).reshape(-1, 3))
            momC = pm[:, None, None] * np.einsum('nij,nkj->nki', C, dpos)
            gpc = np.zeros((ng ** 3, 3)); np.add.at(gpc, flat.ravel(), (W[..., None] * momC).reshape(-1, 3))
            gps = np.zeros((ng ** 3, 3)); np.add.at(gps, flat.ravel(), (W[..., None] * np.einsum('nij,nkj->nki', affS, dpos)).reshape(-1, 3))
            if log is not None:
                tz = np.zeros((n,3,3)); tz[:,2,2] = affS[:,2,2]
                gpzz = np.zeros((ng ** 3, 3)); np.add.at(gpzz, flat.ravel(), (W[..., None] * np.einsum('nij,nkj->nki', tz, dpos)).reshape(-1, 3))
            gpv = np.zeros((ng ** 3, 3)); np.add.at(gpv, flat.ravel(), (W[..., None] * (pm[:, None, None] * v[:, None, :])).reshape(-1, 3))
            has = gm > 0
            gv = np.zeros_like(gp); gv[has] = gp[has] / gm[has, None] + (0 if variant == 'gafter' else dt * g)
            kk = np.arange(ng ** 3) % ng
            gnd = has & (kk <= ktop)
            vin = gv.copy()
            vpic = np.zeros_like(gp); vpic[has] = (gp[has] - gpc[has]) / gm[has, None] + dt * g
            if variant == 'v4':
                gv[gnd, 2] = vpic[gnd, 2]
            vn = gv[:, 2]
            hit = gnd & (vn < 0)
            if variant == 'partc':
                hit = hit & False
            if variant == 'bilat':
                hit = gnd
            if variant == 'v1':
                hit = gnd & (vpic[:, 2] < 0)
            if variant == 'sfirst':   # project the node velocity without this substep's stress force, then add it
                vs = np.zeros_like(gp); vs[has] = gps[has] / gm[has, None]
                gv = gv - vs
                vn = gv[:, 2]; hit = gnd & (vn < 0)
            vt = gv[hit].copy(); vt[:, 2] = 0
            lt = np.linalg.norm(vt, axis=1)
            sc = np.where(lt > 1e-30, np.maximum(0, 1 + mu_b * vn[hit] / np.maximum(lt, 1e-300)), 0.0)
            gv[hit] = vt * sc[:, None]
            if variant == 'gafter':
                gv[has] += dt * g
            if variant == 'sfirst':
                gv = gv + vs
            if log is not None:
                ii = np.arange(ng ** 3)
                pos = LO + dx * np.stack([ii // (ng * ng), (ii // ng) % ng, ii % ng], 1)
                imp = gm[:, None] * (gv - vin)
                cm = m @ x
                tq = np.cross(pos - cm, imp).sum(0)
                Jz = imp[:, 2].sum()
                if Jz > 0:
                    ctr = (imp[:, 2] @ pos[:, :2]) / Jz - cm[:2]
                    Lp = (np.cross(x - cm, pm[:, None] * v) ).sum(0)
                    log.append(dict(gpzz=gpzz.copy(), gps=gps.copy(), pos=pos, f=f, s=s, Jz=Jz, ctr=ctr, tq=tq, imp=imp.copy(), gm=gm.copy(), vin=vin.copy(), vpic=vpic.copy(), gpv=gpv.copy(), gpc=gpc.copy(), hit=hit.copy(), tau=tau.copy(), xs=x.copy(),
                                    cm=cm, Lp=Lp, x=x.copy(), v=v.copy(), C=C.copy()))
            vg = gv[flat]  # n,27,3
            v = np.einsum('nk,nki->ni', W, vg)
            if variant == "pic":
                C = np.zeros_like(C)
            else:
                vC = vin[flat] if variant == 'cunproj' else vg
                C = 4 * inv_dx ** 2 * np.einsum('nk,nki,nkj->nij', W, vC, dpos)
                if variant in ('gradc', 'gradboth'):
                    CG = np.einsum('nki,nkj->nij', vg, GW)
                CA = 4 * inv_dx ** 2 * np.einsum('nk,nki,nkj->nij', W, vin[flat], dpos)
            if variant == 'partc':
                pc = (x[:, 2] <= 0.0) & (v[:, 2] < 0)
                v[pc, 2] = 0.0
            x = x + dt * v
        cc = m @ x
        H = ((x0 - c0) * m[:, None]).T @ (x - cc)
        U_, S_, Vt_ = np.linalg.svd(H)
        Rm = Vt_.T @ np.diag([1, 1, np.sign(np.linalg.det(Vt_.T @ U_.T))]) @ U_.T
        ang = math.degrees(math.acos(max(-1, min(1, (np.trace(Rm) - 1) / 2))))
        out.append((f, *(1e3 * (cc - c0)), ang))
        if verbose and (f % every == 0):
            print(f"f{f:3d} dx {1e3*(cc-c0)[0]:+8.3f} dy {1e3*(cc-c0)[1]:+8.3f} dz {1e3*(cc-c0)[2]:+8.2f} mm  spin {ang:7.3f} deg", flush=True)
    return np.array(out), nsub

def torque_split(log, nsub, g=-9.81, frame_dt=1 / 30):
    """Torque about the centroid (N m s, summed over the logged substeps) of the ground's vertical
    impulses, split into the hit nodes' pre-projection momentum parts: m v, APIC m C dpos, the
    tau_zz stress part, the other stress parts, gravity (mu = 0 only: then the ground's impulse is
    vertical and tau = sum rx (p_z) over the hit nodes)."""
    dt = frame_dt / nsub
    tot = dict(mv=0.0, apic=0.0, tau_zz=0.0, tau_other=0.0, gravity=0.0)
    for e in log:
        h = e['hit']
        rx = e['pos'][h, 0] - e['cm'][0]
        parts = dict(mv=e['gpv'][h, 2], apic=e['gpc'][h, 2], tau_zz=e['gpzz'][h, 2],
                     tau_other=e['gps'][h, 2] - e['gpzz'][h, 2], gravity=e['gm'][h] * g * dt)
        for k, val in parts.items():
            tot[k] += float(np.sum(rx * val))
    return tot

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--mu", type=float, default=0.5); ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--variant", default="base"); ap.add_argument("--cfl", type=float, default=0.4)
    ap.add_argument("--n_grid", type=int, default=16); ap.add_argument("--ppc", type=float, default=2.0)
    a = ap.parse_args()
    import time; t = time.time()
    o, nsub = run(a.mu, a.frames, a.n_grid, cfl=a.cfl, ppc=a.ppc, variant=a.variant)
    print("nsub", nsub, "time", round(time.time() - t, 1))
