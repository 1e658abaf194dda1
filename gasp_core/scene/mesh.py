"""``[[object]] mesh``: Gaussians bound to a triangle mesh whose vertices the engine moves (GaMeS mesh mode,
:mod:`gasp_core.maps.mesh_bind`, ``docs/mesh_mode.md``).

Two ways in::

    [[object]]
    file = "donut.ply"          # (a) trained Gaussians + a mesh of the same object: each Gaussian is
    mesh = "donut_mesh.ply"     #     projected on its nearest face
    mesh_tolerance = 0.02       #     far limit, share of the object's size (default 0.02)
    mesh_far = "static"         #     Gaussians beyond it: "static" (named in run.json) or "error"

    [[object]]
    mesh = "spot.obj"           # (c) a bare mesh: Gaussians laid on its faces, coloured from its
    gaussians_per_face = 4      #     texture or vertex colours, else grey

The mesh (OBJ, PLY, STL, ... through trimesh) is in the same file frame as ``file``: ``up_axis``,
``scale``, ``rotation`` and ``position`` place both.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from gasp_core.errors import SceneError
from gasp_core.gs.registry import is_dynamic
from gasp_core.scene.values import as_number, as_string, resolve_path

#: What a Gaussian farther than the limit from every face does.
MESH_FAR = ("static", "error")
#: The object keys of mesh mode (besides ``mesh`` itself).
MESH_KEYS = ("mesh_tolerance", "mesh_far", "gaussians_per_face")
#: Keys that do not combine with ``mesh`` -> why.
EXCLUDED = {"select": "the mesh decides what moves", "core_fraction": "the mesh is already the reduced model",
            "static": "a static object is never simulated", "keep_floaters": "the mesh decides what is far",
            "dynamic_time": "a dynamic model has no mesh binding"}


@dataclass(frozen=True)
class MeshSpec:
    """An object's mesh.

    Attributes
    ----------
    path : Path
        The mesh file (resolved).
    laid : bool
        True: no Gaussian file, Gaussians are laid on the faces (``file`` is then the mesh too).
    tolerance : float
        A Gaussian whose 2-sigma footprint stays farther than ``tolerance`` times the object's size from
        every face is far.
    far : str
        ``"static"``: far Gaussians are written unchanged (run.json names them); ``"error"``: refused.
    per_face : float
        Mean Gaussians per face when laying (proportional to area, at least one per face).
    """

    path: Path
    laid: bool = False
    tolerance: float = 0.02
    far: str = "static"
    per_face: float = 4.0


def read_mesh(o: dict, where: str, src: Path) -> MeshSpec | None:
    """An object's ``mesh`` keys, checked (None without ``mesh``).

    Raises
    ------
    SceneError
        ``mesh`` missing or a directory; a mesh key without ``mesh``; ``mesh`` with a key it does not
        combine with (:data:`EXCLUDED`); ``gaussians_per_face`` with a Gaussian file, or
        ``mesh_tolerance`` / ``mesh_far`` without one.
    """
    if "mesh" not in o:
        extra = [k for k in MESH_KEYS if k in o]
        if extra:
            raise SceneError(f"{src}: {where}.{extra[0]} needs 'mesh' (a triangle mesh file)")
        return None
    name = as_string(o["mesh"], f"{where}.mesh", src)
    path = resolve_path(src, name, f"{where}.mesh")
    if not path.is_file():
        raise SceneError(f"{src}: {where}.mesh '{name}' is not a file (looked for {path}); expected a triangle "
                         "mesh (.obj, .ply, .stl)")
    if is_dynamic(o.get("file", "")):
        raise SceneError(f"{src}: {where} sets both 'mesh' and a dynamic model (.splatv); a dynamic model has no "
                         "mesh binding: remove 'mesh'")
    for key, why in EXCLUDED.items():
        if key in o:
            raise SceneError(f"{src}: {where} sets both 'mesh' and '{key}'; {why}: remove '{key}'")
    laid = "file" not in o
    wrong = ["gaussians_per_face"] if not laid else [k for k in ("mesh_tolerance", "mesh_far") if k in o]
    wrong = [k for k in wrong if k in o]
    if wrong:
        raise SceneError(f"{src}: {where}.{wrong[0]} applies to "
                         + ("a bare mesh (no 'file')" if not laid else "a Gaussian 'file' bound to the mesh"))
    return MeshSpec(
        path=path, laid=laid,
        tolerance=as_number(o.get("mesh_tolerance", MeshSpec.tolerance), f"{where}.mesh_tolerance", src, 0.0, 1.0,
                            lo_open=True),
        far=as_string(o.get("mesh_far", MeshSpec.far), f"{where}.mesh_far", src, MESH_FAR),
        per_face=as_number(o.get("gaussians_per_face", MeshSpec.per_face), f"{where}.gaussians_per_face", src,
                           0.0, 1000.0, lo_open=True))
