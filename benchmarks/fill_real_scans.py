"""Filled volume of real captures against an independent estimate (issue 19; method in docs/fill.md).

Objects, each placed z up in metres as a scene would place it (``prepare_object``), filled at the spacing a
default scene gives (n_grid 64, padding 0.5, 8 particles per cell):

* trained captures: the donut (examples/data), the guitar (examples/data, -y up), the kitchen's spinach
  region (examples/kitchen_spinach.toml's selection); the independent estimate is a **visual hull**: voxels
  whose orthographic projection lies inside the opaque footprints' silhouette in each of ``N_VIEWS``
  directions over a hemisphere, an upper bound of the solid (it cannot see concavities);
* the two trained scene slices in /work/shared/data/gs (train-1000: visgl/loaders.gl test data, MIT / data
  Apache-2.0, COLMAP frame, -y up; pc_short: cvlab-epfl/gaussian-splatting-web, Apache-2.0), floaters
  left out as a scene would, against the same visual hull;
* meshes as GaMeS mesh-mode splats (``gasp_core.testing.meshes.mesh_splats``): spot (closed), spot with
  its hoof soles removed (an open capture: the base the cameras never saw), and the Stanford bunny as
  scanned (5 holes in its base); the estimate is the mesh volume (the bunny's holes capped by fans).

Writes a JSON list to ``benchmarks/results/fill_real_scans.json`` (or the path given) and prints a table.
Run:  python benchmarks/fill_real_scans.py [out.json]
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.special import expit

from gasp_core.gs.io import write_gaussians
from gasp_core.maps.fill import fill_interior, fill_spacing
from gasp_core.maps.occupancy import density_voxel, splat_samples
from gasp_core.prepare.placement import prepare_object
from gasp_core.scene.spec import ObjectSpec, load_scene
from gasp_core.testing.meshes import mesh_splats

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "examples" / "data"
MESH = Path("/work/shared/data/mesh")
#: Silhouettes carved: view directions over the hemisphere.
N_VIEWS = 64


def directions(n: int = N_VIEWS) -> np.ndarray:
    """``n`` view directions spread over a hemisphere (Fibonacci points; a silhouette is the same from
    opposite sides), shape (n, 3)."""
    i = np.arange(n) + 0.5
    z = i / n
    phi = np.pi * (1 + 5 ** 0.5) * i
    r = np.sqrt(1 - z ** 2)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def visual_hull(splats: np.ndarray, voxel: float) -> float:
    """Volume (m^3) of the voxels (size ``voxel``) inside the footprints' silhouette from every direction."""
    pts = np.concatenate(list(splat_samples(splats, 0.5 * voxel)))
    lo, hi = pts.min(axis=0) - voxel, pts.max(axis=0) + voxel
    axes = [np.arange(a, b, voxel) + 0.5 * voxel for a, b in zip(lo, hi)]
    keep = np.ones([len(a) for a in axes], bool)
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    for d in directions():
        u = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(d, u)
        p2 = np.stack([pts @ u, pts @ v], axis=1)
        o = p2.min(axis=0) - 2 * voxel
        shape = np.ceil((p2.max(axis=0) + 2 * voxel - o) / voxel).astype(int) + 1
        sil = np.zeros(shape, bool)
        ij = np.floor((p2 - o) / voxel).astype(int)
        sil[ij[:, 0], ij[:, 1]] = True
        sil = ndimage.binary_closing(sil, iterations=1)
        g2 = np.stack([grid @ u, grid @ v], axis=-1)
        ij = np.floor((g2 - o) / voxel).astype(int)
        ok = (ij >= 0).all(-1) & (ij < shape).all(-1)
        inside = np.zeros(keep.shape, bool)
        inside[ok] = sil[ij[ok][:, 0], ij[ok][:, 1]]
        keep &= inside
    return float(keep.sum()) * voxel ** 3


def fill_of(o, n_grid: int = 64, padding: float = 0.5, ppc: float = 8.0):
    """The object's fill as a default scene would make it, and its opaque splats."""
    opaque = expit(o.simulated_rows(o.gaussians.opacities).astype(np.float64)) >= o.spec.min_opacity
    splats = o.tri_rest[opaque]
    ext = float(np.ptp(o.tri_rest.reshape(-1, 3), axis=0).max())
    dx = ext * (1 + 2 * padding) / n_grid
    h = fill_spacing(dx, ppc)
    return fill_interior(o.tri_rest.reshape(-1, 3), h, splats=splats, name=o.name), splats


