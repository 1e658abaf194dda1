"""The frames of a run on disk: how ``gasp simulate`` writes them and the one reader of every layout.

Two layouts, in any per-frame output format of :mod:`gasp_core.gs.registry` (``--format ply|compressed_ply|spz|sog|glb``;
``usd`` writes its frames as ``ply`` and one ``.usdc`` at the end):

``frames``
    ``<object>/frame_0000<suffix> ...``: every frame of every object complete, as frame-sequence
    players load them. The default for ``ply`` (the layout of every earlier run).
``split``
    What does not move is written once: a ``static = true`` object as ``<object>/static<suffix>``,
    the unselected rows of an object with ``select`` as ``<object>/rest<suffix>`` with their row
    numbers in ``<object>/moving_rows.npy`` (int64, the rows that move, input order); the frames hold
    only the rows that move. The default for the compressed formats.

Both write ``frames.json``, the manifest: format, layout, and per object its Gaussian count and the
files (relative to the run folder) of each frame. It is rewritten (atomically) after every frame, listing the
frames whose files are complete, so a reader can follow a run in progress (:mod:`gasp_core.render.live`). :func:`open_frames` reads a run folder of any
layout, and a folder of an older run without a manifest (``<object>/frame_*.ply``);
``gasp render``, ``gasp view`` and ``--resume`` read frames through it.
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.fsutil import atomic_json, atomic_write
from gasp_core.gs import registry
from gasp_core.gs.gaussians import Gaussians
from gasp_core.gs.io import read_gaussians
from gasp_core.run.run_json import check_component, check_run_json, load_json

MANIFEST = "frames.json"
LAYOUTS = ("frames", "split")


def default_layout(fmt: str) -> str:
    """``frames`` for ``ply`` (unchanged runs) and ``glb`` (players load whole files), ``split`` for the others."""
    return "frames" if fmt in ("ply", "glb") else "split"


#: Rows that never move per row that does, from which a ``ply`` run is written ``split`` by default (issue 54: one
#: donut selected among 49, 2.24M rows, rewrote 125 MB a frame of which 2 % moved).
SPLIT_RATIO = 10
#: Bytes of ``moving_rows.npy`` besides its rows: NumPy's ``.npy`` header (version 1, padded to 128 bytes).
MOVING_ROWS_NPY = 128


def choose_layout(fmt: str, static_rows: int, moving_rows: int) -> str:
    """The layout of a run that names none: :func:`default_layout`, but ``split`` for ``ply`` where the rows that
    never move (``static`` objects, the unselected rows of a selection) number :data:`SPLIT_RATIO` times those that
    move or more; ``glb`` stays ``frames`` (its players load whole files)."""
    if fmt == "ply" and static_rows >= SPLIT_RATIO * max(moving_rows, 1):
        return "split"
    return default_layout(fmt)


def run_bytes(objects: list[tuple[Gaussians, int, int]], n_frames: int, layout: str, fmt: str) -> int | None:
    """The bytes a run writes in ``fmt`` and ``layout``: frames ``0 .. n_frames``, and the files written once.

    ``objects``: per object, its Gaussians (the whole file), the rows written every frame in the ``frames`` layout
    and the rows that move. Row and header sizes are measured by writing one and two rows of each object into a
    temporary folder (exact for ``ply``, whose rows have a fixed size); None for a compressed format, whose size
    depends on the values.
    """
    if frame_format(fmt) != "ply":
        return None
    total = 0
    with tempfile.TemporaryDirectory(prefix="gasp-probe-") as tmp:
        for k, (g, rows, moving) in enumerate(objects):
            sizes = []
            for n in (1, 2):
                path = Path(tmp) / f"{k}_{n}.ply"
                write_file(path, g.subset(np.arange(min(n, g.n))), "ply")
                sizes.append(path.stat().st_size)
            row = sizes[1] - sizes[0]

            def ply(n: int) -> int:   # the header names the count: one digit in the probe
                return sizes[0] - row + len(str(n)) - 1 + n * row
            if layout == "frames":
                total += (n_frames + 1) * ply(rows)
            elif moving == 0:         # a static object: once
                total += ply(g.n)
            elif moving < g.n:        # the moving rows every frame, the others once, with the rows that move
                total += (n_frames + 1) * ply(moving) + ply(g.n - moving) + MOVING_ROWS_NPY + 8 * moving
            else:
                total += (n_frames + 1) * ply(g.n)
    return total


def frame_format(fmt: str) -> str:
    """The format of the frame files of a run asked for ``fmt``: ``fmt`` itself, or ``ply`` for a format written
    once per run (``usd``: :mod:`gasp_core.run.usd_export` reads the PLY frames at the end)."""
    return "ply" if registry.get(fmt).sequence else fmt


def write_file(path: Path, g: Gaussians, fmt: str, overwrite: bool = False, up_axis: str | None = None) -> Path:
    """One splat file of the per-frame format ``fmt`` (:func:`gasp_core.gs.registry.write`), atomically;
    ``up_axis``: the file frame's up axis, for a format with its own (glTF: +Y)."""
    return registry.write(path, g, fmt, overwrite=overwrite, up_axis=up_axis)


