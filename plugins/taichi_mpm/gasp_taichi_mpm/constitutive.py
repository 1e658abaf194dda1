"""Constitutive models (docs/mpm.md "Constitutive models"): the Kirchhoff stresses, the polar rotation, the SVD
and the per-material return mapping, as Taichi functions.

Mixed into :class:`gasp_taichi_mpm.solver.MPMSolver`, whose fields and flags (``real``, ``atomic``, ...) it reads.
Sources: taichi_elements (materials), Klar et al. 2016 (Drucker-Prager sand), Stomakhin et al. 2013 (snow),
Higham 1986 (polar decomposition), Golub & Van Loan (Jacobi eigenvalues), Rankine damage in a crack band
(Bazant & Oh 1983; docs/fracture.md) for brittle.
"""
import taichi as ti

# Material codes and the per-body parameter columns (``MPMSolver.mat``) are gasp_core.mpm.materials'.
from gasp_core.mpm.cells import OPENING as CELL_OPENING
from gasp_core.mpm.materials import (BRITTLE, JELLY, LIQUID, METAL, NEO_HOOKEAN, P_ALPHA, P_DMU, P_FT, P_HARDENING, P_IK,
                                         P_CELLS, P_K, P_LAM, P_MU, P_SF, P_SOFTENING, P_THETA_C, P_THETA_S, P_YIELD,
                                         PLASTICINE, SAND, SNOW, VON_MISES_RADIUS)


