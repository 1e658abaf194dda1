"""Colliders from a scene: ``[[collider]]`` entries and static objects turned into :class:`~gasp_core.colliders.model.Collider` s."""
from __future__ import annotations
import numpy as np
from gasp_core.errors import SceneError, missing_module_message

from gasp_core.colliders.model import Collider, Motion
from gasp_core.colliders.sdf import collider_from_splats, collider_from_triangles, SDF_SPACING


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


def build_colliders(scene, objects, dx: float) -> list[Collider]:
    """Every ``[[collider]]`` of ``scene`` as a :class:`Collider` (SDF spacing :data:`SDF_SPACING` ``dx``).

    Parameters
    ----------
    scene : gasp_core.scene.spec.Scene
    objects : list of gasp_core.prepare.placed.PreparedObject
        The scene's objects, placed (for ``object = ...`` colliders).
    dx : float
        Simulation grid spacing, metres.

    Raises
    ------
    SceneError
        An unreadable mesh, an open mesh, an ``object`` that is not found or not static.
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
                mesh = trimesh.load(spec.mesh, force="mesh")
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
        if spec.object is None:
            splats = (splats.reshape(-1, 3) @ R.T + np.asarray(spec.position, float)).reshape(-1, 3, 3)
        source = f"gaussians:{spec.gaussians}" if spec.object is None else f"object:{spec.object}"
        out.append(collider_from_splats(splats, h, name=spec.where, friction=spec.friction, source=source))
    return out


def _opaque(o, min_opacity: float) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-o.gaussians.opacities.astype(np.float64))) >= min_opacity


def _collider_splats(spec, objects) -> np.ndarray:
    """The opaque splats (GaMeS triangles, metres) of a ``gaussians`` (collider frame) or ``object`` (world) collider."""
    from gasp_core.prepare.placement import prepare_object
    from gasp_core.scene.spec import ObjectSpec
    if spec.gaussians is not None:
        o = prepare_object(ObjectSpec(file=spec.gaussians, up_axis=spec.up_axis, scale=spec.scale,
                                      recentre=spec.recentre, fill=False, alpha=None))
        return o.tri_rest[_opaque(o, spec.min_opacity)]
    names = [o.name for o in objects]
    if isinstance(spec.object, int):
        o = objects[spec.object - 1]
    elif spec.object in names:
        o = objects[names.index(spec.object)]
    else:
        raise SceneError(f"{spec.where}.object = {spec.object!r}: no [[object]] with that file stem; "
                         f"objects: {names}")
    from gasp_core.prepare.selection import static_rows
    rows = static_rows(o)
    if not len(rows):
        raise SceneError(f"{spec.where}.object = {spec.object!r}: the object is simulated; a collider can only "
                         "be made from a static object (static = true) or the unselected rest of one with "
                         "'select', or use gaussians = \"file.ply\"")
    if any(spec.position) or any(spec.rotation):
        raise SceneError(f"{spec.where}: a collider from an [[object]] sits where the object is (its position "
                         "and rotation); remove 'position' and 'rotation' here")
    alpha = 1.0 / (1.0 + np.exp(-o.gaussians.opacities[rows].astype(np.float64)))
    return o.static_tri[alpha >= spec.min_opacity]
