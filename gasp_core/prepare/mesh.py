"""Mesh mode: an object's triangle mesh read, Gaussians laid on a bare mesh, and each Gaussian bound to a face
(:mod:`gasp_core.maps.mesh_bind`, ``[[object]] mesh``, :mod:`gasp_core.scene.mesh`, ``docs/mesh_mode.md``).

:func:`gasp_core.prepare.placement.prepare_object` calls :func:`laid_gaussians` for a bare mesh (before placing)
and :func:`bind_object` after flattening; the engine then moves ``binding.vertices`` instead of the
Gaussians' triangle vertices (the surface map, :class:`gasp_core.maps.surface.MeshMap`).
"""
from __future__ import annotations

import dataclasses
import re
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from gasp_core.errors import SceneError, extra_hint, missing_module_message
from gasp_core.gs.gaussians import Gaussians, rotmat_to_quat
from gasp_core.maps.games import EPS
from gasp_core.maps.mesh_bind import MeshBinding, bind, binding_report, degenerate_faces, lay_on_faces, project_to_mesh
from gasp_core.maps.occupancy import SPLAT_SIGMA
from gasp_core.prepare.placed import Placement

if TYPE_CHECKING:
    from gasp_core.scene.spec import ObjectSpec

#: Over this share of far Gaussians the mesh is refused as not the object's (whatever ``mesh_far`` says).
MAX_FAR_SHARE = 0.1
#: Opacity of laid Gaussians (activated); their colour where the mesh has none (linear RGB).
LAID_OPACITY = 0.99
GREY = 0.5
#: SH degree-0 constant: colour = 0.5 + SH_C0 * sh_dc (graphdeco).
SH_C0 = 0.28209479177387814


def read_mesh(path: Path):
    """A triangle mesh, faces in file order, vertices welded across texture seams (one simulated point per
    position); ``(trimesh.Trimesh, corner_uv or None, corner_rgb or None)`` where ``corner_uv`` (nf, 3, 2) and
    ``corner_rgb`` (nf, 3, 3) in [0, 1] are read before the weld.

    Raises
    ------
    SceneError
        trimesh missing, a file it cannot read, or one with no faces, a face naming a vertex the file does not
        have (an OBJ's vertex 0 too), an ASCII PLY whose header counts other rows than it holds, non-finite vertices, a vertex beyond
        :data:`gasp_core.scene.values.MAX_COORD` from the origin, or only degenerate faces (zero area).
    """
    from gasp_core.scene.values import MAX_COORD
    try:
        import trimesh
    except ImportError:
        raise SceneError(f"{path}: mesh mode needs trimesh ({extra_hint('mesh')})") from None
    _check_ascii_ply_rows(path)
    _check_obj_indices(path)
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except ImportError as e:   # trimesh needs Pillow for a mesh with texture coordinates
        raise SceneError(missing_module_message(e, f"{path}: reading the mesh", "mesh") or f"{path}: {e}") from None
    except Exception as e:  # trimesh raises many kinds on a bad file
        raise SceneError(f"{path}: cannot read the mesh ({type(e).__name__}: {e}); expected OBJ, PLY or STL") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise SceneError(f"{path}: no triangle faces in the mesh")
    faces = np.asarray(mesh.faces)
    wrong = (faces < 0) | (faces >= len(mesh.vertices))
    if wrong.any():
        i, j = np.argwhere(wrong)[0]
        raise SceneError(f"{path}: face {i} names vertex {faces[i, j]}; the mesh has {len(mesh.vertices)} vertices "
                         f"(expected indices 0..{len(mesh.vertices) - 1})")
    if not np.isfinite(mesh.vertices).all():
        raise SceneError(f"{path}: non-finite vertex coordinates in the mesh")
    far = np.abs(np.asarray(mesh.vertices)).max(axis=1) > MAX_COORD
    if far.any():
        k = int(np.flatnonzero(far)[0])
        raise SceneError(f"{path}: {int(far.sum())} vertex(es) beyond {MAX_COORD:g} from the origin (vertex {k} at "
                         f"{np.asarray(mesh.vertices)[k].tolist()}): a corrupt or mis-scaled vertex?")
    bad = degenerate_faces(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64))
    if bad.all():
        raise SceneError(f"{path}: all {len(bad)} faces are degenerate (zero area: coincident or collinear corners); "
                         "nothing to lay Gaussians on")
    uv, rgb = _corner_colours(mesh)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    return mesh, uv, rgb


