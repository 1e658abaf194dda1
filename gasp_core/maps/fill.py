"""Interior filling and per-point volumes, from the Gaussians' own footprints.

Triangle vertices alone are a hollow shell; a solid needs mass inside. Following PhysGaussian
(Xie et al. 2024, Sec. 4.3 "internal filling"), occupied space is found on a voxel grid and every
interior cell without a surface point gets one simulated (never rendered) point at its centre.

What decides "interior" here:

1. **Footprints, not means.** Every opaque Gaussian is splatted as its flat ellipse
   ``v1 + a (v2 - v1) + b (v3 - v1)``, ``a^2 + b^2 <= SPLAT_SIGMA^2`` (GaMeS triangle, so ``v2 - v1
   = s2 r2``), sampled at half a voxel, into an occupancy grid (the *shell*).
2. **Voxel size from the splat density.** The occupancy voxel is the 90th percentile of the
   distance from each opaque Gaussian to its nearest neighbour (the gap a one-voxel dilation
   bridges), kept between ``extent / MAX_VOXELS`` and ``extent / MIN_VOXELS``.
3. **Bounded closing, exterior flood fill.** For ``r = 1 .. max_dilation`` voxels the shell is
   dilated ``r`` times by the 18-neighbourhood (a discrete ball, :func:`scipy.ndimage.binary_dilation`), the exterior is
   the part of its complement connected to the grid border (:func:`scipy.ndimage.label`), and it is
   grown back by ``r``. The smallest ``r`` whose enclosed volume no longer grows (within
   ``STABLE_TOL`` from ``r`` to ``r + 1``) and holds an interior core is taken: a gap narrower than
   about ``2 r`` voxels is sealed, real openings (a donut's hole) are not, because closing them
   would keep growing the volume. If no ``r`` up to ``max_dilation`` gives a stable enclosed
   volume the object is *open*: it is simulated as a shell, with a warning naming it (or a
   :class:`~gasp_core.seam.engine.SceneError` with ``if_open = "error"``).
4. **Sub-voxel surface.** With ``d_ext``, ``d_core`` the taxicab distances (voxels,
   :func:`scipy.ndimage.distance_transform_cdt`) to the exterior and to the interior core (enclosed,
   not shell), ``phi = d_ext - min((d_ext + d_core) / 2, HALF_SHELL)``: zero mid-shell where the
   shell is a sheet of splats on the surface, at most ``HALF_SHELL`` voxels under its outside where
   the footprints fill the object (a trained splat's interior Gaussians). Fill-grid cell centres at
   the simulation spacing ``h`` are inside where the trilinear interpolation of ``phi`` is
   positive; the solid's volume is the count of inside cells times ``h^3``. The enclosure is
   *closed* when, besides being stable, more than ``DEEP_SHARE`` of it lies deeper than ``DEEP``
   voxels (an open sheet, such as a bowl, has nothing that deep).

Volumes: each inside cell's ``h^3`` is shared equally by the simulated surface points assigned to
it (a surface point outside every inside cell goes to the nearest one), and a cell with none gets
one fill point; so the points' volumes sum to the solid's volume exactly (PhysGaussian: ``dx^3``
over the particles in the cell). Morphology and distances come from :mod:`scipy.ndimage`.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from gasp_core.errors import SceneError

#: Footprint radius of a splat, in standard deviations of its in-plane scales.
SPLAT_SIGMA = 2.0
#: Occupancy-grid resolution bounds, voxels along the object's longest side.
MIN_VOXELS, MAX_VOXELS = 48, 160
#: Relative growth of the enclosed volume from ``r`` to ``r + 1`` below which the closing is final.
STABLE_TOL = 0.03
#: Largest fill grid (cells) before the fill spacing is refused as too fine.
MAX_FILL_CELLS = 512 ** 3
IF_OPEN = ("warn", "error")
#: A closed solid has more than DEEP_SHARE of its cells deeper than DEEP voxels (a sheet has none).
DEEP, DEEP_SHARE = 3, 0.05
#: Largest depth of the surface below the outside of the occupied shell, voxels.
HALF_SHELL = 1.5


@dataclass(frozen=True)
class FillReport:
    """How an object's solid was decided, for ``run.json`` and ``gasp info``.

    Attributes
    ----------
    name : str
        Object name (file stem).
    volume : float
        Volume of the simulated solid (sum of the points' volumes), m^3.
    n_fill : int
        Interior (simulated, never rendered) points.
    h : float
        Fill spacing (simulation particle spacing), metres.
    voxel : float
        Occupancy-grid voxel size chosen from the splat density, metres (0 for a plain shell).
    method : str
        ``"flood"`` (closed, filled), ``"shell-open"`` (open or leaking: a shell), ``"shell"``
        (``fill = false``).
    closed : bool
        The footprints enclose a volume.
    dilation : int
        Closing radius used, occupancy voxels (0 when none).
    enclosed : list of float
        Enclosed volume (m^3, occupancy grid) at each tried closing radius ``1, 2, ...``.
    warning : str
        Empty, or a sentence naming the object when it is open.
    """

    name: str
    volume: float
    n_fill: int
    h: float
    voxel: float
    method: str
    closed: bool
    dilation: int
    enclosed: list = field(default_factory=list)
    warning: str = ""

    def as_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class FillResult:
    """Interior points and volumes of one object.

    Attributes
    ----------
    fill_x : ndarray, shape (m, 3), float64
        Interior points, metres.
    p_vol_surface : ndarray, shape (n,), float64
        Volume of each given surface point, m^3.
    p_vol_fill : ndarray, shape (m,), float64
        Volume of each interior point, m^3.
    h : float
        Fill spacing, metres.
    volume : float
        Solid volume, m^3 (sum of all point volumes).
    report : FillReport
    """

    fill_x: np.ndarray
    p_vol_surface: np.ndarray
    p_vol_fill: np.ndarray
    h: float
    volume: float
    report: FillReport


def fill_spacing(dx: float, particles_per_cell: float, core_fraction: float = 1.0) -> float:
    """Fill spacing ``h = dx / (particles_per_cell * core_fraction)^(1/3)``, at most ``dx``.

    The interior is thinned with the surface (``core_fraction``), down to one point per grid cell,
    the least an MPM grid can carry without numerical fracture.
    """
    return float(min(dx, dx / (particles_per_cell * core_fraction) ** (1.0 / 3.0)))


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


def density_voxel(splats: np.ndarray) -> float:
    """Occupancy voxel from the splat density, metres (see the module notes, step 2)."""
    means = splats[:, 0]
    ext = float(np.ptp(np.concatenate([means, splats[:, 1], splats[:, 2]]), axis=0).max()) or 1.0
    if len(means) > 1:
        d, _ = cKDTree(means).query(means, k=2)
        gap = float(np.quantile(d[:, 1], 0.9))
    else:
        gap = ext
    return float(np.clip(gap, ext / MAX_VOXELS, ext / MIN_VOXELS))


def _grid(lo_pts: np.ndarray, hi_pts: np.ndarray, h: float, pad: int):
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
    for pts in splat_samples(splats, 0.5 * h):
        idx = np.clip(np.floor((pts - lo) / h).astype(np.int64), 0, hi)
        occ[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    return occ


_BALL = ndimage.generate_binary_structure(3, 2)      # 18-neighbourhood: one step of a discrete ball


def _exterior(closed_shell: np.ndarray, r: int) -> np.ndarray:
    """Exterior of a shell dilated ``r`` times: the free cells connected to the border, grown back by ``r``."""
    lab, _ = ndimage.label(~closed_shell)
    border = np.unique(np.concatenate([lab[0].ravel(), lab[-1].ravel(), lab[:, 0].ravel(), lab[:, -1].ravel(),
                                       lab[:, :, 0].ravel(), lab[:, :, -1].ravel()]))
    outside = np.isin(lab, border[border > 0])
    return ndimage.binary_dilation(outside, _BALL, iterations=r)


def solid_field(splats: np.ndarray, max_dilation: int = 4, voxel: float | None = None):
    """The signed inside field of the splats' footprints (module notes, steps 2-4).

    Parameters
    ----------
    splats : ndarray, shape (n, 3, 3)
        GaMeS triangles of the opaque Gaussians, metres.
    max_dilation : int
        Largest closing radius tried, occupancy voxels.
    voxel : float, optional
        Occupancy voxel size, metres; default :func:`density_voxel`.

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
    """
    splats = np.asarray(splats, dtype=np.float64)
    voxel = density_voxel(splats) if voxel is None else float(voxel)
    pts = splats.reshape(-1, 3)
    reach = SPLAT_SIGMA * np.linalg.norm(splats[:, 1:] - splats[:, :1], axis=2).max()
    lo, shape = _grid(pts.min(axis=0) - reach, pts.max(axis=0) + reach, voxel, max_dilation + 3)
    shell = rasterize(splats, lo, shape, voxel)
    closed_shell = shell
    enclosed, solids = [], []
    chosen = 0
    for r in range(1, max_dilation + 2):
        closed_shell = ndimage.binary_dilation(closed_shell, _BALL)
        ext = _exterior(closed_shell, r)
        solids.append(ext)
        enclosed.append(float((~ext).sum()) * voxel ** 3)
        if r >= 2 and enclosed[-1] <= enclosed[-2] * (1.0 + STABLE_TOL):
            # stable; and a solid, not a sheet: some of it lies deeper than DEEP voxels
            solid = ~solids[-2]
            deep = int((ndimage.distance_transform_cdt(solid, metric="taxicab") > DEEP).sum())
            if deep > DEEP_SHARE * solid.sum():
                chosen = r - 1
                break
    if not chosen:
        return None, lo, voxel, 0, enclosed
    ext = solids[chosen - 1]
    core = ~ext & ~shell
    d_ext = ndimage.distance_transform_cdt(~ext, metric="taxicab").astype(np.float32)
    d_core = (ndimage.distance_transform_cdt(~core, metric="taxicab").astype(np.float32) if core.any()
              else np.full(shape, np.inf, np.float32))
    # surface mid-shell where the shell is a sheet, at most HALF_SHELL voxels inside a thick one
    phi = d_ext - np.minimum(0.5 * (d_ext + d_core), HALF_SHELL)
    return phi, lo, voxel, chosen, enclosed


def fill_interior(points: np.ndarray, h: float, splats: np.ndarray | None = None, fill: bool = True,
                  name: str = "object", if_open: str = "warn", max_dilation: int = 4,
                  voxel: float | None = None, surface_mass: bool = True) -> FillResult:
    """Fill an object's enclosed interior at spacing ``h`` and give every point its volume.

    Parameters
    ----------
    points : ndarray, shape (n, 3), float
        Simulated surface points (triangle vertices of the simulated Gaussians), metres.
    h : float
        Fill spacing, metres (:func:`fill_spacing`).
    splats : ndarray, shape (m, 3, 3), optional
        GaMeS triangles of the opaque Gaussians (all of them, also when only cores are
        simulated); they decide the occupied space. Default: ``points`` as degenerate splats.
    fill : bool
        Fill the enclosed interior (solids). False: a shell, the cells the footprints touch
        (the paper's vertices-only mode).
    name : str
        Object name for the warning or error.
    if_open : {"warn", "error"}
        An object whose footprints enclose no volume (open, or leaking through gaps wider than
        about ``2 max_dilation`` voxels) is simulated as a shell with ``report.warning`` set, or
        raises.
    max_dilation : int
        Largest closing radius, occupancy voxels.
    voxel : float, optional
        Occupancy voxel, metres; default from the splat density.
    surface_mass : bool
        True: the surface points share their cells' volume and only cells without one get a
        fill point. False (passive surface, ``surface = "passive"``): the surface points get
        volume 0 and every inside cell gets a fill point, so the fill alone is the whole solid.

    Returns
    -------
    FillResult

    Raises
    ------
    SceneError
        Bad shapes, ``h <= 0``, a fill grid above 512^3 cells, or an open object with
        ``if_open = "error"`` (the message names the object).
    """
    points = np.asarray(points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise SceneError(f"object '{name}': fill_interior needs a non-empty (n, 3) point array, got {points.shape}")
    if not h > 0:
        raise SceneError(f"object '{name}': fill spacing h must be > 0, got {h}")
    if if_open not in IF_OPEN:
        raise SceneError(f"object '{name}': if_open = {if_open!r}; expected one of {list(IF_OPEN)}")
    splats = (np.repeat(points[:, None], 3, axis=1) if splats is None
              else np.asarray(splats, dtype=np.float64).reshape(-1, 3, 3))
    if len(splats) == 0:
        splats = np.repeat(points[:, None], 3, axis=1)
    reach = SPLAT_SIGMA * np.linalg.norm(splats[:, 1:] - splats[:, :1], axis=2).max()
    allpts = np.concatenate([points, splats.reshape(-1, 3)])
    lo, shape = _grid(allpts.min(axis=0) - reach, allpts.max(axis=0) + reach, h, 2)
    if np.prod(shape, dtype=np.float64) > MAX_FILL_CELLS:
        raise SceneError(f"object '{name}': fill grid {shape} too large for h = {h:g} m; raise h "
                         f"(fewer particles per cell or a coarser n_grid)")
    centres = lambda cells: lo + (cells + 0.5) * h                      # noqa: E731
    phi, vlo, voxel_used, r, enclosed = (None, lo, 0.0, 0, [])
    if fill:
        phi, vlo, voxel_used, r, enclosed = solid_field(splats, max_dilation, voxel)
    if phi is not None:
        # sample phi at the fill-grid centres, slab by slab along x (bounded memory)
        inside = np.zeros(shape, dtype=bool)
        j, k = np.meshgrid(np.arange(shape[1]), np.arange(shape[2]), indexing="ij")
        cy = (lo[1] + (j + 0.5) * h - vlo[1]) / voxel_used - 0.5
        cz = (lo[2] + (k + 0.5) * h - vlo[2]) / voxel_used - 0.5
        for i in range(shape[0]):
            cx = np.full(cy.shape, (lo[0] + (i + 0.5) * h - vlo[0]) / voxel_used - 0.5)
            inside[i] = ndimage.map_coordinates(phi, [cx, cy, cz], order=1, mode="constant", cval=-1.0) > 0
        method, closed, warning = "flood", True, ""
    else:
        inside = rasterize(splats, lo, shape, h)
        closed = False
        method = "shell" if not fill else "shell-open"
        warning = "" if not fill else (
            f"object '{name}': its Gaussians enclose no volume (open, or gaps wider than the largest "
            f"closing, {max_dilation} voxels of {voxel_used * 1e3:.3g} mm); simulated as a hollow shell "
            f"of {float(inside.sum()) * h ** 3:.4g} m^3. Set fill = false to accept a shell, or close the model")
        if fill and if_open == "error":
            raise SceneError(warning.replace("; simulated as a hollow shell", "; refusing to simulate a hollow shell"))
    cells = np.argwhere(inside)
    if not surface_mass:
        idx = np.clip(np.floor((points - lo) / h).astype(np.int64), 0, np.array(shape) - 1)
        if not len(cells):      # nothing inside at this spacing: the surface points' own cells
            cells = np.unique(idx, axis=0)
        fill_x = centres(cells)
        p_vol_fill = np.full(len(fill_x), h ** 3)
        volume = float(p_vol_fill.sum())
        report = FillReport(name=name, volume=volume, n_fill=len(fill_x), h=float(h), voxel=float(voxel_used),
                            method=method, closed=closed, dilation=int(r), enclosed=enclosed, warning=warning)
        return FillResult(fill_x, np.zeros(len(points)), p_vol_fill, float(h), volume, report)
    flat_inside = np.ravel_multi_index(cells.T, shape)
    idx = np.clip(np.floor((points - lo) / h).astype(np.int64), 0, np.array(shape) - 1)
    flat_pts = np.ravel_multi_index(idx.T, shape)
    pos = np.searchsorted(flat_inside, flat_pts)        # argwhere order == ravel order (sorted)
    hit = (pos < len(flat_inside)) & (flat_inside[np.minimum(pos, len(flat_inside) - 1)] == flat_pts)
    owner = np.where(hit, pos, -1)
    if (~hit).any() and len(cells):
        _, near = cKDTree(centres(cells)).query(points[~hit])
        owner[~hit] = near
    if len(cells):
        counts = np.bincount(owner, minlength=len(cells))
        p_vol_surface = h ** 3 / counts[owner]
        empty = counts == 0
    else:   # nothing inside at this spacing: the points keep their own cells
        _, inv, counts = np.unique(flat_pts, return_inverse=True, return_counts=True)
        p_vol_surface = h ** 3 / counts[inv]
        empty = np.zeros(0, bool)
    fill_x = centres(cells[empty])
    p_vol_fill = np.full(len(fill_x), h ** 3)
    volume = float(p_vol_surface.sum() + p_vol_fill.sum())
    report = FillReport(name=name, volume=volume, n_fill=len(fill_x), h=float(h), voxel=float(voxel_used),
                        method=method, closed=closed, dilation=int(r), enclosed=enclosed, warning=warning)
    return FillResult(fill_x, p_vol_surface, p_vol_fill, float(h), volume, report)
