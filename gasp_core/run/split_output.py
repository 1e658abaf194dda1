"""Sub-triangle Gaussians in a run's output: ``<object>/split_NNNN.ply`` beside a frame of an object that tears.

Where the alpha rule clamps a triangle of an object that can tear (plasticine, brittle) and the triangle straddles
no crack, :func:`gasp_core.run.frames.rebuild` splits it into sub-triangle Gaussians that keep the surface covered
(:mod:`gasp_core.maps.split`). They go in a per-frame sidecar, a graphdeco 3DGS PLY in the object's file frame
(the frame file's), a row per sub-Gaussian, **a variable row count per frame**: its parent's opacity and SH, and an
int32 property ``parent``, the row of the object's file it comes from. A frame with none has no file (a stale one
from an earlier try of the same frame is removed). The object's own frame file is unchanged (one row per input
Gaussian, the parent clamped as before); ``gasp render`` draws the sidecar after every object's rows and crack faces
(:meth:`gasp_core.render.run.Run.splats`).
"""
from __future__ import annotations

from pathlib import Path

from gasp_core.gs.io import write_gaussians

#: A frame's sub-triangle file in an object's folder.
SPLIT_FILE = "split_{:04d}.ply"


def write_split(folder, names, frame: int, split: list) -> list[str]:
    """Write each object's sub-triangle Gaussians of ``frame`` (``split``: per object, Gaussians or None, as
    :attr:`gasp_core.run.frames.Rebuilder.last_split`) to ``<folder>/<name>/split_NNNN.ply``; an object with none
    has its file removed. The files written, relative to ``folder``."""
    rels = []
    for name, g in zip(names, split):
        rel = f"{name}/{SPLIT_FILE.format(frame)}"
        path = Path(folder) / rel
        if g is None:
            path.unlink(missing_ok=True)
            continue
        write_gaussians(path, g, overwrite=True)
        rels.append(rel)
    return rels


def read_split(run, name: str, frame: int):
    """Object ``name``'s sub-triangle Gaussians at ``frame`` in the run folder ``run`` (:class:`Gaussians`, file
    frame, with the field ``parent``), or None when that frame has none."""
    path = Path(run) / name / SPLIT_FILE.format(frame)
    if not path.is_file():
        return None
    from gasp_core.gs.io import read_gaussians
    return read_gaussians(path)
