"""One record per splat file format: how it is recognised, who reads and writes it, what it keeps and loses.

Every reader and writer of GASP is reached through this table (after splat-transform's reader/writer table and
imageio's plugin records): :func:`sniff` recognises a file, :func:`read` reads any readable one,
:func:`write` writes a frame in any per-frame output format, :func:`check_writer` refuses a format whose
writer is not installed before a run starts. ``gasp info``, ``gasp simulate --format``, ``gasp export``, the
run's frame writer (:mod:`gasp_core.run.layout`), the studio (through :func:`gasp_core.gs.io.read_gaussians`)
and the tables of ``docs/formats.md`` (:func:`markdown_tables`, checked by ``tests/test_format_registry.py``)
read it.

A record names its reader and writer as ``"module:function"`` and imports them only when used, so this module
imports no reader (no import circle with :mod:`gasp_core.gs.io`) and an optional library is needed only by the
format that uses it. Readers are called ``reader(path, name)`` and return a
:class:`~gasp_core.gs.gaussians.Gaussians` in the file's own frame; per-frame writers
``writer(path, g, overwrite=...)``; a sequence writer (``sequence``) writes a whole run into one file
(:mod:`gasp_core.run.export`).
"""
from __future__ import annotations

import importlib
import json
import struct
from dataclasses import dataclass
from pathlib import Path

from gasp_core.errors import GaspError, extra_hint
from gasp_core.gs.ply import check_is_file, reject_file

#: Triangle-mesh suffixes: a mesh given where a splat file is expected is pointed to mesh mode.
MESH_SUFFIXES = (".obj", ".stl", ".off", ".glb", ".gltf", ".dae", ".3mf")


@dataclass(frozen=True)
class SplatFormat:
    """A splat file format: one row of the registry.

    Attributes
    ----------
    name : str
        The key (``--format`` value for an output format).
    title : str
        What the format is, for people.
    suffixes : tuple of str
        File suffixes, lower case; the first is the one GASP writes.
    recognised : str
        How :func:`sniff` tells it (a signature, or the suffix where there is none).
    reader, writer, sequence : str or None
        ``"module:function"`` of the reader, the per-frame writer, or the whole-run writer.
    read_by, written_by : str
        Which code reads and writes it (docs).
    keeps, loses, limits : str
        What survives a write and a read, what does not, and the format's own limits (docs).
    needs : tuple of str
        Modules the writer imports; a missing one is named with :attr:`extra`'s install line before a run starts
        (readers name their own: reading a compressed PLY needs none of gsply, writing one does).
    extra : str
        The pyproject extra that installs :attr:`needs`.
    dynamic : bool
        A dynamic model (``psi(V, t)``): :func:`read` gives it at model time 0.5.
    """

    name: str
    title: str
    suffixes: tuple[str, ...]
    recognised: str
    reader: str | None
    writer: str | None
    read_by: str
    written_by: str
    keeps: str
    loses: str
    limits: str = ""
    needs: tuple[str, ...] = ()
    extra: str = "formats"
    dynamic: bool = False
    sequence: str | None = None
    #: Keyword options the writer takes beyond ``overwrite`` (``up_axis``: the file frame's up axis).
    options: tuple[str, ...] = ()

    @property
    def suffix(self) -> str:
        """The suffix GASP writes (``.compressed.ply``, ``.glb``, ...)."""
        return self.suffixes[0]

    def missing(self) -> list[str]:
        """The modules of :attr:`needs` that are not installed."""
        out = []
        for m in self.needs:
            try:
                __import__(m)   # imported, not only found: a package that fails to import is missing too
            except ImportError:
                out.append(m)
        return out


def load(ref: str):
    """The function a record names as ``"module:function"`` (imported now)."""
    module, _, name = ref.partition(":")
    return getattr(importlib.import_module(module), name)


