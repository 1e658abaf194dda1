"""What a placed object is: the file -> world transform (:class:`Placement`) and the prepared object
(:class:`PreparedObject`), apart from the code that makes them (:mod:`gasp_core.prepare.placement`).

Kept in their own module so that :mod:`.mesh` and :mod:`.selection`, which :mod:`.placement` calls, can name
these types without importing it back (issue 42: an import circle mesh / selection <-> placement).
World frame: metres, z up.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from gasp_core.gs.gaussians import Gaussians
from gasp_core.maps.fill import FillReport
from gasp_core.maps.games import FlattenReport
from gasp_core.maps.surface import SurfaceMap
from gasp_core.scene.spec import ObjectSpec

__all__ = ["UP_ROTATIONS", "euler_matrix", "Placement", "PreparedObject"]

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


@dataclass(frozen=True)
class PreparedObject:
    """One object ready to simulate: its placement and its surface map, built once (immutable).

    Attributes
    ----------
    spec : ObjectSpec
    gaussians : Gaussians
        As read (file frame).
    placement : Placement
    surface : SurfaceMap
        ``T`` and ``T^-1`` of the simulated rows (:mod:`gasp_core.maps.surface`: triangles, centres, Core
        Gaussians or mesh binding), world frame; bound to its fill by the assembly.
    thin_scale : ndarray, shape (n,)
        The input's own thinnest scale, file units (``thickness = "keep"``).
    flatten_report : FlattenReport
    vertex_slice, fill_slice : slice
        Rows of this object's surface points and fill points in ``SimSetup.x`` (set by the assembly,
        :func:`gasp_core.prepare.assembly.build_setup`, which returns a new object).
    moving : ndarray of int64, or None
        Rows of the file that are simulated (``select``; empty for a ``static`` object); None
        when all are. ``surface`` and ``thin_scale`` hold those rows only; ``gaussians`` is always the
        whole file (:mod:`gasp_core.prepare.selection`).
    static_tri : ndarray, shape (m, 3, 3)
        World-frame triangles of the rows that never move, metres (colliders:
        :func:`gasp_core.prepare.selection.static_splats`).
    n_floaters : int
        Floaters left out of the physics (static rows, :func:`drop_floaters`).
    fill_report : FillReport or None
        The interior fill (set by the assembly).
    surface_rule : dict or None
        ``surface = "auto"``'s choice and why (set by the assembly).
    body_model : dict or None
        The model the body takes and why (``gasp_core.prepare.route.resolve_models``; ``run.json``'s ``model``).
    """

    spec: ObjectSpec
    gaussians: Gaussians
    placement: Placement
    surface: SurfaceMap
    thin_scale: np.ndarray
    flatten_report: FlattenReport
    fill_report: FillReport | None = None
    vertex_slice: slice = field(default_factory=lambda: slice(0, 0))
    fill_slice: slice = field(default_factory=lambda: slice(0, 0))
    name: str = ""
    moving: np.ndarray | None = None
    static_tri: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3)))
    surface_rule: dict | None = None
    body_model: dict | None = None
    n_floaters: int = 0

    @property
    def tri_rest(self) -> np.ndarray:
        """Rest triangles of the simulated rows, world frame, metres, shape (n, 3, 3) (the surface map's)."""
        return self.surface.tri_rest

    @property
    def rot_rest(self) -> np.ndarray:
        """Flattened rest rotations of the simulated rows, world frame, shape (n, 3, 3) (the surface map's)."""
        return self.surface.rot_rest

    @property
    def scales_rest(self) -> np.ndarray:
        """Flattened rest scales of the simulated rows, metres, shape (n, 3) (the surface map's)."""
        return self.surface.scales_rest

    def simulated_rows(self, a: np.ndarray) -> np.ndarray:
        """The rows of a per-Gaussian array ``a`` (shape (n, ...)) that are simulated."""
        return a if self.moving is None else a[self.moving]