def check_format(fmt: str) -> None:
    """Refuse an output format whose writer is not installed, naming the option and the install line
    (:func:`gasp_core.gs.registry.check_writer`).

    Raises
    ------
    GaspError
        e.g. ``--format spz`` without gsply, ``--format sog`` without Pillow's WebP, ``--format glb`` without
        pygltflib.
    """
    registry.check_writer(fmt)


@dataclass
class FrameWriter:
    """Writes each frame of a run into ``folder`` in one format and layout, then the manifest.

    Parameters
    ----------
    folder : Path
        The (partial) run folder; one subfolder per object exists.
    names : list of str
        Object folder names, scene order.
    static : list of bool
        Per object: never moves (``static = true``).
    moving : list of (ndarray or None)
        Per object: the rows that move (``PreparedObject.moving``; None = all).
    fmt : str
        An output format of :mod:`gasp_core.gs.registry` (a whole-run one writes its frames as ``ply``).
    layout : {"frames", "split"}
    overwrite : bool
        Replace files already there (a resumed run rewrites the frame it was killed in).
    up_axes : list of str, optional
        Per object, the file frame's up axis (its ``up_axis``), for a format with an up axis of its own (``glb``).
    """

    folder: Path
    names: list[str]
    static: list[bool]
    moving: list[np.ndarray | None]
    fmt: str = "ply"
    layout: str = "frames"
    overwrite: bool = False
    up_axes: list[str] | None = None
    #: Per object, the files written once (``static``, ``rest``, ``moving_rows``), relative to ``folder``.
    once: list[dict] = field(default_factory=list)

    def __post_init__(self):
        if self.fmt not in registry.output_formats():
            raise ValueError(f"unknown format {self.fmt!r}; expected one of {', '.join(registry.output_formats())}")
        if self.layout not in LAYOUTS:
            raise ValueError(f"unknown layout {self.layout!r}; expected one of {', '.join(LAYOUTS)}")
        check_format(self.fmt)   # refuse before the first frame
        self.fmt = frame_format(self.fmt)
        self.suffix = registry.get(self.fmt).suffix
        self.once = [{} for _ in self.names]

    def write(self, frame: int, gs: list[Gaussians]) -> list[str]:
        """Write frame ``frame`` of every object (``gs``: whole objects, input order), then the manifest
        listing frames ``0..frame`` (the frames before it are on disk: written in order, or kept by ``--resume``).

        Returns the files it needs, relative to ``folder`` (those written once included), for ``--resume``'s check.
        """
        files = []
        for k, (g, name) in enumerate(zip(gs, self.names)):
            rel = f"{name}/frame_{frame:04d}{self.suffix}"
            if self.layout == "split" and self.static[k]:
                self._once(k, "static", g)
                files.append(self.once[k]["static"])
                continue
            if self.layout == "split" and self.moving[k] is not None:
                rows = self.moving[k]
                if "rest" not in self.once[k]:
                    rest = np.ones(g.n, bool)
                    rest[rows] = False
                    self._once(k, "rest", g.subset(rest))
                    atomic_write(self.folder / name / "moving_rows.npy",
                                 lambda f: np.save(f, np.asarray(rows, np.int64)))
                    self.once[k]["moving_rows"] = f"{name}/moving_rows.npy"
                g = g.subset(rows)
                files += [self.once[k]["rest"], self.once[k]["moving_rows"]]
            write_file(self.folder / rel, g, self.fmt, overwrite=self.overwrite, **self._turn(k))
            files.append(rel)
        self.finish(frame, [g.n for g in gs])   # frames 0..frame complete: what a reader of the live run sees
        return files

    def _once(self, k: int, what: str, g: Gaussians) -> None:
        """Write ``<object>/<what><suffix>`` the first time (a resumed run finds it there)."""
        if what in self.once[k]:
            return
        rel = f"{self.names[k]}/{what}{self.suffix}"
        if not (self.folder / rel).exists():
            write_file(self.folder / rel, g, self.fmt, **self._turn(k))
        self.once[k][what] = rel

    def _turn(self, k: int) -> dict:
        """``{"up_axis": ...}`` of object ``k`` for a format with an up axis of its own (glTF), else ``{}``."""
        if self.up_axes is None or "up_axis" not in registry.get(self.fmt).options:
            return {}
        return {"up_axis": self.up_axes[k]}

    def finish(self, n_frames: int, counts: list[int]) -> Path:
        """Write the manifest ``frames.json`` (frames ``0..n_frames``; ``counts``: Gaussians per object), atomically."""
        objects = []
        for k, name in enumerate(self.names):
            frames = [] if "static" in self.once[k] else \
                [f"{name}/frame_{f:04d}{self.suffix}" for f in range(n_frames + 1)]
            objects.append({"name": name, "n_gaussians": counts[k], **self.once[k], **self._turn(k), "frames": frames})
        return atomic_json(self.folder / MANIFEST, {"format": self.fmt, "layout": self.layout,
                                                    "n_frames": n_frames + 1, "objects": objects})


