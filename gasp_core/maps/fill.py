"""Interior filling and per-point volumes, from the Gaussians' own footprints.

Triangle vertices alone are a hollow shell; a solid needs mass inside. Following PhysGaussian
(Xie et al. 2024, Sec. 4.3 "internal filling"), occupied space is found on a voxel grid and every
interior cell without a surface point gets one simulated (never rendered) point at its centre.

What decides "interior" is :mod:`gasp_core.maps.occupancy` (footprints, voxel size from the
splat density, bounded closing, sub-voxel surface).

Volumes (issue 66): a cell deep inside holds ``h^3``; a cell the surface crosses holds its share of ``h^3``, measured
at sub-cells against the planes of the surface splats, its fill point at the centre of its inside part
(:mod:`.fill_shares`; where those planes do not hold the splats, each cell whose centre ``phi`` puts inside is whole).
The surface points in a cell share its volume (one outside every cell goes to the nearest), and a cell with none gets
one fill point: the points' volumes sum to the solid's (PhysGaussian: ``dx^3`` over the particles in the cell). Whole
cells by ``phi`` made bars of 4-10 cells across 42 % light to 41 % heavy (docs/fill.md, "The mass at the faces").
Morphology and distances come from :mod:`scipy.ndimage`.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from gasp_core.errors import SceneError
from gasp_core.maps import fill_shares
from gasp_core.maps.occupancy import HALF_SHELL, SPLAT_SIGMA, padded_grid, rasterize, solid_field

#: Largest fill grid (cells) before the fill spacing is refused as too fine.
MAX_FILL_CELLS = 512 ** 3
IF_OPEN = ("warn", "error")


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
        ``"six-ray"`` (closed, filled by the six-ray inside vote of :mod:`gasp_core.maps.occupancy`), ``"shell-open"`` (open or leaking: a shell), ``"shell"``
        (``fill = false``).
    closed : bool
        The footprints enclose a volume.
    dilation : int
        Closing radius used, occupancy voxels (0 when none).
    enclosed : list of float
        Enclosed volume (m^3, occupancy grid) at each tried closing radius ``1, 2, ...``.
    warning : str
        Empty, or a sentence naming the object when it is open.
    confidence : float
        Inside test's confidence, 0..1: how little the enclosed volume depends on the closing radius
        (:func:`gasp_core.maps.occupancy.solid_field`); 0 when open.
    sealed : float
        Share of the enclosure sealed on all six sides; low (under
        :data:`gasp_core.maps.occupancy.OPEN_BASE`) where an unseen base was forgiven.
    bbox_share : float
        The solid's volume over the bounding box of its fill cells (its share of its bounding volume).
    thin_share : float
        Share of the occupancy solid farther than ``h`` from every inside fill cell (parts thinner than
        about two cells): they stay shells, their surface points carry their mass.
    thin_h : float
        Fill spacing (metres) that would fill those parts (half their largest thickness); 0 when none.
    thin_box : list
        Their bounding box ``[lo, hi]``, metres (world frame); empty when none.
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
    confidence: float = 0.0
    sealed: float = 0.0
    bbox_share: float = 0.0
    thin_share: float = 0.0
    thin_h: float = 0.0
    thin_box: list = field(default_factory=list)

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
    n_floored : int
        Cells the ``floor`` took out (0 without one).
    floored_low : float or None
        Lowest centre of those cells, metres (None when none).
    """

    fill_x: np.ndarray
    p_vol_surface: np.ndarray
    p_vol_fill: np.ndarray
    h: float
    volume: float
    report: FillReport
    n_floored: int = 0
    floored_low: float | None = None


def fill_spacing(dx: float, particles_per_cell: float, core_fraction: float = 1.0) -> float:
    """Fill spacing ``h = dx / (particles_per_cell * core_fraction)^(1/3)``, at most ``dx``.

    The interior is thinned with the surface (``core_fraction``), down to one point per grid cell,
    the least an MPM grid can carry without numerical fracture.
    """
    return float(min(dx, dx / (particles_per_cell * core_fraction) ** (1.0 / 3.0)))


