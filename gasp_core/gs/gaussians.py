"""The in-memory Gaussian Splatting model and quaternion / rotation-matrix helpers.

A :class:`Gaussians` holds one trained scene in the field's standard terms (see
the project's style guide, ``shared/STYLE.md``): ``means (N,3)``, activated ``scales (N,3)``, unit quaternions
``rotations (N,4)`` in **wxyz** order, raw logit ``opacities (N,)``, ``sh_dc (N,3)`` and
``sh_rest (N,K,3)``. Geometry is float64 (it is transformed and simulated); appearance fields
stay the float32 values read from the file so that a write-back is bit for bit
(:mod:`gasp_core.gs.io`).

Conventions
-----------
* Covariance ``Sigma = R diag(scales)^2 R^T`` with ``R = quat_to_rotmat(rotations)``; column ``j``
  of ``R`` is the local axis that ``scales[:, j]`` measures (graphdeco-inria/gaussian-splatting,
  ``utils/general_utils.py: build_rotation, build_scaling_rotation``).
* Flat (GaMeS) Gaussians have their thin axis in column 0: ``scales[:, 0] == eps`` (GaMeS writes
  ``scale_0 = log(1e-8)``). 2DGS files are converted to this convention on read
  (:func:`gasp_core.gs.io.read_gaussians`).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from gasp_core.errors import SceneError

#: Spherical-harmonics rest coefficients per colour channel, by SH degree 0..3.
SH_REST_COUNT = {0: 0, 1: 3, 2: 8, 3: 15}

#: Layout names a :class:`Gaussians` may carry (the file layout it was read from).
LAYOUTS = frozenset({"3dgs", "games", "2dgs", "compressed", "splatv", "spz", "glb", "sog", "splat", "ksplat"})

#: Largest ``|mean|`` component and largest scale accepted, file units: their squares (distances,
#: covariances) stay finite in float32 (largest 3.4e38) with a factor 300 to spare.
MAX_MAGNITUDE = 1e18


def quat_to_rotmat(q: np.ndarray) -> np.ndarray:
    """Rotation matrices of quaternions, vectorised.

    Parameters
    ----------
    q : array-like, shape (n, 4) or (4,)
        Quaternions **w, x, y, z**. They are normalised here, so an unnormalised quaternion
        (as graphdeco PLYs store them) gives the same matrix as its unit version.

    Returns
    -------
    R : ndarray, shape (n, 3, 3) (or (3, 3) for a single quaternion), float64
        Proper rotation matrices; column ``j`` is local axis ``j`` in world coordinates, so that
        ``x_world = R @ x_local``.

    Raises
    ------
    ValueError
        If the last dimension is not 4.

    Notes
    -----
    Standard Hamilton convention, identical to graphdeco-inria/gaussian-splatting
    ``utils/general_utils.py: build_rotation`` (which takes ``r = q[:, 0]`` as the real part).
    A zero quaternion gives NaN rows; :class:`Gaussians` rejects those before they get here.
    """
    q = np.asarray(q, dtype=np.float64)
    single = q.ndim == 1
    q = np.atleast_2d(q)
    if q.shape[-1] != 4:
        raise ValueError(f"quat_to_rotmat: expected shape (n, 4) wxyz, got {q.shape}")
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    R = np.empty((len(q), 3, 3))
    R[:, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[:, 0, 1] = 2.0 * (x * y - w * z)
    R[:, 0, 2] = 2.0 * (x * z + w * y)
    R[:, 1, 0] = 2.0 * (x * y + w * z)
    R[:, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[:, 1, 2] = 2.0 * (y * z - w * x)
    R[:, 2, 0] = 2.0 * (x * z - w * y)
    R[:, 2, 1] = 2.0 * (y * z + w * x)
    R[:, 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return R[0] if single else R


def rotmat_to_quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) of rotation matrices, vectorised.

    Parameters
    ----------
    R : array-like, shape (n, 3, 3) or (3, 3)
        Proper rotation matrices (columns = local axes, as :func:`quat_to_rotmat` returns).

    Returns
    -------
    q : ndarray, shape (n, 4) (or (4,)), float64
        Unit quaternions **w, x, y, z**, canonical sign ``w >= 0``.

    Raises
    ------
    ValueError
        If the trailing shape is not (3, 3).

    Notes
    -----
    Shepperd's method (S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and
    Control 1(3), 1978): of ``4w^2 = 1 + tr R`` and ``4x^2 = 1 + 2 R00 - tr R`` (and y, z alike)
    it takes the largest, so the divisor is never below ``1/2`` and the result is accurate for
    every rotation, including 180-degree turns where ``w = 0``. The result is renormalised, so a
    slightly non-orthogonal input gives a nearby unit quaternion.
    """
    R = np.asarray(R, dtype=np.float64)
    single = R.ndim == 2
    if single:
        R = R[None]
    if R.shape[-2:] != (3, 3):
        raise ValueError(f"rotmat_to_quat: expected shape (n, 3, 3), got {R.shape}")
    m00, m11, m22 = R[:, 0, 0], R[:, 1, 1], R[:, 2, 2]
    tr = m00 + m11 + m22
    # candidates 4w^2, 4x^2, 4y^2, 4z^2 (times 1, up to a common factor)
    cand = np.stack([tr, m00, m11, m22], axis=1)
    k = np.argmax(cand, axis=1)
    q = np.empty((len(R), 4))
    # case w largest
    i = k == 0
    s = np.sqrt(1.0 + tr[i]) * 2.0  # s = 4w
    q[i, 0] = 0.25 * s
    q[i, 1] = (R[i, 2, 1] - R[i, 1, 2]) / s
    q[i, 2] = (R[i, 0, 2] - R[i, 2, 0]) / s
    q[i, 3] = (R[i, 1, 0] - R[i, 0, 1]) / s
    # case x largest
    i = k == 1
    s = np.sqrt(np.maximum(1.0 + m00[i] - m11[i] - m22[i], 0.0)) * 2.0  # s = 4x
    q[i, 0] = (R[i, 2, 1] - R[i, 1, 2]) / s
    q[i, 1] = 0.25 * s
    q[i, 2] = (R[i, 0, 1] + R[i, 1, 0]) / s
    q[i, 3] = (R[i, 0, 2] + R[i, 2, 0]) / s
    # case y largest
    i = k == 2
    s = np.sqrt(np.maximum(1.0 + m11[i] - m00[i] - m22[i], 0.0)) * 2.0  # s = 4y
    q[i, 0] = (R[i, 0, 2] - R[i, 2, 0]) / s
    q[i, 1] = (R[i, 0, 1] + R[i, 1, 0]) / s
    q[i, 2] = 0.25 * s
    q[i, 3] = (R[i, 1, 2] + R[i, 2, 1]) / s
    # case z largest
    i = k == 3
    s = np.sqrt(np.maximum(1.0 + m22[i] - m00[i] - m11[i], 0.0)) * 2.0  # s = 4z
    q[i, 0] = (R[i, 1, 0] - R[i, 0, 1]) / s
    q[i, 1] = (R[i, 0, 2] + R[i, 2, 0]) / s
    q[i, 2] = (R[i, 1, 2] + R[i, 2, 1]) / s
    q[i, 3] = 0.25 * s
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[q[:, 0] < 0] *= -1.0
    return q[0] if single else q


