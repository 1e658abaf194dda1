"""Occupied space of Gaussians, from their own footprints: the shell they touch and the solid they enclose.

What decides "interior" (used by the interior fill, :mod:`gasp_core.maps.fill`, and by colliders
made from Gaussians):

1. **Footprints, not means.** Every opaque Gaussian is splatted as its flat ellipse
   ``v1 + a (v2 - v1) + b (v3 - v1)``, ``a^2 + b^2 <= SPLAT_SIGMA^2`` (GaMeS triangle, so ``v2 - v1
   = s2 r2``), sampled at half a voxel, into an occupancy grid (the *shell*).
2. **Voxel size from the splat density.** The occupancy voxel is the 90th percentile of the
   distance from each opaque Gaussian to its nearest neighbour (the gap a one-voxel dilation
   bridges), kept between ``extent / MAX_VOXELS`` and ``extent / MIN_VOXELS``.
3. **Bounded closing, ray votes.** For ``r = 1 .. max_dilation`` voxels the shell is
   dilated ``r`` times by the 18-neighbourhood (a discrete ball, :func:`scipy.ndimage.binary_dilation`); a free
   voxel is enclosed when its axis rays ``-x, +x, -y, +y, +z`` all hit the dilated shell (PhysGaussian's
   six-ray test, forgiving the ray down: real captures rarely see an object's base), the exterior is every
   other free voxel, and it is grown back by ``r``. A gap in the surface leaks only the voxels in line with
   it, where a flood fill from the border would leak the whole interior. The smallest ``r`` whose enclosed volume no longer grows (within
   ``STABLE_TOL`` from ``r`` to ``r + 1``) and holds an interior core is taken (failing that, the ``r`` of
   least growth if under ``LOOSE_TOL``): a gap narrower than
   about ``2 r`` voxels is sealed, real openings (a donut's hole) are not, because closing them
   would keep growing the volume; a bowl open upwards is a sheet, not a solid. On a ground (``floor``) the ground
   closes the soles whose outline it touches (:func:`_soles`). If no ``r`` up to ``max_dilation`` gives a stable enclosed
   volume the object is *open*: it is simulated as a shell, with a warning naming it (or a
   :class:`~gasp_core.errors.SceneError` with ``if_open = "error"``).
4. **Sub-voxel surface.** With ``d_ext``, ``d_core`` the taxicab distances (voxels,
   :func:`scipy.ndimage.distance_transform_cdt`) to the exterior and to the interior core (enclosed,
   not shell), ``phi = d_ext - min((d_ext + d_core) / 2, HALF_SHELL)``: zero mid-shell where the
   shell is a sheet of splats on the surface, at most ``HALF_SHELL`` voxels under its outside where
   the footprints fill the object (a trained splat's interior Gaussians). Fill-grid cell centres at
   the simulation spacing ``h`` are inside where the trilinear interpolation of ``phi`` is
   positive; the solid's volume is the count of inside cells times ``h^3``. The enclosure is
   *closed* when, besides being stable, more than ``DEEP_SHARE`` of it lies deeper than ``DEEP``
   voxels (an open sheet, such as a bowl, has nothing that deep).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

#: Footprint radius of a splat, in standard deviations of its in-plane scales.
SPLAT_SIGMA = 2.0
#: Occupancy-grid resolution bounds, voxels along the object's longest side.
MIN_VOXELS, MAX_VOXELS = 48, 160
#: Relative growth of the enclosed volume from ``r`` to ``r + 1`` below which the closing is final; when none
#: is, the least growth below ``LOOSE_TOL`` (the report's confidence falls with it, ``1 - growth / LOOSE_TOL``).
STABLE_TOL, LOOSE_TOL = 0.03, 0.10
#: A closed solid has more than DEEP_SHARE of its cells deeper than DEEP voxels (a sheet has none).
DEEP, DEEP_SHARE = 3, 0.05
#: Share of the five-ray enclosure (down forgiven) that must also be sealed below for the six-ray test to
#: decide; under it the object's base is taken as open (see :func:`_exterior`).
OPEN_BASE = 0.75
#: Largest depth of the surface below the outside of the occupied shell, voxels.
HALF_SHELL = 1.5


def splat_samples(splats: np.ndarray, step: float, sigma: float = SPLAT_SIGMA, chunk: int = 200_000):
    """Points covering each splat's footprint ellipse, at most ``step`` apart, yielded in chunks.

    Parameters
    ----------
    splats : ndarray, shape (n, 3, 3)
        GaMeS triangles ``v1 = m``, ``v2 = m + s2 r2``, ``v3 = m + s3 r3`` (metres).
    step : float
        Sample spacing, metres.
    sigma : float
        Footprint radius in standard deviations.

    Yields
    ------
    ndarray, shape (k, 3), float64
    """
    v1 = splats[:, 0]
    e2 = splats[:, 1] - v1
    e3 = splats[:, 2] - v1
    r = sigma * np.maximum(np.linalg.norm(e2, axis=1), np.linalg.norm(e3, axis=1))
    m = np.clip(np.ceil(r / step), 0, 32).astype(np.int64)          # samples per half-axis
    for mm in np.unique(m):
        sel = np.flatnonzero(m == mm)
        u = np.linspace(-sigma, sigma, 2 * mm + 1) if mm else np.zeros(1)
        a, b = np.meshgrid(u, u, indexing="ij")
        keep = a ** 2 + b ** 2 <= sigma ** 2 + 1e-12
        a, b = a[keep], b[keep]
        per = max(1, chunk // len(a))
        for s in range(0, len(sel), per):
            i = sel[s:s + per]
            pts = v1[i, None] + a[None, :, None] * e2[i, None] + b[None, :, None] * e3[i, None]
            yield pts.reshape(-1, 3)


def distinct_points(means: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct rows of ``means`` (shape (n, k), any k; centres: k = 3): the rows (shape (m, k), sorted), each
    input row's index among them (shape (n,)) and how many input rows each stands for (shape (m,)):
    ``points[inverse] == means``. O(n log n) time, O(n k) memory. Equal splats are the degenerate input of
    the k-d tree searches (which compare every pair of equal points) and of :func:`rasterize` (each sampled
    alike): 200,000 at one point took over 60 s."""
    means = np.ascontiguousarray(means, dtype=np.float64)
    if len(means) == 0:
        return means, np.zeros(0, np.intp), np.zeros(0, np.intp)
    order = np.lexsort(means.T[::-1])
    s = means[order]
    first = np.ones(len(s), bool)
    first[1:] = (s[1:] != s[:-1]).any(axis=1)
    group = np.cumsum(first) - 1
    inverse = np.empty(len(s), np.intp)
    inverse[order] = group
    return s[first], inverse, np.bincount(group)