def mesh_volume(mesh) -> float:
    """Volume of a mesh, its boundary loops capped by fans from their centroids (the bunny's 5 holes)."""
    import trimesh
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    directed = set(map(tuple, np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])))
    newV, newF, n = [V], [F], len(V)
    if len(mesh.outline().entities) if not mesh.is_watertight else 0:
        for e in mesh.outline().entities:
            p = list(e.points)[:-1] if e.points[0] == e.points[-1] else list(e.points)
            newV.append(V[p].mean(axis=0)[None])
            fwd = (p[0], p[1]) in directed
            newF += [np.array([[n, p[(i + 1) % len(p)], p[i]] if fwd else [n, p[i], p[(i + 1) % len(p)]]])
                     for i in range(len(p))]
            n += 1
    closed = trimesh.Trimesh(np.concatenate(newV), np.concatenate(newF), process=False)
    assert closed.is_watertight, "capping left the mesh open"
    return float(closed.volume)


def mesh_object(tmp: Path, name: str, mesh, n: int, up_axis: str):
    ply = tmp / f"{name}.ply"
    write_gaussians(ply, mesh_splats(mesh.vertices, mesh.faces, n), overwrite=True)
    return prepare_object(ObjectSpec(file=ply, up_axis=up_axis))


def cases(tmp: Path):
    import trimesh
    yield "donut", prepare_object(ObjectSpec(file=DATA / "donut_v3dg.ply")), None
    yield "guitar", prepare_object(ObjectSpec(file=DATA / "guitar.compressed.ply", up_axis="-y")), None
    spinach = load_scene(ROOT / "examples" / "kitchen_spinach.toml").objects[0]
    yield "kitchen spinach region", prepare_object(spinach), None
    gs = MESH.parent / "gs"
    yield "train-1000 (scene slice)", prepare_object(ObjectSpec(file=gs / "train-1000.ply", up_axis="-y")), None
    yield "pc_short (scene slice)", prepare_object(ObjectSpec(file=gs / "pc_short.ply")), None
    spot = trimesh.load(MESH / "spot_triangulated.obj", process=False)
    spot.merge_vertices(merge_tex=True, merge_norm=True)
    v_spot = mesh_volume(spot)
    yield "spot (GaMeS, closed)", mesh_object(tmp, "spot", spot, 20000, "+y"), v_spot
    y = spot.vertices[:, 1]
    soles = spot.triangles_center[:, 1] < y.min() + 0.02 * np.ptp(y)
    open_spot = trimesh.Trimesh(spot.vertices, spot.faces[~soles], process=False)
    yield (f"spot, hoof soles removed ({int(soles.sum())} faces: open base)",
           mesh_object(tmp, "spot_open", open_spot, 20000, "+y"), v_spot)
    bunny = trimesh.load(MESH / "bun_zipper.ply", process=True)
    yield "bunny (GaMeS, scan with 5 holes)", mesh_object(tmp, "bunny", bunny, 20000, "+y"), mesh_volume(bunny)


def main(out: Path) -> list[dict]:
    import tempfile
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, o, v_mesh in cases(Path(tmp)):
            t0 = time.perf_counter()
            fr, splats = fill_of(o)
            t_fill = time.perf_counter() - t0
            ref = v_mesh if v_mesh is not None else visual_hull(splats, density_voxel(splats))
            r = fr.report
            rows.append({"object": name, "n_gaussians": int(len(o.tri_rest)), "volume_m3": fr.volume,
                         "reference_m3": ref, "reference": "mesh volume" if v_mesh is not None else "visual hull",
                         "ratio": fr.volume / ref, "closed": r.closed, "confidence": r.confidence, "sealed": r.sealed,
                         "bbox_share": r.bbox_share, "thin_share": r.thin_share, "h_m": r.h, "voxel_m": r.voxel,
                         "dilation": r.dilation, "fill_s": round(t_fill, 2), "warning": r.warning})
            print(f"{name:55s} fill {fr.volume:.4g} m^3  {rows[-1]['reference']} {ref:.4g}  "
                  f"ratio {fr.volume / ref:.3f}  closed {r.closed}  conf {r.confidence:.2f} sealed {r.sealed:.2f} "
                  f"thin {r.thin_share:.2f}  ({t_fill:.1f} s)", flush=True)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(rows, indent=1))
    return rows


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "benchmarks" / "results" / "fill_real_scans.json")
