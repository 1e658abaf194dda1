"""GaMeS maps between flat Gaussians and triangles, flattening, and the alpha control rule.

A flat Gaussian ``(m, R = [r1, r2, r3], S = diag(eps, s2, s3))`` is the triangle
``v1 = m, v2 = m + s2 r2, v3 = m + s3 r3`` (map ``T``); ``T^-1`` rebuilds the Gaussian from a moved
triangle (GASP paper Sec. 3, "GaMeS", Eqs. for m-hat, r-hat, s-hat; Waczynska et al. 2024).
Rotations here are matrices ``(n, 3, 3)`` whose **columns** are the local axes r1, r2, r3;
r1 is the thin axis (the normal). Quaternion conversion lives in :mod:`gasp_core.gs.gaussians`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Thin-axis scale of a flat Gaussian (GaMeS writes ``scale_0 = log(1e-8)``).
EPS = 1e-8


@dataclass(frozen=True)
class FlattenReport:
    """How far from flat the input was.

    Attributes
    ----------
    n : int
        Gaussians.
    n_flat : int
        Gaussians whose thinnest/largest scale ratio was already below ``flat_ratio``.
    flat_ratio : float
        The threshold used (0.01).
    median_ratio, max_ratio : float
        Of ``min(scale) / max(scale)`` over all Gaussians (0 = perfectly flat, 1 = a sphere).
    n_reordered : int
        Gaussians whose thin axis was not already rotation column 0.
    """

    n: int
    n_flat: int
    flat_ratio: float
    median_ratio: float
    max_ratio: float
    n_reordered: int

    def as_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def flatten(scales: np.ndarray, rotmats: np.ndarray, eps: float = EPS,
            flat_ratio: float = 0.01) -> tuple[np.ndarray, np.ndarray, FlattenReport]:
    """Flatten Gaussians into the GaMeS convention.

    The thinnest axis becomes rotation column 0 (the normal) with scale ``eps``; the larger in-plane
    scale goes to column 1 (vertex v2), as the GaMeS code does. Column permutations that would
    make ``det R = -1`` negate the normal, so ``R`` stays a proper rotation.

    Parameters
    ----------
    scales : ndarray, shape (n, 3), float
        Activated (linear) scales, any units.
    rotmats : ndarray, shape (n, 3, 3), float
        Rotation matrices, columns = local axes, det +1.
    eps : float
        Thin-axis scale after flattening.
    flat_ratio : float
        A Gaussian with ``min/max`` scale ratio below this counts as already flat.

    Returns
    -------
    scales_flat : ndarray, shape (n, 3), float64
        ``[eps, s2, s3]`` with ``s2 >= s3``.
    rotmats_flat : ndarray, shape (n, 3, 3), float64
        Permuted (and sign-fixed) columns.
    report : FlattenReport

    Raises
    ------
    ValueError
        If the shapes are wrong or a scale is negative or non-finite.

    Notes
    -----
    GASP paper Sec. 3: "a non-flat 3DGS scene is flattened first". The thin scale (the third
    moment along the normal) is discarded; :mod:`gasp_core.run.pipeline` can restore it on output.
    """
    scales = np.asarray(scales, dtype=np.float64)
    rotmats = np.asarray(rotmats, dtype=np.float64)
    n = len(scales)
    if scales.shape != (n, 3) or rotmats.shape != (n, 3, 3):
        raise ValueError(f"flatten: expected scales (n, 3) and rotmats (n, 3, 3), got {scales.shape}, {rotmats.shape}")
    if not np.all(np.isfinite(scales)) or np.any(scales < 0):
        bad = int(np.flatnonzero(~(np.isfinite(scales) & (scales >= 0)).all(axis=1))[0])
        raise ValueError(f"flatten: scales must be finite and >= 0 (first bad Gaussian {bad})")
    order = np.argsort(scales, axis=1, kind="stable")   # ascending
    perm = order[:, [0, 2, 1]]                          # thin, largest, middle
    rows = np.arange(n)[:, None]
    scales_flat = scales[rows, perm]
    scales_flat[:, 0] = eps
    rot = np.take_along_axis(rotmats, perm[:, None, :], axis=2)
    flip = np.linalg.det(rot) < 0
    rot[flip, :, 0] *= -1.0
    return scales_flat, rot, flatten_report(scales, flat_ratio, perm)


def flatten_report(scales: np.ndarray, flat_ratio: float = 0.01, perm: np.ndarray | None = None) -> FlattenReport:
    """The :class:`FlattenReport` of :func:`flatten` for Gaussians of these activated scales, shape (n, 3).

    ``perm`` (n, 3) is :func:`flatten` 's column order (recomputed when None): a subset of flattened
    rows gets its report without being flattened again.
    """
    scales = np.asarray(scales, dtype=np.float64)
    n = len(scales)
    if perm is None:
        perm = np.argsort(scales, axis=1, kind="stable")[:, [0, 2, 1]]
    ratio = scales.min(axis=1) / np.maximum(scales.max(axis=1), np.finfo(float).tiny)
    return FlattenReport(
        n=n, n_flat=int(np.sum(ratio < flat_ratio)), flat_ratio=flat_ratio,
        median_ratio=float(np.median(ratio)) if n else 0.0,
        max_ratio=float(ratio.max()) if n else 0.0,
        n_reordered=int(np.sum(np.any(perm != [0, 1, 2], axis=1))))


def gaussians_to_triangles(means: np.ndarray, rotmats: np.ndarray, scales: np.ndarray) -> np.ndarray:
    """GaMeS map ``T``: flat Gaussians to triangles.

    Parameters
    ----------
    means : ndarray, shape (n, 3)
        Metres (or file units).
    rotmats : ndarray, shape (n, 3, 3)
        Columns r1 (normal), r2, r3.
    scales : ndarray, shape (n, 3)
        ``[eps, s2, s3]``, same units as ``means``.

    Returns
    -------
    triangles : ndarray, shape (n, 3, 3), float64
        ``triangles[:, k]`` is vertex v_{k+1}: ``v1 = m``, ``v2 = m + s2 r2``, ``v3 = m + s3 r3``.

    Raises
    ------
    ValueError
        If the shapes are not (n, 3), (n, 3, 3) and (n, 3) for one ``n`` (nothing is broadcast).

    Notes
    -----
    GASP paper Sec. 3 (GaMeS parametrisation).
    """
    means = np.asarray(means, dtype=np.float64)
    rotmats = np.asarray(rotmats, dtype=np.float64)
    scales = np.asarray(scales, dtype=np.float64)
    n = len(means) if means.ndim else -1
    if means.shape != (n, 3) or rotmats.shape != (n, 3, 3) or scales.shape != (n, 3):
        raise ValueError(f"gaussians_to_triangles: expected means (n, 3), rotmats (n, 3, 3) and scales (n, 3), got "
                         f"{means.shape}, {rotmats.shape}, {scales.shape}")
    tri = np.empty((len(means), 3, 3))
    tri[:, 0] = means
    tri[:, 1] = means + scales[:, 1:2] * rotmats[:, :, 1]
    tri[:, 2] = means + scales[:, 2:3] * rotmats[:, :, 2]
    return tri


def _unit(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    nrm = np.linalg.norm(a, axis=-1)
    return a / np.where(nrm > 0, nrm, 1.0)[..., None], nrm


def triangles_to_gaussians(triangles: np.ndarray, fallback: np.ndarray | None = None,
                           eps: float = EPS) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """GaMeS inverse map ``T^-1``: triangles to flat Gaussians.

    ``m = v1``; ``r1 = unit((v2 - v1) x (v3 - v1))``; ``r2 = unit(v2 - v1)``;
    ``r3 = unit(orth(v3 - v1; r1, r2))`` (one Gram-Schmidt step); ``s = (eps, |v2 - v1|, <v3 - v1, r3>)``.
    ``[r1, r2, r3]`` is then always a proper rotation and ``s3 > 0``.

    Parameters
    ----------
    triangles : ndarray, shape (n, 3, 3)
        Vertices v1, v2, v3 of each face.
    fallback : ndarray, shape (n, 3, 3), optional
        Rotation to use for degenerate faces (the rest or previous-frame rotation); identity if
        not given.
    eps : float
        Thin-axis scale, and the floor of the in-plane scales.

    Returns
    -------
    means : ndarray, shape (n, 3), float64
    rotmats : ndarray, shape (n, 3, 3), float64
    scales : ndarray, shape (n, 3), float64
        ``[eps, s2, s3]``, each ``>= eps``.
    degenerate : ndarray, shape (n,), bool
        Faces whose edge collapsed or whose area vanished (``|e2 x e3| <= 1e-12 |e2| |e3|``).

    Notes
    -----
    GASP paper Sec. 3, Eqs. for ``m-hat``, ``R-hat``, ``S-hat``. Degenerate faces (the paper leaves
    them undefined): the rotation is ``fallback``; the scales are the edge lengths projected on
    the fallback's in-plane axes, floored at ``eps``. The result is finite for any finite input;
    non-finite vertices give a ``ValueError`` naming the first face.

    Raises
    ------
    ValueError
        If ``triangles`` is not (n, 3, 3) or holds non-finite values.
    """
    tri = np.asarray(triangles, dtype=np.float64)
    if tri.ndim != 3 or tri.shape[1:] != (3, 3):
        raise ValueError(f"triangles_to_gaussians: expected shape (n, 3, 3), got {tri.shape}")
    finite = np.isfinite(tri).all(axis=(1, 2))
    if not finite.all():
        raise ValueError(f"triangles_to_gaussians: non-finite vertex in face {int(np.flatnonzero(~finite)[0])}")
    v1 = tri[:, 0]
    e2 = tri[:, 1] - v1
    e3 = tri[:, 2] - v1
    r1, area2 = _unit(np.cross(e2, e3))
    r2, l2 = _unit(e2)
    l3 = np.linalg.norm(e3, axis=1)
    degenerate = ~(area2 > 1e-12 * l2 * l3) | (l2 == 0) | (l3 == 0)
    r3, _ = _unit(e3 - np.sum(e3 * r2, axis=1, keepdims=True) * r2)
    rot = np.stack([r1, r2, r3], axis=2)
    s2 = l2
    s3 = np.sum(e3 * r3, axis=1)
    if degenerate.any():
        fb = np.broadcast_to(np.eye(3), (len(tri), 3, 3)) if fallback is None else np.asarray(fallback, np.float64)
        rot[degenerate] = fb[degenerate]
        s2 = np.where(degenerate, np.abs(np.sum(e2 * rot[:, :, 1], axis=1)), s2)
        s3 = np.where(degenerate, np.abs(np.sum(e3 * rot[:, :, 2], axis=1)), s3)
    scales = np.stack([np.full(len(tri), eps), np.maximum(s2, eps), np.maximum(s3, eps)], axis=1)
    return v1.copy(), rot, scales, degenerate



#: Rebuild rules of ``T^-1`` (``[[object]] rebuild``): the paper's GaMeS Gram-Schmidt, or the moved
#: triangle's covariance ``F Sigma F^T`` (PhysGaussian Eq. 6, with ``F`` the triangle's own map).
REBUILDS = ("games", "covariance")


def triangles_to_gaussians_covariance(triangles: np.ndarray, fallback: np.ndarray | None = None,
                                      eps: float = EPS) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``T^-1`` by covariance: the flat Gaussian whose covariance is ``e2 e2^T + e3 e3^T``.

    With ``e2 = v2 - v1`` and ``e3 = v3 - v1`` the moved edges, and the rest edges ``s2 r2``, ``s3 r3``
    (map ``T``), the affine map ``F`` that carries the rest triangle onto the moved one gives
    ``F Sigma F^T = F (s2^2 r2 r2^T + s3^2 r3 r3^T) F^T = e2 e2^T + e3 e3^T`` (plus ``eps^2`` along the
    normal): PhysGaussian's covariance update (Xie et al. 2024, Eq. 6) with the deformation gradient
    the triangle itself defines in its plane. The in-plane axes and standard deviations are the left
    singular vectors and singular values of ``[e2, e3]``. Same mean, normal and in-plane area as
    :func:`triangles_to_gaussians`; identical for rotation, uniform stretch and any map that keeps the
    edges orthogonal; under shear it keeps the ellipse's shear where Gram-Schmidt drops it
    (``docs/rebuild.md``).

    Parameters
    ----------
    triangles : ndarray, shape (n, 3, 3)
        Vertices v1, v2, v3 of each face, metres.
    fallback : ndarray, shape (n, 3, 3), optional
        Rotation for degenerate faces (as :func:`triangles_to_gaussians`).
    eps : float
        Thin-axis scale, and the floor of the in-plane scales.

    Returns
    -------
    means, rotmats, scales, degenerate
        As :func:`triangles_to_gaussians`: ``rotmats[:, :, 0]`` is the unit normal (the sign of
        ``e2 x e3``), columns 1 and 2 the major and minor in-plane axes; ``scales = [eps, s_major,
        s_minor]``.

    Raises
    ------
    ValueError
        If ``triangles`` is not (n, 3, 3) or holds non-finite values.
    """
    v1, rot_g, scales_g, degenerate = triangles_to_gaussians(triangles, fallback, eps)
    tri = np.asarray(triangles, dtype=np.float64)
    edges = np.stack([tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]], axis=2)         # (n, 3, 2)
    u, sv, _ = np.linalg.svd(edges, full_matrices=False)                             # (n,3,2), (n,2)
    normal = rot_g[:, :, 0]
    a1, a2 = u[:, :, 0], u[:, :, 1]
    a2 = np.where(np.sum(np.cross(a1, a2) * normal, axis=1, keepdims=True) < 0, -a2, a2)   # right-handed
    rot = np.stack([normal, a1, a2], axis=2)
    scales = np.stack([np.full(len(tri), eps), np.maximum(sv[:, 0], eps), np.maximum(sv[:, 1], eps)], axis=1)
    rot[degenerate] = rot_g[degenerate]
    scales[degenerate] = scales_g[degenerate]
    return v1, rot, scales, degenerate