FORMATS: dict[str, SplatFormat] = {f.name: f for f in (
    SplatFormat("ply", "graphdeco 3DGS / GaMeS / 2DGS PLY", (".ply",), "`ply` header without a `chunk` element",
                "gasp_core.gs.io:read_ply_gaussians", "gasp_core.gs.io:write_gaussians", "GASP (`gs/io.py`)",
                "GASP", "everything, float32 (opacity, SH and extra properties bit for bit)", "nothing",
                "float32 positions"),
    SplatFormat("compressed_ply", "PlayCanvas compressed PLY", (".compressed.ply", ".ply"),
                "`ply` header with a `chunk` element or `packed_*` properties", "gasp_core.gs.io:read_ply_gaussians",
                "gasp_core.gs.formats:write_compressed_ply", "GASP (`gs/compressed.py`)", "gsply `compress_to_bytes`",
                "SH degree 0-3", "positions and log-scales 11/10/11 bits per 256-splat chunk, colour and opacity "
                "8 bits, rotation 2+3x10 bits, SH rest 8 bits; extra properties", needs=("gsply",)),
    SplatFormat("spz", "Niantic SPZ (v1-v4)", (".spz",), "gzip or `NGSP` magic",
                "gasp_core.gs.formats:read_splat_file", "gasp_core.gs.formats:write_spz", "gsply 0.4.6 `read_spz`",
                "gsply `write_spz` (v3, gzip), RUB axes", "SH degree 0-3",
                "positions 24-bit fixed point (2.4e-4 file units), log-scale, colour, opacity 8 bits",
                "coordinates within +-2048 file units; log-scales within [-10, 5.94]; v4 reads need zstandard",
                needs=("gsply",)),
    SplatFormat("sog", "PlayCanvas SOG (v1, v2): bundle, folder or its `meta.json`", (".sog",),
                "zip magic, or a `meta.json`", "gasp_core.gs.formats:read_splat_file", "gasp_core.gs.sog:write_sog",
                "gsply 0.4.6 `sogread` (+ imagecodecs)", "GASP (`gs/sog.py`, Pillow WebP)", "SH degree 0-3",
                "positions 16 bits per axis in log space, log-scales and colour one of 256 codebook values, "
                "opacity and rotation 8 bits, SH rest a k-means palette", needs=("PIL.WebPImagePlugin",)),
    SplatFormat("splat", "antimatter15 `.splat`", (".splat",), "suffix (no signature)",
                "gasp_core.gs.formats:read_splat_file", None, "GASP (`gs/splat.py`)", "--",
                "positions, scales float32", "SH rest; colour, opacity and rotation 8 bits", "32 bytes per splat"),
    SplatFormat("ksplat", "GaussianSplats3D `.ksplat`", (".ksplat",), "suffix (no signature)",
                "gasp_core.gs.formats:read_splat_file", None, "GASP (`gs/splat.py`)", "--",
                "compression levels 0, 1, 2; SH degree 0-3", "per level", ""),
    SplatFormat("splatv", "splaTV dynamic model", (".splatv",), "suffix (magic 0x674B checked)",
                "gasp_core.gs.splatv:read_splatv_middle", None, "GASP (`gs/splatv.py`)", "--",
                "motion and rotation rates (a scene's `file`)", "SH rest",
                "read as one frame at model time 0.5 here; a scene simulates it from `dynamic_time`", dynamic=True),
    SplatFormat("glb", "glTF binary with `KHR_gaussian_splatting`", (".glb",), "`glTF` magic and the extension",
                "gasp_core.gs.gltf:read_glb", "gasp_core.gs.gltf:write_glb", "GASP (`gs/gltf.py`, pygltflib)",
                "GASP (`gs/gltf.py`, pygltflib)", "float32 positions, linear scales, xyzw rotations, SH degree 0-3",
                "extra properties; opacity passes through a sigmoid (float32); axes turned to glTF's +Y up",
                "one POINTS primitive per file, float32 attributes", needs=("pygltflib",), extra="export",
                options=("up_axis",)),
    SplatFormat("glb_sequence", "one GLB that plays the run (`KHR_node_visibility` switched per frame)", (".glb",),
                "as `glb` (read: its first primitive)", None, None, "--", "GASP (`run/glb_sequence.py`, pygltflib)",
                "as `glb`, one mesh per frame; static objects and unselected rows once",
                "as `glb`; readers without `KHR_node_visibility` refuse it (required)",
                "whole run in one file: every frame's moving rows in memory at once", needs=("pygltflib",),
                extra="export", sequence="gasp_core.run.glb_sequence:write_glb_sequence"),
    SplatFormat("usd", "OpenUSD `ParticleField3DGaussianSplat`, one file for the run", (".usdc", ".usd"),
                "`PXR-USDC` magic", None, None, "--", "usd-core (`run/usd_export.py`)",
                "positions, orientations and scales time-sampled per frame; opacity, SH once per object",
                "extra properties; opacity and colour do not change over time (they never do in a GASP run)",
                "whole run in one file (not written per frame)", needs=("pxr",), extra="export",
                sequence="gasp_core.run.usd_export:write_usd"),
)}