class Constitutive:
    """Return mapping and stress of a point (:meth:`return_mapping`) and the decompositions it uses."""

    #: True: a free brittle point's softening range is scaled by its crack band weight (:meth:`band_sf`, round 33);
    #: False: one ``s_f`` for every point, as before (the catch of ``tests/test_tension_family.py``). Compile-time.
    weighted_band = True
    #: True: with :attr:`weighted_band`, the band of a free brittle point is the cell's projection on its crack's normal
    #: (:meth:`band_sf`, round 34); False (the default): the band ``dx`` at every angle (docs/fracture.md "Oblique
    #: specimens (round 34)": on, the damage's dissipation is G_f but the work to separate -28 % at 45 deg).
    #: Compile-time.
    oblique_band = False

    @ti.func
    def udvt(self, U, d, V):
        D = ti.Matrix.zero(self.real, 3, 3)
        D[0, 0] = d[0]
        D[1, 1] = d[1]
        D[2, 2] = d[2]
        return U @ D @ V.transpose()

    @ti.func
    def corotated_tau(self, F, U, V, mu, lam):
        R = U @ V.transpose()
        J = F.determinant()
        return 2.0 * mu * (F - R) @ F.transpose() + ti.Matrix.identity(self.real, 3) * (lam * J * (J - 1.0))

    @ti.func
    def polar_rotation(self, F):
        """``(R, converged)``: the rotation of the polar decomposition ``F = R S`` (the SVD's ``U V^T`` when
        ``det F > 0``) by Newton's iteration ``X <- (g X + X^-T / g) / 2`` with the determinant scaling
        ``g = det(X)^(-1/3)`` on the first step (Higham 1986, "Computing the polar decomposition"), stopped when
        the l1 change of X is below about 30 ulp of 1 (4e-6 in f32, 1e-13 in f64), at most 30 steps;
        ``converged`` is 0 where ``det F <= 0`` or it did not converge. The Warp plugin's ``polar_rotation``
        (the reference, docs/mpm.md), written in Taichi: ``X^-T det X`` is the matrix of the rows' cross products.
        """
        X = F
        ok = 0
        tol = ti.static(4e-6 if self.real == ti.f32 else 1e-13)
        for it in range(30):
            r0 = ti.Vector([X[0, 0], X[0, 1], X[0, 2]])
            r1 = ti.Vector([X[1, 0], X[1, 1], X[1, 2]])
            r2 = ti.Vector([X[2, 0], X[2, 1], X[2, 2]])
            c0 = r1.cross(r2)
            c1 = r2.cross(r0)
            c2 = r0.cross(r1)
            det = X[0, 0] * c0[0] + X[0, 1] * c0[1] + X[0, 2] * c0[2]
            if det <= 0.0:
                break
            g = ti.cast(1.0, self.real)
            if it == 0:
                g = ti.pow(det, -1.0 / 3.0)
            a = 0.5 * g
            bb = 0.5 / (g * det)
            Xn = a * X + bb * ti.Matrix.rows([c0, c1, c2])
            D = Xn - X
            X = Xn
            err = (ti.abs(D[0, 0]) + ti.abs(D[0, 1]) + ti.abs(D[0, 2]) + ti.abs(D[1, 0]) + ti.abs(D[1, 1])
                   + ti.abs(D[1, 2]) + ti.abs(D[2, 0]) + ti.abs(D[2, 1]) + ti.abs(D[2, 2]))
            if err < tol:
                ok = 1
                break
        return X, ok

    @ti.func
    def svd_rotation(self, F):
        """``U V^T`` of the SVD with proper rotations (the rotation closest to F): :meth:`polar_rotation`, or
        ``ti.svd`` where ``det F <= 0`` or the iteration did not converge (Warp: ``jelly_tau``)."""
        R, ok = self.polar_rotation(F)
        if ok == 0:
            U, S, V = ti.svd(F, self.real)
            R = U @ V.transpose()
        return R

    @ti.func
    def sym_eig(self, A):
        """Eigen-decomposition ``A = V diag(lam) V^T`` of a symmetric 3x3 matrix, V a rotation.

        Cyclic Jacobi rotations (Golub & Van Loan, "Matrix Computations", Sec. 8.5), stopped when
        the off-diagonal part is below the working precision relative to the diagonal.
        """
        V = ti.Matrix.identity(self.real, 3)
        tol = ti.static(1e-14 if self.real == ti.f32 else 1e-30)  # squared, relative
        for sweep in range(12):
            off = A[0, 1] ** 2 + A[0, 2] ** 2 + A[1, 2] ** 2
            if off <= tol * (A[0, 0] ** 2 + A[1, 1] ** 2 + A[2, 2] ** 2):
                break
            for pqr in ti.static([(0, 1, 2), (0, 2, 1), (1, 2, 0)]):
                p, q, r = ti.static(pqr[0], pqr[1], pqr[2])
                apq = A[p, q]
                if apq != 0.0:
                    theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                    t = 1.0 / (ti.abs(theta) + ti.sqrt(theta * theta + 1.0))
                    if theta < 0.0:
                        t = -t
                    c = 1.0 / ti.sqrt(t * t + 1.0)
                    s = t * c
                    A[p, p] -= t * apq
                    A[q, q] += t * apq
                    A[p, q] = 0.0
                    A[q, p] = 0.0
                    arp = A[r, p]
                    arq = A[r, q]
                    A[r, p] = c * arp - s * arq
                    A[p, r] = A[r, p]
                    A[r, q] = s * arp + c * arq
                    A[q, r] = A[r, q]
                    for k in ti.static(range(3)):
                        vkp = V[k, p]
                        vkq = V[k, q]
                        V[k, p] = c * vkp - s * vkq
                        V[k, q] = s * vkp + c * vkq
        return V, ti.Vector([A[0, 0], A[1, 1], A[2, 2]])

    @ti.func
    def svd(self, F):
        """``F = U diag(sig) V^T`` with U, V rotations (docs/mpm.md: a reflection is carried by
        the sign of a singular value).

        For ``det F > 0``: polar ``F = R S`` (:meth:`polar_rotation`), ``S = V diag(sig) V^T`` by Jacobi,
        ``U = R V`` - several times cheaper than ``ti.svd`` on CPU. Where ``det F <= 0`` or the polar
        iteration did not converge, ``ti.svd``. The singular values are not sorted; every use here is an
        isotropic function of them. The Warp plugin's ``svd`` (docs/mpm.md "Constitutive models").
        """
        U = ti.Matrix.identity(self.real, 3)
        V = ti.Matrix.identity(self.real, 3)
        sig = ti.Vector.zero(self.real, 3)
        R, ok = self.polar_rotation(F)
        if ok == 1:
            S = R.transpose() @ F
            S = 0.5 * (S + S.transpose())
            V, sig = self.sym_eig(S)
            U = R @ V
        else:
            U0, S0, V0 = ti.svd(F, self.real)
            U = U0
            V = V0
            sig = ti.Vector([S0[0, 0], S0[1, 1], S0[2, 2]])
        return U, sig, V

    @ti.func
    def hencky_tau(self, U, eps, mu, lam):
        tr = eps.sum()
        d = 2.0 * mu * eps + lam * tr
        return self.udvt(U, d, U)

    @ti.func
    def drucker_prager(self, eps, mu, lam, alpha):
        """The Hencky strain ``eps`` (principal) return-mapped onto the Drucker-Prager cone of ``alpha`` without
        cohesion (Klar et al. 2016, Sec. 4 and Eq. 27): 0 in volumetric tension, else its deviator shortened by
        ``dg = |e| + (3 lam + 2 mu) / (2 mu) tr(eps) alpha`` where that is positive. Sand, and a brittle point
        broken through."""
        tr = eps.sum()
        e = eps - tr / 3.0
        ne = e.norm()
        if tr >= 0.0:
            eps = ti.Vector.zero(self.real, 3)
        else:
            dg = ne + (3.0 * lam + 2.0 * mu) / (2.0 * mu) * tr * alpha
            if dg > 0.0:
                eps -= dg * e / ne
        return eps

    @ti.func
    def mu_i_alpha(self, eps, mu, lam, prm):
        """The cone's ``alpha`` for the Hencky strain ``eps``: ``P_ALPHA``, widened by the mu(I) rheology where the
        body has it (``P_DMU > 0``; ``gasp_core.mpm.materials.mu_of_I``, Jop et al. 2006): ``I`` from the plastic
        shear rate ``sqrt(2) dg / dt`` the rate-independent cone gives this substep and the pressure of ``eps``."""
        alpha = prm[P_ALPHA]
        tr = eps.sum()
        if prm[P_DMU] > 0.0 and tr < 0.0:
            k = (3.0 * lam + 2.0 * mu)
            dg = (eps - tr / 3.0).norm() + k / (2.0 * mu) * tr * alpha
            if dg > 0.0:
                rate = ti.sqrt(2.0) * dg / self.dt[None]
                alpha *= 1.0 + prm[P_DMU] / (1.0 + prm[P_IK] * ti.sqrt(-k / 3.0 * tr) / rate)
        return alpha

    @ti.func
    def brittle_tau(self, U, eps, mu, lam, ft, sf, d):
        """``(tau, d)``: the brittle Kirchhoff stress and the damage after it (docs/fracture.md).

        The undamaged Hencky principal stresses ``s_i = 2 mu eps_i + lam tr(eps)`` (Pa); the largest one sets the
        damage of linear softening in a crack band (Bazant & Oh 1983; ``gasp_core.mpm.materials.brittle_damage``
        with ``ft = f_t``, ``sf = s_f``), kept when larger than ``d`` (never heals); only the tensile ``s_i > 0`` are
        scaled by ``1 - d`` (compression is still carried). The Warp plugin's ``brittle_tau``.
        """
        s = 2.0 * mu * eps + lam * eps.sum()
        smax = ti.max(s[0], s[1], s[2])
        if smax > ft:
            dt = ti.cast(1.0, self.real)
            if smax < sf:
                dt = 1.0 - ft * (sf - smax) / (smax * (sf - ft))
            d = ti.max(d, dt)
        for i in ti.static(range(3)):
            if s[i] > 0.0:
                s[i] *= 1.0 - d
        return self.udvt(U, s, U), d

    @ti.func
    def band_sf(self, p, U, eps, mu, lam, ft, sf):
        """Point ``p``'s own end of softening (Pa): ``f_t + W (s_f - f_t)``, ``W`` its crack band weight along the
        direction ``U[:, i]`` of its largest principal stress (``gasp_core.mpm.materials.band_weight`` and
        ``band_softening_stress``: its MLS gradient weight on its own cell, so every point of a cracked cell breaks
        through at the same opening); with :attr:`oblique_band`, ``s_f`` of the band ``g dx``, ``g = sum_a |n_a|``
        the cell's projection on that normal (``gasp_core.mpm.materials.band_projection``, round 34), where it stays
        above ``f_t``; ``s_f`` for a held point (its stress is its image's) or with :attr:`weighted_band` off. The Warp
        plugin's ``band_sf``."""
        out = sf
        if ti.static(self.weighted_band):
            held = 0
            if ti.static(self.any_fixed or self.n_set_boxes > 0):
                if self.fixed[p] != 0 or self.held_axis(p) >= 0:
                    held = 1
            if held == 0:
                s = 2.0 * mu * eps + lam * eps.sum()
                im = 0
                if s[1] > s[im]:
                    im = 1
                if s[2] > s[im]:
                    im = 2
                X = (self.x[p] - self.lo[None]) * self.inv_dx[None]
                W = ti.cast(0.0, self.real)
                g = ti.cast(0.0, self.real)
                for a in ti.static(range(3)):
                    fx = X[a] - ti.floor(X[a] - 0.5)
                    w = 2.0 * fx * (1.5 - fx) ** 2
                    W += U[a, im] ** 2 * ti.max(w, 1.0 - w)
                    g += ti.abs(U[a, im])
                sfb = sf
                if ti.static(self.oblique_band):
                    if sf / g > ft:
                        sfb = sf / g
                out = ft + W * (sfb - ft)
        return out

    @ti.func
    def elastic_tau(self, kind, F, mu, lam):
        """The Kirchhoff stress of the hyperelastic models, a function of ``F`` alone (docs/mpm.md table): jelly's
        fixed corotated, neo-Hookean's; zero for every other ``kind``. Read by :meth:`return_mapping` and the midpoint
        stress (``mid_stress.py``)."""
        tau = ti.Matrix.zero(self.real, 3, 3)
        eye = ti.Matrix.identity(self.real, 3)
        if ti.static(JELLY in self.kinds):
            if kind == JELLY:
                R = self.svd_rotation(F)
                J = F.determinant()
                tau = 2.0 * mu * (F - R) @ F.transpose() + eye * (lam * J * (J - 1.0))
        if ti.static(NEO_HOOKEAN in self.kinds):
            if kind == NEO_HOOKEAN:
                J = F.determinant()
                tau = mu * (F @ F.transpose() - eye) + eye * (lam * ti.log(ti.max(J, 1e-6)))
        return tau

    @ti.func
    def return_mapping(self, p, F):
        """Return mapping and Kirchhoff stress (docs/mpm.md table). Writes F[p], Jp[p]; returns tau."""
        b = self.body[p]
        prm = self.mat[b]
        mu = prm[P_MU]
        lam = prm[P_LAM]
        kind = self.kind[b]
        if ti.static(not self.multi_kind):
            kind = ti.static(next(iter(self.kinds)))
        tau = self.elastic_tau(kind, F, mu, lam)   # the other models' below
        Jp = self.Jp[p]
        eye = ti.Matrix.identity(self.real, 3)
        if ti.static(SNOW in self.kinds):
            if kind == SNOW:
                h = ti.exp(prm[P_HARDENING] * (1.0 - Jp))
                U, sig, V = self.svd(F)
                sig_c = ti.min(ti.max(sig, 1.0 - prm[P_THETA_C]), 1.0 + prm[P_THETA_S])
                Jp *= (sig[0] * sig[1] * sig[2]) / (sig_c[0] * sig_c[1] * sig_c[2])
                F = self.udvt(U, sig_c, V)
                tau = self.corotated_tau(F, U, V, mu * h, lam * h)
        if ti.static(METAL in self.kinds or PLASTICINE in self.kinds or SAND in self.kinds):
            if kind == METAL or kind == PLASTICINE or kind == SAND:
                U, sig, V = self.svd(F)
                eps = ti.log(ti.max(sig, 1e-4))
                tr = eps.sum()
                e = eps - tr / 3.0
                ne = e.norm()
                if kind == SAND:
                    eps = self.drucker_prager(eps, mu, lam, self.mu_i_alpha(eps, mu, lam, prm))
                    F = self.udvt(U, ti.exp(eps), V)
                else:
                    yield_stress = prm[P_YIELD]
                    if kind == PLASTICINE:
                        yield_stress = prm[P_YIELD] * ti.max(0.0, 1.0 - prm[P_SOFTENING] * Jp)
                    dg = ne - VON_MISES_RADIUS * yield_stress / (2.0 * mu)   # ||dev tau|| <= sqrt(2/3) Y
                    if dg > 0.0:
                        eps -= dg * e / ne
                        F = self.udvt(U, ti.exp(eps), V)
                    if kind == PLASTICINE:
                        Jp += ti.max(dg, 0.0)
                tau = self.hencky_tau(U, eps, mu, lam)
        if ti.static(BRITTLE in self.kinds):
            if kind == BRITTLE:
                U, sig, V = self.svd(F)
                eps = ti.log(ti.max(sig, 1e-4))
                if Jp >= 1.0 and prm[P_CELLS] == 0.0:   # broken through: cohesionless sand (docs/fracture.md)
                    eps = self.drucker_prager(eps, mu, lam, prm[P_ALPHA])
                    F = self.udvt(U, ti.exp(eps), V)
                    tau = self.hencky_tau(U, eps, mu, lam)
                elif Jp < 0.0:   # a Grady cell's inside (initial_Jp -1) never damages (cells.py)
                    tau = self.hencky_tau(U, eps, mu, lam)
                else:   # in Grady's cells (P_CELLS) a broken point keeps its tension-free stress (cells.py)
                    sf = self.band_sf(p, U, eps, mu, lam, prm[P_FT], prm[P_SF])   # round 33's band weight
                    tau, Jp = self.brittle_tau(U, eps, mu, lam, prm[P_FT], sf, Jp)
                    if Jp >= 1.0 and prm[P_CELLS] != 0.0:   # its opening kept in F up to a stretch of 2 (cells.py)
                        eps = ti.min(eps, ti.static(CELL_OPENING))
                        F = self.udvt(U, ti.exp(eps), V)
                        tau, Jp = self.brittle_tau(U, eps, mu, lam, prm[P_FT], sf, Jp)
        if ti.static(LIQUID in self.kinds):
            if kind == LIQUID:
                J = F.determinant()
                F = eye * ti.pow(J, 1.0 / 3.0)
                tau = eye * (prm[P_K] * J * (J - 1.0))
        self.F[p] = F
        self.Jp[p] = Jp
        return tau
