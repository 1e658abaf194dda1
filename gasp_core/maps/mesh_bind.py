"""Gaussians bound to the faces of a triangle mesh (GaMeS mesh mode): the engine moves the mesh's
vertices and every Gaussian follows its face.

GaMeS (Waczynska et al. 2024) places a flat Gaussian on a face ``(a, b, c)`` by barycentric weights
(``m = alpha_1 a + alpha_2 b + alpha_3 c``), takes its rotation from the face's normal and an edge, and
its scales from the face's size times learned factors. Here the same information is held as one
linear map per face: the face frame ``A = [b - a, c - a, L n]`` (columns; ``n`` the unit normal of
``(b - a) x (c - a)``, ``L = sqrt(|(b - a) x (c - a)|)`` a length of the face), and each Gaussian's
GaMeS triangle ``v1 = m, v2 = m + s2 r2, v3 = m + s3 r3`` (:func:`gasp_core.maps.games.gaussians_to_triangles`)
stored as coefficients ``k_j = A^-1 (v_j - a)``. Each frame the triangle is ``v_j' = a' + A' k_j``
and ``T^-1`` rebuilds the Gaussian (with the alpha rule, :mod:`gasp_core.run.frames`).

* ``k_1`` is the mean: barycentric coordinates ``(1 - k_11 - k_12, k_11, k_12)`` and an offset
  ``k_13 L`` along the normal (:attr:`MeshBinding.barycentric`, :attr:`MeshBinding.offset`).
* ``k_2 - k_1`` and ``k_3 - k_1`` are the Gaussian's in-plane axes times its scales in the face's
  frame: its rotation and scales relative to the face.
* Any affine map of the face's plane carries the Gaussian with it; a rigid motion (or a uniform
  scaling) of the mesh moves every bound Gaussian rigidly (scaled): ``A' = Q A`` for a rotation
  ``Q``, so ``v_j' = Q v_j + t`` exactly.

Binding comes from (a) projecting each Gaussian on its nearest face (:func:`project_to_mesh`, a trained
file plus a mesh of the same object) or (c) laying Gaussians on the faces of a bare mesh
(:func:`lay_on_faces`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Faces with ``|(b - a) x (c - a)|`` below this times the mesh size squared are degenerate: no
#: Gaussian is bound to them (their frame has no inverse).
DEGENERATE_AREA = 1e-12
#: Gaussians laid on a face, per unit of ``sqrt(area / count)``: their in-plane standard deviation
#: (0.6 of the spacing: neighbouring footprints overlap, so the surface shows no holes).
LAY_SIGMA = 0.6
#: R2 low-discrepancy sequence (Roberts 2018): the positions of the Gaussians laid on one face.
_R2 = (0.7548776662466927, 0.5698402909980532)


@dataclass(frozen=True)
class MeshBinding:
    """Gaussians bound to mesh faces.

    Attributes
    ----------
    vertices : ndarray, shape (nv, 3), float64
        Rest vertices, world frame, metres: these points are simulated.
    faces : ndarray, shape (nf, 3), int64
        Vertex indices of each face.
    face_of : ndarray, shape (n,), int64
        Face of each bound Gaussian.
    local : ndarray, shape (n, 3, 3), float64
        Row ``j``: vertex ``j`` of the Gaussian's GaMeS triangle in its face's frame (module notes).
    distance : ndarray, shape (n,), float64
        Distance of each Gaussian's mean from its face at binding, metres.
    angle : ndarray, shape (n,), float64
        Angle between the Gaussian's normal and its face's, degrees in [0, 90].
    report : dict
        What ``run.json`` ``mesh`` holds (:func:`binding_report`).
    """

    vertices: np.ndarray
    faces: np.ndarray
    face_of: np.ndarray
    local: np.ndarray
    distance: np.ndarray
    angle: np.ndarray
    report: dict = field(default_factory=dict)

    @property
    def barycentric(self) -> np.ndarray:
        """Barycentric coordinates of each mean on its face (the projection), shape (n, 3)."""
        k = self.local[:, 0]
        return np.stack([1.0 - k[:, 0] - k[:, 1], k[:, 0], k[:, 1]], axis=1)

    @property
    def offset(self) -> np.ndarray:
        """Signed distance of each mean along its face's normal, metres, shape (n,)."""
        _, A = face_frames(self.vertices[self.faces])
        return self.local[:, 0, 2] * np.linalg.norm(A[self.face_of, :, 2], axis=1)