def limit_edges(tri_rest: np.ndarray, tri_t: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """The alpha rule on the edges themselves, for the covariance rebuild: an edge ``v_i - v1`` stretched
    past ``alpha`` times its rest length is shortened to ``alpha`` times it, along its own direction.

    For :func:`triangles_to_gaussians` this is :func:`alpha_rule` on ``s2`` (``s2 = |v2 - v1|``);
    for :func:`triangles_to_gaussians_covariance` it bounds the covariance the same way, and it only
    ever shrinks (paper Eq. alpha_rule; issue 17).

    Parameters
    ----------
    tri_rest, tri_t : ndarray, shape (n, 3, 3)
        Rest and moved triangles, metres.
    alpha : float
        Allowed stretch factor, > 0.

    Returns
    -------
    triangles : ndarray, shape (n, 3, 3), float64
        ``tri_t`` with the over-stretched edges shortened (``v1`` unchanged).
    clamped : ndarray, shape (n, 2), bool
        Which of the edges ``v2 - v1``, ``v3 - v1`` were shortened.

    Raises
    ------
    ValueError
        If ``alpha <= 0``.
    """
    if not alpha > 0:
        raise ValueError(f"limit_edges: alpha must be > 0, got {alpha}")
    out = np.array(tri_t, dtype=np.float64, copy=True)
    e_t = out[:, 1:] - out[:, :1]
    d_t = np.linalg.norm(e_t, axis=2)
    d_0 = np.linalg.norm(np.asarray(tri_rest, np.float64)[:, 1:] - np.asarray(tri_rest, np.float64)[:, :1], axis=2)
    clamped = d_t > alpha * d_0
    factor = np.where(clamped, alpha * d_0 / np.where(d_t > 0, d_t, 1.0), 1.0)
    out[:, 1:] = out[:, :1] + e_t * factor[:, :, None]
    return out, clamped

def alpha_rule(tri_rest: np.ndarray, tri_t: np.ndarray, scales_t: np.ndarray,
               scales_rest: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """The paper's control rule on Gaussian size.

    Where ``|phi(v1) - phi(vi)| > alpha |v1 - vi|`` (i = 2, 3), the scale ``s_i`` is limited to
    ``alpha`` times its rest value: ``s_i = min(s_i, alpha s_i_rest)``. The rule only ever shrinks
    a scale; under shear ``s3`` from ``T^-1`` (the height of the triangle) can be far below the
    stretched edge, and setting it to ``alpha s3_rest`` would enlarge it (issue 17).

    Parameters
    ----------
    tri_rest, tri_t : ndarray, shape (n, 3, 3)
        Rest and moved triangles.
    scales_t, scales_rest : ndarray, shape (n, 3)
        Scales from ``T^-1`` of the moved and of the rest triangles (``[eps, s2, s3]``).
    alpha : float
        Allowed stretch factor, > 0.

    Returns
    -------
    scales : ndarray, shape (n, 3), float64
        Clamped copy of ``scales_t``.
    clamped : ndarray, shape (n, 2), bool
        Which of s2, s3 the rule made smaller (edge over ``alpha`` and scale over
        ``alpha s_rest``).

    Raises
    ------
    ValueError
        If ``alpha <= 0``.

    Notes
    -----
    GASP paper Eq. (alpha_rule); Table 4 ablates alpha = 1 (best FID) to 5 and no rule. The paper
    says ``s_i`` "should be identical to" ``alpha s_i_rest``; it is a rule against oversized
    Gaussians, so a scale already below that bound is kept.
    """
    if not alpha > 0:
        raise ValueError(f"alpha_rule: alpha must be > 0, got {alpha}")
    d_t = np.linalg.norm(tri_t[:, 1:] - tri_t[:, :1], axis=2)          # (n, 2)
    d_0 = np.linalg.norm(tri_rest[:, 1:] - tri_rest[:, :1], axis=2)
    out = np.array(scales_t, dtype=np.float64, copy=True)
    bound = alpha * np.asarray(scales_rest, dtype=np.float64)[:, 1:]
    clamped = (d_t > alpha * d_0) & (out[:, 1:] > bound)
    out[:, 1:] = np.where(clamped, bound, out[:, 1:])
    return out, clamped
