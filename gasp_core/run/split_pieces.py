"""``gasp export RUN --format glb|usd --split-pieces``: each piece of a broken body its own node (GLB) or prim (USD).

A run with a ``brittle`` body records each Gaussian's piece per frame (``<object>/pieces_NNNN.npy``,
:mod:`gasp_core.run.pieces`: numbered from 0 within the object, the heaviest first; -1 for rows not simulated).

* ``glb``: every frame's file holds one node per piece of that frame, ``<object>_piece_NNN``, each with its own
  ``KHR_gaussian_splatting`` mesh of the piece's Gaussians, then ``<object>_piece_NNN_faces`` with the piece's crack
  faces shown at that frame (:mod:`gasp_core.run.crack_output`; none while it is whole), and
  ``<object>_unsimulated`` for the rows not simulated (:func:`gasp_core.gs.gltf.write_glb_nodes`);
* ``usd``: the object is an ``Xform`` ``/Run/<object>`` with one ``ParticleField3DGaussianSplat`` prim per piece of
  the run's **last** frame, ``/Run/<object>/piece_NNN``, time-sampled over every frame. A body only comes apart
  (damage never heals), so the last frame's pieces are the finest: each prim moves as one piece from the frame it
  broke off (:func:`gasp_core.run.usd_export.write_usd`), beside ``piece_NNN_faces``, the crack faces of that piece at
  the last frame, time-sampled (hidden until their crack opens; :func:`usd_faces`).

An object without piece files (not brittle) is written as without the flag; a run with none is refused.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.errors import GaspError, SceneError
from gasp_core.run.pieces import PIECES_FILE, read_pieces

#: The formats ``--split-pieces`` writes.
SPLIT_FORMATS = ("glb", "usd")


def parts_of(labels: np.ndarray, prefix: str) -> list[tuple[str, np.ndarray]]:
    """``[(name, rows)]``: ``<prefix>piece_NNN`` for each piece ``NNN`` >= 0 present in ``labels`` (n,), in order,
    then ``<prefix>unsimulated`` for the rows labelled -1 (if any); ``rows`` int64 indices into the object's rows."""
    labels = np.asarray(labels)
    parts = [(f"{prefix}piece_{k:03d}", np.flatnonzero(labels == k)) for k in np.unique(labels[labels >= 0])]
    rest = np.flatnonzero(labels < 0)
    return parts + ([(f"{prefix}unsimulated", rest)] if len(rest) else [])


def frame_labels(run, name: str, frame: int, n_gaussians: int) -> np.ndarray | None:
    """:func:`gasp_core.run.pieces.read_pieces`, checked against the object's Gaussian count.

    Raises
    ------
    SceneError
        The file does not hold one integer per Gaussian (naming it).
    """
    labels = read_pieces(run, name, frame)
    if labels is not None and (labels.shape != (n_gaussians,) or labels.dtype.kind != "i"):
        raise SceneError(f"{Path(run) / name / PIECES_FILE.format(frame)}: {labels.dtype} array of shape "
                         f"{labels.shape}; expected one integer piece per Gaussian, shape ({n_gaussians},)")
    return None if labels is None else np.array(labels)


def missing_sidecars(run, n_frames: int, names: list[str], pieces: bool = True, faces: bool = True) -> list[str]:
    """The sidecar files a damaged run lacks, relative to ``run``: for each object with a ``pieces_NNNN.npy``
    (``pieces``) or a ``crack_faces_NNNN.ply`` (``faces``, :mod:`gasp_core.run.crack_output`) at some frame, those of
    the frames ``0 .. n_frames - 1`` without theirs (gasp simulate writes both at every frame of a brittle object).
    Issue 68: a frame without its pieces file was exported unsplit, and its crack faces dropped, without a word."""
    from gasp_core.run.crack_output import CRACK_FILE
    out = []
    for name in names:
        folder = Path(run) / name
        for pattern, wanted in ((PIECES_FILE, pieces), (CRACK_FILE, faces)):
            if not wanted:
                continue
            have = [(folder / pattern.format(f)).is_file() for f in range(n_frames)]
            if any(have) and not all(have):
                out += [f"{name}/{pattern.format(f)}" for f, h in enumerate(have) if not h]
    return out


def check_split(run, fmt: str, frames, names: list[str]) -> list[np.ndarray | None]:
    """Each object's labels at the run's last frame (None without piece files).

    Raises
    ------
    GaspError
        ``fmt`` not one of :data:`SPLIT_FORMATS`, or no object of the run has pieces.
    SceneError
        A piece file that does not fit its object (:func:`frame_labels`).
    """
    if fmt not in SPLIT_FORMATS:
        raise GaspError(f"--split-pieces writes --format {' or '.join(SPLIT_FORMATS)}, not {fmt}")
    counts = [o["n_gaussians"] for o in frames.manifest["objects"]]
    last = [frame_labels(run, n, frames.n_frames - 1, c) for n, c in zip(names, counts)]
    if all(x is None for x in last):
        raise GaspError(f"{run}: --split-pieces: the run has no pieces (no {PIECES_FILE.format(frames.n_frames - 1)} "
                        "in any object's folder: no body of the brittle material, or a run written before pieces "
                        "were recorded); export it without --split-pieces")
    return last


def glb_parts(run, name: str, frame: int, g, labels: np.ndarray, with_faces: bool = True) -> list:
    """The ``(node name, Gaussians)`` of object ``name`` at ``frame`` for a split GLB: each piece's Gaussians
    (:func:`parts_of`), each followed by its shown crack faces, ``<object>_piece_NNN_faces``, when the run wrote
    them (``<object>/crack_faces_NNNN.ply``, :mod:`gasp_core.run.crack_output`) and ``with_faces``."""
    from gasp_core.run.crack_output import read_crack_faces
    faces = read_crack_faces(run, name, frame) if with_faces else None
    out = []
    for part, rows in parts_of(labels, f"{name}_"):
        out.append((part, g.subset(rows)))
        if faces is not None and "piece" in faces.extra and part.startswith(f"{name}_piece_"):
            k = int(part.rsplit("_", 1)[1])
            shown = np.flatnonzero((np.asarray(faces.extra["piece"]) == k) & (faces.opacities > 0))
            if len(shown):
                out.append((f"{part}_faces", faces.subset(shown)))
    return out


def usd_faces(run, names: list[str]) -> list:
    """Per object, the function ``frame -> crack faces or None`` (:func:`gasp_core.run.crack_output.read_crack_faces`)
    that :func:`gasp_core.run.usd_export.write_usd` reads for a split USD."""
    from gasp_core.run.crack_output import read_crack_faces
    return [lambda f, n=n: read_crack_faces(run, n, f) for n in names]
