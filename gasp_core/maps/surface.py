"""The surface map: which points of an object the engine moves (``T``) and its Gaussians from where they moved
(``T^-1`` with the control rule), in one place, one class per form (GASP paper Sec. 3, ``G_t = T^-1(phi(T(G), t))``).

A :class:`SurfaceMap` holds the object's simulated Gaussians at rest, world frame, flattened (GaMeS, paper Eq. 2:
a flat Gaussian ``(m, R = [r1, r2, r3], S = diag(eps, s2, s3))`` is the triangle ``v1 = m, v2 = m + s2 r2,
v3 = m + s3 r3``), and answers three questions:

- :meth:`SurfaceMap.points`: the points the engine moves, shape (k, 3), metres;
- :meth:`SurfaceMap.velocities`: their starting velocities from the triangle vertices' (a dynamic model's motion);
- :meth:`SurfaceMap.gaussians`: ``T^-1`` of the moved points with the control rule (paper Eq. alpha_rule).

The forms, one class each, beside the maths they use:

==================  ==============================================  ==========================================
form                the engine moves                                the Gaussians from the moved points
==================  ==============================================  ==========================================
``triangles``       every Gaussian's three triangle vertices        the moved triangles (the paper's map)
``centres``         every Gaussian's centre (PhysGaussian's         ``F`` fitted to the rest neighbours' motion,
                    layout, :mod:`gasp_core.maps.centres`)          the triangle ``[x_c, x_c + F e2, x_c + F e3]``
``cores``           the Core Gaussians' 4-point frames              each sub-Gaussian in its core's moved frame
                    (:mod:`gasp_core.maps.hierarchy`)               (D-MiSo binding, paper Sec. 3.2)
``mesh``            the vertices of a mesh (GaMeS mesh mode,        each Gaussian in its moved face's frame
                    :mod:`gasp_core.maps.mesh_bind`)
==================  ==============================================  ==========================================

:func:`surface_map` is the one place that chooses the form. A map is immutable; the centres' neighbourhoods need
the interior fill, so the assembly binds it once with :meth:`SurfaceMap.with_fill` and keeps the new map.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.maps.centres import CentreFrame, build_centre_frame, centre_triangles
from gasp_core.maps.games import alpha_rule, limit_edges, triangles_to_gaussians, triangles_to_gaussians_covariance
from gasp_core.maps.hierarchy import Hierarchy, build_hierarchy, sub_triangles
from gasp_core.maps.mesh_bind import MeshBinding, bound_triangles
from gasp_core.maps.rows import by_rows

__all__ = ["SurfaceMap", "CentreMap", "CoreMap", "MeshMap", "surface_map"]


@dataclass(frozen=True)
class SurfaceMap:
    """``T`` and ``T^-1`` of one object's simulated Gaussians (the base of the forms; see the module's table).

    Attributes
    ----------
    tri_rest : ndarray, shape (n, 3, 3), float64
        Rest GaMeS triangles of the simulated Gaussians, world frame, metres.
    rot_rest : ndarray, shape (n, 3, 3), float64
        Their flattened rest rotations (columns ``r1, r2, r3``), world frame.
    scales_rest : ndarray, shape (n, 3), float64
        Their flattened rest scales, metres (``eps, s2, s3``).
    rebuild : str
        ``"triangles"`` (the paper's ``T^-1``, :func:`gasp_core.maps.games.triangles_to_gaussians`) or
        ``"covariance"`` (:func:`gasp_core.maps.games.triangles_to_gaussians_covariance`).
    alpha : float or None
        The control rule's ``alpha`` (paper Eq. alpha_rule); None leaves scales free.
    """

    form: ClassVar[str] = "triangles"
    #: Whether the engine moves points of each Gaussian's own triangle (a passive surface then fills from them).
    per_gaussian: ClassVar[bool] = True

    tri_rest: np.ndarray
    rot_rest: np.ndarray
    scales_rest: np.ndarray
    rebuild: str = "triangles"
    alpha: float | None = None

    @property
    def n_gaussians(self) -> int:
        """The Gaussians the engine simulates: every one here, the cores in the ``cores`` form."""
        return len(self.tri_rest)

    def as_triangles(self) -> SurfaceMap:
        """The same Gaussians and rule on the paper's own form, every triangle's three vertices (the soup)."""
        return SurfaceMap(self.tri_rest, self.rot_rest, self.scales_rest, self.rebuild, self.alpha)

    def record(self) -> dict:
        """What ``run.json`` says of the map: ``n_simulated_gaussians`` and the ``centres_degenerate`` and ``mesh``
        reports of those forms (None for the others)."""
        return {"n_simulated_gaussians": self.n_gaussians, "centres_degenerate": None, "mesh": None}

    def points(self) -> np.ndarray:
        """The points the engine moves, at rest, shape (k, 3), float64, metres (``T``)."""
        return self.tri_rest.reshape(-1, 3)

    def reach(self) -> np.ndarray:
        """Simulated points at rest that lie beyond the rest triangles, which the domain must hold too, shape (j, 3),
        metres (none but a mesh's vertices)."""
        return np.zeros((0, 3))

    def shape_rows(self) -> np.ndarray:
        """For each Gaussian :meth:`gaussians` returns, the rows of :meth:`points` its shape is rebuilt from, shape
        (n, k), int64, the anchor first: its triangle's ``v1, v2, v3`` here."""
        return np.arange(3 * len(self.tri_rest), dtype=np.int64).reshape(-1, 3)

    def anchors(self) -> np.ndarray:
        """For each Gaussian :meth:`gaussians` returns, the row of :meth:`points` it is labelled by, shape (n,),
        int64: the first of :meth:`shape_rows` (the triangle's ``v1``, its centre); a piece of a broken body
        (``gasp_core.run.pieces``) takes the whole Gaussian, so a triangle whose vertices fall in different pieces
        belongs to ``v1``'s."""
        return self.shape_rows()[:, 0]

    def velocities(self, v_tri: np.ndarray) -> np.ndarray:
        """The velocities of :meth:`points` (shape (k, 3), m/s) from those of the rest triangles' vertices
        ``v_tri`` (shape (n, 3, 3), m/s)."""
        return v_tri.reshape(-1, 3)

    def with_fill(self, fill_rest: np.ndarray) -> SurfaceMap:
        """This map bound to the object's interior fill points at rest (shape (m, 3), metres); itself where the
        form does not use them."""
        return self

    def triangles(self, x: np.ndarray, fill: np.ndarray) -> np.ndarray:
        """The moved triangles, shape (n, 3, 3), metres, from the moved :meth:`points` ``x`` (shape (k, 3)) and
        fill points ``fill`` (shape (m, 3))."""
        return x.reshape(-1, 3, 3)

    def gaussians(self, x: np.ndarray, fill: np.ndarray, prev_rot: np.ndarray, out: dict | None = None):
        """``T^-1`` with the control rule: the Gaussians of the moved points, world frame.

        Parameters
        ----------
        x : ndarray, shape (k, 3), float
            The moved :meth:`points`, metres.
        fill : ndarray, shape (m, 3), float
            The object's moved fill points, metres (read by the ``centres`` form only).
        prev_rot : ndarray, shape (n, 3, 3)
            The previous frame's rotations, the fallback of a degenerate triangle.
        out : dict, optional
            Filled with ``tri`` (the moved triangles before any clamp, shape (n, 3, 3), metres) and ``clamped``
            (shape (n,), bool: the rule held one of the Gaussian's scales), for the split of clamped triangles
            (:mod:`gasp_core.maps.split`).

        Returns
        -------
        means, rotations, scales : ndarray, shapes (n, 3), (n, 3, 3), (n, 3), float64
            World frame, metres; the thinnest scale is GaMeS' ``eps``.
        counts : dict
            ``degenerate`` triangles and ``clamped`` scales (the alpha rule) of this frame.
        """
        tri_t = self.triangles(x, fill)
        args = (tri_t, prev_rot, self.tri_rest, self.scales_rest)
        # on the host's cores in chunks (a non-finite vertex in one call: its error names the whole object's face)
        means, rot, scales, degenerate, clamped = (by_rows(self._inverse, len(tri_t), *args)
                                                   if np.isfinite(tri_t).all() else self._inverse(*args))
        if out is not None:
            out["tri"], out["clamped"] = tri_t, clamped.any(axis=1)
        return means, rot, scales, {"degenerate": int(degenerate.sum()), "clamped": int(clamped.sum())}

    def _inverse(self, tri, prev_rot, tri_rest, scales_rest) -> tuple:
        """:meth:`gaussians`' rows: ``T^-1`` and the control rule of the moved triangles ``tri`` (k, 3, 3) beside
        their rest ``tri_rest`` and ``scales_rest``; ``(means, rot, scales, degenerate, clamped (k, 2))``, row by row
        (:func:`gasp_core.maps.rows.by_rows` runs it in chunks)."""
        clamped = np.zeros((len(tri), 2), bool)
        if self.rebuild == "covariance":
            if self.alpha is not None:
                tri, clamped = limit_edges(tri_rest, tri, self.alpha)
            means, rot, scales, degenerate = triangles_to_gaussians_covariance(tri, fallback=prev_rot)
        else:
            means, rot, scales, degenerate = triangles_to_gaussians(tri, fallback=prev_rot)
            if self.alpha is not None:
                scales, clamped = alpha_rule(tri_rest, tri, scales, scales_rest, self.alpha)
        return means, rot, scales, degenerate, clamped


@dataclass(frozen=True)
class CentreMap(SurfaceMap):
    """PhysGaussian's layout: the engine moves each Gaussian's centre; ``F`` is fitted to the motion of its rest
    neighbours among the centres and the fill (:mod:`gasp_core.maps.centres`).

    ``frame`` (:class:`gasp_core.maps.centres.CentreFrame`, rows local to ``[centres; fill]``) is None until
    :meth:`with_fill`.
    """

    form: ClassVar[str] = "centres"
    frame: CentreFrame | None = None

    def points(self) -> np.ndarray:
        return self.tri_rest[:, 0]

    def shape_rows(self) -> np.ndarray:
        """Each Gaussian's centre (its frame is fitted to the rest neighbours, never split by a crack)."""
        return np.arange(len(self.tri_rest), dtype=np.int64)[:, None]

    def record(self) -> dict:
        return {**super().record(), "centres_degenerate": None if self.frame is None else self.frame.n_degenerate}

    def velocities(self, v_tri: np.ndarray) -> np.ndarray:
        return v_tri[:, 0]

    def with_fill(self, fill_rest: np.ndarray) -> CentreMap:
        n = len(self.tri_rest)
        x = np.concatenate([self.points(), fill_rest])
        return dataclasses.replace(self, frame=build_centre_frame(x, np.arange(n), np.arange(len(x))))

    def triangles(self, x: np.ndarray, fill: np.ndarray) -> np.ndarray:
        if self.frame is None:
            raise RuntimeError("CentreMap.triangles: the map was not bound to its fill (with_fill)")
        return centre_triangles(self.frame, np.concatenate([x, fill]), self.tri_rest)


@dataclass(frozen=True)
class CoreMap(SurfaceMap):
    """Core Gaussians (paper Sec. 3.2): the engine moves each core's 4-point frame and every sub-Gaussian follows
    it, bound in the core triangle's frame (D-MiSo; :mod:`gasp_core.maps.hierarchy`)."""

    form: ClassVar[str] = "cores"
    per_gaussian: ClassVar[bool] = False
    hierarchy: Hierarchy | None = None

    @property
    def n_gaussians(self) -> int:
        """The simulated Gaussians: the cores."""
        return self.hierarchy.n_cores

    def points(self) -> np.ndarray:
        return self.hierarchy.core_points.reshape(-1, 3)

    def shape_rows(self) -> np.ndarray:
        """Each sub-Gaussian: its core's four points, ``v1`` (the core's centroid) first."""
        return 4 * np.asarray(self.hierarchy.core_of, np.int64)[:, None] + np.arange(4)

    def velocities(self, v_tri: np.ndarray) -> np.ndarray:
        """Each core's four points take the mean velocity of its members' triangle vertices."""
        h = self.hierarchy
        member = np.repeat(h.core_of, 3)
        count = np.bincount(member, minlength=h.n_cores)[:, None]
        v = v_tri.reshape(-1, 3)
        mean = np.stack([np.bincount(member, v[:, d], minlength=h.n_cores) for d in range(3)], 1) / count
        return np.repeat(mean, 4, axis=0)

    def triangles(self, x: np.ndarray, fill: np.ndarray) -> np.ndarray:
        return sub_triangles(self.hierarchy, x)


@dataclass(frozen=True)
class MeshMap(SurfaceMap):
    """GaMeS mesh mode: the engine moves a mesh's vertices and every Gaussian follows its face
    (:mod:`gasp_core.maps.mesh_bind`)."""

    form: ClassVar[str] = "mesh"
    per_gaussian: ClassVar[bool] = False
    binding: MeshBinding | None = None

    @property
    def n_gaussians(self) -> int:
        return len(self.binding.face_of)

    def points(self) -> np.ndarray:
        return self.binding.vertices

    def shape_rows(self) -> np.ndarray:
        """Each Gaussian: its face's three vertices."""
        return np.asarray(self.binding.faces, np.int64)[self.binding.face_of]

    def reach(self) -> np.ndarray:
        return self.binding.vertices

    def record(self) -> dict:
        return {**super().record(), "mesh": self.binding.report}

    def velocities(self, v_tri: np.ndarray) -> np.ndarray:
        raise SceneError("mesh mode takes no velocity from a dynamic model: set the object's 'velocity'")

    def triangles(self, x: np.ndarray, fill: np.ndarray) -> np.ndarray:
        return bound_triangles(self.binding, x)


def surface_map(tri_rest: np.ndarray, rot_rest: np.ndarray, scales_rest: np.ndarray, *, surface_points: str,
                rebuild: str, alpha: float | None, core_fraction: float = 1.0, means: np.ndarray | None = None,
                binding: MeshBinding | None = None, name: str = "core_fraction") -> SurfaceMap:
    """The one place that chooses an object's form: ``surface_points = "centres"`` first, then a mesh
    (``binding``), then Core Gaussians (``core_fraction < 1``, built here from ``means``, shape (n, 3)), else the
    triangles.

    Raises
    ------
    SceneError
        From :func:`gasp_core.maps.hierarchy.build_hierarchy` (a ``core_fraction`` that leaves no core), naming
        ``name``.
    """
    rule = dict(tri_rest=tri_rest, rot_rest=rot_rest, scales_rest=scales_rest, rebuild=rebuild, alpha=alpha)
    if surface_points == "centres":
        return CentreMap(**rule)
    if binding is not None:
        return MeshMap(**rule, binding=binding)
    if core_fraction < 1.0 and len(tri_rest):
        return CoreMap(**rule, hierarchy=build_hierarchy(means, tri_rest, core_fraction, name=name))
    return SurfaceMap(**rule)
