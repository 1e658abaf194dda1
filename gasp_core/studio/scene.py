"""The studio's scene: the splats on the page, what is selected, and the scene TOML the form describes.

The studio opens a splat file (any format :func:`gasp_core.gs.io.read_gaussians` reads) or a scene TOML.
A file becomes a one-object scene (:func:`file_document`): the file placed with its guessed up axis
(:func:`gasp_core.gs.up_axis.guess_up`), dropped onto a ground; the selected splats move, the rest stay as a
static background. A scene keeps its own objects and keys; the form sets the material and the selection of
the object clicked, the engine, the quality level and the frame count.

Every document the studio runs or saves passes :func:`gasp_core.scene.spec.parse_scene`, so a bad value is
refused with the scene checker's one line, and the studio's run *is* ``gasp simulate`` on the saved file.
Paths inside the document are absolute while the studio holds it and written relative to the saved file.
"""
from __future__ import annotations

import copy
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.fsutil import atomic_write
from gasp_core.gs.gaussians import Gaussians
from gasp_core.maps.floaters import find_floaters
from gasp_core.prepare.placement import load_gaussians, place
from gasp_core.prepare.selection import GROW_SIGMAS
from gasp_core.gs.splat_numpy import splats_from_gaussians
from gasp_core.scene.spec import Scene, parse_scene
from gasp_core.studio.pick import world_frames

#: Keys whose string values are paths resolved against the scene file's folder.
PATH_KEYS = ("file", "mesh", "mask", "gaussians")
#: Frames of a run the studio starts, and their interval, seconds (a file opened alone; a scene keeps its own).
STUDIO_FRAMES = 30
STUDIO_FRAME_DT = 1.0 / 30.0
#: Height the object's lowest centre starts above the ground, metres (the README donut's drop).
STUDIO_DROP = 0.05


def _map_paths(doc, fn):
    """A deep copy of ``doc`` with ``fn`` applied to every string under a key of :data:`PATH_KEYS`."""
    if isinstance(doc, dict):
        return {k: fn(v) if k in PATH_KEYS and isinstance(v, str) else _map_paths(v, fn) for k, v in doc.items()}
    if isinstance(doc, list):
        return [_map_paths(v, fn) for v in doc]
    return copy.deepcopy(doc)


def absolute_paths(doc: dict, base: Path) -> dict:
    """``doc`` with its paths made absolute against the folder ``base``."""
    return _map_paths(doc, lambda v: str((base / v).resolve()) if not os.path.isabs(v) else v)


def relative_paths(doc: dict, base: Path) -> dict:
    """``doc`` with its absolute paths written relative to ``base`` (``..`` where needed)."""
    return _map_paths(doc, lambda v: os.path.relpath(v, base.resolve()) if os.path.isabs(v) else v)


def file_document(path: Path, up_axis: str) -> dict:
    """The one-object scene of a splat file: placed by ``up_axis``, its lowest centre :data:`STUDIO_DROP` above a
    ground at height 0 (friction 0.5), the page's material and selection still to fill in."""
    return {"name": f"{path.stem}_studio", "frame_dt": STUDIO_FRAME_DT, "n_frames": STUDIO_FRAMES,
            "gravity": [0.0, 0.0, -9.81],
            "boundary": [{"kind": "ground", "height": 0.0, "friction": 0.5}],
            "object": [{"file": str(path.resolve()), "up_axis": up_axis, "scale": 1.0,
                        "position": [0.0, 0.0, STUDIO_DROP]}]}


