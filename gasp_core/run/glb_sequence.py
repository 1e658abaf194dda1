"""A run as one GLB that plays the whole sequence (``gasp export RUN --format glb_sequence``).

glTF animates nodes, not per-point attributes, so each frame is its own ``KHR_gaussian_splatting`` mesh
(:mod:`gasp_core.gs.gltf`) on its own node, and one animation shows one frame's node at a time:

* every frame node carries ``KHR_node_visibility`` (``visible`` true for frame 0 only) and is switched by a
  ``KHR_animation_pointer`` channel on ``/nodes/<i>/extensions/KHR_node_visibility/visible`` with ``STEP``
  interpolation at times ``0, frame_dt, 2 frame_dt, ...`` (seconds; output 1.0 at the node's own frame, 0.0
  elsewhere: the extension reads a float as a boolean, non-zero = true);
* what does not move is written once, always visible: a ``static`` object, and the rows an object's ``select``
  leaves out (the run's ``moving_rows.npy``), so the frame nodes hold only the rows that move;
* a ``brittle`` object's crack faces shown at a frame (``crack_faces``) follow that frame's rows in its node;
* ``KHR_node_visibility`` is in ``extensionsRequired``: a reader without it would draw every frame at once, so it
  refuses the file instead. Babylon.js reads both extensions (``tests/test_export_browser.py``).

Axes as :func:`gasp_core.gs.gltf.write_glb` (each object's ``up_axis`` turned to glTF's +Y).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from gasp_core.fsutil import atomic_write
from gasp_core.gs.gltf import UP_TO_Z, Z_TO_Y, GlbBuilder, gltf_module, turned
from gasp_core.run.crack_output import with_crack_faces

VISIBILITY, POINTER = "KHR_node_visibility", "KHR_animation_pointer"


def write_glb_sequence(path, frames, names: list[str], up_axes: list[str], frame_dt: float, moving: list[bool], *,
                       overwrite: bool = False, crack_faces: list | None = None) -> Path:
    """Write a run's frames as one animated GLB (module notes), atomically.

    Parameters
    ----------
    path : path-like
        The ``.glb`` to write.
    frames : gasp_core.run.layout.RunFrames
        The run's frames; ``frames.gaussians(f, k)`` is object ``k`` at frame ``f`` in its file frame, and
        ``frames.manifest["objects"][k]["moving_rows"]`` (split layout) names the rows that move.
    names, up_axes : list of str
        Per object: the node name and the file frame's up axis.
    frame_dt : float
        Seconds between frames.
    moving : list of bool
        Per object: false for an object that never moves (one node, no animation).
    overwrite : bool
        Replace an existing file.
    crack_faces : list, optional
        Per object, None or a function ``frame -> Gaussians or None`` (its crack faces,
        :func:`gasp_core.run.crack_output.read_crack_faces`): the faces shown at a frame are drawn with it.

    Raises
    ------
    FileExistsError
        ``path`` exists and ``overwrite`` is false.
    GaspError
        pygltflib not installed.
    """
    gl = gltf_module(path)
    b, nodes, switched = GlbBuilder(gl), [], []
    for k, name in enumerate(names):
        M = Z_TO_Y @ UP_TO_Z[up_axes[k]]
        g0 = frames.gaussians(0, k)
        rows = _moving_rows(frames, k, g0.n) if moving[k] else np.zeros(0, np.int64)
        if len(rows) < g0.n:                       # what never moves: once, always visible
            keep = np.ones(g0.n, bool)
            keep[rows] = False
            nodes.append({"mesh": b.splat_mesh(turned(g0.subset(keep), M)), "name": f"{name}_static"})
        if not len(rows):
            continue
        faces_at = None if crack_faces is None else crack_faces[k]
        for f in range(frames.n_frames):
            g = (g0 if f == 0 else frames.gaussians(f, k)).subset(rows)
            faces = None if faces_at is None else faces_at(f)
            if faces is not None and (faces.opacities > 0).any():
                g = with_crack_faces(g, faces.subset(np.flatnonzero(faces.opacities > 0)))
            switched.append((len(nodes), f))
            nodes.append({"mesh": b.splat_mesh(turned(g, M)), "name": f"{name}_frame_{f:04d}",
                          "extensions": {VISIBILITY: {"visible": f == 0}}})
    animations = [_switch_animation(gl, b, switched, frames.n_frames, frame_dt)] if switched else []
    data = b.to_bytes(nodes, animations, used=(VISIBILITY, POINTER) if switched else (),
                      required=(VISIBILITY,) if switched else ())
    return atomic_write(Path(path), lambda f: f.write(data), overwrite=overwrite)


def _moving_rows(frames, k: int, n: int) -> np.ndarray:
    """The rows of object ``k`` that move: the run's ``moving_rows.npy`` (split layout), else all ``n``."""
    o = frames.manifest["objects"][k]
    if o.get("moving_rows"):
        return np.asarray(np.load(frames.folder / o["moving_rows"]), np.int64)
    return np.arange(n)


def _switch_animation(gl, b: GlbBuilder, switched: list[tuple[int, int]], n_frames: int, frame_dt: float):
    """One animation: per frame node, a STEP channel on its visibility, 1.0 at its frame and 0.0 elsewhere."""
    times = b.array(np.arange(n_frames) * float(frame_dt), bounds=True, vertex=False)
    samplers, channels = [], []
    for node, f in switched:
        samplers.append(gl.AnimationSampler(input=times, output=b.array(
            (np.arange(n_frames) == f).astype(np.float32), vertex=False), interpolation="STEP"))
        channels.append(gl.AnimationChannel(sampler=len(samplers) - 1, target=gl.AnimationChannelTarget(
            path="pointer", extensions={POINTER: {"pointer": f"/nodes/{node}/extensions/{VISIBILITY}/visible"}})))
    return gl.Animation(name="frames", samplers=samplers, channels=channels)
