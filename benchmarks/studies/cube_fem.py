"""Round 80 (docs/contact.md "Round 80: the cube by finite elements"): the jelly cube of ``tests/test_elastic_slope.py``
(and the issue's flat block) by a solver that shares nothing with the MPM engines, to ask whether a lightly damped
elastic continuum walks where the particle contact walks. Prints one line a case.

**Solver.** Explicit trilinear hexahedra (St. Venant-Kirchhoff, ``S = lambda tr(E) I + 2 mu E``; 8 Gauss points;
lumped mass; central differences), on the plane z = 0 of the slope's frame with gravity ``g (sin, 0, -cos)``. Each
node is a point mass on the plane with Coulomb's law by impulses (the kinematic nodal contact of explicit codes:
Belytschko, Liu & Moran, *Nonlinear Finite Elements*, 2000, sec. 10.4): the normal impulse that puts a node on the
plane, never pulling, and a tangential one within ``mu`` times it. A stiffness-proportional (Rayleigh) damping
``beta`` (s) adds ``beta C : sym(grad v)``: a damping ratio ``beta omega / 2``, large on the element-scale modes
(without it the base nodes chatter on and off the plane and slip 1 mm even at ``mu`` 10) and small on the cube's
25 Hz ring (0.8 % at ``beta`` 1e-4; the MPM engines' own at n_grid 32 is about 2 %, from round 79's ring at ``mu`` 10).

    python benchmarks/studies/cube_fem.py "n=6,mu=0.6,beta=1e-4" "n=10,mu=0.6,beta=1e-4"
    python benchmarks/studies/cube_fem.py "n=6,mu=10,beta=1e-4" "n=6,mu=0.6,beta=4e-4"
    python benchmarks/studies/cube_fem.py "n=3,mu=0.6,beta=1e-4,side=(0.15,0.15,0.05)"   # the issue's flat block
    python benchmarks/studies/cube_fem.py "n=6,mu=0.6,beta=1e-4,settle=0.5"             # brought to rest first

Each argument is the keywords of :func:`run`: ``n`` elements along the shortest side, ``mu``, ``beta`` (s),
``theta`` (degrees), ``T`` (s, at least 1.6), ``side`` (m), ``E`` (Pa; nu 0.3, rho 1000), ``settle`` (s of a drag of
200 1/s at ``mu`` 100 before the release). The figures: the base nodes' mean slip along the slope over 0-0.5 s and
0.5-1.5 s (the test's stick window), and the centroid's height peak to peak over 1.0-1.6 s at 60 frames a second.
"""

import math
import sys
import time

import numpy as np


def gauss_gradients(h):
    g = 1.0 / math.sqrt(3.0)
    pts = [(sx * g, sy * g, sz * g) for sz in (-1, 1) for sy in (-1, 1) for sx in (-1, 1)]
    sign = np.array([[(a & 1) * 2 - 1, (a >> 1 & 1) * 2 - 1, (a >> 2 & 1) * 2 - 1] for a in range(8)], float)
    out = np.zeros((8, 8, 3))
    for p, xi in enumerate(pts):
        for a in range(8):
            f = [(1.0 + sign[a, d] * xi[d]) / 2.0 for d in range(3)]
            for d in range(3):
                others = np.prod([f[e] for e in range(3) if e != d])
                out[p, a, d] = sign[a, d] / 2.0 * others * (2.0 / h)
    return out


