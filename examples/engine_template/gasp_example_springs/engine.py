"""The ``example_springs`` engine: points joined by damped springs, semi-implicit Euler, ground contact.

Model (deliberately simple; a template, not a calibrated elastic solver):

- mass of point ``i``: ``m_i = rho * p_vol_i`` (kg);
- springs join points of the same body closer than ``radius * h``, with ``h = mean(p_vol)^(1/3)`` the
  lattice spacing (m). A radius graph rather than k nearest neighbours: on a lattice the k-th
  neighbour is a tie, and ties broken by rounding make the network depend on the orientation;
- stiffness of a spring ``k = E h`` (N/m; the order of magnitude of a lattice of spacing h with
  Young's modulus E; Poisson's ratio is ignored), a dashpot ``c = 2 zeta sqrt(k m_red)`` along it;
- semi-implicit (symplectic) Euler, ``dt = cfl sqrt(min_i m_i / sum_j k_ij)`` unless ``n_substeps`` is given;
- ground ``z = height``: a point moving into it loses its normal velocity ``dv_n``, and its tangential
  velocity is reduced by ``friction * dv_n`` (Coulomb), as in docs/mpm.md.
"""
from __future__ import annotations

import math

import numpy as np
from scipy import sparse
from scipy.spatial import cKDTree

from gasp_core.seam import CAUSE_UNSTABLE, EngineDivergence, EngineStats, SceneError, SimSetup

ENGINE = "example_springs"


class SpringEngine:
    """A :class:`gasp_core.seam.PointEngine` over a mass-spring network.

    Parameters
    ----------
    setup : SimSetup
        Checked by the core (materials, boundaries, options with defaults filled in).

    Raises
    ------
    SceneError
        A point outside ``[domain_lo, domain_hi]`` (named by index and position).
    """

    def __init__(self, setup: SimSetup):
        # The core has refused unsupported materials/boundaries and bad options (build_engine);
        # what only this engine knows is checked here, as a SceneError naming the offender.
        out = np.flatnonzero(((setup.x < setup.domain_lo) | (setup.x > setup.domain_hi)).any(axis=1))
        if len(out):
            raise SceneError(f"engine '{ENGINE}': {len(out)} point(s) outside the domain "
                             f"[{setup.domain_lo.tolist()}, {setup.domain_hi.tolist()}] (first index {out[0]} "
                             f"at {setup.x[out[0]].tolist()})")
        o = setup.options
        self.setup, self.frame = setup, 0
        self.x = setup.x.copy()
        self.v = setup.v.copy()
        self.m = setup.p_mass.astype(np.float64)
        self.g = np.asarray(setup.gravity, dtype=np.float64)
        h = float(np.mean(setup.p_vol)) ** (1.0 / 3.0)
        pairs = cKDTree(self.x).query_pairs(o["radius"] * h, output_type="ndarray").reshape(-1, 2)
        pairs = pairs[setup.body_id[pairs[:, 0]] == setup.body_id[pairs[:, 1]]]  # bodies are not glued
        self.i, self.j = pairs[:, 0], pairs[:, 1]
        n = len(self.x)
        # incidence matrix: (D @ x)[s] = x[j_s] - x[i_s]; -(D.T @ F) puts +F on i_s and -F on j_s
        rows = np.repeat(np.arange(len(self.i)), 2)
        self.D = sparse.csr_matrix((np.tile([-1.0, 1.0], len(self.i)), (rows, np.stack([self.i, self.j], 1).ravel())),
                                   shape=(len(self.i), n))
        self.DT = self.D.T.tocsr()
        self.rest = np.linalg.norm(self.D @ self.x, axis=1)
        E = np.array([m.E for m in setup.materials])[setup.body_id]
        self.k = 0.5 * (E[self.i] + E[self.j]) * h
        m_red = self.m[self.i] * self.m[self.j] / (self.m[self.i] + self.m[self.j])
        self.c = 2.0 * o["damping"] * np.sqrt(self.k * m_red)
        k_sum = np.bincount(self.i, self.k, n) + np.bincount(self.j, self.k, n)
        linked = k_sum > 0
        dt_max = o["cfl"] * math.sqrt(float(np.min(self.m[linked] / k_sum[linked]))) if linked.any() else setup.frame_dt
        if o["n_substeps"] is not None:
            self.n_substeps = int(o["n_substeps"])
        else:
            self.n_substeps = max(1, math.ceil(setup.frame_dt / dt_max - 1e-9))
        self.dt = setup.frame_dt / self.n_substeps
        grounds = [b for b in setup.boundaries if b.kind == "ground"]
        self.ground = (grounds[0].height, grounds[0].friction) if grounds else None

    def _substep(self, dt: float) -> None:
        x, v = self.x, self.v
        d = self.D @ x
        length = np.sqrt(np.einsum("sd,sd->s", d, d))
        u = d / np.maximum(length, 1e-12)[:, None]
        f = self.k * (length - self.rest) + self.c * np.einsum("sd,sd->s", self.D @ v, u)  # > 0 pulls together
        v += dt * (self.g - (self.DT @ (f[:, None] * u)) / self.m[:, None])
        if self.ground is not None:
            height, friction = self.ground
            hit = (x[:, 2] + dt * v[:, 2] < height) & (v[:, 2] < 0.0)
            if hit.any():
                dvn = -v[hit, 2]
                vt = v[hit, :2]
                speed = np.linalg.norm(vt, axis=1)
                scale = np.clip(1.0 - friction * dvn / np.maximum(speed, 1e-12), 0.0, 1.0)
                v[hit, :2] = vt * scale[:, None]
                v[hit, 2] = 0.0
        x += dt * v
        if self.ground is not None:
            np.maximum(x[:, 2], self.ground[0], out=x[:, 2])

    def step_frame(self) -> None:
        """Advance ``frame_dt`` in ``n_substeps`` substeps.

        Raises
        ------
        EngineDivergence
            When positions or velocities become non-finite (the core also catches points leaving
            the domain).
        """
        self.frame += 1
        with np.errstate(over="ignore", invalid="ignore"):
            for _ in range(self.n_substeps):
                self._substep(self.dt)
        if not (np.isfinite(self.x).all() and np.isfinite(self.v).all()):
            raise EngineDivergence(f"non-finite positions or velocities (substep dt = {self.dt:.3g} s; lower "
                                   "option cfl, raise n_substeps, or soften E)", self.frame, CAUSE_UNSTABLE)

    def positions(self) -> np.ndarray:
        return self.x.copy()

    def velocities(self) -> np.ndarray:
        return self.v.copy()

    def stats(self) -> EngineStats:
        # mass and centre of mass as simulated: the conformance scene ``mass_agreement`` checks them
        mass = float(self.m.sum())
        return {"device": "cpu", "precision": "f64", "n_points": len(self.x), "n_springs": len(self.i),
                "n_substeps": self.n_substeps, "dt": self.dt, "mass": mass,
                "centre_of_mass": (self.m @ self.x / mass).tolist() if mass > 0 else None}

    def close(self) -> None:
        pass
