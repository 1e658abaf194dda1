"""The silhouette of a broken piece from its geometry (issue 66, the cup's must-show; docs/fracture.md, "Crack faces
against the piece's geometry").

A mesh-mode body (a closed triangle mesh) broken into rigid pieces: a piece *is* the part of the mesh's solid whose
nearest material point at rest is one of its points (the rule :func:`gasp_core.run.fragments.split_body` gives the
passive points, and the Voronoi interface between two pieces' points is where their crack faces stand), moved by the
piece's rigid motion (the best fit of its points, rest to now). Its silhouette in a camera is the projection of that
solid: the pixels whose centre (where the renderer evaluates the Gaussians) lies in the projection of

* the piece's share of the mesh surface: the mesh subdivided to edges of at most ``pitch``, each small triangle the
  piece's when its centroid's nearest material point is, rasterized exactly (pixel centres inside its projection);
* the piece's interior: the centres of the mesh's interior voxels (``voxel`` cubes, none touching the surface) that
  are the piece's, each a disc of radius ``voxel / 2``. These are the rays that meet the solid through crack faces
  only (a strip of wall seen along its length); being a voxel inside the surface, a sample never reaches past it.

Both parts are inside the mesh's solid, so the outline is never larger than the body's; along a cut it is the
Voronoi interface to within a small triangle (``pitch``), and it may miss a band of about ``voxel`` where the
crack's own edge is the outline.
The crack surface is the points' Voronoi interface, stepped at the fill spacing: that is the cut the simulation made.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def subdivide(v: np.ndarray, f: np.ndarray, pitch: float) -> np.ndarray:
    """Triangles of the mesh ``(v, f)`` (vertices (nv, 3) metres, faces (nf, 3) int) split until no edge is over
    ``pitch``, shape (k, 3, 3), metres."""
    import trimesh
    vv, ff = trimesh.remesh.subdivide_to_size(np.asarray(v, np.float64), np.asarray(f, np.int64), pitch,
                                              max_iter=20)
    return vv[ff]


def interior_voxels(v: np.ndarray, f: np.ndarray, pitch: float) -> np.ndarray:
    """Centres (m, 3) of the cubes of side ``pitch`` inside the closed mesh ``(v, f)`` that no face touches."""
    import trimesh
    mesh = trimesh.Trimesh(v, f, process=False)
    shell = mesh.voxelized(pitch)
    solid = shell.copy().fill()
    inner = solid.matrix & ~shell.matrix
    return solid.indices_to_points(np.argwhere(inner))


class PieceGeometry:
    """The broken body's geometry at rest, labelled by nearest material point (module notes).

    Parameters
    ----------
    v, f : ndarray, shapes (nv, 3) float, (nf, 3) int
        The closed mesh at rest, world frame, metres.
    material_rest : ndarray, shape (n, 3)
        The body's material points at rest (setup rows ``rows``), metres.
    rows : ndarray, shape (n,), int
        Their rows in the setup (the labels' index).
    pitch : float
        Longest edge of the subdivided surface, metres (> 0): the cut's granularity on the surface.
    voxel : float or None
        Side of the interior cubes, metres (default ``2 pitch``).

    Raises
    ------
    ValueError
        ``pitch`` or ``voxel`` not positive.
    """

    def __init__(self, v, f, material_rest, rows, pitch: float, voxel: float | None = None):
        voxel = 2.0 * pitch if voxel is None else voxel
        if not (pitch > 0 and voxel > 0):
            raise ValueError(f"pitch and voxel must be positive, got {pitch} and {voxel}")
        self.pitch, self.voxel = float(pitch), float(voxel)
        self.rows = np.asarray(rows, np.int64)
        self.rest = np.asarray(material_rest, np.float64)
        tree = cKDTree(self.rest)
        self.tri = subdivide(v, f, pitch)
        self.tri_owner = self.rows[tree.query(self.tri.mean(1), workers=-1)[1]]
        self.vox = interior_voxels(v, f, self.voxel)
        self.vox_owner = self.rows[tree.query(self.vox, workers=-1)[1]]

    def pose(self, x: np.ndarray, labels: np.ndarray, piece: int) -> tuple[np.ndarray, np.ndarray]:
        """``(R, t)`` of the piece's best rigid fit, rest to the positions ``x`` (setup rows): ``x ~ R x0 + t``."""
        sel = labels[self.rows] == piece
        a, b = self.rest[sel], np.asarray(x, np.float64)[self.rows[sel]]
        ca, cb = a.mean(0), b.mean(0)
        u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
        dd = np.sign(np.linalg.det(vt.T @ u.T))
        R = vt.T @ np.diag([1.0, 1.0, dd]) @ u.T
        return R, cb - R @ ca

    def silhouette(self, cam, x: np.ndarray, labels: np.ndarray, piece: int) -> np.ndarray:
        """The piece's silhouette in ``cam`` at the positions ``x`` with point ``labels`` (setup rows), shape
        (H, W), bool."""
        R, t = self.pose(x, labels, piece)
        mask = np.zeros((cam.height, cam.width), bool)
        tri = self.tri[labels[self.tri_owner] == piece] @ R.T + t
        rasterize(mask, cam, tri)
        vox = self.vox[labels[self.vox_owner] == piece] @ R.T + t
        splat_discs(mask, cam, vox, 0.5 * self.voxel)
        return mask


def rasterize(mask: np.ndarray, cam, tri: np.ndarray) -> None:
    """Set the pixels of ``mask`` (H, W) whose centre lies in the projection of a triangle of ``tri`` (k, 3, 3)."""
    if len(tri) == 0:
        return
    uv, z = cam.project_points(tri.reshape(-1, 3))
    uv = uv.reshape(-1, 3, 2)
    uv = uv[(z.reshape(-1, 3) > cam.near).all(1)]
    lo = np.floor(uv.min(1) - 0.5).astype(np.int64)
    span = np.ceil(uv.max(1) - 0.5).astype(np.int64) - lo + 1
    a, b, c = uv[:, 0], uv[:, 1], uv[:, 2]
    area = cross2(b - a, c - a)
    keep = np.abs(area) > 1e-12
    for du in range(int(span[:, 0].max()) + 1):
        for dv in range(int(span[:, 1].max()) + 1):
            p = np.stack([lo[:, 0] + du + 0.5, lo[:, 1] + dv + 0.5], 1)
            w0, w1, w2 = cross2(b - p, c - p), cross2(c - p, a - p), cross2(a - p, b - p)
            s = np.sign(area)[:, None]
            inside = keep & (np.stack([w0, w1, w2], 1) * s >= 0).all(1)
            i, j = lo[inside, 0] + du, lo[inside, 1] + dv
            ok = (i >= 0) & (i < mask.shape[1]) & (j >= 0) & (j < mask.shape[0])
            mask[j[ok], i[ok]] = True


def cross2(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The z of the cross product of 2-vectors, rows of ``p`` and ``q`` (k, 2)."""
    return p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]


def splat_discs(mask: np.ndarray, cam, pts: np.ndarray, radius: float) -> None:
    """Set the pixels of ``mask`` whose centre is within the projected ``radius`` (metres) of a point ``pts``."""
    if len(pts) == 0:
        return
    uv, z = cam.project_points(pts)
    uv, z = uv[z > cam.near], z[z > cam.near]
    r = radius * cam.focal_px / z
    rmax = int(np.ceil(r.max()))
    base = np.floor(uv).astype(np.int64)
    for du in range(-rmax, rmax + 1):
        for dv in range(-rmax, rmax + 1):
            i, j = base[:, 0] + du, base[:, 1] + dv
            hit = (i + 0.5 - uv[:, 0]) ** 2 + (j + 0.5 - uv[:, 1]) ** 2 <= r * r
            ok = hit & (i >= 0) & (i < mask.shape[1]) & (j >= 0) & (j < mask.shape[0])
            mask[j[ok], i[ok]] = True


#: Longest subdivided edge of the surface, metres: the measure read the same to 0.03 points of share at 0.3 mm
#: (interior cubes 0.3 mm) as at 0.5 mm (1 mm) on the cup's three pieces at 4.43 m/s (docs/fracture.md).
PITCH = 5e-4


def object_geometry(setup, o, pitch: float = PITCH) -> PieceGeometry:
    """The :class:`PieceGeometry` of a mesh-mode object ``o`` (a ``PreparedObject`` with ``spec.mesh``) of the
    prepared ``setup``: its mesh placed in the world at rest, labelled by its material points (its rows with mass).

    Raises
    ------
    ValueError
        The object has no mesh, or no material point.
    """
    from gasp_core.prepare.mesh import read_mesh
    if o.spec.mesh is None:
        raise ValueError(f"object {o.name!r} has no mesh: its geometry is its capture, not a closed surface")
    mesh = read_mesh(o.spec.mesh.path)[0]
    v = o.placement.to_world(np.asarray(mesh.vertices, np.float64))
    rows = np.arange(len(setup.x))
    own = ((rows >= o.fill_slice.start) & (rows < o.fill_slice.stop)) | \
        ((rows >= o.vertex_slice.start) & (rows < o.vertex_slice.stop))
    rows = rows[own & (np.asarray(setup.p_mass) > 0)]
    if len(rows) == 0:
        raise ValueError(f"object {o.name!r} has no material point")
    return PieceGeometry(v, np.asarray(mesh.faces, np.int64), setup.x[rows], rows, pitch)