@dataclass
class Piece:
    """One ``[[object]]`` on the page: its Gaussians placed in the world, and which rows are selected.

    Attributes
    ----------
    index : int
        Its place in the document's ``object`` list.
    gaussians : Gaussians
        As read (file frame).
    means, rotmats, scales : ndarray, shapes (n, 3), (n, 3, 3), (n, 3)
        World frame, metres.
    covs : ndarray, shape (n, 3, 3), float32
        World covariances, m^2 (what the viewer draws).
    rgb : ndarray, shape (n, 3), float32
    opacities : ndarray, shape (n,), float32
        Activated.
    linking : ndarray, shape (n,), bool
        Opaque enough to link (``min_opacity``, the ``grow`` rule of :mod:`gasp_core.prepare.selection`).
    radii : ndarray, shape (n,)
        ``GROW_SIGMAS`` times the largest world scale, metres.
    selected : ndarray, shape (n,), bool
    static : bool
        ``static = true``: shown, never simulated.
    scale : float
        File units to metres (the placement's scale).
    dynamic_time : float or None
        A dynamic model's ``dynamic_time`` (the page shows it there); None for a still file.
    """

    index: int
    gaussians: Gaussians
    means: np.ndarray
    rotmats: np.ndarray
    scales: np.ndarray
    covs: np.ndarray
    rgb: np.ndarray
    opacities: np.ndarray
    linking: np.ndarray
    radii: np.ndarray
    static: bool = False
    selected: np.ndarray = field(default=None)
    scale: float = 1.0
    dynamic_time: float | None = None

    def __post_init__(self):
        if self.selected is None:
            self.selected = np.zeros(self.gaussians.n, bool)

    @property
    def n(self) -> int:
        return self.gaussians.n


def place_piece(index: int, spec, g: Gaussians, selected: np.ndarray | None = None) -> Piece:
    """A :class:`Piece` of object ``spec`` placed as :func:`gasp_core.prepare.placement.prepare_object` places it
    (floaters left out of the bounding box of a whole, unselected object)."""
    floating = None if spec.select is not None or spec.keep_floaters or spec.static or spec.mesh else \
        find_floaters(g.means, g.scales.max(axis=1))
    pl = place(g, spec, floating)
    sp = splats_from_gaussians(g, pl.R, pl.scale, pl.t)
    rotmats, scales = world_frames(g, pl.R, pl.scale)
    return Piece(index, g, sp.means, rotmats, scales, sp.covs.astype(np.float32), sp.rgb, sp.opacities,
                 linking=sp.opacities.astype(np.float64) >= spec.min_opacity,
                 radii=GROW_SIGMAS * scales.max(axis=1), static=spec.static, selected=selected, scale=pl.scale,
                 dynamic_time=spec.dynamic_time)