def _first_bad_row(bad: np.ndarray) -> int:
    """Index of the first row of a boolean array (n,) or (n, k) that has a True."""
    if bad.ndim > 1:
        bad = bad.reshape(len(bad), -1).any(axis=1)
    return int(np.flatnonzero(bad)[0])


def _check_values(g: "Gaussians", fail) -> None:
    """The value checks of :meth:`Gaussians.check`; ``fail(msg)`` raises."""
    bad = ~np.isfinite(g.means)
    if bad.any():
        fail(f"field 'means': non-finite position at index {_first_bad_row(bad)}")
    bad = ~np.isfinite(g.rotations)
    if bad.any():
        fail(f"field 'rotations': non-finite quaternion at index {_first_bad_row(bad)}")
    bad = ~(np.linalg.norm(g.rotations, axis=1) > 1e-12)
    if bad.any():
        fail(f"field 'rotations': zero-norm quaternion at index {_first_bad_row(bad)}")
    bad = ~(np.isfinite(g.scales) & (g.scales >= 0))
    if bad.any():
        fail(f"field 'scales': expected finite scales >= 0, bad at index {_first_bad_row(bad)}")
    for name in ("means", "scales"):
        bad = np.abs(getattr(g, name)) > MAX_MAGNITUDE
        if bad.any():
            i = _first_bad_row(bad)
            fail(f"field '{name}': {getattr(g, name)[i].tolist()} at index {i}; expected magnitudes "
                 f"<= {MAX_MAGNITUDE:g} (float32 headroom)")
    for name in ("opacities", "sh_dc", "sh_rest"):  # an opacity logit of +-inf is alpha 1 or 0
        bad = np.isnan(g.opacities) if name == "opacities" else ~np.isfinite(getattr(g, name))
        if bad.any():
            fail(f"field '{name}': non-finite value at index {_first_bad_row(bad)}")


