"""Passive surface points: carried by the material's motion, carrying no mass.

An object with ``surface = "passive"`` hands the engine its triangle vertices as *passive* rows
(:attr:`gasp_core.seam.setup.SimSetup.passive`, ``p_vol = 0``) and its filled solid as the material
points. An engine with the feature ``passive_points`` moves them itself (a grid engine gathers
the grid velocity at them, G2P only). For every other engine :func:`build_with_fallback` builds
the engine on the material points alone and moves the passive points with an **embedding** fixed
at rest: each passive point ``p`` is bound to its ``K`` nearest material points ``i`` of the same
body with weights ``phi_i`` from a linear moving-least-squares fit (weights ``w_i = (1 - d_i^2 /
R^2)^2`` with ``R`` just beyond the ``K``-th distance). A linear MLS basis reproduces affine
fields, so ``sum_i phi_i = 1`` and ``sum_i phi_i x_i = p``: ``p(t) = sum_i phi_i x_i(t)`` is exact at
rest and for every affine (rigid included) motion of the neighbours. The basis is scaled by ``R``
so the moment matrix is of order one; where the neighbours are nearly coplanar its eigenvalues below
``MLS_RCOND`` times the largest are dropped (pseudo-inverse), which blends towards the weighted
average along the missing direction only.

Also here: the mass properties of a setup (:func:`mass_properties`), which every engine's
``stats()`` reports and the ``mass_agreement`` conformance scene compares.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from gasp_core.seam.setup import SimSetup

#: Material neighbours of each passive point in the core's embedding.
K_NEIGHBOURS = 12
#: Relative eigenvalue cut-off of the (scaled) MLS moment matrix's pseudo-inverse.
MLS_RCOND = 1e-8


def mls_embedding(points: np.ndarray, anchors: np.ndarray, k: int = K_NEIGHBOURS) -> tuple[np.ndarray, np.ndarray]:
    """Linear MLS weights binding ``points`` to their ``k`` nearest ``anchors``.

    Parameters
    ----------
    points : ndarray, shape (m, 3)
        Passive points at rest, metres.
    anchors : ndarray, shape (a, 3)
        Material points at rest, metres (``a >= 1``).
    k : int
        Neighbours per point (cut to ``a``).

    Returns
    -------
    idx : ndarray, shape (m, k), int64
        Rows of ``anchors``.
    phi : ndarray, shape (m, k), float64
        Weights: ``sum phi = 1`` and ``phi @ anchors[idx] == points`` (to rounding) when the
        neighbours span 3-D; ``points(t) = sum phi x_anchor(t)``.
    """
    points = np.asarray(points, dtype=np.float64)
    anchors = np.asarray(anchors, dtype=np.float64)
    k = int(min(k, len(anchors)))
    d, idx = cKDTree(anchors).query(points, k=k)
    d, idx = d.reshape(len(points), k), idx.reshape(len(points), k)
    R = d[:, -1:] * 1.5 + 1e-12
    w = (1.0 - (d / R) ** 2) ** 2                                   # (m, k) > 0
    r = (anchors[idx] - points[:, None, :]) / R[:, :, None]         # (m, k, 3), scaled by R
    P = np.concatenate([np.ones((len(points), k, 1)), r], axis=2)   # basis [1, r / R] at the neighbours
    M = np.einsum("mk,mki,mkj->mij", w, P, P)                       # (m, 4, 4) moment matrix
    lam, V = np.linalg.eigh(M)
    keep = lam > MLS_RCOND * lam[:, -1:]
    inv_lam = np.where(keep, 1.0 / np.where(keep, lam, 1.0), 0.0)
    c = np.einsum("mij,mj,mj->mi", V, inv_lam, V[:, 0, :])          # M^+ [1,0,0,0] (M symmetric)
    phi = w * np.einsum("mkj,mj->mk", P, c)                         # value of the fit at r = 0
    phi /= phi.sum(axis=1, keepdims=True)
    return idx.astype(np.int64), phi


class Embedding:
    """Passive rows of a setup bound to its material rows (per body; :func:`mls_embedding`).

    Attributes
    ----------
    passive_rows, material_rows : ndarray of int64
        Rows of the full setup.
    idx : ndarray, shape (n_passive, k), int64
        For each passive row, positions in ``material_rows`` of its anchors.
    phi : ndarray, shape (n_passive, k), float64
    """

    def __init__(self, setup: SimSetup, k: int = K_NEIGHBOURS):
        mask = setup.passive if setup.passive is not None else np.zeros(len(setup.x), bool)
        self.n = len(setup.x)
        self.passive_rows = np.flatnonzero(mask)
        self.material_rows = np.flatnonzero(~mask)
        kk = k
        self.idx = np.zeros((len(self.passive_rows), kk), np.int64)
        self.phi = np.zeros((len(self.passive_rows), kk))
        pos_in_mat = np.empty(self.n, np.int64)
        pos_in_mat[self.material_rows] = np.arange(len(self.material_rows))
        for b in np.unique(setup.body_id[self.passive_rows]):
            sel = np.flatnonzero(setup.body_id[self.passive_rows] == b)
            anchors = self.material_rows[setup.body_id[self.material_rows] == b]
            idx, phi = mls_embedding(setup.x[self.passive_rows[sel]], setup.x[anchors], kk)
            pad = kk - idx.shape[1]
            if pad:        # fewer anchors than k: repeat the first with weight 0
                idx = np.concatenate([idx, np.repeat(idx[:, :1], pad, 1)], 1)
                phi = np.concatenate([phi, np.zeros((len(phi), pad))], 1)
            self.idx[sel] = pos_in_mat[anchors[idx]]
            self.phi[sel] = phi

    def expand(self, material_values: np.ndarray) -> np.ndarray:
        """Values on every row from values on the material rows, shape (n, 3)."""
        vals = np.asarray(material_values)
        out = np.empty((self.n, vals.shape[1]), dtype=np.result_type(vals.dtype, np.float64))
        out[self.material_rows] = vals
        out[self.passive_rows] = np.einsum("mk,mkj->mj", self.phi, vals[self.idx])
        return out


class EmbeddedEngine:
    """A :class:`~gasp_core.seam.engine.PointEngine` over the material rows; passive rows embedded.

    Built by :func:`build_with_fallback` for engines without the feature ``passive_points``.
    """

    def __init__(self, inner, embedding: Embedding, setup: SimSetup):
        self.inner = inner
        self.embedding = embedding
        self.setup = setup

    def step_frame(self) -> None:
        self.inner.step_frame()

    def positions(self) -> np.ndarray:
        return self.embedding.expand(self.inner.positions())

    def velocities(self) -> np.ndarray:
        return self.embedding.expand(self.inner.velocities())

    def stats(self) -> dict[str, Any]:
        out = dict(self.inner.stats())
        out["n_points"] = len(self.setup.x)
        out["n_passive"] = len(self.embedding.passive_rows)
        out["passive"] = "embedded by the core (MLS, gasp_core.seam.passive)"
        return out

    def get_state(self) -> dict[str, np.ndarray]:
        """The inner engine's state (the embedding is fixed at rest, so it needs none of its own)."""
        return self.inner.get_state()

    def set_state(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`get_state` into the inner engine."""
        self.inner.set_state(state)

    def close(self) -> None:
        self.inner.close()


def material_setup(setup: SimSetup) -> SimSetup:
    """The setup restricted to its material rows (passive rows dropped; ``n_render`` counts the
    material rows among the rendered ones)."""
    keep = setup.material_mask
    return setup.replace(x=setup.x[keep], v=setup.v[keep], p_vol=setup.p_vol[keep],
                         body_id=setup.body_id[keep], C=None if setup.C is None else setup.C[keep],
                         n_render=int(keep[:setup.n_render].sum()), passive=None,
                         faint=None if setup.faint is None else setup.faint[keep])


def build_with_fallback(info, setup: SimSetup, build):
    """Build an engine for a setup with passive rows the engine cannot move itself.

    Parameters
    ----------
    info : EngineInfo
    setup : SimSetup
        With ``setup.passive``.
    build : callable
        ``build(info, setup) -> PointEngine`` (:func:`gasp_core.seam.build.build_engine`).

    Returns
    -------
    PointEngine
        ``build(info, setup)`` itself when the engine has the feature ``passive_points`` or the
        setup has no passive row, else an :class:`EmbeddedEngine`.
    """
    if setup.passive is None or "passive_points" in info.capabilities.features:
        return build(info, setup)
    emb = Embedding(setup)
    sub = material_setup(setup)
    inner = build(info, sub)
    setup.options = sub.options
    return EmbeddedEngine(inner, emb, setup)


def mass_properties(x: np.ndarray, mass: np.ndarray) -> dict[str, Any]:
    """Total mass (kg), centre of mass (m) and inertia tensor about it (kg m^2) of point masses.

    Parameters
    ----------
    x : ndarray, shape (n, 3)
    mass : ndarray, shape (n,)

    Returns
    -------
    dict
        ``mass`` float, ``centre_of_mass`` list of 3 floats, ``inertia`` 3x3 nested list.
    """
    x = np.asarray(x, dtype=np.float64)
    m = np.asarray(mass, dtype=np.float64)
    M = float(m.sum())
    c = (m @ x) / M if M > 0 else np.zeros(3)
    r = x - c
    inertia = np.eye(3) * float(np.einsum("n,ni,ni->", m, r, r)) - np.einsum("n,ni,nj->ij", m, r, r)
    return {"mass": M, "centre_of_mass": c.tolist(), "inertia": inertia.tolist()}


def setup_mass_properties(setup: SimSetup) -> dict[str, Any]:
    """:func:`mass_properties` of a setup at rest (``rho p_vol`` at ``x``)."""
    return mass_properties(setup.x, setup.p_mass)
