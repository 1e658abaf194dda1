"""Building colliders: a signed distance field sampled on a regular grid in the collider's own frame.

From a closed triangle mesh (:func:`collider_from_triangles`; ``trimesh``'s signed distance), from
a static object's Gaussians (:func:`collider_from_splats`: the interior fill's occupancy,
:func:`gasp_core.maps.occupancy.solid_field`, turned into Euclidean distances by
:func:`scipy.ndimage.distance_transform_edt`), or a box with its exact distance (:func:`box_collider`).
Samples are :data:`SDF_SPACING` times the simulation grid's ``dx`` apart, with :data:`SDF_PAD`
samples of padding, at most :data:`MAX_SDF_SAMPLES` of them.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from gasp_core.colliders.model import Collider
from gasp_core.errors import SceneError, extra_hint
from gasp_core.maps.occupancy import rasterize, solid_field

#: SDF sample spacing as a fraction of the simulation grid spacing ``dx``.
SDF_SPACING = 0.5
#: Cells of padding around a collider's SDF grid (the field is exact out to this distance).
SDF_PAD = 4
#: Largest SDF grid, samples.
MAX_SDF_SAMPLES = 256 ** 3


def _grid_around(lo: np.ndarray, hi: np.ndarray, h: float, name: str) -> tuple[np.ndarray, tuple[int, int, int]]:
    origin = lo - SDF_PAD * h
    shape = tuple(int(s) for s in np.ceil((hi - lo) / h).astype(np.int64) + 2 * SDF_PAD + 1)
    if np.prod(shape, dtype=np.float64) > MAX_SDF_SAMPLES:
        raise SceneError(f"collider '{name}': its distance field would need {shape} samples at "
                         f"{h:.3g} m (more than {MAX_SDF_SAMPLES}); lower [domain] n_grid or make it smaller")
    return origin, shape


def _finish(name: str, phi: np.ndarray, origin: np.ndarray, h: float, **kw) -> Collider:
    grad = np.stack(np.gradient(phi, h), axis=-1)
    return Collider(name=name, phi=phi, grad=grad, origin=origin, h=float(h), **kw)


def collider_from_triangles(triangles: np.ndarray, h: float, name: str = "collider", **kw) -> Collider:
    """A collider from a closed triangle mesh (collider frame, metres).

    Parameters
    ----------
    triangles : ndarray, shape (m, 3, 3)
        The mesh, collider frame; it must be closed (watertight) so that inside is defined.
    h : float
        SDF sample spacing, metres (:data:`SDF_SPACING` times the grid's ``dx``).
    name : str
        For messages.
    **kw
        ``friction``, ``position``, ``rotation``, ``motion`` of :class:`Collider`.

    Returns
    -------
    Collider
        ``phi`` from ``trimesh.proximity.signed_distance`` (exact distance to the triangles,
        sign from ray tests), negated to be negative inside.

    Raises
    ------
    SceneError
        trimesh missing, no triangles, or a mesh that is not watertight.
    """
    try:
        import trimesh
    except ImportError:
        raise SceneError(f"collider '{name}': mesh colliders need trimesh and rtree "
                         f"({extra_hint('mesh')})") from None
    tris = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    if len(tris) == 0:
        raise SceneError(f"collider '{name}': the mesh has no triangles")
    mesh = trimesh.Trimesh(**trimesh.triangles.to_kwargs(tris))
    mesh.merge_vertices()
    if not mesh.is_watertight:
        raise SceneError(f"collider '{name}': the mesh is not closed (watertight), so its inside is not "
                         "defined; close it (e.g. give the surface a thickness)")
    origin, shape = _grid_around(mesh.bounds[0], mesh.bounds[1], h, name)
    ii = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    pts = origin + ii * h
    try:
        sd = trimesh.proximity.signed_distance(mesh, pts)
    except (ImportError, ModuleNotFoundError, ValueError) as e:
        raise SceneError(f"collider '{name}': trimesh could not compute distances ({e}); "
                         f"{extra_hint('mesh')}") from None
    phi = (-np.asarray(sd, dtype=np.float64)).reshape(shape)
    return _finish(name, phi, origin, h, triangles=tris, **kw)


def collider_from_splats(splats: np.ndarray, h: float, name: str = "collider", shell: bool = False,
                         bounds=None, carve=None, **kw) -> Collider:
    """A collider from Gaussians (world frame): the space their footprints enclose, as the fill finds it.

    Parameters
    ----------
    splats : ndarray, shape (n, 3, 3)
        GaMeS triangles of the opaque Gaussians, world frame, metres.
    h : float
        SDF sample spacing, metres.
    name : str
    shell : bool
        True for an open surface (the unselected rest of a capture: a pan, a counter): the samples its footprints
        touch are solid and nothing they enclose is filled. False: a closed object, as described below.
    bounds : (lo, hi), optional
        A box (metres, shape (3,) each) the distance grid is clipped to (the simulation domain and its padding).
    carve : ndarray, shape (k, 3), optional
        Points (metres) that must start outside: the samples within :data:`CARVE_SAMPLES` samples of one are made free
        (a selection lying in the captured surface it was cut from: its leaves in the pan's footprints).
    **kw
        ``friction`` of :class:`Collider` (a collider from Gaussians is static).

    Returns
    -------
    Collider
        Occupancy = inside of :func:`gasp_core.maps.occupancy.solid_field` deeper than one of its voxels, with the
        samples its footprints touch within a voxel of its surface and what they enclose (for an open object, the
        samples its footprints touch); ``phi`` = Euclidean distance to it outside minus the
        distance to its outside inside (:func:`scipy.ndimage.distance_transform_edt`), each with
        half a sample removed, so the surface lies between occupied and free samples.
    """
    splats = np.asarray(splats, dtype=np.float64).reshape(-1, 3, 3)
    if len(splats) == 0:
        raise SceneError(f"collider '{name}': no opaque Gaussians to collide with")
    pts = splats.reshape(-1, 3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    if bounds is not None:
        lo, hi = np.maximum(lo, bounds[0]), np.minimum(hi, bounds[1])
    origin, shape = _grid_around(lo, hi, h, name)
    inside_field, field_lo, voxel = (None, None, None) if shell else solid_field(splats)[:3]
    ii = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), axis=-1).reshape(-1, 3)
    samples = origin + ii * h
    surface = rasterize(splats, origin - 0.5 * h, shape, h)
    if inside_field is not None:
        u = (samples - field_lo) / voxel - 0.5
        depth = ndimage.map_coordinates(inside_field, u.T, order=1, mode="constant", cval=-1.0).reshape(shape)
        # the fill's voxel bounds its grid (MAX_VOXELS a side: 9 mm on the 1.1 m guitar), and its surface lies up to
        # a voxel outside the footprints; within a voxel of that surface the footprints, at the SDF's spacing, say
        # what is solid, and the space they enclose with the deeper inside is filled
        occ = ndimage.binary_fill_holes((depth > 1.0) | (surface & (depth > -1.0)))
    else:   # an open surface, thickened so that the grid's nodes (dx = 2 samples apart) see its thinnest wall
        occ = ndimage.binary_dilation(surface, structure=ndimage.generate_binary_structure(3, 1),
                                      iterations=SHELL_SAMPLES) if SHELL_SAMPLES else surface
    if carve is not None and len(carve):
        occ &= ~_near(np.asarray(carve, float), origin, shape, h)
    if not occ.any():
        raise SceneError(f"collider '{name}': its Gaussians occupy no sample of the {h:.3g} m distance grid")
    out = ndimage.distance_transform_edt(~occ) * h
    ins = ndimage.distance_transform_edt(occ) * h
    phi = np.where(occ, -(ins - 0.5 * h), out - 0.5 * h)
    return _finish(name, phi, origin, h, **kw)


#: An open surface (``shell``) is thickened by this many samples on every side (a wall one sample thick grows to
#: three, 1.5 grid cells at :data:`SDF_SPACING`): a grid node lies in it wherever it is crossed. On the kitchen, the
#: spinach Gaussians ending beyond the pan's wall by more than a grid cell: 2 of 351 unthickened, 1 thickened by 1
#: (and by 2, which raises the pan's bottom a further sample), 0 with the carve's six neighbours (docs/colliders.md).
SHELL_SAMPLES = 1
#: A carved point frees the samples within this many samples of it, along the axes (its nearest sample and the six
#: beside it, not the 26 of a cube: a smaller pocket in the wall a selection starts against; the start check allows
#: a quarter sample, and the kitchen's spinach starts at least 0.13 samples outside).
CARVE_SAMPLES = 1.0


def _near(points: np.ndarray, origin: np.ndarray, shape, h: float) -> np.ndarray:
    """Samples of the grid ``origin + i h`` (``shape``) within :data:`CARVE_SAMPLES` samples (city-block) of a point's
    nearest sample, bool."""
    mark = np.zeros(shape, bool)
    idx = np.rint((points - origin) / h).astype(np.int64)
    ok = np.all((idx >= 0) & (idx < np.asarray(shape)), axis=1)
    mark[tuple(idx[ok].T)] = True
    r = int(np.ceil(CARVE_SAMPLES))
    return ndimage.binary_dilation(mark, structure=ndimage.generate_binary_structure(3, 1), iterations=r)


def box_collider(half_extents, h: float, name: str = "box", **kw) -> Collider:
    """A box collider, exact signed distance (no mesh library needed).

    Parameters
    ----------
    half_extents : (3,) float
        Half sides along the collider frame's axes, metres; the box is centred on the frame's origin.
    h : float
        Sample spacing, metres.
    name : str
    **kw
        ``friction``, ``position`` (world position of the centre), ``rotation``, ``motion`` of :class:`Collider`.
    """
    b = np.asarray(half_extents, float)
    if not np.all(b > 0):
        raise SceneError(f"collider '{name}': half extents must be positive, got {b.tolist()}")
    origin, shape = _grid_around(-b, b, h, name)
    ii = np.stack(np.meshgrid(*[np.arange(s) for s in shape], indexing="ij"), axis=-1)
    p = origin + ii * h
    q = np.abs(p) - b
    phi = np.linalg.norm(np.maximum(q, 0.0), axis=-1) + np.minimum(q.max(axis=-1), 0.0)
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * b
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return _finish(name, phi, origin, h, triangles=corners[np.array(faces)], **kw)