def face_frames(tri: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Origins ``a`` (nf, 3) and frames ``A = [b - a, c - a, L n]`` (nf, 3, 3, columns) of faces ``tri`` (nf, 3, 3).

    A degenerate face gets a zero third column (finite, singular).
    """
    tri = np.asarray(tri, dtype=np.float64)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    cross = np.cross(e1, e2)
    area2 = np.linalg.norm(cross, axis=1)
    ln = cross / np.sqrt(np.where(area2 > 0, area2, 1.0))[:, None]      # L n = cross / sqrt(|cross|)
    return tri[:, 0], np.stack([e1, e2, ln], axis=2)


def degenerate_faces(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces too small to bind to (:data:`DEGENERATE_AREA`), bool, shape (nf,)."""
    tri = vertices[faces]
    size = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    return ~(area2 > DEGENERATE_AREA * size ** 2)


def bind(vertices: np.ndarray, faces: np.ndarray, face_of: np.ndarray, triangles: np.ndarray,
         distance: np.ndarray | None = None, angle: np.ndarray | None = None, report: dict | None = None) -> MeshBinding:
    """Express each Gaussian's GaMeS triangle in the frame of its face.

    Parameters
    ----------
    vertices : ndarray, shape (nv, 3)
        Rest vertices, metres.
    faces : ndarray, shape (nf, 3), int
    face_of : ndarray, shape (n,), int
        Face of each Gaussian; none may be degenerate (:func:`degenerate_faces`).
    triangles : ndarray, shape (n, 3, 3)
        The Gaussians' GaMeS triangles (:func:`gasp_core.maps.games.gaussians_to_triangles`), same frame.
    distance, angle, report
        Kept in the :class:`MeshBinding` (zeros and an empty dict when not given).

    Raises
    ------
    ValueError
        If the shapes disagree or a face index is out of range.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    face_of = np.asarray(face_of, dtype=np.int64)
    tri = np.asarray(triangles, dtype=np.float64)
    n = len(face_of)
    if tri.shape != (n, 3, 3) or faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"bind: expected faces (nf, 3) and triangles ({n}, 3, 3), got {faces.shape}, {tri.shape}")
    if n and (face_of.min() < 0 or face_of.max() >= len(faces)):
        raise ValueError(f"bind: face index out of range [0, {len(faces)})")
    origin, A = face_frames(vertices[faces])
    rel = np.swapaxes(tri - origin[face_of][:, None, :], 1, 2)          # (n, 3, 3): columns = vertices
    local = np.swapaxes(np.linalg.solve(A[face_of], rel), 1, 2) if n else np.zeros((0, 3, 3))
    zeros = np.zeros(n)
    return MeshBinding(vertices=vertices, faces=faces, face_of=face_of, local=local,
                       distance=zeros if distance is None else np.asarray(distance, np.float64),
                       angle=zeros if angle is None else np.asarray(angle, np.float64), report=report or {})


def bound_triangles(b: MeshBinding, x: np.ndarray) -> np.ndarray:
    """Every bound Gaussian's triangle from the moved mesh: ``v_j' = a' + A' k_j``.

    Parameters
    ----------
    b : MeshBinding
    x : ndarray, shape (nv, 3)
        Moved vertices, metres.

    Returns
    -------
    ndarray, shape (n, 3, 3), float64
        Triangles to pass through ``T^-1``; exact for any affine motion of each face's plane.
    """
    origin, A = face_frames(np.asarray(x, dtype=np.float64)[b.faces])
    return origin[b.face_of][:, None, :] + np.einsum("nij,nvj->nvi", A[b.face_of], b.local)


def project_to_mesh(means: np.ndarray, normals: np.ndarray, vertices: np.ndarray,
                    faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each Gaussian's nearest non-degenerate face (``trimesh.proximity.closest_point``, an r-tree search).

    Parameters
    ----------
    means, normals : ndarray, shape (n, 3)
        Gaussian means (metres) and unit normals (the flat Gaussians' rotation column 0).
    vertices, faces : ndarray, shapes (nv, 3), (nf, 3)
        The mesh, same frame.

    Returns
    -------
    face_of : ndarray, shape (n,), int64
    distance : ndarray, shape (n,), float64
        From the mean to the face, metres.
    angle : ndarray, shape (n,), float64
        Between the Gaussian's normal and the face's, degrees in [0, 90].

    Raises
    ------
    ValueError
        If every face is degenerate.
    """
    import trimesh
    keep = np.flatnonzero(~degenerate_faces(vertices, faces))
    if not len(keep):
        raise ValueError("every face of the mesh is degenerate (zero area)")
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces[keep], process=False, validate=False)
    _, distance, tid = trimesh.proximity.closest_point(mesh, np.asarray(means, dtype=np.float64))
    face_of = keep[np.asarray(tid, dtype=np.int64)]
    fn = mesh.face_normals[tid]
    cos = np.clip(np.abs(np.sum(fn * normals, axis=1)), 0.0, 1.0)
    return face_of, np.asarray(distance, np.float64), np.degrees(np.arccos(cos))


