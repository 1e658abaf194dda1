"""Placing an object: read its Gaussians, turn them into the world frame, flatten, triangulate.

World frame: metres, z up. ``x_world = scale * R @ x_file + t`` (:class:`Placement`), ``R`` the
object's ``rotation`` after its up axis; the GaMeS map
``T`` (GASP paper Sec. 3) turns each flattened Gaussian into its triangle.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from gasp_core.maps.floaters import find_floaters
from gasp_core.maps.games import flatten_report
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.io import read_gaussians
from gasp_core.gs.splatv import read_splatv, splatv_at
from gasp_core.maps.surface import surface_map
from gasp_core.prepare.checks import check_object
from gasp_core.prepare.mesh import bind_object, laid_gaussians
from gasp_core.prepare.placed import Placement, PreparedObject, euler_matrix
from gasp_core.scene.spec import ObjectSpec
from gasp_core.prepare.selection import flat_world, moving_rows
from gasp_core.prepare.surface import choose_surface_points
from gasp_core.prepare.up import resolve_up_axis, up_rotation

__all__ = ["place", "load_gaussians", "prepare_object", "drop_floaters"]

def place(g: Gaussians, spec: ObjectSpec, floating: np.ndarray | None = None) -> Placement:
    """The file -> world transform of an object (up-axis, rotation, metres, position).

    ``R = euler_matrix(spec.rotation) @ U``, ``U`` the turn of the file's up to +z (``up_axis``, or ``up``:
    :func:`gasp_core.prepare.up.up_rotation`). With ``recentre``, the bottom centre of the means' bounding box
    (world orientation) lands on
    ``spec.position``; otherwise ``spec.position`` is a plain offset. ``floating`` (bool, shape (n,)) marks
    floaters, which the bounding box leaves out.
    """
    R = up_rotation(g, spec.up_axis, getattr(spec, "up", None), Path(spec.file).stem,
                    Path(spec.file).parent / "cameras.json")
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
    spec = choose_surface_points(spec)   # the levels' surface_points = "auto"
    g = load_gaussians(spec) if g is None else g
    check_object(spec, g)
    spec = resolve_up_axis(spec, g)      # no up_axis in the scene: the sure guess, said in one line (issue 68)
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
        if spec.select is not None and spec.select.offset is not None:     # the selection moved, the rest stays
            means_w, tri = means_w + spec.select.offset, tri + np.asarray(spec.select.offset)
    surface = surface_map(tri, rot_flat, scales_flat, surface_points=spec.surface_points, rebuild=spec.rebuild,
                          alpha=spec.alpha, core_fraction=spec.core_fraction if sim.n else 1.0, means=means_w,
                          binding=binding, name=f"{spec.file}: core_fraction")
    return PreparedObject(spec=spec, gaussians=g, placement=pl, surface=surface, thin_scale=sim.scales.min(axis=1),
                          flatten_report=report, name=Path(spec.file).stem, moving=moving, static_tri=static_tri,
                          n_floaters=n_floaters)


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