#: Points a k-d tree query takes at once in :func:`nearest_other`: between two queries Python runs, so a signal's
#: handler (SIGTERM, Ctrl-C) runs within a fraction of a second, not after one native call over all points.
QUERY_CHUNK = 2**16


def nearest_other(points: np.ndarray, mult: np.ndarray, tree: cKDTree | None = None) -> np.ndarray:
    """Distance from each of the distinct ``points`` (:func:`distinct_points`) to the nearest other input row: 0
    for a point that stands for several rows (``mult > 1``), else to the nearest other point; queried
    :data:`QUERY_CHUNK` points at a time. Shape (m,), float64, the units of ``points``; needs m >= 2."""
    tree = cKDTree(points) if tree is None else tree
    d = np.concatenate([tree.query(points[s:s + QUERY_CHUNK], k=2)[0][:, 1]
                        for s in range(0, len(points), QUERY_CHUNK)])
    return np.where(mult > 1, 0.0, d)


def density_voxel(splats: np.ndarray) -> float:
    """Occupancy voxel from the splat density, metres (see the module notes, step 2)."""
    means = splats[:, 0]
    ext = float(np.ptp(np.concatenate([means, splats[:, 1], splats[:, 2]]), axis=0).max()) or 1.0
    points, inverse, mult = distinct_points(means)    # coincident splats: a k-d tree compares every pair
    if len(points) > 1:
        nearest = nearest_other(points, mult)
        gap = float(np.quantile(nearest[inverse], 0.9))
    else:
        gap = ext
    return float(np.clip(gap, ext / MAX_VOXELS, ext / MIN_VOXELS))