def lay_on_faces(vertices: np.ndarray, faces: np.ndarray, per_face: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Places for Gaussians on a bare mesh: a few per face, in proportion to its area.

    Face ``f`` gets ``max(1, round(per_face * area_f / mean area))`` Gaussians (none on degenerate
    faces) at the points of the R2 low-discrepancy sequence folded into the triangle, each with an
    in-plane standard deviation ``LAY_SIGMA * sqrt(area_f / count_f)``.

    Returns
    -------
    face_of : ndarray, shape (n,), int64
    barycentric : ndarray, shape (n, 3), float64
    sigma : ndarray, shape (n,), float64
        Standard deviation in the face's plane, metres (file units).
    """
    tri = np.asarray(vertices, dtype=np.float64)[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    good = ~degenerate_faces(np.asarray(vertices, np.float64), faces)
    count = np.where(good, np.maximum(1, np.rint(per_face * area / area[good].mean())), 0).astype(np.int64)
    face_of = np.repeat(np.arange(len(faces)), count)
    j = np.arange(len(face_of)) - np.repeat(np.cumsum(count) - count, count)     # index within its face
    u = np.mod((j + 0.5)[:, None] * np.array(_R2), 1.0)
    fold = u.sum(axis=1) > 1.0
    u[fold] = 1.0 - u[fold]
    bary = np.stack([1.0 - u[:, 0] - u[:, 1], u[:, 0], u[:, 1]], axis=1)
    sigma = LAY_SIGMA * np.sqrt(area[face_of] / count[face_of])
    return face_of, bary, sigma


def binding_report(b: MeshBinding, n_gaussians: int, size: float, far_rows: np.ndarray, tolerance: float,
                   mode: str, mesh: str) -> dict:
    """The ``run.json`` ``mesh`` record: faces, Gaussians per face, projection distances and angles.

    Parameters
    ----------
    b : MeshBinding
        Its arrays cover the bound Gaussians only.
    n_gaussians : int
        Gaussians of the object (bound and far).
    size : float
        The object's size (largest side of the mesh's bounding box), metres.
    far_rows : ndarray of int
        Rows of the file too far from every face (left static), all of them.
    tolerance : float
        The far limit's share of ``size``.
    mode, mesh : str
        ``"projected"`` or ``"laid"``; the mesh file.
    """
    per_face = np.bincount(b.face_of, minlength=len(b.faces))
    used = per_face > 0
    q = (lambda a, p: float(np.percentile(a, p)) if len(a) else 0.0)
    return {
        "mode": mode, "file": mesh, "n_vertices": int(len(b.vertices)), "n_faces": int(len(b.faces)),
        "n_faces_used": int(used.sum()), "n_bound": int(len(b.face_of)), "n_far": int(len(far_rows)),
        "far_rows": [int(i) for i in far_rows[:100]], "size": size, "tolerance": tolerance,
        "gaussians_per_face": {"mean": float(per_face[used].mean()) if used.any() else 0.0,
                               "max": int(per_face.max()) if len(per_face) else 0},
        "distance": {"median": q(b.distance, 50), "p99": q(b.distance, 99),
                     "max": float(b.distance.max()) if len(b.distance) else 0.0},
        "angle_deg": {"median": q(b.angle, 50), "p99": q(b.angle, 99)},
        "n_vertices_per_gaussian": float(len(b.vertices)) / max(n_gaussians, 1),
    }
