"""Colliders from a scene: ``[[collider]]`` entries and static objects turned into :class:`~gasp_core.colliders.model.Collider` s."""
from __future__ import annotations
import numpy as np
from scipy.special import expit
from gasp_core.errors import SceneError, missing_module_message

from gasp_core.colliders.model import Collider, Motion
from gasp_core.colliders.sdf import collider_from_splats, collider_from_triangles, SDF_PAD, SDF_SPACING


# --------------------------------------------------------------------------- from a scene
def _euler_deg(r) -> np.ndarray:
    """Rotation about x, then y, then z (degrees), as a matrix (the objects' own rule)."""
    from gasp_core.prepare.placed import euler_matrix
    return euler_matrix(r)


def _placed_frame(points: np.ndarray, spec) -> np.ndarray:
    """File points -> collider frame: up axis to +z, scaled, bottom centre at the origin (``recentre``)."""
    from gasp_core.prepare.placed import UP_ROTATIONS
    p = float(spec.scale) * np.asarray(points, float) @ UP_ROTATIONS[spec.up_axis].T
    if spec.recentre:
        lo, hi = p.min(axis=0), p.max(axis=0)
        p = p - np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    return p


def build_colliders(scene, objects, dx: float, lo=None, hi=None, x=None) -> list[Collider]:
    """Every ``[[collider]]`` of ``scene`` as a :class:`Collider` (SDF spacing :data:`SDF_SPACING` ``dx``).

    Parameters
    ----------
    scene : gasp_core.scene.spec.Scene
    objects : list of gasp_core.prepare.placed.PreparedObject
        The scene's objects, placed (for ``object = ...`` colliders).
    dx : float
        Simulation grid spacing, metres.
    lo, hi : array-like, shape (3,), optional
        The simulation domain, metres: an ``object`` collider keeps only the Gaussians within it (padded by the
        SDF's own padding), so that the rest of a large capture costs only the part the bodies can touch.
    x : ndarray, shape (n, 3), optional
        The simulated points at the start, metres: the rest of a capture is carved free around them (a selection
        lies in the surface it was cut from).

    Raises
    ------
    SceneError
        An unreadable mesh, an open, degenerate or too small mesh (:func:`gasp_core.colliders.sdf.closed_mesh`), an
        ``object`` that is not found or not static.
    """
    out = []
    h = SDF_SPACING * dx
    for spec in getattr(scene, "colliders", []):
        R = _euler_deg(spec.rotation)
        motion = Motion(velocity=spec.velocity, angular_velocity=spec.angular_velocity,
                        path=None if spec.path is None else np.array(spec.path, float))
        if spec.mesh is not None:
            try:
                import trimesh
                mesh = trimesh.load(spec.mesh, force="mesh", process=False)   # merged relative to its size later
            except ImportError as e:   # trimesh itself, or Pillow for a mesh with texture coordinates
                raise SceneError(missing_module_message(e, f"{spec.where}.mesh '{spec.mesh}'", "mesh")
                                 or f"{spec.where}.mesh '{spec.mesh}': {e}") from None
            except Exception as e:  # trimesh raises many kinds on a bad file
                raise SceneError(f"{spec.where}.mesh '{spec.mesh}': cannot read it as a mesh ({e})") from None
            if len(getattr(mesh, "faces", [])) == 0:
                raise SceneError(f"{spec.where}.mesh '{spec.mesh}': no triangles")
            verts = _placed_frame(mesh.vertices, spec)
            tris = verts[np.asarray(mesh.faces)]
            out.append(collider_from_triangles(tris, h, name=f"{spec.where} ({spec.mesh.name})",
                                               friction=spec.friction, position=np.array(spec.position, float),
                                               rotation=R, motion=motion, source=f"mesh:{spec.mesh}"))
            continue
        splats = _collider_splats(spec, objects)
        if not len(splats):
            if spec.by_default:    # a selection's rest with no opaque Gaussian (floaters, a halo): nothing to touch
                continue
            raise SceneError(f"{spec.where}: none of its Gaussians has an opacity of min_opacity = "
                             f"{spec.min_opacity} or more: nothing to collide with (lower min_opacity)")
        bounds = None
        if spec.object is not None and lo is not None:
            splats = _within(splats, lo, hi, SDF_PAD * h, spec.where, spec.by_default)
            if not len(splats):    # a selection's rest by default, none of it within reach: nothing to touch
                continue
            bounds = (np.asarray(lo) - SDF_PAD * h, np.asarray(hi) + SDF_PAD * h)
        if spec.object is None:
            splats = (splats.reshape(-1, 3) @ R.T + np.asarray(spec.position, float)).reshape(-1, 3, 3)
        source = f"gaussians:{spec.gaussians}" if spec.object is None else f"object:{spec.object}"
        rest = spec.object is not None and _is_rest(spec, objects)
        out.append(collider_from_splats(splats, h, name=spec.where, friction=spec.friction, source=source,
                                        shell=rest, bounds=bounds, carve=x if rest else None))
    return out


