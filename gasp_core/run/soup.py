"""Triangle-soup exchange with any mesh tool: export the rest soup, import an animated one.

GASP's engine is a black box that moves triangle vertices (paper Sec. 3, ``V_t = phi(V, t)``).
Any mesh tool can be that black box: :func:`export_soup` writes, per scene object, the rest
triangle soup ``T(G)`` (world frame, metres, z up; one face per Gaussian, ``v1 = m``,
``v2 = m + s2 r2``, ``v3 = m + s3 r3`` after the pipeline's placement and flattening), and
:func:`import_motion` reads a sequence of moved soups back and rebuilds the Gaussians with ``T^-1``
and the object's alpha rule, writing frames in the layout of ``gasp simulate``.

Binding: face ``i`` is Gaussian ``i`` of the object's input file, and the face's first corner is
``v1`` (the mean). The exported files keep vertex ``3 i + k`` = ``v_{k+1}`` of face ``i``; on import
the faces are read through their own vertex indices, so a tool may re-index vertices as long as
it keeps the face order and each face's first corner.

Formats: OBJ and PLY through trimesh (``process=False``: nothing merged or reordered). More
formats come from installed plugins: a ``gasp_soup_writers`` hook returns
:class:`~gasp_core.seam.plugins.SoupWriterInfo` records whose ``write`` is called as
``write(outdir: Path, soups: dict[str, ndarray (n, 3, 3)]) -> list[str]`` (file names it wrote,
relative to ``outdir``) and may raise :class:`~gasp_core.errors.EngineError` when it cannot run
here; the manifest records the reason. They are found like engines (:func:`gasp_core.seam.plugins.registered`),
so ``GASP_LOAD_PLUGINS`` and the duplicate-name check apply.
"""
from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np

from gasp_core import __version__
from gasp_core.errors import EngineError, SceneError, missing_module_message
from gasp_core.gs.gaussians import MAX_MAGNITUDE
from gasp_core.gs.io import write_gaussians
from gasp_core.fsutil import atomic_json, output_folder
from gasp_core.prepare.placed import PreparedObject
from gasp_core.prepare.placement import prepare_object
from gasp_core.run.frames import rebuild
from gasp_core.scene.spec import Scene
from gasp_core.seam.plugins import soup_writers

__all__ = ["SOUP_FORMAT", "MANIFEST", "MESH_SUFFIXES", "object_names", "soup_mesh",
           "export_soup", "read_soup", "motion_files", "import_motion"]

#: Manifest format tag.
SOUP_FORMAT = "gasp-soup/1"
#: Manifest file name inside an export folder.
MANIFEST = "soup.json"
#: Mesh files :func:`import_motion` reads.
MESH_SUFFIXES = (".obj", ".ply")
#: A frame whose object has at least this share of its triangles degenerate (zero area; ``T^-1``'s ``degenerate``
#: count) is refused: no tool's motion of the exported soup collapses every face, and the Gaussians written would be
#: a file the readers refuse (all at one point) or a surface of needles (round 100).
DEGENERATE_SHARE = 1.0


def object_names(objects: list[PreparedObject]) -> list[str]:
    """Output names of the objects, as ``gasp simulate`` names their folders (stem; index prefix if repeated)."""
    stems = [o.name for o in objects]
    return [n if stems.count(n) == 1 else f"{i}_{n}" for i, n in enumerate(stems)]


def soup_mesh(tri: np.ndarray):
    """A ``trimesh.Trimesh`` of a triangle soup, vertex ``3 i + k`` = corner ``k`` of face ``i``.

    Parameters
    ----------
    tri : ndarray, shape (n, 3, 3), float64
        Faces, metres.
    """
    import trimesh
    tri = np.asarray(tri, dtype=np.float64)
    faces = np.arange(3 * len(tri), dtype=np.int64).reshape(-1, 3)
    return trimesh.Trimesh(vertices=tri.reshape(-1, 3), faces=faces, process=False, validate=False)


def _write_mesh(path: Path, tri: np.ndarray) -> None:
    mesh = soup_mesh(tri)
    if path.suffix == ".obj":
        from trimesh.exchange.obj import export_obj
        # 17 significant digits: the file holds the float64 vertices exactly
        text = export_obj(mesh, include_normals=False, include_color=False, include_texture=False,
                          digits=17, header=None)
        path.write_text(text)
    else:
        path.write_bytes(mesh.export(file_type="ply", encoding="binary"))


