"""``SimSetup.colliders`` (static ones) as MuJoCo mesh geoms.

MuJoCo collides with a mesh geom through its **convex hull** (MuJoCo XML reference, ``mesh``:
"collisions are computed with the convex hull"): a convex collider (a box, a ramp, a ball) is
exact, a concave one (a bowl, a guitar) is its hull. Colliders made from Gaussians carry no mesh
(``Collider.triangles is None``) become the convex hull of their occupied distance-field samples
(``phi <= 0``; :class:`scipy.spatial.ConvexHull`), which is what MuJoCo would collide with anyway. Moving colliders are not
offered: as mocap bodies, the conformance scene ``pusher`` inverted tetrahedra of the pushed block
at frame 10 (t = 0.2 s).
The collider geoms have priority 1, so a contact with them uses the collider's friction.
"""
from __future__ import annotations

import numpy as np

from gasp_core.seam import SceneError


def _fmt(a) -> str:
    return " ".join(f"{float(v):.17g}" for v in np.ravel(a))


def _quat(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix."""
    from gasp_core.gs.gaussians import rotmat_to_quat
    return np.asarray(rotmat_to_quat(np.asarray(R, float)[None]))[0]


def collider_xml(colliders, engine: str) -> tuple[str, str]:
    """``(asset xml, worldbody xml)`` of static colliders.

    Raises
    ------
    SceneError
        A collider from Gaussians whose occupied samples span no volume.
    """
    assets, geoms = [], []
    for i, c in enumerate(colliders):
        if c.triangles is None:
            verts, faces = _hull(c, engine)
        else:
            verts, faces = np.unique(np.asarray(c.triangles, float).reshape(-1, 3), axis=0, return_inverse=True)
        assets.append(f'<mesh name="collider{i}" vertex="{_fmt(verts)}" face="{" ".join(map(str, faces.ravel()))}"/>')
        R, T, _, _ = c.pose(0.0)
        geoms.append(f'<geom type="mesh" mesh="collider{i}" pos="{_fmt(T)}" quat="{_fmt(_quat(R))}" '
                     f'friction="{c.friction:.17g} 0.005 0.0001" priority="1"/>')
    asset = f"<asset>\n{chr(10).join(assets)}\n</asset>\n" if assets else ""
    return asset, "\n".join(geoms)


def _hull(c, engine: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangle indices of the convex hull of a collider's samples with ``phi <= 0``."""
    from scipy.spatial import ConvexHull, QhullError
    idx = np.argwhere(c.phi <= 0.0)
    pts = c.origin + idx * c.h
    try:
        hull = ConvexHull(pts)
    except (QhullError, ValueError) as e:
        raise SceneError(f"engine '{engine}': collider '{c.name}' occupies no volume for a MuJoCo hull: {e}") from None
    used, faces = np.unique(hull.simplices, return_inverse=True)
    return pts[used], faces.reshape(-1, 3)