@dataclass
class RunFrames:
    """The frames of a run folder, read object by object through :meth:`gaussians`.

    Attributes
    ----------
    folder : Path
    manifest : dict
        ``frames.json`` (or the one an older run's ``frame_*.ply`` files imply).
    n_frames : int
        Frames every object has (frame 0 = the input).
    """

    folder: Path
    manifest: dict
    n_frames: int
    _cache: dict = field(default_factory=dict, repr=False)

    def gaussians(self, frame: int, k: int) -> Gaussians:
        """Object ``k`` (manifest order) at ``frame``, whole, input row order, file frame."""
        o = self.manifest["objects"][k]
        if o.get("static"):
            return self._once(o["static"], k)
        g = self._read(self.folder / o["frames"][frame], k)
        if not o.get("rest"):
            return self._whole(g, frame, k)
        rows = self._once(o["moving_rows"], k)
        rest = self._once(o["rest"], k)
        if len(rows) != g.n or len(rows) + rest.n != o["n_gaussians"]:
            raise SceneError(f"{self.folder / o['frames'][frame]}: {g.n} moving rows + {rest.n} rest rows; "
                             f"expected {len(rows)} + {o['n_gaussians'] - len(rows)} "
                             f"({o['moving_rows']}, {MANIFEST})")
        return _merge(rest, rows, g, o["n_gaussians"])

    def _whole(self, g: Gaussians, frame: int, k: int) -> Gaussians:
        """``g``, frame ``frame`` of object ``k`` in the ``frames`` layout, after checking it has the object's rows
        (``n_gaussians``, else frame 0's): a frame cut short would give a USD whose counts differ."""
        o = self.manifest["objects"][k]
        if ("n", k) not in self._cache:
            self._cache[("n", k)] = o.get("n_gaussians") or (g.n if frame == 0 else self.gaussians(0, k).n)
        want = self._cache[("n", k)]
        if g.n != want:
            raise SceneError(f"{self.folder / o['frames'][frame]}: {g.n} Gaussians; the object '{o['name']}' has "
                             f"{want} in every frame ({MANIFEST} n_gaussians, or frame 0): a cut or foreign frame")
        return g

    def _once(self, rel: str, k: int):
        if rel not in self._cache:
            p = self.folder / rel
            self._cache[rel] = self._rows(p, k) if p.suffix == ".npy" else self._read(p, k)
        return self._cache[rel]

    def _rows(self, path: Path, k: int) -> np.ndarray:
        """The moving rows of object ``k`` (``moving_rows.npy``): distinct integers in ``[0, n_gaussians)``."""
        n = self.manifest["objects"][k].get("n_gaussians", 0)
        try:
            rows = np.load(path, allow_pickle=False)
        except (OSError, ValueError, EOFError) as e:   # garbage bytes; an object array (pickled)
            raise SceneError(f"{path}: not a moving_rows.npy written by gasp simulate ({type(e).__name__}: "
                             f"{str(e)[:120]})") from None
        if not isinstance(rows, np.ndarray):   # an .npz archive under the name
            raise SceneError(f"{path}: not a moving_rows.npy written by gasp simulate (an archive)")
        if (rows.ndim != 1 or rows.dtype.kind not in "iu"
                or (rows.size and (rows.min() < 0 or rows.max() >= n)) or len(np.unique(rows)) != rows.size):
            raise SceneError(f"{path}: expected distinct integer row numbers in [0, {n}) ({MANIFEST}'s "
                             f"n_gaussians), got {rows.dtype} values of shape {rows.shape}")
        return rows.astype(np.int64)

    def _read(self, path: Path, k: int) -> Gaussians:
        """A frame file of object ``k`` in its file frame: a format with an up axis of its own (glTF's +Y, read back
        +Z up) is turned back from the object's ``up_axis`` (the manifest's, written by :class:`FrameWriter`)."""
        g = read_gaussians(path)
        up = self.manifest["objects"][k].get("up_axis", "+z")
        if up == "+z":
            return g
        from gasp_core.gs.gltf import UP_TO_Z, turned
        return turned(g, UP_TO_Z[up].T)