def fill_interior(points: np.ndarray, h: float, splats: np.ndarray | None = None, fill: bool = True,
                  name: str = "object", if_open: str = "warn", max_dilation: int = 4,
                  voxel: float | None = None, surface_mass: bool = True, unit: str = "m",
                  check_points: Callable[[int], None] | None = None, floor: float | None = None) -> FillResult:
    """Fill an object's enclosed interior at spacing ``h`` and give every point its volume.
    It is long because the solid, the shell and the faces' shares (:mod:`.fill_shares`) each decide the cells.

    Parameters
    ----------
    points : ndarray, shape (n, 3), float
        Simulated surface points (triangle vertices of the simulated Gaussians), metres.
    h : float
        Fill spacing, metres (:func:`fill_spacing`).
    splats : ndarray, shape (m, 3, 3), optional
        GaMeS triangles of the opaque Gaussians (all, also when only cores are simulated): they decide the
        occupied space. Default: ``points`` as degenerate splats.
    fill : bool
        Fill the enclosed interior (solids). False: a shell, the cells the footprints touch
        (the paper's vertices-only mode).
    name : str
        Object name for the warning or error.
    if_open : {"warn", "error"}
        An object whose footprints enclose no volume (open, or leaking through gaps wider than about
        ``2 max_dilation`` voxels) is simulated as a shell with ``report.warning`` set, or raises.
    max_dilation : int
        Largest closing radius, occupancy voxels.
    voxel : float, optional
        Occupancy voxel, metres; default from the splat density.
    unit : str
        Length unit of the coordinates as the warning names it: ``"m"``, or ``"file units"`` (``gasp info``).
    surface_mass : bool
        True: the surface points share their cells' volume and only cells without one get a
        fill point. False (passive surface, ``surface = "passive"``): the surface points get
        volume 0 and every inside cell gets a fill point, so the fill alone is the whole solid.
    check_points : callable, optional
        Called with the point count before the faces' shares are measured (with the cells ``phi`` puts inside) and
        before the fill is allocated (its cells); raises to refuse it.
    floor : float, optional
        Height (metres, world z) of the ground it is set on: no fill point starts under it (:func:`_above`).

    Returns
    -------
    FillResult

    Raises
    ------
    SceneError
        Bad shapes, ``h <= 0``, a fill grid above 512^3 cells, or an open object with
        ``if_open = "error"`` (the message names the object); from ``check_points``.
    """
    points = np.asarray(points, dtype=np.float64)
    _check_fill_arguments(points, h, name, if_open)
    splats = None if splats is None else np.asarray(splats, dtype=np.float64).reshape(-1, 3, 3)
    if splats is None or len(splats) == 0:
        splats = np.repeat(points[:, None], 3, axis=1)
    lo, shape = _fill_grid(points, splats, h, name)
    phi, vlo, voxel_used, r, enclosed, confidence, sealed, thin = (None, lo, 0.0, 0, [], 0.0, 0.0, (0.0, 0.0, []))
    if fill:
        phi, vlo, voxel_used, r, enclosed, confidence, sealed = solid_field(splats, max_dilation, voxel, floor)
    frac = cent = None
    if phi is not None:
        inside, seed, deep = _centre_masks(phi, vlo, voxel_used, lo, shape, h, band(h, voxel_used))
        inside, floored = _above(inside, lo, h, floor)
        thin = thin_parts(phi, vlo, voxel_used, inside, lo, h)
        if check_points is not None:      # refused before the shares are measured: the cells phi puts inside
            check_points(len(points) + int(inside.sum()))
        # the cells at the faces by their shares (issue 66), unless the splats' planes do not hold the splats
        cells, frac, cent = fill_shares.cell_fractions(seed, deep, phi, vlo, voxel_used, splats, lo, h, floor)
        if cells is None:
            cells = np.argwhere(inside)
        method, closed, warning = "six-ray", True, ""
    else:
        inside, floored = _above(rasterize(splats, lo, shape, h), lo, h, floor)
        cells = np.argwhere(inside)
        closed = False
        method = "shell" if not fill else "shell-open"
        shell = float(inside.sum()) * h ** 3
        warning = "" if not fill else _open_warning(name, max_dilation, voxel_used, shell, unit)
        if fill and if_open == "error":
            raise SceneError(warning.replace("; simulated as a hollow shell", "; refusing to simulate a hollow shell"))
    if check_points is not None:
        check_points(len(points) + len(cells))
    fill_x, p_vol_surface, p_vol_fill = _points_and_volumes(points, cells, lo, shape, h, surface_mass, frac, cent)
    volume = float(p_vol_surface.sum() + p_vol_fill.sum())
    box = float(np.prod(np.ptp(cells, axis=0) + 1)) * h ** 3 if len(cells) else 0.0
    report = FillReport(name=name, volume=volume, n_fill=len(fill_x), h=float(h), voxel=float(voxel_used),
                        method=method, closed=closed, dilation=int(r), enclosed=enclosed, warning=warning,
                        confidence=round(confidence, 4), sealed=round(sealed, 4), bbox_share=volume / box if box > 0 else 0.0,
                        thin_share=thin[0], thin_h=thin[1], thin_box=thin[2])
    return FillResult(fill_x, p_vol_surface, p_vol_fill, float(h), volume, report, *floored)