def _within(splats: np.ndarray, lo, hi, pad: float, where: str, may_be_empty: bool = False) -> np.ndarray:
    """The splats (n, 3, 3) with a vertex inside the box ``[lo - pad, hi + pad]``; SceneError when none is (unless
    ``may_be_empty``: then none)."""
    p = splats.reshape(len(splats), -1, 3)
    keep = ((p >= np.asarray(lo) - pad) & (p <= np.asarray(hi) + pad)).all(axis=2).any(axis=1)
    if not keep.any() and not may_be_empty:
        raise SceneError(f"{where}: none of its Gaussians lies within the simulation domain "
                         f"{np.round(lo, 3).tolist()} - {np.round(hi, 3).tolist()}: nothing could touch it")
    return splats[keep]


def _is_rest(spec, objects) -> bool:
    """True when an ``object`` collider is the unselected rest of a capture (``select``): an open surface (a pan,
    a counter, a shelf), so its footprints alone are solid (no enclosed space is filled)."""
    o = _named_object(spec, objects)
    return o.spec.select is not None and not o.spec.static


def _named_object(spec, objects):
    names = [o.name for o in objects]
    if isinstance(spec.object, int):
        return objects[spec.object - 1]
    if spec.object in names:
        return objects[names.index(spec.object)]
    raise SceneError(f"{spec.where}.object = {spec.object!r}: no [[object]] with that file stem; objects: {names}")


def _opaque(o, min_opacity: float) -> np.ndarray:
    return expit(o.gaussians.opacities.astype(np.float64)) >= min_opacity


def _collider_splats(spec, objects) -> np.ndarray:
    """The opaque splats (GaMeS triangles, metres) of a ``gaussians`` (collider frame) or ``object`` (world) collider."""
    from gasp_core.prepare.placement import prepare_object
    from gasp_core.scene.spec import ObjectSpec
    if spec.gaussians is not None:
        o = prepare_object(ObjectSpec(file=spec.gaussians, up_axis=spec.up_axis, scale=spec.scale,
                                      recentre=spec.recentre, fill=False, alpha=None))
        return o.tri_rest[_opaque(o, spec.min_opacity)]
    o = _named_object(spec, objects)
    from gasp_core.prepare.selection import static_rows
    rows = static_rows(o)
    if not len(rows):
        raise SceneError(f"{spec.where}.object = {spec.object!r}: the object is simulated; a collider can only "
                         "be made from a static object (static = true) or the unselected rest of one with "
                         "'select', or use gaussians = \"file.ply\"")
    if any(spec.position) or any(spec.rotation):
        raise SceneError(f"{spec.where}: a collider from an [[object]] sits where the object is (its position "
                         "and rotation); remove 'position' and 'rotation' here")
    alpha = expit(o.gaussians.opacities[rows].astype(np.float64))
    return o.static_tri[alpha >= spec.min_opacity]