def _merge(rest: Gaussians, rows: np.ndarray, moving: Gaussians, n: int) -> Gaussians:
    """The whole object: ``moving`` at ``rows``, ``rest`` (in order) at every other row; extras both have."""
    keep = np.ones(n, bool)
    keep[rows] = False

    def put(a, b):
        out = np.empty((n, *a.shape[1:]), a.dtype)
        out[keep], out[rows] = a, b
        return out

    return Gaussians(means=put(rest.means, moving.means), scales=put(rest.scales, moving.scales),
                     rotations=put(rest.rotations, moving.rotations),
                     opacities=put(rest.opacities, moving.opacities), sh_dc=put(rest.sh_dc, moving.sh_dc),
                     sh_rest=put(rest.sh_rest, moving.sh_rest),
                     extra={k: put(v, moving.extra[k]) for k, v in rest.extra.items() if k in moving.extra},
                     source=moving.source, layout=moving.layout)


def open_frames(folder) -> RunFrames:
    """The frames of the run folder ``folder``, any layout and format.

    Raises
    ------
    SceneError
        No ``frames.json`` and no ``<object>/frame_*.ply`` for an object of ``run.json``, a
        manifest that is not JSON or not what :class:`FrameWriter` writes (:func:`_check_manifest`: among others,
        an object that is not ``static`` listing more or fewer frame files than ``n_frames``); the message names
        the path.
    """
    folder = Path(folder)
    path = folder / MANIFEST
    if path.is_file():
        manifest = load_json(path)
        objects = manifest.get("objects") if isinstance(manifest, dict) else None
    else:  # a run written before the manifest: full PLY frames per object
        if not (folder / "run.json").is_file():
            raise SceneError(f"{folder}: neither {MANIFEST} nor a run.json listing objects")
        names = [o["name"] for o in check_run_json(folder, need_frame_dt=False)["objects"]]
        objects = [{"name": name, "frames": _numbered_frames(folder, name)} for name in names]
        manifest = {"format": "ply", "layout": "frames", "objects": objects}
    _check_manifest(path, manifest)
    counts = [len(o["frames"]) for o in objects if o["frames"]]
    n = min(counts) if counts else int(manifest.get("n_frames", 1))
    return RunFrames(folder, manifest, n)


