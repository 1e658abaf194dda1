"""View-dependent colour: real spherical harmonics up to degree 3, as the 3DGS rasteriser evaluates them.

Source: graphdeco-inria/gaussian-splatting ``utils/sh_utils.py: eval_sh`` (constants and sign
conventions) and ``gaussian_renderer/__init__.py`` (direction ``mean - camera centre``, colour
``max(0, sh + 0.5)``). A Gaussian that the simulation turns carries its colour with it: the view
direction is taken into the Gaussian's rest frame before evaluating, ``d_rest = R_0 R_t^T d`` with
``R_0``, ``R_t`` its rotations at frame 0 and frame ``t`` (PhysGaussian, Xie et al. 2024, rotates the
SH coefficients by the rotation of the deformation's polar decomposition; rotating the direction the
other way is the same thing, since SH of one degree span a rotation-invariant space).
"""
from __future__ import annotations

import numpy as np

SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396)
SH_C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154,
         -0.4570457994644658, 1.445305721320277, -0.5900435899266435)


def sh_basis(dirs: np.ndarray, degree: int) -> np.ndarray:
    """The 3DGS real SH basis at unit directions.

    Parameters
    ----------
    dirs : ndarray, shape (n, 3)
        Unit view directions (Gaussian centre minus camera centre, normalised).
    degree : int
        0 to 3.

    Returns
    -------
    ndarray, shape (n, (degree + 1) ** 2), float64
        Column ``k`` multiplies coefficient ``k`` (0 = DC, then ``sh_rest[:, k - 1]``).

    Raises
    ------
    ValueError
        If ``degree`` is not 0..3.
    """
    if degree not in (0, 1, 2, 3):
        raise ValueError(f"SH degree: expected 0, 1, 2 or 3, got {degree}")
    x, y, z = (np.asarray(dirs, dtype=np.float64)[:, i] for i in range(3))
    cols = [np.full_like(x, SH_C0)]
    if degree > 0:
        cols += [-SH_C1 * y, SH_C1 * z, -SH_C1 * x]
    if degree > 1:
        xx, yy, zz = x * x, y * y, z * z
        cols += [SH_C2[0] * x * y, SH_C2[1] * y * z, SH_C2[2] * (2 * zz - xx - yy), SH_C2[3] * x * z,
                 SH_C2[4] * (xx - yy)]
    if degree > 2:
        cols += [SH_C3[0] * y * (3 * xx - yy), SH_C3[1] * x * y * z, SH_C3[2] * y * (4 * zz - xx - yy),
                 SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy), SH_C3[4] * x * (4 * zz - xx - yy),
                 SH_C3[5] * z * (xx - yy), SH_C3[6] * x * (xx - 3 * yy)]
    return np.stack(cols, axis=1)


def sh_colours(sh: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """Colours ``max(0, sum_k basis_k(d) sh_k + 0.5)`` of Gaussians seen along ``dirs``.

    Parameters
    ----------
    sh : ndarray, shape (n, (degree + 1) ** 2, 3)
        Coefficients, DC first (``sh_dc`` then ``sh_rest``), per colour channel.
    dirs : ndarray, shape (n, 3)
        Unit directions in the frame the coefficients were fitted in.

    Returns
    -------
    ndarray, shape (n, 3), float32
        Not clipped above (the image is, once blended).
    """
    degree = int(round(np.sqrt(sh.shape[1]))) - 1
    basis = sh_basis(dirs, degree)
    return np.maximum(np.einsum("nk,nkc->nc", basis, sh) + 0.5, 0.0).astype(np.float32)


def view_dirs(means: np.ndarray, eye: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """Unit directions from the camera centre ``eye`` to ``means``, in each Gaussian's SH frame.

    Parameters
    ----------
    means : ndarray, shape (n, 3)
        World metres.
    eye : ndarray, shape (3,)
        Camera centre, world metres.
    frames : ndarray, shape (n, 3, 3), optional
        Rotations world direction -> SH frame (identity when absent).

    Returns
    -------
    ndarray, shape (n, 3), float64
    """
    d = np.asarray(means, dtype=np.float64) - np.asarray(eye, dtype=np.float64)
    d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-30)
    if frames is not None:
        d = np.einsum("nij,nj->ni", frames, d)
    return d