def _placement_dict(o: PreparedObject) -> dict:
    pl = o.placement
    return {"R": pl.R.tolist(), "scale": pl.scale, "t": pl.t.tolist(),
            "rule": "x_world = scale * R @ x_file + t"}


def export_soup(scene: Scene, outdir: str | Path, overwrite: bool = False,
                formats: tuple[str, ...] = ("obj", "ply"), extra_writers: bool = True) -> dict:
    """Write the rest triangle soup of every scene object, and a manifest.

    Layout: ``OUTDIR/<object>.obj``, ``OUTDIR/<object>.ply`` (world frame, metres, z up; one face
    per Gaussian in input order), files from extra writers (``gasp_soup_writers`` plugins), and
    ``OUTDIR/soup.json`` (format, binding, placement, alpha rule, files, skipped writers).

    Parameters
    ----------
    scene : Scene
    outdir : str or Path
        Must not exist unless ``overwrite`` (replaced only when the export succeeded).
    overwrite : bool
    formats : tuple of {"obj", "ply"}
    extra_writers : bool
        Also run the installed extra writers.

    Returns
    -------
    dict
        The manifest.

    Raises
    ------
    FileExistsError
        ``outdir`` exists and ``overwrite`` is false.
    SceneError
        Unreadable object file, or an unknown format.
    """
    outdir = Path(outdir)
    bad = sorted(set(formats) - {"obj", "ply"})
    if bad:
        raise SceneError(f"export-soup: unknown format(s) {bad}; offered: ['obj', 'ply']")
    protected = [scene.path] + [o.file for o in scene.objects]
    with output_folder(outdir, overwrite=overwrite, protected=protected) as tmp:
        objects = [prepare_object(spec) for spec in scene.objects]
        names = object_names(objects)
        entries = []
        for o, name in zip(objects, names):
            files = {}
            for fmt in formats:
                _write_mesh(tmp / f"{name}.{fmt}", o.tri_rest)
                files[fmt] = f"{name}.{fmt}"
            lo, hi = o.tri_rest.reshape(-1, 3).min(0), o.tri_rest.reshape(-1, 3).max(0)
            entries.append({
                "name": name, "file": str(o.spec.file), "n_gaussians": int(len(o.tri_rest)),
                "n_vertices": int(3 * len(o.tri_rest)), "files": files,
                "placement": _placement_dict(o), "alpha": o.spec.alpha, "thickness": o.spec.thickness,
                "bbox_world": {"lo": lo.tolist(), "hi": hi.tolist()},
                "flatten": o.flatten_report.as_dict()})
        extra, skipped = {}, {}
        if extra_writers:
            soups = {name: o.tri_rest for o, name in zip(objects, names)}
            for name, writer in soup_writers().items():
                try:
                    extra[name] = list(writer.write(tmp, soups))
                except EngineError as e:
                    skipped[name] = str(e)
        manifest = {
            "format": SOUP_FORMAT, "gasp": __version__, "scene": str(scene.path),
            "frame": "world: metres, z up (the frame the engines see)",
            "binding": ("face i = Gaussian i of the object's input file; corners (v1, v2, v3) = "
                        "(m, m + s2 r2, m + s3 r3); vertex 3 i + k = corner k of face i"),
            "objects": entries, "extra_files": extra, "skipped_writers": skipped}
        atomic_json(tmp / MANIFEST, manifest)
    return manifest


