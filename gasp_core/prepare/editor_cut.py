"""``select = { file = "cut.ply" }``: the part of an object chosen in a splat editor (PhysGaussian #14, #45).

A user opens the object's file in SuperSplat, deletes splats, and exports what is left (PLY or compressed
PLY). Editors may reorder splats and a compressed export quantises positions, so rows are matched by
position: each splat of the edited file takes the file's nearest Gaussian within ``tolerance``. A splat
with none that near (moved or added in the editor, or a different scene) is *unmatched*: reported as a
warning, and an error when it is most of the edited file.
"""
from __future__ import annotations

import warnings

import numpy as np

from gasp_core.errors import SceneError

#: Default match distance as a fraction of the file's bounding-box diagonal (a compressed PLY stores
#: positions in 11/10/11 bits per chunk of 256 splats: errors far below this).
DEFAULT_TOLERANCE = 1e-3


def match_cut(cut_means: np.ndarray, means: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """Rows of ``means`` that the edited file's splats ``cut_means`` stand for.

    Parameters
    ----------
    cut_means : ndarray, shape (m, 3)
        Centres of the edited file, file units.
    means : ndarray, shape (n, 3)
        Centres of the object's file, same frame and units.
    tolerance : float
        Largest distance of a match, file units.

    Returns
    -------
    rows : ndarray, int64
        Sorted unique rows of ``means`` nearest to a splat of ``cut_means`` within ``tolerance``.
    unmatched : ndarray, int64
        Rows of ``cut_means`` with no Gaussian within ``tolerance``.

    Notes
    -----
    Nearest neighbours from :class:`scipy.spatial.cKDTree`; two Gaussians of the file at one
    position (duplicates) match one edited splat once, so one of them is left out.
    """
    from scipy.spatial import cKDTree
    d, i = cKDTree(means).query(cut_means, distance_upper_bound=tolerance)
    ok = np.isfinite(d)
    return np.unique(i[ok]).astype(np.int64), np.flatnonzero(~ok)


def cut_rows(sel, means: np.ndarray, where: str) -> np.ndarray:
    """Rows picked by ``select = { file, take, tolerance }`` (:class:`gasp_core.scene.select.SelectSpec`).

    Parameters
    ----------
    sel : SelectSpec
        ``kind == "file"``.
    means : ndarray, shape (n, 3)
        The object's centres, file frame (a dynamic model at ``dynamic_time``).
    where : str
        Prefix of messages (file and key).

    Returns
    -------
    rows : ndarray, int64
        ``take = "kept"``: the matched rows; ``"deleted"``: every other row.

    Raises
    ------
    SceneError
        The edited file cannot be read, or more than half of its splats match nothing (the message gives
        the counts, the tolerance and the bounding boxes of both files).

    Warns
    -----
    UserWarning
        Some (at most half) of the edited file's splats match nothing: their count and the first positions.
    """
    from gasp_core.gs.io import read_gaussians
    cut = read_gaussians(sel.file).means
    diag = float(np.linalg.norm(means.max(axis=0) - means.min(axis=0)))
    tol = sel.tolerance if sel.tolerance is not None else DEFAULT_TOLERANCE * max(diag, 1e-12)
    rows, unmatched = match_cut(cut, means, tol)
    if len(unmatched) * 2 > len(cut):
        raise SceneError(
            f"{where} '{sel.file}': {len(unmatched)} of its {len(cut)} splats are farther than {tol:.3g} (file units) "
            f"from every Gaussian of the object; is it an edit of this file, saved without moving it? Its centres "
            f"span {np.round(cut.min(0), 4).tolist()} to {np.round(cut.max(0), 4).tolist()}, the object's "
            f"{np.round(means.min(0), 4).tolist()} to {np.round(means.max(0), 4).tolist()} (raise 'tolerance' "
            f"if the editor quantised positions)")
    if len(unmatched):
        first = np.round(cut[unmatched[:3]], 4).tolist()
        warnings.warn(f"{where} '{sel.file}': {len(unmatched)} of its {len(cut)} splats match no Gaussian of the "
                      f"object within {tol:.3g} (file units), ignored; first at {first}", stacklevel=2)
    if sel.take == "deleted":
        keep = np.ones(len(means), bool)
        keep[rows] = False
        rows = np.flatnonzero(keep)
    return rows