def _points_and_volumes(points: np.ndarray, cells: np.ndarray, lo: np.ndarray, shape, h: float,
                        surface_mass: bool, share: np.ndarray | None = None,
                        centre: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fill points (m, 3) and the volumes (m^3) of the surface points (n,) and of the fill points (m,) for the
    ``cells`` (k, 3) of the grid of corner ``lo`` and spacing ``h`` (``surface_mass``: see :func:`fill_interior`),
    each holding ``share`` (k,) of its ``h^3`` with its fill point at ``centre`` (k, 3) (default: whole, centred)."""
    if share is None:
        share, centre = np.ones(len(cells)), fill_shares.cell_centres(cells, lo, h)
    vol = share * h ** 3
    if surface_mass:
        p_vol_surface, empty = _share_cells(points, cells, lo, shape, h, vol)
        return centre[empty], p_vol_surface, vol[empty]
    if len(cells):
        return centre, np.zeros(len(points)), vol
    own = _cells_or_own(points, cells, lo, shape, h)
    return fill_shares.cell_centres(own, lo, h), np.zeros(len(points)), np.full(len(own), h ** 3)


def _open_warning(name: str, max_dilation: int, voxel: float, volume: float, unit: str = "m") -> str:
    """The warning for an object whose footprints enclose no volume (a shell of ``volume`` ``unit``^3)."""
    size = f"{voxel * 1e3:.3g} mm" if unit == "m" else f"{voxel:.3g} {unit}"
    return (f"object '{name}': its Gaussians enclose no volume (open, or gaps wider than the largest closing, "
            f"{max_dilation} voxels of {size}); simulated as a hollow shell of {volume:.4g} {unit}^3. "
            f"Set fill = false to accept a shell, or close the model")


def _check_fill_arguments(points: np.ndarray, h: float, name: str, if_open: str) -> None:
    """Refuse (:class:`SceneError`) points that are not a non-empty (n, 3) array, ``h <= 0`` or a bad ``if_open``."""
    if points.ndim != 2 or points.shape[1] != 3 or len(points) == 0:
        raise SceneError(f"object '{name}': fill_interior needs a non-empty (n, 3) point array, got {points.shape}")
    if not h > 0:
        raise SceneError(f"object '{name}': fill spacing h must be > 0, got {h}")
    if if_open not in IF_OPEN:
        raise SceneError(f"object '{name}': if_open = {if_open!r}; expected one of {list(IF_OPEN)}")


def _fill_grid(points: np.ndarray, splats: np.ndarray, h: float, name: str) -> tuple[np.ndarray, tuple[int, int, int]]:
    """Corner (metres) and shape of the fill grid of spacing ``h`` around the points and the splats' reach.

    Raises :class:`SceneError` above :data:`MAX_FILL_CELLS` cells.
    """
    reach = SPLAT_SIGMA * np.linalg.norm(splats[:, 1:] - splats[:, :1], axis=2).max()
    allpts = np.concatenate([points, splats.reshape(-1, 3)])
    lo, shape = padded_grid(allpts.min(axis=0) - reach, allpts.max(axis=0) + reach, h, 2)
    if np.prod(shape, dtype=np.float64) > MAX_FILL_CELLS:
        raise SceneError(f"object '{name}': fill grid {shape} too large for h = {h:g} m; raise h "
                         f"(fewer particles per cell or a coarser n_grid)")
    return lo, shape


def _centre_masks(phi: np.ndarray, vlo: np.ndarray, voxel: float, lo: np.ndarray, shape, h: float,
                  band: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where ``phi`` (voxels, positive inside; trilinear in the occupancy field of corner ``vlo``, voxel ``voxel``) at
    the centres of the fill grid's cells is positive, above ``-fill_shares.NEAR_PHI`` and at least ``band``, sampled slab by slab
    along x (bounded memory). Three bool arrays of shape ``shape``."""
    inside, seed, deep = (np.zeros(shape, dtype=bool) for _ in range(3))
    j, k = np.meshgrid(np.arange(shape[1]), np.arange(shape[2]), indexing="ij")
    cy = (lo[1] + (j + 0.5) * h - vlo[1]) / voxel - 0.5
    cz = (lo[2] + (k + 0.5) * h - vlo[2]) / voxel - 0.5
    for i in range(shape[0]):
        cx = np.full(cy.shape, (lo[0] + (i + 0.5) * h - vlo[0]) / voxel - 0.5)
        v = ndimage.map_coordinates(phi, [cx, cy, cz], order=1, mode="constant", cval=-HALF_SHELL)
        inside[i], seed[i], deep[i] = v > 0, v > -fill_shares.NEAR_PHI, v >= band
    return inside, seed, deep


def band(h: float, voxel: float) -> float:
    """Depth (voxels of ``phi``) from which a cell of spacing ``h`` is whole: its taxicab diagonal and two voxels."""
    return 1.5 * h / voxel + 2.0


def _above(inside: np.ndarray, lo: np.ndarray, h: float, floor: float | None) -> tuple[np.ndarray, tuple]:
    """``inside`` (bool, the fill grid's shape) without the cells whose centre lies below ``floor`` (metres, world z
    up; None: unchanged), and (how many it took out, the lowest one's centre z or None). Where a scan's base is
    open the enclosure ends at its side splats' footprints, :data:`~gasp_core.maps.occupancy.SPLAT_SIGMA` of their
    sizes under the lowest Gaussians: set on a ground, the scan-like figure of ``tests/test_stand.py`` got 13 fill
    points 2.2 mm in it under its soles, which held it up at a fifth of the ``E`` it needs (issue 54 item 6,
    ``docs/contact.md``)."""
    if floor is None:
        return inside, (0, None)
    centres = lo[2] + (np.arange(inside.shape[2]) + 0.5) * h
    below = centres < floor
    taken = inside[:, :, below]
    if not taken.any():
        return inside, (0, None)
    low = float(centres[below][taken.any(axis=(0, 1))].min())
    inside = inside.copy()
    inside[:, :, below] = False
    return inside, (int(taken.sum()), low)


def thin_parts(phi: np.ndarray, vlo: np.ndarray, voxel: float, inside: np.ndarray, lo: np.ndarray,
               h: float) -> tuple[float, float, list]:
    """The parts of the occupancy solid (``phi > 0``) farther than ``h`` from every inside fill cell (spacing
    ``h``): thinner than about two cells, so no cell centre falls in them (the band under the surface that
    any cell grid leaves is within ``h`` and does not count).

    Returns
    -------
    share : float
        Their share of the solid's voxels (0 when none).
    h_fill : float
        Half the thickness of the thickest of them, metres (a spacing that puts two cells across it);
        0 when none.
    box : list
        Their bounding box ``[lo, hi]`` (two lists of 3 floats, metres); empty when none.
    """
    solid = phi > 0
    n = int(solid.sum())
    if n == 0:
        return 0.0, 0.0, []
    idx = np.argwhere(solid)
    cell = np.floor((vlo + (idx + 0.5) * voxel - lo) / h).astype(np.int64)
    ok = ((cell >= 0) & (cell < np.array(inside.shape))).all(axis=1)
    covered = np.zeros(solid.shape, bool)
    covered[tuple(idx[ok][inside[tuple(cell[ok].T)]].T)] = True
    if covered.any():
        far = solid & (ndimage.distance_transform_edt(~covered) * voxel > h)
    else:
        far = solid
    if not far.any():
        return 0.0, 0.0, []
    depth = ndimage.distance_transform_edt(solid)[far]
    at = vlo + (np.argwhere(far) + 0.5) * voxel
    return float(far.sum() / n), float(depth.max() * voxel), [at.min(axis=0).tolist(), at.max(axis=0).tolist()]


def _cells_or_own(points: np.ndarray, cells: np.ndarray, lo: np.ndarray, shape, h: float) -> np.ndarray:
    """``cells``, or when nothing is inside at this spacing, the cells of the points themselves."""
    if len(cells):
        return cells
    idx = np.clip(np.floor((points - lo) / h).astype(np.int64), 0, np.array(shape) - 1)
    return np.unique(idx, axis=0)


def _share_cells(points: np.ndarray, cells: np.ndarray, lo: np.ndarray, shape,
                 h: float, vol: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface points share the volume ``vol`` (k,) of the cell of ``cells`` they lie in (or the nearest one); each
    cell no point lies in gets a fill point.

    Returns
    -------
    p_vol_surface : ndarray, shape (n,)
        m^3 per surface point (with no cell, each point's own cell's ``h^3`` shared among its points).
    empty : ndarray, shape (k,), bool
        The cells left without a surface point (each gets a fill point).
    """
    flat_inside = np.ravel_multi_index(cells.T, shape)
    idx = np.clip(np.floor((points - lo) / h).astype(np.int64), 0, np.array(shape) - 1)
    flat_pts = np.ravel_multi_index(idx.T, shape)
    pos = np.searchsorted(flat_inside, flat_pts)        # cells are in ravel order (sorted)
    hit = (pos < len(flat_inside)) & (flat_inside[np.minimum(pos, max(len(flat_inside) - 1, 0))] == flat_pts) \
        if len(flat_inside) else np.zeros(len(flat_pts), bool)
    owner = np.where(hit, pos, -1)
    if (~hit).any() and len(cells):
        _, near = cKDTree(fill_shares.cell_centres(cells, lo, h)).query(points[~hit])
        owner[~hit] = near
    if len(cells):
        counts = np.bincount(owner, minlength=len(cells))
        p_vol_surface = vol[owner] / counts[owner]
        empty = counts == 0
    else:   # nothing inside at this spacing: the points keep their own cells
        _, inv, counts = np.unique(flat_pts, return_inverse=True, return_counts=True)
        p_vol_surface = h ** 3 / counts[inv]
        empty = np.zeros(0, bool)
    return p_vol_surface, empty