def _check_obj_indices(path: Path) -> None:
    """Refuse (:class:`SceneError`) an OBJ face that names vertex 0: OBJ counts its vertices from 1 (negative indices
    count back from the last), so 0 names none, and trimesh read it as some other vertex without a word."""
    if Path(path).suffix.lower() != ".obj":
        return
    with open(path, "rb") as f:
        for n, line in enumerate(f, 1):
            if line.startswith(b"f ") and any(tok.split(b"/")[0] in (b"0", b"-0", b"+0") for tok in line.split()[1:]):
                raise SceneError(f"{path}: line {n}: a face names vertex 0; OBJ counts vertices from 1 (or back from "
                                 "the last with -1), so 0 names none")


def _check_ascii_ply_rows(path: Path) -> None:
    """Refuse (:class:`SceneError`) an ASCII PLY whose header's element counts do not add up to its rows (one a line):
    trimesh reads such a file as some other mesh (a face row taken for a vertex, faces left out) without a word."""
    if path.suffix.lower() != ".ply":
        return
    with open(path, "rb") as f:
        head = f.read(65536)
    if not re.search(rb"^format\s+ascii", head, re.MULTILINE) or b"end_header" not in head:
        return
    counts = [int(c) for c in re.findall(rb"^element\s+\S+\s+(\d+)", head.split(b"end_header", 1)[0], re.MULTILINE)]
    with open(path, "rb") as f:
        f.seek(head.index(b"end_header"))
        f.readline()
        rows = sum(1 for line in f if line.strip())
    if rows != sum(counts):
        raise SceneError(f"{path}: an ASCII PLY whose header counts {sum(counts)} rows (elements {counts}) but whose "
                         f"body holds {rows}; expected one row a line, as many as the header says")


def _corner_colours(mesh) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Texture coordinates of the face corners with the texture image, or the corners' vertex colours."""
    visual = mesh.visual
    if visual.kind == "texture" and getattr(visual, "uv", None) is not None:
        image = getattr(visual.material, "image", None) or getattr(visual.material, "baseColorTexture", None)
        if image is not None:
            return np.asarray(visual.uv)[mesh.faces], image
    if visual.kind == "vertex":
        return None, np.asarray(visual.vertex_colors)[mesh.faces, :3] / 255.0
    if visual.kind == "face":
        return None, np.repeat(np.asarray(visual.face_colors)[:, None, :3] / 255.0, 3, axis=1)
    return None, None


def laid_gaussians(path: Path, per_face: float) -> Gaussians:
    """Flat Gaussians laid on the faces of a bare mesh (:func:`gasp_core.maps.mesh_bind.lay_on_faces`), file frame.

    Each lies in its face's plane (thin axis = the face normal, scale :data:`gasp_core.maps.games.EPS`),
    opacity :data:`LAID_OPACITY`, colour from the texture at its point, else the vertex colours
    interpolated, else grey. The binding finds each one's face again by projection (at zero distance).

    Raises
    ------
    SceneError
        From :func:`read_mesh`.
    """
    mesh, uv, rgb = read_mesh(path)
    v, f = np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int64)
    face_of, bary, sigma = lay_on_faces(v, f, per_face)
    means = np.einsum("nk,nkd->nd", bary, v[f[face_of]])
    e1 = v[f[face_of, 1]] - v[f[face_of, 0]]
    normal = np.cross(e1, v[f[face_of, 2]] - v[f[face_of, 0]])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    r2 = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    rot = np.stack([normal, r2, np.cross(normal, r2)], axis=2)
    if uv is not None:
        import trimesh
        colour = trimesh.visual.color.uv_to_color(np.einsum("nk,nkd->nd", bary, uv[face_of]), rgb)[:, :3] / 255.0
    elif rgb is not None:
        colour = np.einsum("nk,nkd->nd", bary, rgb[face_of])
    else:
        colour = np.full((len(face_of), 3), GREY)
    n = len(face_of)
    return Gaussians(means=means, scales=np.stack([np.full(n, EPS), sigma, sigma], axis=1),
                     rotations=rotmat_to_quat(rot), opacities=np.full(n, np.log(LAID_OPACITY / (1 - LAID_OPACITY))),
                     sh_dc=(colour - 0.5) / SH_C0, source=str(path), layout="games")