def _numbered_frames(folder: Path, name: str) -> list[str]:
    """``name/frame_0000.ply, name/frame_0001.ply, ...`` of a run without a manifest, numbered from 0 without a
    gap (a missing frame would shift every later frame's time).

    Raises
    ------
    SceneError
        No frame, or the first missing number named.
    """
    numbers = sorted(int(f.stem[6:]) for f in (folder / name).glob("frame_*.ply") if f.stem[6:].isdigit())
    if not numbers:
        raise SceneError(f"{folder / name}: no frame_*.ply files for object '{name}'")
    missing = next((i for i, n in enumerate(numbers) if n != i), None)
    if missing is not None:
        raise SceneError(f"{folder / name}: frame_{missing:04d}.ply is missing (frames {numbers[0]}-{numbers[-1]} "
                         f"otherwise, no {MANIFEST}); its times would shift: restore it or write a {MANIFEST}")
    return [f"{name}/frame_{n:04d}.ply" for n in numbers]


def _check_manifest(path: Path, manifest) -> None:
    """Refuse (:class:`SceneError` naming ``path`` and the field) a manifest that is not what
    :class:`FrameWriter` writes: ``objects`` a list of tables with a ``frames`` list of relative file names
    inside the run folder, ``n_gaussians`` an integer, and ``n_frames`` a count (1 or more) that every object but a
    ``static`` one (written once, no frames) has as many frame files as (round 101: a manifest saying 3 frames and
    listing 2 was read as 2 without a word)."""
    def bad(field, why):
        raise SceneError(f"{path}: {field}: {why}; not a frame manifest written by gasp simulate")
    if not isinstance(manifest, dict) or not isinstance(manifest.get("objects"), list):
        bad("objects", "expected a list of objects")
    n_frames = manifest.get("n_frames", 1)
    if not isinstance(n_frames, int) or isinstance(n_frames, bool) or n_frames < 1:
        bad("n_frames", f"expected a count of frames, 1 or more (frame 0 is always written), got {n_frames!r}")
    for k, o in enumerate(manifest["objects"]):
        if not isinstance(o, dict) or not isinstance(o.get("frames"), list):
            bad(f"objects[{k}]", "expected a table with a list 'frames'")
        check_component(o.get("name"), f"{path}: objects[{k}].name")   # a folder name under -o on export
        files = [*o["frames"], *(o[key] for key in ("static", "rest", "moving_rows") if key in o)]
        for f in files:
            if not isinstance(f, str) or Path(f).is_absolute() or ".." in Path(f).parts:
                bad(f"objects[{k}]", f"expected file names inside the run folder, got {f!r}")
        if "n_frames" in manifest and "static" not in o and len(o["frames"]) != manifest["n_frames"]:
            bad(f"objects[{k}].frames", f"lists {len(o['frames'])} frame files, but n_frames = "
                f"{manifest['n_frames']}; expected one file per frame")
        if o.get("up_axis", "+z") not in ("+x", "-x", "+y", "-y", "+z", "-z"):
            bad(f"objects[{k}].up_axis", f"expected one of +x -x +y -y +z -z, got {o.get('up_axis')!r}")
        n = o.get("n_gaussians", 0)
        if not isinstance(n, int) or isinstance(n, bool) or n < 0:
            bad(f"objects[{k}].n_gaussians", f"expected a count, got {n!r}")
    names = [o["name"] for o in manifest["objects"]]
    if len(set(names)) != len(names):
        bad("objects", f"the name '{next(n for n in names if names.count(n) > 1)}' is there twice")
