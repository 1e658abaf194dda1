"""Interior filling and per-point volumes, from the Gaussians' own footprints.

Triangle vertices alone are a hollow shell; a solid needs mass inside. Following PhysGaussian
(Xie et al. 2024, Sec. 4.3 "internal filling"), occupied space is found on a voxel grid and every
interior cell without a surface point gets one simulated (never rendered) point at its centre.

What decides "interior" is :mod:`gasp_core.maps.occupancy` (footprints, voxel size from the
splat density, bounded closing, sub-voxel surface).

Volumes (issue 66): a cell deep inside holds ``h^3``; a cell the surface crosses holds its share of ``h^3``, measured
at sub-cells against the planes of the surface splats (:func:`surface_distance`, :func:`cell_fractions`), and its fill
point sits at the centre of its inside part. The simulated surface points assigned to a cell share its volume (a
surface point outside every cell goes to the nearest one), and a cell with none gets one fill point; so the points'
volumes sum to the solid's volume (PhysGaussian: ``dx^3`` over the particles in the cell). Counting every cell whose
centre is inside as a whole ``h^3`` made bars of 4-10 cells across 42 % light to 41 % heavy (docs/fill.md, "The mass at
the faces"). Morphology and distances come from :mod:`scipy.ndimage`.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Callable

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from gasp_core.errors import SceneError
from gasp_core.maps.occupancy import SPLAT_SIGMA, padded_grid, rasterize, sample_phi, solid_field, surface_planes

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
        Called with the point count (an upper bound) before the fill is allocated; raises to refuse it.
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
        cells, frac, cent = cell_fractions(seed, deep, phi, vlo, voxel_used, splats, lo, h, floor)
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
        share, centre = np.ones(len(cells)), _cell_centres(cells, lo, h)
    vol = share * h ** 3
    if surface_mass:
        p_vol_surface, empty = _share_cells(points, cells, lo, shape, h, vol)
        return centre[empty], p_vol_surface, vol[empty]
    if len(cells):
        return centre, np.zeros(len(points)), vol
    own = _cells_or_own(points, cells, lo, shape, h)
    return _cell_centres(own, lo, h), np.zeros(len(points)), np.full(len(own), h ** 3)


def _open_warning(name: str, max_dilation: int, voxel: float, volume: float, unit: str = "m") -> str:
    """The warning for an object whose footprints enclose no volume (simulated as a shell of ``volume``
    ``unit``^3)."""
    size = f"{voxel * 1e3:.3g} mm" if unit == "m" else f"{voxel:.3g} {unit}"
    return (f"object '{name}': its Gaussians enclose no volume (open, or gaps wider than the largest closing, "
            f"{max_dilation} voxels of {size}); simulated as a hollow shell of {volume:.4g} {unit}^3. "
            f"Set fill = false to accept a shell, or close the model")


def _check_fill_arguments(points: np.ndarray, h: float, name: str, if_open: str) -> None:
    """Refuse (:class:`SceneError`) points that are not a non-empty (n, 3) array, ``h <= 0`` or an unknown
    ``if_open``."""
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


def _cell_centres(cells: np.ndarray, lo: np.ndarray, h: float) -> np.ndarray:
    """Centres (metres) of the fill-grid cells ``cells`` (k, 3) of corner ``lo`` and spacing ``h``."""
    return lo + (cells + 0.5) * h


def _centre_masks(phi: np.ndarray, vlo: np.ndarray, voxel: float, lo: np.ndarray, shape, h: float,
                  band: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where ``phi`` (voxels, positive inside; trilinear in the occupancy field of corner ``vlo``, voxel ``voxel``) at
    the centres of the fill grid's cells is positive, above ``-NEAR_PHI`` and at least ``band``, sampled slab by slab
    along x (bounded memory). Three bool arrays of shape ``shape``."""
    inside, seed, deep = (np.zeros(shape, dtype=bool) for _ in range(3))
    j, k = np.meshgrid(np.arange(shape[1]), np.arange(shape[2]), indexing="ij")
    cy = (lo[1] + (j + 0.5) * h - vlo[1]) / voxel - 0.5
    cz = (lo[2] + (k + 0.5) * h - vlo[2]) / voxel - 0.5
    for i in range(shape[0]):
        cx = np.full(cy.shape, (lo[0] + (i + 0.5) * h - vlo[0]) / voxel - 0.5)
        v = ndimage.map_coordinates(phi, [cx, cy, cz], order=1, mode="constant", cval=-1.0)
        inside[i], seed[i], deep[i] = v > 0, v > -NEAR_PHI, v >= band
    return inside, seed, deep


def band(h: float, voxel: float) -> float:
    """Depth (voxels of ``phi``) from which a fill cell of spacing ``h`` is whole: its diagonal in taxicab voxels and
    two voxels for where ``phi`` puts the surface."""
    return 1.5 * h / voxel + 2.0