class StudioScene:
    """The document, its objects on the page, and the selection (module notes).

    Parameters
    ----------
    path : path-like
        A splat file or a scene ``.toml``.
    workdir : path-like
        Folder of the studio's own files (its working scene, selection masks, runs); created if missing.

    Raises
    ------
    SceneError
        The file cannot be read, or the scene is refused by the scene checker (one line).
    """

    def __init__(self, path, workdir):
        from gasp_core.gs.up_axis import guess_up
        self.path = Path(path)
        self.workdir = Path(workdir)
        self.is_file = self.path.suffix.lower() != ".toml"
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.scene_file = self.workdir / "scene.toml"
        self.pieces: list[Piece] = []
        if self.is_file:                  # read as the scene reads it (a .splatv: its model at s = 0)
            self.doc = file_document(self.path, "+z")
            g = load_gaussians(parse_scene(self.doc, self.scene_file).objects[0])
            self.up_guess = guess_up(g, self.path.parent / "cameras.json")
            self.doc["object"][0]["up_axis"] = self.up_guess.up if self.up_guess.up != "unknown" else "+z"
            self._read = [g]
        else:
            from gasp_core.scene.spec import load_scene
            load_scene(self.path)                     # the checker's one line for a bad scene, before anything
            self.up_guess = None
            self.doc = absolute_paths(tomllib.loads(self.path.read_text(encoding="utf-8")), self.path.parent)
            if isinstance(self.doc.get("engine"), str):      # the shorthand engine = "NAME" (issue 68): the table
                self.doc["engine"] = {"name": self.doc["engine"]}      # the form and the warm-up read and write
            self._read = []
        self.replace(self.doc, keep_selection=False)

    # -- the document -----------------------------------------------------------------------------------
    def replace(self, doc: dict, keep_selection: bool = True) -> Scene:
        """Make ``doc`` the studio's document and place its objects again (up axis, scale, position may have
        changed). Raises :class:`SceneError` (the document is then unchanged)."""
        scene = self.check(doc, with_selection=False)
        old = {p.index: p.selected for p in self.pieces} if keep_selection else {}
        pieces = []
        for i, spec in enumerate(scene.objects):
            g = self.pieces[i].gaussians if i < len(self.pieces) else \
                self._read[i] if i < len(self._read) else load_gaussians(spec)
            pieces.append(place_piece(i, spec, g, old.get(i)))
        self.doc, self.pieces = doc, pieces
        return scene

    @staticmethod
    def mask_path(index: int, folder: Path, stem: str) -> Path:
        """Where object ``index``'s selection mask is written beside the scene ``folder/stem.toml`` (``.npy``, bool,
        one entry per Gaussian)."""
        return folder / f"{stem}.select{index}.npy"

    def check(self, doc: dict | None = None, with_selection: bool = True) -> Scene:
        """``doc`` (default: the studio's document) through the scene checker with the page's selection (as
        ``select = { indices }``), as if read from ``WORKDIR/scene.toml``.

        Raises
        ------
        SceneError
            The checker's one line; also when a file opened alone has nothing selected to simulate.
        """
        doc = self.doc if doc is None else doc
        if with_selection and self.is_file and not self.pieces[0].selected.any():
            raise SceneError(f"{self.path}: nothing is selected to simulate; click an object first")
        if with_selection:   # the masks are checked by the reader: give it the ones on the page
            doc = copy.deepcopy(doc)
            for p in self.pieces:
                if p.selected.any():
                    doc["object"][p.index]["select"] = {"indices": np.flatnonzero(p.selected).tolist()}
        return parse_scene(doc, self.scene_file)

    def write(self, path: Path, overwrite: bool = False) -> Path:
        """Write the document (:meth:`check`\\ ed first) as a scene TOML at ``path`` with its selection masks beside
        it (:func:`write_document`).

        Raises
        ------
        SceneError
            The document is refused (nothing is written).
        FileExistsError
            ``path`` or a mask exists and ``overwrite`` is false (nothing is written).
        """
        self.check()
        return write_document(self.doc, self.selections(), path, overwrite)

    def selections(self) -> dict[int, np.ndarray]:
        """``{object index: selection mask}`` of the objects with something selected (copies; bool, one entry per
        Gaussian)."""
        return {p.index: p.selected.copy() for p in self.pieces if p.selected.any()}


def write_document(doc: dict, selections: dict[int, np.ndarray], path: Path, overwrite: bool = False) -> Path:
    """Write ``doc`` (absolute paths) as a scene TOML at ``path``, object ``k`` selecting ``selections[k]`` (saved
    beside it as ``<stem>.select<k>.npy``, :meth:`StudioScene.mask_path`), paths relative to its folder; atomically.

    Raises
    ------
    FileExistsError
        ``path`` or a mask exists and ``overwrite`` is false (nothing is written).
    """
    import tomli_w
    path = Path(path)
    masks = {k: (StudioScene.mask_path(k, path.parent, path.stem), sel) for k, sel in selections.items()}
    if not overwrite:
        for f in [path, *(m for m, _ in masks.values())]:
            if f.exists():
                raise FileExistsError(f"{f} exists; choose another name (or overwrite)")
    path.parent.mkdir(parents=True, exist_ok=True)
    doc = copy.deepcopy(doc)
    for k, (m, sel) in masks.items():
        atomic_write(m, lambda f, sel=sel: np.save(f, sel), overwrite=True)
        doc["object"][k]["select"] = {"mask": str(m.resolve())}
    text = tomli_w.dumps(relative_paths(doc, path.parent))
    atomic_write(path, lambda f: f.write(text.encode("utf-8")), overwrite=True)
    return path