def padded_grid(lo_pts: np.ndarray, hi_pts: np.ndarray, h: float,
                pad: int) -> tuple[np.ndarray, tuple[int, int, int]]:
    """Corner (metres) and shape (cells) of a grid of spacing ``h`` holding ``[lo_pts, hi_pts]`` with ``pad`` cells
    of margin below and about ``pad`` above."""
    lo = lo_pts - pad * h
    shape = tuple(int(s) for s in np.floor((hi_pts - lo) / h).astype(np.int64) + pad + 1)
    return lo, shape


def rasterize(splats: np.ndarray, lo: np.ndarray, shape, h: float) -> np.ndarray:
    """Voxels the Gaussians' footprints touch.

    Parameters
    ----------
    splats : ndarray, shape (n, 3, 3)
        GaMeS triangles, metres.
    lo : ndarray, shape (3,)
        Corner of voxel ``(0, 0, 0)``, metres.
    shape : tuple of 3 int
        Voxels per axis.
    h : float
        Voxel size, metres; footprints are sampled every ``h / 2`` (:func:`splat_samples`), samples
        outside the grid count in the nearest edge voxel.

    Returns
    -------
    ndarray, shape ``shape``, bool
    """
    occ = np.zeros(shape, dtype=bool)
    hi = np.array(shape) - 1
    splats = np.asarray(splats, dtype=np.float64)        # equal splats touch the same voxels: sampled once
    splats = distinct_points(splats.reshape(len(splats), -1))[0].reshape(-1, 3, 3)
    for pts in splat_samples(splats, 0.5 * h):
        idx = np.clip(np.floor((pts - lo) / h).astype(np.int64), 0, hi)
        occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    return occ


_BALL = ndimage.generate_binary_structure(3, 2)      # 18-neighbourhood: one step of a discrete ball