@dataclass
class Gaussians:
    """A Gaussian Splatting scene, one row per Gaussian.

    Attributes
    ----------
    means : ndarray, shape (n, 3), float64
        Centres, file units (metres once the scene says so).
    scales : ndarray, shape (n, 3), float64
        Activated standard deviations along the local axes (``exp`` of the PLY log scales),
        file units. Flat Gaussians have ``scales[:, 0] == FLAT_EPS`` (thin axis = column 0).
    rotations : ndarray, shape (n, 4), float64
        Unit quaternions **w, x, y, z** (normalised here; the stored norms are not kept).
    opacities : ndarray, shape (n,), float32
        Raw opacity logits as stored (``sigmoid(opacities)`` is the opacity).
    sh_dc : ndarray, shape (n, 3), float32
        Degree-0 SH coefficients (``f_dc_0..2``); colour ``0.5 + 0.28209479 * sh_dc``.
    sh_rest : ndarray, shape (n, K, 3), float32
        Higher SH coefficients, coefficient-major with channel last; ``K`` is 0, 3, 8 or 15 for
        SH degree 0..3.
    extra : dict of str -> ndarray, shape (n,)
        Other per-vertex properties, kept verbatim (dtype included), e.g. ``nx, ny, nz``.
    source : str
        Path the scene was read from ("" if built in memory); used in error messages.
    layout : str
        File layout it was read from, one of :data:`LAYOUTS`.
    meta : dict
        Layout details needed to write the file back, e.g. for 2DGS
        ``{"rotation_columns_from_file": (2, 0, 1)}``: column ``j`` of ``R`` is column
        ``perm[j]`` of the stored rotation. Never per-Gaussian arrays (those go in ``extra``):
        :meth:`subset` and :meth:`copy` carry it over unchanged.

    Raises
    ------
    SceneError
        From the constructor, if a shape is wrong, a mean or rotation is not finite, a quaternion
        has zero norm, a scale is negative or not finite, a mean or scale exceeds
        :data:`MAX_MAGNITUDE`, an opacity is NaN (+-inf logits are alpha 1 and 0) or an SH
        coefficient is not finite; the message names
        ``source``, the field and the first bad index.
    """

    means: np.ndarray
    scales: np.ndarray
    rotations: np.ndarray
    opacities: np.ndarray
    sh_dc: np.ndarray
    sh_rest: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    source: str = ""
    layout: str = "3dgs"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        self.means = np.ascontiguousarray(self.means, dtype=np.float64)
        n = len(self.means) if self.means.ndim else 0
        self.scales = np.ascontiguousarray(self.scales, dtype=np.float64)
        self.rotations = np.ascontiguousarray(self.rotations, dtype=np.float64)
        self.opacities = np.ascontiguousarray(self.opacities, dtype=np.float32)
        self.sh_dc = np.ascontiguousarray(self.sh_dc, dtype=np.float32)
        if self.sh_rest is None:
            self.sh_rest = np.zeros((n, 0, 3), dtype=np.float32)
        self.sh_rest = np.ascontiguousarray(self.sh_rest, dtype=np.float32)
        self.extra = {str(key): np.asarray(val) for key, val in self.extra.items()}
        self.check()
        norm = np.linalg.norm(self.rotations, axis=1)
        off = np.abs(norm - 1.0) > 1e-12  # leave unit rows untouched so copies stay equal
        if off.any():
            self.rotations = self.rotations.copy()  # never scale the caller's array in place
            self.rotations[off] /= norm[off, None]

    def check(self, where: str | None = None) -> None:
        """Refuse what the constructor refuses, as the fields are now: a writer calls it, since the arrays can be
        changed after the Gaussians were built (``g.scales[0] = nan``).

        Parameters
        ----------
        where : str, optional
            What the message names first (a file being written); default ``source``.

        Raises
        ------
        SceneError
            As the class (a shape, a non-finite or zero-norm quaternion, a negative or non-finite scale, ...);
            the message names ``where``, the field and the first bad index.
        """
        where = where or self.source or "<in-memory Gaussians>"

        def fail(msg: str):
            raise SceneError(f"{where}: {msg}")

        if self.means.ndim != 2 or self.means.shape[1] != 3:
            fail(f"field 'means': expected shape (n, 3), got {self.means.shape}")
        n = len(self.means)
        for name, shape in (("scales", (n, 3)), ("rotations", (n, 4)), ("opacities", (n,)),
                            ("sh_dc", (n, 3))):
            got = getattr(self, name).shape
            if got != shape:
                fail(f"field '{name}': expected shape {shape}, got {got}")
        k = self.sh_rest.shape[1] if self.sh_rest.ndim == 3 else -1
        if self.sh_rest.ndim != 3 or self.sh_rest.shape[0] != n or self.sh_rest.shape[2] != 3 \
                or k not in SH_REST_COUNT.values():
            fail(f"field 'sh_rest': expected shape ({n}, K, 3) with K in (0, 3, 8, 15), "
                 f"got {self.sh_rest.shape}")
        for key, val in self.extra.items():
            if val.shape != (n,):
                fail(f"extra property '{key}': expected shape ({n},), got {val.shape}")
        if self.layout not in LAYOUTS:
            fail(f"layout '{self.layout}': expected one of {sorted(LAYOUTS)}")
        _check_values(self, fail)

    @property
    def n(self) -> int:
        """Number of Gaussians."""
        return len(self.means)

    def __len__(self) -> int:
        return len(self.means)

    @property
    def sh_degree(self) -> int:
        """SH degree 0..3, from ``sh_rest.shape[1]``."""
        k = self.sh_rest.shape[1]
        return next(d for d, count in SH_REST_COUNT.items() if count == k)

    def rotmats(self) -> np.ndarray:
        """Rotation matrices, shape (n, 3, 3), float64 (columns = local axes)."""
        return quat_to_rotmat(self.rotations)

    def copy(self) -> "Gaussians":
        """A deep copy (arrays and dicts copied)."""
        return dataclasses.replace(
            self, means=self.means.copy(), scales=self.scales.copy(),
            rotations=self.rotations.copy(), opacities=self.opacities.copy(),
            sh_dc=self.sh_dc.copy(), sh_rest=self.sh_rest.copy(),
            extra={k: v.copy() for k, v in self.extra.items()}, meta=dict(self.meta))

    def subset(self, idx) -> "Gaussians":
        """The Gaussians selected by ``idx`` (integer indices, a slice or a boolean mask (n,)).

        Raises
        ------
        IndexError
            If an index is out of range (numpy's error).
        """
        if isinstance(idx, slice):
            idx = np.arange(self.n)[idx]
        idx = np.atleast_1d(np.asarray(idx))
        if idx.dtype == bool and idx.shape != (self.n,):
            raise IndexError(f"subset: boolean mask must have shape ({self.n},), got {idx.shape}")
        return dataclasses.replace(
            self, means=self.means[idx], scales=self.scales[idx], rotations=self.rotations[idx],
            opacities=self.opacities[idx], sh_dc=self.sh_dc[idx], sh_rest=self.sh_rest[idx],
            extra={k: v[idx] for k, v in self.extra.items()}, meta=dict(self.meta))