def read_soup(path: str | Path, n_faces: int) -> np.ndarray:
    """Read one triangle soup (OBJ or PLY) as faces, shape (n_faces, 3, 3), float64.

    Raises
    ------
    SceneError
        The file cannot be read, holds something other than ``n_faces`` triangles, or has
        non-finite vertices; the message names the file.
    """
    import trimesh
    path = Path(path)
    try:
        mesh = trimesh.load(path, process=False, force="mesh", maintain_order=True)
    except ImportError as e:   # trimesh needs Pillow for a mesh with texture coordinates
        raise SceneError(missing_module_message(e, f"{path}: reading the mesh", "mesh") or f"{path}: {e}") from None
    except Exception as e:  # trimesh raises many types for a bad file
        raise SceneError(f"{path}: cannot read as a triangle mesh: {e}") from None
    faces = np.asarray(mesh.faces)
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) != n_faces:
        raise SceneError(f"{path}: {len(faces)} faces, expected {n_faces} triangles (one per Gaussian, "
                         "in the exported order)")
    tri = np.asarray(mesh.vertices, dtype=np.float64)[faces]
    if not np.isfinite(tri).all():
        raise SceneError(f"{path}: non-finite vertex in face {int(np.flatnonzero(~np.isfinite(tri).all(axis=(1, 2)))[0])}")
    big = np.abs(tri).max(axis=(1, 2)) > MAX_MAGNITUDE
    if big.any():
        i = int(np.flatnonzero(big)[0])
        raise SceneError(f"{path}: face {i} has a vertex coordinate of {np.abs(tri[i]).max():g}; expected magnitudes "
                         f"<= {MAX_MAGNITUDE:g} (float32 headroom)")
    return tri


def _frame_key(p: Path):
    m = re.search(r"(\d+)$", p.stem)
    return (int(m.group(1)) if m else -1, p.name)


def _frame_numbers(files: list[Path], where: Path) -> list[int]:
    """The frame number ending each file's stem (``files`` sorted by :func:`_frame_key`).

    Raises
    ------
    SceneError
        Of two or more files, one whose stem ends in no number, or two with the same number (``frame_1.obj`` and
        ``frame_01.obj``, ``frame_3.obj`` and ``frame_3.ply``): their order would be a guess.
    """
    numbers = [_frame_key(p)[0] for p in files]
    if len(files) > 1 and numbers[0] < 0:
        raise SceneError(f"{files[0]}: the file name ends in no frame number; each frame file in {where} is ordered "
                         "by the number ending its name (frame_0000.obj, frame_0001.obj, ...)")
    same = [i for i in range(1, len(files)) if numbers[i] == numbers[i - 1]]
    if same:
        a, b = files[same[0] - 1], files[same[0]]
        raise SceneError(f"{where}: '{a.name}' and '{b.name}' are both frame {numbers[same[0]]}; expected one file "
                         "per frame number")
    return numbers


def motion_files(motion_dir: str | Path, names: list[str]) -> dict[str, list[Path]] | list[Path]:
    """The frame files of a motion folder, in frame order.

    ``MOTION_DIR/<object>/*.obj|*.ply`` per object (names as in the manifest), or, when those
    folders are absent, the mesh files in ``MOTION_DIR`` itself (each frame file holds every
    object's faces, in scene order). Frames are ordered by the trailing number of the file stem.

    Returns
    -------
    dict of name -> list of Path, or list of Path (one folder for all objects)

    Raises
    ------
    SceneError
        No frame files; per-object folders with different frame counts or frame numbers; of two or more files, one
        whose name ends in no number, or two with the same number (:func:`_frame_numbers`).
    """
    motion_dir = Path(motion_dir)
    if not motion_dir.is_dir():
        raise SceneError(f"{motion_dir}: motion folder not found")

    def files_in(d: Path) -> list[Path]:
        return sorted((p for p in d.iterdir() if p.suffix.lower() in MESH_SUFFIXES and p.is_file()),
                      key=_frame_key)

    if all((motion_dir / n).is_dir() for n in names):
        per = {n: files_in(motion_dir / n) for n in names}
        counts = {n: len(v) for n, v in per.items()}
        if len(set(counts.values())) != 1 or not next(iter(counts.values())):
            raise SceneError(f"{motion_dir}: per-object folders must hold the same, non-zero number of "
                             f"frame files ({', '.join(MESH_SUFFIXES)}); found {counts}")
        numbers = {n: _frame_numbers(v, motion_dir / n) for n, v in per.items()}
        first = names[0]
        for n in names[1:]:
            if len(per[first]) > 1 and numbers[n] != numbers[first]:
                k = next(i for i, (a, b) in enumerate(zip(numbers[first], numbers[n])) if a != b)
                raise SceneError(f"{motion_dir}: frame {k} is '{per[first][k].name}' for '{first}' but "
                                 f"'{per[n][k].name}' for '{n}'; per-object folders must number the same frames")
        return per
    flat = files_in(motion_dir)
    if not flat:
        raise SceneError(f"{motion_dir}: no frame files ({', '.join(MESH_SUFFIXES)}) and no per-object "
                         f"folders {names}")
    _frame_numbers(flat, motion_dir)
    return flat


