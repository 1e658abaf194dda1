"""A cup of revolution for examples/cup_drop.toml: the GASP paper's cup, outer radius 4 cm, wall 1 cm, here 8 cm tall
with a 1 cm base (issue 66 item 5). The closed profile (outer wall, rim, inner wall, floor) is revolved about z by
trimesh into a watertight triangle mesh (Euler number 2). Writes examples/data/cup_mesh.ply (metres, z up, the base
at z = 0). Run: python examples/make_cup_mesh.py
"""
from pathlib import Path

import numpy as np
import trimesh

HERE = Path(__file__).resolve().parent
RADIUS, WALL, HEIGHT, BASE = 0.04, 0.01, 0.08, 0.01   # metres
SECTIONS = 48                                          # around the axis


def cup_mesh(radius: float = RADIUS, wall: float = WALL, height: float = HEIGHT, base: float = BASE,
             sections: int = SECTIONS) -> trimesh.Trimesh:
    """The cup: the (r, z) profile revolved about z, watertight; metres."""
    profile = np.array([[0.0, 0.0], [radius, 0.0], [radius, height], [radius - wall, height],
                        [radius - wall, base], [0.0, base]])
    # subdivide the long edges so the faces stay near the wall's thickness (Gaussians laid per face area)
    pts = []
    for a, b in zip(profile[:-1], profile[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / (wall / 2))))
        pts += [a + (b - a) * t for t in np.arange(n) / n]
    pts.append(profile[-1])
    mesh = trimesh.creation.revolve(np.array(pts), sections=sections)
    mesh.merge_vertices()
    mesh.fix_normals()
    return mesh


if __name__ == "__main__":
    m = cup_mesh()
    out = HERE / "data" / "cup_mesh.ply"
    m.export(out)
    print(f"{out}: {len(m.vertices)} vertices, {len(m.faces)} faces, watertight {m.is_watertight}, "
          f"volume {m.volume * 1e6:.1f} cm^3")