def get(name: str) -> SplatFormat:
    """The record of format ``name``.

    Raises
    ------
    GaspError
        Unknown name; the message lists the known ones.
    """
    try:
        return FORMATS[name]
    except KeyError:
        raise GaspError(f"unknown format {name!r}; expected one of {', '.join(FORMATS)}") from None


def output_formats() -> tuple[str, ...]:
    """The names ``gasp simulate --format`` and ``gasp export --format`` accept (a writer or a sequence writer)."""
    return tuple(n for n, f in FORMATS.items() if f.writer or f.sequence)


def is_dynamic(path) -> bool:
    """Whether ``path`` names a dynamic model (a format with ``dynamic``, told by its suffix: a scene decides
    ``dynamic_time`` and ``background`` before the file is read)."""
    name = str(path).lower()
    return any(name.endswith(sfx) for f in FORMATS.values() if f.dynamic for sfx in f.suffixes)


def readable() -> tuple[str, ...]:
    """The names of the formats :func:`read` reads."""
    return tuple(n for n, f in FORMATS.items() if f.reader)


def _ply_kind(path: Path) -> str:
    """``compressed_ply`` when the PLY header (first 64 KiB) declares a ``chunk`` element or ``packed_*``."""
    with open(path, "rb") as f:
        head = f.read(65536)
    header = head.split(b"end_header", 1)[0]
    return "compressed_ply" if b"element chunk" in header or b" packed_" in header else "ply"


def glb_has_splats(path) -> bool:
    """Whether the GLB at ``path`` lists ``KHR_gaussian_splatting`` in ``extensionsUsed`` (reads its JSON chunk only,
    at most 64 MiB; a glTF without it is a mesh).

    Raises
    ------
    SceneError
        A JSON chunk longer than the file, cut short, nested too deep or not JSON: the file is corrupt, whatever
        it holds (never called a mesh).
    """
    size = Path(path).stat().st_size
    with open(path, "rb") as f:
        head = f.read(20)
        if len(head) < 20:
            return False
        length, kind = struct.unpack_from("<II", head, 12)
        if kind != 0x4E4F534A:   # "JSON"
            return False
        if length > size - 20:
            reject_file(path, f"a GLB whose JSON chunk says {length:,} bytes; the file has {size:,} bytes in all "
                        "(truncated or corrupt?)")
        if length > 1 << 26:   # a mesh's JSON may be that large; a splat file's never is
            return False
        try:
            doc = json.loads(f.read(length))
        except (ValueError, RecursionError) as e:   # cut inside the JSON; nested 200,000 deep
            reject_file(path, f"a GLB whose JSON chunk is not readable JSON (truncated or corrupt?): "
                        f"{type(e).__name__}: {str(e)[:200]}")
    return isinstance(doc, dict) and "KHR_gaussian_splatting" in (doc.get("extensionsUsed") or [])


def sniff(path) -> SplatFormat:
    """The format of a splat file, from its first bytes where the format has a signature, else its suffix.

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    SceneError
        No known signature or suffix (a mesh's suffix, or a glTF without ``KHR_gaussian_splatting``: the line
        points to mesh mode).
    """
    path = Path(path)
    if path.is_dir() and (path / "meta.json").is_file():
        return FORMATS["sog"]
    check_is_file(path, "Gaussian Splatting file")
    with open(path, "rb") as f:
        head = f.read(8)
    suffix = path.suffix.lower()
    if head[:3] == b"ply":
        return FORMATS[_ply_kind(path)]
    if head[:2] == b"\x1f\x8b" or head[:4] == b"NGSP":
        return FORMATS["spz"]
    if head[:4] == b"PK\x03\x04" or path.name == "meta.json":
        return FORMATS["sog"]
    if head[:4] == b"glTF" and glb_has_splats(path):
        return FORMATS["glb"]
    if head == b"PXR-USDC" or head[:5] == b"#usda":
        reject_file(path, "an OpenUSD file: GASP writes USD (gasp export --format usd) but reads splats from PLY, "
                    ".spz, .sog, .splat, .ksplat, .splatv or .glb")
    for f in FORMATS.values():
        if f.recognised.startswith("suffix") and suffix in f.suffixes:
            return f
    if suffix in MESH_SUFFIXES:
        reject_file(path, f"a triangle mesh ({suffix}), not a Gaussian Splatting file: simulate it in mesh mode, "
                    f"mesh = \"{path.name}\" in an [[object]] (docs/mesh_mode.md)")
    reject_file(path, f"unknown file format (first bytes {head[:4]!r}); expected "
                f"{', '.join(_readable_names())} file")