#: Sub-cells per axis that a cell the surface crosses is sampled at (:func:`cell_fractions`).
SUB = 3
#: Surface planes a point is measured against (its nearest, and the neighbours that make an edge with it), and the
#: cosine under which a neighbour's plane turns from the nearest's (an edge: :func:`surface_distance`).
NEIGHBOURS, EDGE_COS = 16, 0.5
#: How far (footprint radii, the 90th percentile's) a point's foot on a plane may lie from its splat for the plane
#: to join the nearest's at a concave edge (:func:`surface_distance`).
COVER = 1.5
#: Planes nearest a cell's centre that its sub-cells look among.
CANDIDATES = 24
#: Cells by the surface (:func:`cell_fractions`): within one cell of those whose centre has ``phi`` above
#: ``-NEAR_PHI`` voxels (``phi`` stops at ``-HALF_SHELL``, 1.5, outside).
NEAR_PHI = 1.25
_CUBE = np.ones((3, 3, 3), bool)
#: A cell whose share inside is under this is left out (its volume, under 1 % of a cell, is lost).
MIN_SHARE = 0.01


def surface_distance(phi: np.ndarray, vlo: np.ndarray, voxel: float, splats: np.ndarray, h: float,
                     floor: float | None = None) -> Callable[..., tuple[np.ndarray, np.ndarray]]:
    """The signed distance to the solid's surface (metres, positive outside) that :func:`cell_fractions` measures
    cells with (issue 66).

    The surface is the planes of the splats that lie on it (:func:`~gasp_core.maps.occupancy.surface_planes`).
    A point is measured against its nearest plane, bent by the surface's curvature across it (from the neighbours'
    normals: on a curved face the tangent planes lie outside the solid, which they would grow by ``l^2 / 2R``), and
    against the neighbours whose plane turns from the nearest's by more than ``acos(EDGE_COS)``: at a convex edge
    (each behind the other) the solid is the intersection of the half-spaces, at a concave edge their union (a
    sampled edge's nearest plane alone bulges out by the sampling gap, as far as the planes reach). Where no plane is
    within ``2 voxel + h + 2 SPLAT_SIGMA`` splat sizes (the 90th percentile), ``phi`` decides; and no point is
    inside where ``phi`` is more than a voxel outside (past the footprints' shell), nor under a ``floor``.

    Returns
    -------
    callable
        ``distance(q, cand=None)``: for points ``q`` (shape (k, 3)), the signed distance and the width factor
        ``|n|_1`` of the plane it came from (1 for ``phi``'s or the floor's), both shape (k,). ``cand`` (shape
        (k, c), c >= :data:`NEIGHBOURS`) are indices of the planes to look among (``len(planes)``: none), for points
        close together (a cell's sub-cells) that share one search.
    """
    means, normals = surface_planes(splats, phi, vlo, voxel)
    size = np.linalg.norm(splats[:, 1:] - splats[:, :1], axis=2).max(axis=1)
    footprint = SPLAT_SIGMA * float(np.quantile(size, 0.9)) if len(size) else 0.0
    reach = 2.0 * voxel + h + 2.0 * footprint
    cover = COVER * footprint
    tree = cKDTree(means) if len(means) else None
    padded_m = np.concatenate([means, np.full((1, 3), np.inf)])

    def candidates(q: np.ndarray, k: int, bound: float) -> np.ndarray:
        """Indices (shape (len(q), k)) of the ``k`` planes nearest each point within ``bound``; ``len(means)``: none."""
        return tree.query(q, k=k, distance_upper_bound=bound)[1].reshape(len(q), k)

    def distance(q: np.ndarray, cand: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        from_phi = -sample_phi(phi, vlo, voxel, q) * voxel
        sd, width = from_phi.copy(), np.ones(len(q))
        if tree is not None:
            if cand is None:
                j = candidates(q, NEIGHBOURS, reach)
            else:
                dc = np.linalg.norm(padded_m[cand] - q[:, None], axis=2)
                order = np.argsort(dc, axis=1)[:, :NEIGHBOURS]
                j = np.take_along_axis(np.where(dc <= reach, cand, len(means)), order, axis=1)
            valid = j < len(means)
            ok = valid[:, 0]
            j, valid, qq = j[ok], valid[ok], q[ok]
            j = np.where(valid, j, j[:, :1])
            n, m = normals[j], means[j]
            plane = np.einsum("ikj,ikj->ik", n, qq[:, None] - m)
            # pairs of planes that meet at an edge, and whether it is convex (each behind the other)
            cosn = np.einsum("ikj,ilj->ikl", n, n)
            # a plane joins at a concave edge only where the point's foot on it lies on its splat's part of the
            # surface (a face's plane goes on past the face: a dog-bone's gauge face under its grip's shoulder)
            foot = np.einsum("ikj,ikj->ik", qq[:, None] - m, qq[:, None] - m) - plane ** 2 <= cover ** 2
            pair = valid[:, :, None] & valid[:, None, :] & (cosn < EDGE_COS)
            convex = np.einsum("ikj,iklj->ikl", n, m[:, None, :, :] - m[:, :, None, :])
            convex = pair & (convex + np.swapaxes(convex, 1, 2) < 0)
            edge = pair[:, 0]
            dm = m[:, 1:] - m[:, :1]
            dm2 = np.einsum("ikj,ikj->ik", dm, dm)
            smooth = valid[:, 1:] & ~edge[:, 1:] & (dm2 > 0)
            kappa = np.einsum("ikj,ikj->ik", n[:, 1:] - n[:, :1], dm) / np.where(smooth, dm2, 1.0)
            kappa = np.where(smooth, kappa, 0.0).sum(axis=1) / np.maximum(smooth.sum(axis=1), 1)
            lat = np.sqrt(np.maximum(np.einsum("ij,ij->i", qq - m[:, 0], qq - m[:, 0]) - plane[:, 0] ** 2, 0.0))
            best = plane[:, 0] + np.clip(0.5 * kappa * lat ** 2, -0.5 * lat, 0.5 * lat)
            # each plane with those it makes a convex edge with is a convex piece (the intersection of the
            # half-spaces); the nearest's piece joins those it meets at a concave edge (the union)
            piece = np.maximum(plane, np.where(convex, plane[:, None, :], -np.inf).max(axis=2))
            best = np.maximum(best, np.where(convex[:, 0], plane, -np.inf).max(axis=1))
            best = np.minimum(best, np.where(edge & ~convex[:, 0] & foot, piece, np.inf).min(axis=1))
            sd[ok] = np.maximum(best, from_phi[ok] - voxel)     # never inside past the footprints' shell
            width[ok] = np.abs(n[:, 0]).sum(axis=1)
        if floor is not None:
            under = floor - q[:, 2]
            width = np.where(under > sd, 1.0, width)
            sd = np.maximum(sd, under)
        return sd, width

    distance.candidates = (lambda q: candidates(q, CANDIDATES, reach + h)) if tree is not None else None
    return distance


def cell_fractions(seed: np.ndarray, deep: np.ndarray, phi: np.ndarray, vlo: np.ndarray, voxel: float,
                   splats: np.ndarray, lo: np.ndarray, h: float,
                   floor: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fill points of spacing ``h``: the cells that hold part of the solid, the volume each point stands for and
    where (issue 66: a body's mass, and its fill inside its faces).

    ``deep`` cells (``phi`` at their centre at least :func:`band` voxels) are whole. The cells within one cell of the
    ``seed`` (``phi`` above ``-NEAR_PHI`` at their centre) are measured against :func:`surface_distance`: a cell the
    surface crosses is sampled at :data:`SUB` ^3 sub-cells, each inside by the share of it under that distance (a
    slab across the sub-cell), and its point goes to the centre of its inside part. Cells under :data:`MIN_SHARE` of
    a cell are left out. Under a ``floor`` (metres, world z) nothing is inside.

    Returns
    -------
    cells : ndarray, shape (k, 3), int64
        Fill-grid indices, in the grid's ravel order.
    share : ndarray, shape (k,)
        Share of each cell inside the solid, in ``[MIN_SHARE, 1]``.
    centre : ndarray, shape (k, 3)
        Centre of each cell's inside part, metres.
    """
    shape = seed.shape
    deep = deep.copy()
    if floor is not None:
        bottom = lo[2] + np.arange(shape[2]) * h
        deep &= (bottom >= floor)[None, None, :]
    near = np.argwhere(ndimage.binary_dilation(seed, _CUBE) & ~deep)
    distance = surface_distance(phi, vlo, voxel, splats, h, floor)
    centres = _cell_centres(near, lo, h)
    sd, _ = distance(centres)
    share = np.where(sd <= 0, 1.0, 0.0)
    cut = np.abs(sd) < h
    centre = centres.copy()
    if cut.any():
        u = (np.arange(SUB) + 0.5) / SUB - 0.5
        offs = np.stack(np.meshgrid(u, u, u, indexing="ij"), -1).reshape(-1, 3) * h
        idx = np.flatnonzero(cut)
        for s in range(0, len(idx), 4_000):
            ii = idx[s:s + 4_000]
            q = (centres[ii, None, :] + offs[None]).reshape(-1, 3)
            cand = None if distance.candidates is None else np.repeat(distance.candidates(centres[ii]), len(offs), axis=0)
            d, w = distance(q, cand)
            f = np.clip(0.5 - d / (w * h / SUB), 0.0, 1.0).reshape(len(ii), -1)
            tot = f.sum(axis=1)
            share[ii] = tot / f.shape[1]
            cen = np.einsum("ik,ikj->ij", f, q.reshape(len(ii), -1, 3)) / np.maximum(tot, 1e-300)[:, None]
            centre[ii] = np.where(tot[:, None] > 0, cen, centres[ii])
    keep = share >= MIN_SHARE
    dcells = np.argwhere(deep)
    cells = np.concatenate([dcells, near[keep]])
    share = np.concatenate([np.ones(len(dcells)), share[keep]])
    centre = np.concatenate([_cell_centres(dcells, lo, h), centre[keep]])
    order = np.argsort(np.ravel_multi_index(cells.T, shape), kind="stable")
    return cells[order], share[order], centre[order]


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
        _, near = cKDTree(_cell_centres(cells, lo, h)).query(points[~hit])
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