def ray_votes(shell: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Which axis rays from each voxel hit the shell (PhysGaussian's six-ray test, Xie et al. 2024, Sec. 4.3).

    Parameters
    ----------
    shell : ndarray, 3-D bool
        Occupied voxels; axis 2 is world z (up).

    Returns
    -------
    sides : ndarray, int8, shape ``shell.shape``
        How many of the five rays ``-x, +x, -y, +y, +z`` hit a shell voxel (the voxel itself counts).
    below : ndarray, bool
        Whether the ray ``-z`` hits one: a scan's unseen base, which the inside test forgives.
    """
    sides = np.zeros(shell.shape, np.int8)
    below = np.zeros(shell.shape, bool)
    for axis in range(3):
        fwd = np.logical_or.accumulate(shell, axis=axis)             # a shell voxel at or before (-axis ray)
        back = np.flip(np.logical_or.accumulate(np.flip(shell, axis), axis=axis), axis)  # (+axis ray)
        sides += back
        if axis < 2:
            sides += fwd
        else:
            below = fwd
    return sides, below


def _exterior(closed_shell: np.ndarray, r: int, floor_k: int | None = None) -> tuple[np.ndarray, float]:
    """Exterior of a shell dilated ``r`` times, grown back by ``r``, and the share of the enclosed free voxels
    sealed on all six sides.

    A free voxel is enclosed when all six axis rays hit the shell (:func:`ray_votes`). When fewer than
    :data:`OPEN_BASE` of the voxels whose rays ``-x, +x, -y, +y, +z`` hit it are sealed below as well, the object
    is taken as a capture with an unseen base and those five rays suffice (an overhang of a closed object,
    such as a torus's underside, is the small difference the first rule keeps out). Either way a gap in the
    surface leaks only the voxels in line with it, where a flood fill from the border leaks the interior. With a
    ground at voxel layer ``floor_k``, the ray down of a sole standing on it hits the ground (:func:`_soles`).
    """
    sides, below = ray_votes(closed_shell)
    five = ~closed_shell & (sides == 5)
    if floor_k is not None:
        soles = _soles(closed_shell, five, floor_k)
        if soles.any():
            below[soles, max(floor_k, 0):] = True
    six = five & below
    sealed = float(six.sum() / max(int(five.sum()), 1))
    outside = ~closed_shell & ~(six if sealed >= OPEN_BASE else five)
    return ndimage.binary_dilation(outside, _BALL, iterations=r), sealed


#: Voxel layers over the ground in which a sole's outline and its inside are looked for (:func:`_soles`).
SOLE_BAND = 2
#: Share of a sole's columns enclosed by five rays at the ground (the rest: gaps in a scanned wall).
SOLE_SHARE = 0.9


def _soles(closed_shell: np.ndarray, five: np.ndarray, floor_k: int) -> np.ndarray:
    """Columns (bool, the grid's x-y shape) of the soles a ground at voxel layer ``floor_k`` closes: the areas the
    shell's outline on the ground (its voxels from one layer under it to :data:`SOLE_BAND` over it) encloses, when
    at least :data:`SOLE_SHARE` of their columns are enclosed by five rays over the ground (a leg whose sole a scan
    never saw, standing on it). A torus lying on the ground touches it along a ring, whose hole is open upwards in
    the middle: not a sole, and the overhang under its inner half stays out (issue 54 item 6)."""
    nz = closed_shell.shape[2]
    lo_k, hi_k = max(floor_k - 1, 0), min(floor_k + SOLE_BAND + 1, nz)
    if lo_k >= hi_k:
        return np.zeros(closed_shell.shape[:2], bool)
    outline = closed_shell[:, :, lo_k:hi_k].any(axis=2)
    holes = ndimage.binary_fill_holes(outline) & ~outline
    enclosed = five[:, :, max(floor_k, 0):hi_k].any(axis=2)
    labels, n = ndimage.label(holes)
    if n == 0:
        return holes
    share = ndimage.mean(enclosed, labels, index=np.arange(1, n + 1))
    good = np.concatenate([[False], np.asarray(share) >= SOLE_SHARE])
    return good[labels]


def solid_field(splats: np.ndarray, max_dilation: int = 4, voxel: float | None = None, floor: float | None = None):
    """The signed inside field of the splats' footprints (module notes, steps 2-4).

    Parameters
    ----------
    splats : ndarray, shape (n, 3, 3)
        GaMeS triangles of the opaque Gaussians, metres.
    max_dilation : int
        Largest closing radius tried, occupancy voxels.
    voxel : float, optional
        Occupancy voxel size, metres; default :func:`density_voxel`.
    floor : float, optional
        Height (metres, world z) of a ground the object stands on: it closes the soles whose outline it touches
        (:func:`_soles`). None: no ground.

    Returns
    -------
    phi : ndarray, 3-D float32 or None
        Signed depth in voxels, positive inside (module notes, step 4); None if the footprints enclose nothing.
    lo : ndarray, shape (3,)
        Corner of the grid (cell ``i`` has centre ``lo + (i + 0.5) voxel``).
    voxel : float
    r : int
        Closing radius chosen (0 when open).
    enclosed : list of float
        Enclosed volume (m^3) at each radius tried.
    confidence : float
        ``1 - growth / LOOSE_TOL``, ``growth`` the enclosed volume's relative growth from the chosen closing
        radius to the next (1: the enclosure does not depend on the closing; 0 when open).
    sealed : float
        Share of the five-ray enclosure sealed below too (all six rays): near 1 for a closed surface, below
        ``OPEN_BASE`` where the inside test forgave an open base; 0 when open.
    """
    splats = np.asarray(splats, dtype=np.float64)
    pts = splats.reshape(-1, 3)
    reach = SPLAT_SIGMA * np.linalg.norm(splats[:, 1:] - splats[:, :1], axis=2).max()
    span = float(np.max(pts.max(axis=0) - pts.min(axis=0) + 2 * reach))
    if not span > 0:            # every footprint is one point: nothing to enclose
        return None, pts.min(axis=0), 0.0, 0, [], 0.0, 0.0
    voxel = density_voxel(splats) if voxel is None else float(voxel)
    voxel = max(voxel, span / MAX_VOXELS)       # bounded grid, whatever the splats' sizes and spacing
    lo, shape = padded_grid(pts.min(axis=0) - reach, pts.max(axis=0) + reach, voxel, max_dilation + 3)
    shell = rasterize(splats, lo, shape, voxel)
    floor_k = None if floor is None else int(np.floor((floor - lo[2]) / voxel))
    closed_shell = shell
    enclosed, solids, sealed, solid_at = [], [], [], {}

    def is_solid(i: int) -> bool:       # computed once per radius
        if i not in solid_at:
            solid_at[i] = _is_solid(~solids[i])
        return solid_at[i]

    for r in range(1, max_dilation + 2):
        closed_shell = ndimage.binary_dilation(closed_shell, _BALL)
        ext, share = _exterior(closed_shell, r, floor_k)
        solids.append(ext)
        sealed.append(share)
        enclosed.append(float((~ext).sum()) * voxel ** 3)
        if r >= 2 and enclosed[-1] <= enclosed[-2] * (1.0 + STABLE_TOL) and is_solid(r - 2):
            break
    chosen, growth = _choose_radius(enclosed, is_solid)
    if not chosen:
        return None, lo, voxel, 0, enclosed, 0.0, 0.0
    ext = solids[chosen - 1]
    core = ~ext & ~shell
    d_ext = ndimage.distance_transform_cdt(~ext, metric="taxicab").astype(np.float32)
    d_core = (ndimage.distance_transform_cdt(~core, metric="taxicab").astype(np.float32) if core.any()
              else np.full(shape, np.inf, np.float32))
    # surface mid-shell where the shell is a sheet, at most HALF_SHELL voxels inside a thick one
    phi = d_ext - np.minimum(0.5 * (d_ext + d_core), HALF_SHELL)
    return phi, lo, voxel, chosen, enclosed, max(0.0, 1.0 - growth / LOOSE_TOL), sealed[chosen - 1]


def _is_solid(solid: np.ndarray) -> bool:
    """More than ``DEEP_SHARE`` of ``solid`` lies deeper than ``DEEP`` voxels (a sheet has nothing that deep)."""
    deep = int((ndimage.distance_transform_cdt(solid, metric="taxicab") > DEEP).sum())
    return deep > DEEP_SHARE * solid.sum()


def _choose_radius(enclosed: list, is_solid) -> tuple[int, float]:
    """Closing radius (1-based; 0: open) and the enclosed volume's relative growth from it to the next;
    ``is_solid(i)`` tells whether the enclosure at radius ``i + 1`` is a solid (:func:`_is_solid`).

    The first radius whose growth is under ``STABLE_TOL`` and whose enclosure is a solid; failing that the
    solid one of least growth, if under ``LOOSE_TOL`` (a capture whose closing keeps sealing small
    concavities, e.g. the real guitar: 3.4 to 7 % per voxel).
    """
    growth = [b / a - 1.0 if a > 0 else np.inf for a, b in zip(enclosed[:-1], enclosed[1:])]
    for i, g in enumerate(growth):
        if g <= STABLE_TOL and is_solid(i):
            return i + 1, g
    for i in np.argsort(growth):
        if growth[i] < LOOSE_TOL and is_solid(int(i)):
            return int(i) + 1, float(growth[i])
    return 0, np.inf



def sample_phi(phi: np.ndarray, lo: np.ndarray, voxel: float, q: np.ndarray) -> np.ndarray:
    """``phi`` (voxels, positive inside; :func:`solid_field`) at the points ``q`` (shape (k, 3), metres), trilinear,
    ``-1`` off the grid. Shape (k,), float64."""
    c = ((np.asarray(q, np.float64) - lo) / voxel - 0.5).T
    return ndimage.map_coordinates(phi, c, order=1, mode="constant", cval=-1.0).astype(np.float64)