def _readable_names() -> list[str]:
    return ["a PLY"] + [FORMATS[n].suffix for n in readable() if n not in ("ply", "compressed_ply")]


def read(path):
    """Read any readable splat file (:func:`readable`) through its record's reader.

    Returns
    -------
    Gaussians
        In the file's frame: means float64 (file units), activated scales, unit wxyz rotations, opacity logits,
        SH as stored; ``layout`` says which layout was read. A dynamic model (``.splatv``) at model time 0.5.

    Raises
    ------
    FileNotFoundError, SceneError
        As :func:`sniff` and the format's reader (one line naming the file).
    GaspError
        The reader's library is not installed (the message gives the install line).
    """
    fmt = sniff(path)
    return load(fmt.reader)(Path(path), fmt.name)   # a reader names its own missing library (one line)


def _require(fmt: SplatFormat, doing: str) -> None:
    missing = fmt.missing()
    if missing:
        raise GaspError(f"{doing} needs {', '.join(missing)}, which is not installed ({extra_hint(fmt.extra)})")


def check_writer(name: str, doing: str | None = None) -> SplatFormat:
    """The record of output format ``name`` after refusing it when its writer's library is missing.

    Raises
    ------
    GaspError
        Not an output format, or a library it needs is not installed (one line: the option, the install line).
    """
    fmt = get(name)
    if not (fmt.writer or fmt.sequence):
        raise GaspError(f"--format {name}: GASP reads {fmt.suffix} files but does not write them; expected one of "
                        f"{', '.join(output_formats())}")
    _require(fmt, doing or f"--format {name}")
    return fmt


def write(path, g, name: str, *, overwrite: bool = False, **options) -> Path:
    """Write ``g`` (a :class:`~gasp_core.gs.gaussians.Gaussians`, file frame) as one file of the per-frame output
    format ``name``, atomically; refuses an existing ``path`` unless ``overwrite``. ``options`` (``up_axis``)
    reach the writers whose record lists them and are dropped for the others.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    GaspError
        Unknown format, one without a per-frame writer (``usd``: :mod:`gasp_core.run.usd_export`), or its
        library missing.
    SceneError
        ``g`` holds what a :class:`~gasp_core.gs.gaussians.Gaussians` refuses (its arrays changed after it was
        built: a NaN, a zero quaternion; :meth:`~gasp_core.gs.gaussians.Gaussians.check`), or what the format
        cannot hold (the writer's own check: no Gaussians, an ``spz`` coordinate past +-2048); named with ``path``.
    """
    fmt = check_writer(name, f"writing {path}")
    g.check(str(path))
    if not fmt.writer:
        raise GaspError(f"--format {name} writes a whole run into one file, not one file per frame")
    kw = {k: v for k, v in options.items() if k in fmt.options and v is not None}
    return load(fmt.writer)(Path(path), g, overwrite=overwrite, **kw)


def _needs(f: SplatFormat) -> str:
    return f"the `{f.extra}` extra" if f.needs else "--"


def markdown_tables() -> str:
    """The reading and writing tables of ``docs/formats.md``, generated from :data:`FORMATS` (Markdown)."""
    rows = ["| format | suffixes | how it is recognised | read by | keeps | limits | needs |",
            "|---|---|---|---|---|---|---|"]
    for f in FORMATS.values():
        if f.reader:
            rows.append(f"| `{f.name}`: {f.title} | {', '.join(f.suffixes)} | {f.recognised} | {f.read_by} | "
                        f"{f.keeps} | {f.limits or '--'} | {_needs(f)} |")
    rows += ["", "| `--format` | file | written by | loses | limits | needs |", "|---|---|---|---|---|---|"]
    for n in output_formats():
        f = FORMATS[n]
        rows.append(f"| `{n}` | {f.suffix}{' (one per run)' if f.sequence else ''} | {f.written_by} | {f.loses} | "
                    f"{f.limits or '--'} | {_needs(f)} |")
    return "\n".join(rows) + "\n"


if __name__ == "__main__":   # python -m gasp_core.gs.registry: the tables to paste into docs/formats.md
    print(markdown_tables(), end="")