class Block:
    """The box ``side`` (m) resting unstressed on the plane, its lower corner at the origin, at rest (module notes)."""

    def __init__(self, side, n, E, nu, rho, theta, mu, beta=0.0, g=9.81, cfl=0.3, law="svk"):
        if law not in ("svk", "corotated"):
            raise ValueError(f"law: 'svk' or 'corotated', got {law!r}")
        self.law = law
        side = np.asarray(side, float)
        self.h = h = float(side.min()) / n
        nx, ny, nz = np.rint(side / h).astype(int)
        ii, jj, kk = np.meshgrid(np.arange(nx + 1), np.arange(ny + 1), np.arange(nz + 1), indexing="ij")
        node = lambda i, j, k: (i * (ny + 1) + j) * (nz + 1) + k  # noqa: E731
        self.X = np.stack([ii.ravel(), jj.ravel(), kk.ravel()], axis=1) * h
        ei, ej, ek = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
        self.elems = np.stack([node(ei + (a & 1), ej + (a >> 1 & 1), ek + (a >> 2 & 1)) for a in range(8)], axis=1)
        self.G = gauss_gradients(h)
        self.w = (h / 2.0) ** 3
        self.lam = E * nu / ((1 + nu) * (1 - 2 * nu))
        self.mu_l = E / (2 * (1 + nu))
        self.beta, self.mu = beta, mu
        self.m = np.bincount(self.elems.ravel(), minlength=len(self.X)) * rho * h ** 3 / 8.0
        t = math.radians(theta)
        self.gravity = np.array([g * math.sin(t), 0.0, -g * math.cos(t)])
        cp = math.sqrt((self.lam + 2 * self.mu_l) / rho)
        wmax = 2.0 * math.sqrt(3.0) * cp / h   # a bound on the mesh's highest frequency
        # central difference with damping ratio z at wmax: dt <= (2 / wmax) (sqrt(1 + z^2) - z)
        z = 0.5 * beta * wmax
        self.dt = cfl * (2.0 / wmax) * (math.sqrt(1 + z * z) - z) / 0.5   # cfl 0.3: 0.6 of the limit
        self.drag = 0.0
        self.x = self.X.copy()
        self.v = np.zeros_like(self.X)

    def forces(self):
        xe = self.x[self.elems]
        F = np.einsum("eai,gaj->egij", xe, self.G)
        if self.law == "svk":
            E = 0.5 * (np.einsum("egki,egkj->egij", F, F) - np.eye(3))
            S = 2.0 * self.mu_l * E + self.lam * np.trace(E, axis1=2, axis2=3)[..., None, None] * np.eye(3)
            P = F @ S
        else:   # fixed corotated (Stomakhin et al. 2012), the MPM engines' jelly: 2 mu (F - R) + lam (J - 1) J F^-T
            U, _, Vt = np.linalg.svd(F)
            J = np.linalg.det(F)
            P = 2.0 * self.mu_l * (F - U @ Vt) + (self.lam * (J - 1.0) * J)[..., None, None] * np.swapaxes(
                np.linalg.inv(F), 2, 3)
        if self.beta > 0.0:
            L = np.einsum("eai,gaj->egij", self.v[self.elems], self.G)
            D = 0.5 * (L + np.swapaxes(L, 2, 3))
            P = P + self.beta * (2.0 * self.mu_l * D + self.lam * np.trace(D, axis1=2, axis2=3)[..., None, None] * np.eye(3))
        fe = -self.w * np.einsum("egij,gaj->eai", P, self.G)
        idx = self.elems.ravel()
        return np.stack([np.bincount(idx, fe[..., d].ravel(), minlength=len(self.X)) for d in range(3)], axis=1)

    def step(self):
        dt = self.dt
        v = self.v + dt * (self.forces() / self.m[:, None] + self.gravity)
        if self.drag:
            v /= 1.0 + self.drag * dt
        z = self.x[:, 2] + dt * v[:, 2]
        on = z < 0.0
        if on.any():
            lam = -z[on] / dt
            v[on, 2] += lam
            vt = v[on, :2]
            s = np.linalg.norm(vt, axis=1)
            keep = np.where(s > self.mu * lam, 1.0 - self.mu * lam / np.maximum(s, 1e-300), 0.0)
            v[on, :2] = vt * keep[:, None]
        self.v = v
        self.x = self.x + dt * v

    def slip(self):
        base = self.X[:, 2] == 0.0
        return float((self.x[base, 0] - self.X[base, 0]).mean())

    def centroid(self):
        return self.m @ self.x / self.m.sum()

    def tilt(self):
        """The body's turn about y (degrees, negative downhill): the rotation of the least-squares rigid fit
        (Kabsch) of its nodes' motion in the x-z plane."""
        return tilt_deg(self.X, self.x)

    def relax(self, ramp=0.5, hold=1.5):
        """Dynamic relaxation to rest in the body's own weight at the plane's ``mu`` (as ``gasp_core.seam.settle``
        does): gravity ramped over ``ramp`` s, then held ``hold`` s, with kinetic damping (Cundall 1976: every
        velocity zeroed when the kinetic energy falls). Where no stable rest exists the body goes on moving (a block
        that topples ends on its side)."""
        g, ke0 = self.gravity.copy(), 0.0
        for k in range(math.ceil((ramp + hold) / self.dt)):
            self.gravity = g * min(1.0, k * self.dt / ramp)
            self.step()
            ke = float(self.m @ (self.v ** 2).sum(axis=1))
            if ke < ke0:
                self.v[:] = 0.0
                ke = 0.0
            ke0 = ke
        self.gravity = g


def tilt_deg(x0, x):
    """The rotation about y (degrees) of the least-squares rigid fit (Kabsch) taking the points ``x0`` (n, 3) to
    ``x`` in the x-z plane."""
    a, b = x0 - x0.mean(axis=0), x - x.mean(axis=0)
    u, _, vt = np.linalg.svd(a[:, [0, 2]].T @ b[:, [0, 2]])
    r = vt.T @ u.T
    return math.degrees(math.atan2(r[1, 0], r[0, 0]))


def run(n=6, mu=0.6, beta=0.0, theta=30.0, T=1.6, side=(0.1, 0.1, 0.1), E=1e5, settle=0.0, fps=60):
    b = Block(side, n, E, 0.3, 1000.0, theta, mu, beta)
    if settle:
        mu0, b.mu, b.drag = b.mu, 100.0, 200.0
        for _ in range(math.ceil(settle / b.dt)):
            b.step()
        b.mu, b.drag = mu0, 0.0
        b.v[:] = 0.0
    per = max(1, math.ceil(1.0 / (fps * b.dt)))
    b.dt = 1.0 / (fps * per)
    s0 = b.slip()
    t0 = time.time()
    c, sl = [b.centroid()], [0.0]
    for _ in range(round(T * fps)):
        for _ in range(per):
            b.step()
        c.append(b.centroid())
        sl.append(b.slip() - s0)
    c, sl = np.array(c), 1000 * np.array(sl)
    z = 1000 * c[round(1.0 * fps):, 2]
    f = lambda t: round(t * fps)
    print(f"n {n} mu {mu} beta {beta:g} settle {settle} E {E:g} side {side}: base slip 0-0.5 {sl[f(0.5)]:.3f}, "
          f"0.5-1.5 {sl[f(1.5)] - sl[f(0.5)]:.3f} mm; ring 1.0-1.6 {np.ptp(z):.4f} mm; dt {b.dt:.2e}; "
          f"{time.time() - t0:.0f} s", flush=True)


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        run(**eval(f"dict({arg})"))