def import_motion(scene: Scene, motion_dir: str | Path, outdir: str | Path,
                  overwrite: bool = False) -> dict:
    """Rebuild Gaussians from an animated triangle soup, one PLY per object per frame.

    Each frame file's faces are the moved triangles of :func:`export_soup` (same count and order);
    ``T^-1`` (:func:`gasp_core.maps.games.triangles_to_gaussians`) and the object's alpha rule turn them
    back into Gaussians in the input file's frame, exactly as ``gasp simulate`` does
    (:func:`gasp_core.run.pipeline.rebuild`). Output layout: ``OUTDIR/<object>/frame_XXXX.ply``
    (frame 0 = the first file of the sequence) and ``OUTDIR/run.json``.

    Parameters
    ----------
    scene : Scene
        The scene the soup was exported from.
    motion_dir : str or Path
        See :func:`motion_files`.
    outdir : str or Path
        Must not exist unless ``overwrite``.

    Returns
    -------
    dict
        The run summary written to ``run.json``.

    Raises
    ------
    FileExistsError
        ``outdir`` exists and ``overwrite`` is false.
    SceneError
        Missing or malformed frame files (wrong face count, unreadable, non-finite, coordinates past
        ``MAX_MAGNITUDE``), or a frame whose object's triangles are all degenerate (:data:`DEGENERATE_SHARE`).
    """
    outdir = Path(outdir)
    objects = [prepare_object(spec) for spec in scene.objects]
    names = object_names(objects)
    # every face of the object (Core Gaussians, mesh mode or not): the soup carries one face per Gaussian
    flat_objects = [dataclasses.replace(o, surface=o.surface.as_triangles(),
                                        vertex_slice=slice(0, 3 * len(o.tri_rest)))
                    for o in objects]
    files = motion_files(motion_dir, names)
    n_faces = [len(o.tri_rest) for o in objects]
    if isinstance(files, dict):
        n_frames = len(files[names[0]])
        frame_sources = [[files[n][f] for n in names] for f in range(n_frames)]
    else:
        n_frames = len(files)
        frame_sources = [[p] for p in files]

    protected = [scene.path, motion_dir] + [o.file for o in scene.objects]
    with output_folder(outdir, overwrite=overwrite, protected=protected) as tmp:
        for name in names:
            (tmp / name).mkdir()
        prev = [o.rot_rest for o in objects]
        rows = []
        for f, sources in enumerate(frame_sources):
            if len(sources) == 1 and len(objects) > 1:
                tri_all = read_soup(sources[0], sum(n_faces))
                tris = np.split(tri_all, np.cumsum(n_faces)[:-1])
            else:
                tris = [read_soup(p, n) for p, n in zip(sources, n_faces)]
            row = {"frame": f, "files": [str(p) for p in sources], "degenerate": 0, "clamped": 0}
            for k, (o, name, tri) in enumerate(zip(flat_objects, names, tris)):
                g, prev[k], counts = rebuild(o, tri.reshape(-1, 3), prev[k])
                if counts["degenerate"] >= DEGENERATE_SHARE * len(tri):
                    raise SceneError(f"{', '.join(map(str, sources))}: all {len(tri):,} triangles of object '{name}' "
                                     "are degenerate (zero area); not a motion of the exported soup")
                write_gaussians(tmp / name / f"frame_{f:04d}.ply", g)
                row["degenerate"] += counts["degenerate"]
                row["clamped"] += counts["clamped"]
            rows.append(row)
        summary = {
            "scene": str(scene.path), "engine": "import-motion", "motion_dir": str(motion_dir),
            "gasp": __version__, "n_frames": n_frames - 1, "frame_dt": scene.frame_dt,
            "objects": [{"name": name, "file": str(o.spec.file), "n_gaussians": o.gaussians.n,
                         "layout": o.gaussians.layout, "alpha": o.spec.alpha, "thickness": o.spec.thickness,
                         "placement": _placement_dict(o)} for o, name in zip(objects, names)],
            "frames": rows}
        atomic_json(tmp / "run.json", summary)
    return summary
