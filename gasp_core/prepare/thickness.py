"""Thin parts by local thickness: the parts of a filled object thinner than :data:`MIN_PART_CELLS` grid cells,
found on the fill's occupancy, named by where they are, with the ``n_grid`` that would put that many cells
across them.

The bounding box says nothing of a guitar's neck: the jelly guitar at ``n_grid`` 64 is 12 cells across its
smallest axis while its neck is under 2. Here the object's occupancy (its fill and surface points on voxels of the
fill spacing ``h``) gets a **local thickness** (Hildebrand & Ruegsegger, J. Microsc. 185, 1997): per voxel, the
diameter of the largest ball inside the solid that covers it, from openings by balls of growing radius
(Euclidean distance transforms, ``scipy.ndimage.distance_transform_edt``). Voxels under ``MIN_PART_CELLS * dx``
form the thin pieces; those holding at least :data:`MIN_PART_SHARE` of the solid are named by the side of the
object they lie on (``+z`` end, ...), their length and their median local thickness.

The thickness is measured on voxels of ``h`` (half a grid cell at 8 points per cell), which shrink with the grid:
a slab of ``N`` voxel layers measures ``N +- 0.5``, and a part that is a shell in the fill measures about a cell
at any ``n_grid``. So the ``n_grid`` named is a lower bound: the jelly guitar's neck measures 1.6 cells at
``n_grid`` 64 (0.049 m: 80 named for it), still 1.6 at 80 (0.039 m), and no part is thin at 96.
"""
from __future__ import annotations

import math

import numpy as np

#: A part thinner than this many grid cells is warned about (MPM's quadratic stencil spans 3 cells: a part
#: under it bends and contacts through one or two nodes).
MIN_PART_CELLS = 2.0
#: A thin piece must hold this share of the object's occupied voxels to be named (the opening also trims every
#: edge and corner of a voxelised solid by a voxel or so: small scattered pieces).
MIN_PART_SHARE = 0.02
#: Thin pieces this many voxels apart (a fret, a bump) count as one part.
MERGE_VOXELS = 1
#: Occupancy voxels on the longest side at most (coarser ``h`` beyond it), to bound the cost.
MAX_VOXELS_SIDE = 256
AXES = "xyz"


def _occupancy(points: np.ndarray, h: float):
    lo = points.min(axis=0) - 2 * h
    idx = np.floor((points - lo) / h).astype(np.int64)
    occ = np.zeros(tuple(idx.max(axis=0) + 3), dtype=bool)
    occ[tuple(idx.T)] = True
    return occ, lo


def local_thickness(occ: np.ndarray, r_max: float, step: float = 0.25) -> np.ndarray:
    """Local thickness of the solid ``occ`` (bool voxels) up to ``2 r_max`` voxels: per voxel, the diameter
    ``2 r`` of the largest ball of radius ``r`` in ``step, 2 step, ... <= r_max`` that lies inside the solid and
    covers it (an opening by that ball: Euclidean distance transforms), in voxels; 0 outside the solid or where
    no such ball fits, ``2 r_max`` where the largest fits."""
    from scipy import ndimage
    depth = ndimage.distance_transform_edt(occ)
    out = np.zeros(occ.shape)
    for r in np.arange(step, r_max + 1e-9, step):
        core = depth > r
        if not core.any():
            break
        out[occ & (ndimage.distance_transform_edt(~core) <= r)] = 2.0 * r
    return out


def thin_parts(points: np.ndarray, h: float, dx: float) -> list[dict]:
    """The parts of the solid ``points`` (n, 3), metres (fill and surface points, spacing about ``h``) thinner
    than :data:`MIN_PART_CELLS` grid cells of ``dx`` (module notes), longest first: each a dict with ``voxels``
    (int), ``share`` of the object's voxels, ``thickness`` (m: the median local thickness of its voxels; a
    slab of ``N`` voxel layers measures ``N + 0.5`` layers for odd ``N``, ``N - 0.5`` for even),
    ``length`` (m, its longest box side), ``lo``,
    ``hi`` (its box, m), ``side`` (e.g. ``"+z"``: where it lies from the object's centre)."""
    from scipy import ndimage
    h = max(h, float(np.ptp(points, axis=0).max()) / MAX_VOXELS_SIDE)
    occ, lo = _occupancy(points, h)
    occ = ndimage.binary_closing(occ, iterations=1) | occ        # fill points' lattice gaps of one voxel
    r = 0.5 * MIN_PART_CELLS * dx / h                           # voxels
    lt = local_thickness(occ, r + 1.0)
    thick = occ & (lt >= 2.0 * r)
    near_thick = ndimage.distance_transform_edt(~thick) <= r + 1.0 if thick.any() else np.zeros_like(occ)
    thin = occ & (lt < 2.0 * r) & ~near_thick                    # a thick part's trimmed edges are no part
    labels, n = ndimage.label(ndimage.binary_dilation(thin, iterations=MERGE_VOXELS), structure=np.ones((3, 3, 3)))
    labels[~thin] = 0                                            # pieces a voxel apart are one part
    if n == 0:
        return []
    counts = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    where = np.argwhere(occ)
    centre, size = where.mean(axis=0), np.maximum(np.ptp(where, axis=0), 1)
    out = []
    for k in np.flatnonzero(counts >= MIN_PART_SHARE * occ.sum()):
        cells = np.argwhere(labels == k + 1)
        off = (cells.mean(axis=0) - centre) / size
        a = int(np.argmax(np.abs(off)))
        out.append({"voxels": int(counts[k]), "share": float(counts[k] / occ.sum()),
                    "thickness": float(np.median(lt[labels == k + 1]) * h),
                    "length": float((np.ptp(cells, axis=0).max() + 1) * h),
                    "lo": (lo + cells.min(axis=0) * h).tolist(), "hi": (lo + (cells.max(axis=0) + 1) * h).tolist(),
                    "side": ("+" if off[a] > 0 else "-") + AXES[a]})
    return sorted(out, key=lambda p: -p["length"])


def thin_part_warnings(name: str, points: np.ndarray, h: float, dx: float, n_grid: int, most: int = 3) -> list[str]:
    """One warning naming the thin parts of :func:`thin_parts` (the ``most`` longest): where each is, how long and
    thick, its share of the solid; and the ``n_grid`` (a lower bound, module notes) that would put
    :data:`MIN_PART_CELLS` cells across the thinnest. An empty list when there are none."""
    parts = thin_parts(points, h, dx)
    if not parts:
        return []
    thinnest = min(p["thickness"] for p in parts)
    need = math.ceil(n_grid * MIN_PART_CELLS * dx / max(thinnest, 1e-12))
    said = "; ".join(f"at its {p['side']} end, {p['length']:.3g} m long, {p['thickness'] / dx:.1f} grid cells across "
                     f"({p['thickness']:.3g} m; {p['share']:.0%} of its solid, within "
                     f"{np.round(p['lo'], 3).tolist()} to {np.round(p['hi'], 3).tolist()} m)" for p in parts[:most])
    more = f" and {len(parts) - most} more" if len(parts) > most else ""
    return [f"object '{name}': {len(parts)} thin part(s) under {MIN_PART_CELLS:g} grid cells across (dx = {dx:.3g} m; "
            f"local thickness of the fill): {said}{more}; the grid moves them through one or two nodes (they smear "
            f"and bend too easily). n_grid >= {need} puts {MIN_PART_CELLS:g} cells across the thinnest if it is solid; "
            f"one that stays this thin at a finer grid is a shell in the fill (open in the capture), which no n_grid "
            f"thickens"]