def bind_object(spec: ObjectSpec, pl: Placement, means: np.ndarray, rot: np.ndarray, scales: np.ndarray,
                tri: np.ndarray) -> tuple[MeshBinding, np.ndarray | None, np.ndarray]:
    """Bind an object's flattened Gaussians (world frame) to its placed mesh.

    Parameters
    ----------
    spec : ObjectSpec
        With ``spec.mesh`` set.
    pl : Placement
        The object's placement; the mesh is placed by it too.
    means, rot, scales, tri : ndarray, shapes (n, 3), (n, 3, 3), (n, 3), (n, 3, 3)
        Flattened Gaussians and their GaMeS triangles, world frame, metres (every row of the file).

    Returns
    -------
    binding : MeshBinding
        Of the bound rows, in file order. A Gaussian far from every face but inside a closed mesh (a
        trained model's interior Gaussians) is bound to its nearest face (``report["n_interior"]``).
    moving : ndarray of int64 or None
        The bound rows (None when all are).
    static_tri : ndarray, shape (m, 3, 3)
        Triangles of the far rows outside the mesh, written unchanged.

    Raises
    ------
    SceneError
        More than :data:`MAX_FAR_SHARE` of the Gaussians far from every face (a mesh of another object),
        or any far and outside with ``mesh_far = "error"``: one line naming the share, the limit and the first rows.
    """
    ms = spec.mesh
    mesh, _, _ = read_mesh(ms.path)
    vertices = pl.to_world(np.asarray(mesh.vertices, np.float64))
    faces = np.asarray(mesh.faces, np.int64)
    size = float(np.ptp(vertices, axis=0).max())
    try:
        face_of, distance, angle = project_to_mesh(means, rot[:, :, 0], vertices, faces)
    except ValueError as e:
        raise SceneError(f"{ms.path}: {e}") from None
    limit = ms.tolerance * size
    far = distance > limit + SPLAT_SIGMA * scales[:, 1:].max(axis=1)
    share = float(far.mean()) if len(far) else 0.0
    what = (f"of '{Path(spec.file).name}' are farther than {limit:.3g} m ({ms.tolerance:g} of the object's size "
            f"{size:.3g} m) beyond their {SPLAT_SIGMA:g}-sigma footprint from every face of '{ms.path.name}'")
    if share > MAX_FAR_SHARE:
        raise SceneError(f"{int(far.sum())} of {len(far)} Gaussians ({100 * share:.1f} %) {what}: the mesh is not "
                         f"of the same object, or not in the same frame (over {100 * MAX_FAR_SHARE:g} % refused)")
    inside = interior(mesh, vertices, means, far)
    off_rows = np.flatnonzero(far & ~inside)      # off the object; deep interior Gaussians are bound
    if len(off_rows):
        what = f"{len(off_rows)} of {len(far)} Gaussians ({100 * len(off_rows) / len(far):.2f} %) {what} (outside it)"
        if ms.far == "error":
            raise SceneError(f"{what}, first rows {off_rows[:8].tolist()}; mesh_far = \"static\" leaves them "
                             "static, or raise mesh_tolerance")
        warnings.warn(f"{what}: left static, written unchanged in every frame (run.json mesh.far_rows names "
                      "them); mesh_far = \"error\" refuses instead", stacklevel=3)
    near = np.setdiff1d(np.arange(len(means)), off_rows)
    b = bind(vertices, faces, face_of[near], tri[near], distance[near], angle[near])
    report = binding_report(b, len(means), size, off_rows, ms.tolerance, "laid" if ms.laid else "projected",
                            str(ms.path))
    report["n_interior"] = int((far & inside).sum())
    return dataclasses.replace(b, report=report), (None if not len(off_rows) else near), tri[off_rows]


def interior(mesh, vertices: np.ndarray, means: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Which of the Gaussians marked in ``rows`` (bool, (n,)) lie inside the closed mesh (placed ``vertices``),
    bool (n,); none where the mesh is open (no inside) or nothing is marked. Inside test: trimesh's ray parity."""
    out = np.zeros(len(means), bool)
    if rows.any() and mesh.is_watertight:
        import trimesh
        placed = trimesh.Trimesh(vertices=vertices, faces=mesh.faces, process=False, validate=False)
        out[rows] = placed.contains(means[rows])
    return out
