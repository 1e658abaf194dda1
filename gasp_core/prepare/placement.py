"""Placing an object: read its Gaussians, turn them into the world frame, flatten, triangulate.

World frame: metres, z up. ``x_world = scale * R @ x_file + t`` (:class:`Placement`), ``R`` the
object's ``rotation`` after its up axis; the GaMeS map
``T`` (GASP paper Sec. 3) turns each flattened Gaussian into its triangle.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gasp_core.maps.fill import FillReport
from gasp_core.maps.floaters import find_floaters
from gasp_core.maps.games import FlattenReport, flatten_report
from gasp_core.gs.gaussians import Gaussians
from gasp_core.maps.hierarchy import Hierarchy, build_hierarchy
from gasp_core.gs.io import read_gaussians
from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.prepare.checks import check_object
from gasp_core.prepare.mesh import bind_object, laid_gaussians
from gasp_core.maps.mesh_bind import MeshBinding
from gasp_core.scene.spec import ObjectSpec
from gasp_core.prepare.selection import flat_world, moving_rows

#: Rotation taking each file up-axis to world +z (proper rotations; x_world = R @ x_file).
UP_ROTATIONS = {
    "+z": np.eye(3),
    "-z": np.diag([1.0, -1.0, -1.0]),
    "+y": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]),
    "-y": np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]]),
    "+x": np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]]),
    "-x": np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]]),
}


def euler_matrix(degrees) -> np.ndarray:
    """Rotation about world x, then y, then z (degrees), as a matrix ``Rz @ Ry @ Rx``, shape (3, 3).

    The ``rotation`` of objects and of ``[[collider]]`` entries (extrinsic x-y-z angles).
    """
    ax, ay, az = (np.radians(float(a)) for a in degrees)
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    Rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return Rz @ Ry @ Rx


@dataclass
class Placement:
    """Similarity transform file -> world: ``x_world = scale * R @ x_file + t``."""

    R: np.ndarray
    scale: float
    t: np.ndarray

    def to_world(self, x: np.ndarray) -> np.ndarray:
        return self.scale * x @ self.R.T + self.t

    def to_file(self, x: np.ndarray) -> np.ndarray:
        return ((x - self.t) / self.scale) @ self.R


@dataclass
class PreparedObject:
    """One object ready to simulate, and what is needed to rebuild its Gaussians.

    Attributes
    ----------
    spec : ObjectSpec
    gaussians : Gaussians
        As read (file frame).
    placement : Placement
    rot_rest, scales_rest : ndarray, shapes (n, 3, 3), (n, 3)
        Flattened rest rotations and scales, world frame (metres).
    tri_rest : ndarray, shape (n, 3, 3)
        Rest triangles, world frame.
    hierarchy : Hierarchy or None
        Core Gaussians and bindings when ``spec.core_fraction < 1``.
    thin_scale : ndarray, shape (n,)
        The input's own thinnest scale, file units (``thickness = "keep"``).
    flatten_report : FlattenReport
    vertex_slice, fill_slice : slice
        Rows of this object's triangle vertices and fill points in ``SimSetup.x``.
    moving : ndarray of int64, or None
        Rows of the file that are simulated (``select``; empty for a ``static`` object); None
        when all are. ``rot_rest``, ``scales_rest``, ``tri_rest``, ``thin_scale`` and
        ``hierarchy`` hold those rows only; ``gaussians`` is always the whole file
        (:mod:`gasp_core.prepare.selection`).
    static_tri : ndarray, shape (m, 3, 3)
        World-frame triangles of the rows that never move, metres (colliders:
        :func:`gasp_core.prepare.selection.static_splats`).
    n_floaters : int
        Floaters left out of the physics (static rows, :func:`drop_floaters`).
    body_model : dict or None
        The model the body takes and why (``gasp_core.prepare.route.resolve_models``; ``run.json``'s ``model``).
    binding : MeshBinding or None
        Mesh mode (``spec.mesh``): the simulated rows bound to the faces of the mesh, whose vertices
        the engine moves (:mod:`gasp_core.prepare.mesh`).
    """

    spec: ObjectSpec
    gaussians: Gaussians
    placement: Placement
    rot_rest: np.ndarray
    scales_rest: np.ndarray
    tri_rest: np.ndarray
    thin_scale: np.ndarray
    flatten_report: FlattenReport
    hierarchy: Hierarchy | None = None
    fill_report: FillReport | None = None
    vertex_slice: slice = field(default_factory=lambda: slice(0, 0))
    fill_slice: slice = field(default_factory=lambda: slice(0, 0))
    name: str = ""
    moving: np.ndarray | None = None
    static_tri: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    surface_rule: dict | None = None
    body_model: dict | None = None
    n_floaters: int = 0
    binding: MeshBinding | None = None

    def simulated_rows(self, a: np.ndarray) -> np.ndarray:
        """The rows of a per-Gaussian array ``a`` (shape (n, ...)) that are simulated."""
        return a if self.moving is None else a[self.moving]


def place(g: Gaussians, spec: ObjectSpec, floating: np.ndarray | None = None) -> Placement:
    """The file -> world transform of an object (up-axis, rotation, metres, position).

    ``R = euler_matrix(spec.rotation) @ UP_ROTATIONS[spec.up_axis]``. With ``recentre``, the bottom centre of the means' bounding box (world orientation) lands on
    ``spec.position``; otherwise ``spec.position`` is a plain offset. ``floating`` (bool, shape (n,)) marks
    floaters, which the bounding box leaves out.
    """
    R = UP_ROTATIONS[spec.up_axis]
    if any(getattr(spec, "rotation", (0.0, 0.0, 0.0))):
        R = euler_matrix(spec.rotation) @ R
    s = float(spec.scale)
    x = s * (g.means if floating is None else g.means[~floating]) @ R.T
    if spec.recentre:
        lo, hi = x.min(axis=0), x.max(axis=0)
        anchor = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
        t = np.asarray(spec.position) - anchor
    else:
        t = np.asarray(spec.position, dtype=np.float64)
    return Placement(R, s, t)


def load_gaussians(spec: ObjectSpec) -> Gaussians:
    """An object's Gaussians: a static file, or a dynamic model ``psi(V, s)`` at ``s = spec.dynamic_time``.

    Raises
    ------
    SceneError
        From :func:`gasp_core.gs.io.read_gaussians` / :func:`gasp_core.gs.io.read_splatv`.
    """
    if spec.mesh is not None and spec.mesh.laid:
        return laid_gaussians(spec.mesh.path, spec.mesh.per_face)
    if spec.dynamic_time is not None:
        base, motion = read_splatv(spec.file)
        return splatv_at(base, motion, spec.dynamic_time)
    return read_gaussians(spec.file)


def prepare_object(spec: ObjectSpec, g: Gaussians | None = None) -> PreparedObject:
    """Read (unless given), place, flatten and triangulate one object.

    Raises
    ------
    SceneError
        From reading the file (see :func:`load_gaussians`), or from
        :func:`gasp_core.prepare.checks.check_object` (no Gaussians, placed beyond the float32 limits).
    """
    g = load_gaussians(spec) if g is None else g
    check_object(spec, g)
    # floaters of a whole object are found in the file frame (the rule is scale and rotation free), so that
    # recentring ignores them; a selection is the user's choice of what moves and is kept as it is
    floating = None if spec.select is not None or spec.keep_floaters or spec.static or spec.mesh else \
        find_floaters(g.means, g.scales.max(axis=1))
    pl = place(g, spec, floating)  # from the whole file: a selection moves, the background stays put
    # flattened and triangulated once, the whole file; a selection takes its rows of the result
    scales_flat, rot_flat, means_w, tri, report = flat_world(g, pl)
    moving, static_tri = moving_rows(spec, g, pl, tri)
    n_floaters, binding = 0, None
    if spec.mesh is not None:           # far Gaussians stay static, like floaters
        binding, moving, static_tri = bind_object(spec, pl, means_w, rot_flat, scales_flat, tri)
    if floating is not None:            # a whole object: moving_rows gave (None, empty)
        moving, static_tri, n_floaters = drop_floaters(spec, g, tri, floating)
    sim = g
    if moving is not None:
        sim = g.subset(moving)
        scales_flat, rot_flat, means_w, tri = scales_flat[moving], rot_flat[moving], means_w[moving], tri[moving]
        report = flatten_report(sim.scales * pl.scale)
    hier = (build_hierarchy(means_w, tri, spec.core_fraction, name=f"{spec.file}: core_fraction")
            if spec.core_fraction < 1.0 and sim.n else None)
    return PreparedObject(spec=spec, gaussians=g, placement=pl, rot_rest=rot_flat,
                          scales_rest=scales_flat, tri_rest=tri, thin_scale=sim.scales.min(axis=1),
                          flatten_report=report, hierarchy=hier, name=Path(spec.file).stem,
                          moving=moving, static_tri=static_tri, n_floaters=n_floaters, binding=binding)


def drop_floaters(spec: ObjectSpec, g: Gaussians, tri: np.ndarray, floating: np.ndarray | None):
    """Moving rows and the static rows' triangles when the floaters ``floating`` (bool, one per row of the
    file, :func:`gasp_core.maps.floaters.find_floaters`) stay static, and their count; warns once naming
    the count. ``(None, empty, 0)`` when there are none."""
    if floating is None or not floating.any():
        return None, np.zeros((0, 3, 3)), 0
    k = int(floating.sum())
    warnings.warn(f"object '{Path(spec.file).stem}': {k} floater(s) (Gaussians detached from the object) left "
                  f"out of the domain and the physics, written unchanged in every frame; keep_floaters = true "
                  f"simulates them", stacklevel=3)
    return np.flatnonzero(~floating), tri[floating], k


def simulated_triangles(o: PreparedObject) -> np.ndarray:
    """The triangles (or, with a hierarchy, the cores' 4-point frames; in mesh mode, the mesh's vertices, shape
    (nv, 3)) whose vertices the engine moves."""
    if o.binding is not None:
        return o.binding.vertices
    return o.tri_rest if o.hierarchy is None else o.hierarchy.core_points
