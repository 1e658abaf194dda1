"""Camera paths for ``gasp render``: a capture's own camera (graphdeco ``cameras.json``), an orbit, keyframes.

A path is a callable ``path(lo, hi, n, width, height, fov_deg) -> list[Camera]`` giving one camera per
rendered frame, from the sequence's box ``[lo, hi]`` (world metres).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.gs.camera import auto_camera, Camera


def find_cameras_json(ply) -> Path | None:
    """``cameras.json`` beside a trained PLY or up to three folders above it (graphdeco writes
    ``MODEL/cameras.json`` and ``MODEL/point_cloud/iteration_N/point_cloud.ply``); ``None`` if absent."""
    for d in list(Path(ply).resolve().parents)[:4]:
        if (d / "cameras.json").is_file():
            return d / "cameras.json"
    return None


def graphdeco_camera(path, index: int, placement: dict | None = None, width: int | None = None,
                     height: int | None = None) -> Camera:
    """Camera ``index`` of a graphdeco ``cameras.json``, moved into the world by an object's placement.

    graphdeco-inria/gaussian-splatting ``utils/camera_utils.py: camera_to_JSON`` writes, per camera,
    ``position`` (centre) and ``rotation`` (camera -> world, columns right, down, forward: COLMAP /
    OpenCV axes) in the capture's frame, ``width``, ``height`` and ``fx``, ``fy`` in pixels.

    Parameters
    ----------
    path : path
        The ``cameras.json``.
    index : int
        Position in the file's list (0 = first).
    placement : dict, optional
        ``{R, scale, t}`` of the object whose file frame the capture shares (``run.json``); identity if absent.
    width, height : int, optional
        Image size, pixels (default: the camera's own); the focal length scales with the height.

    Returns
    -------
    Camera

    Raises
    ------
    SceneError
        Missing or unreadable file, an index outside the list (the message gives its length), a
        camera entry without ``position`` / ``rotation`` / ``fy`` / ``height``, or one whose values make no camera
        (``fy`` not above 0, an empty image, a position that is not finite, a rotation that is not proper), naming
        the file and the camera.
    """
    path = Path(path)
    try:
        cams = json.loads(path.read_text())
    except (OSError, ValueError, RecursionError) as e:
        raise SceneError(f"{path}: cannot read a graphdeco cameras.json ({e})") from None
    if not isinstance(cams, list) or not cams:
        raise SceneError(f"{path}: expected a non-empty JSON list of cameras (graphdeco cameras.json)")
    if not 0 <= index < len(cams):
        raise SceneError(f"--camera-index {index}: {path} has {len(cams)} cameras (0 to {len(cams) - 1})")
    c = cams[index]
    try:
        pos = np.asarray(c["position"], float).reshape(3)
        c2w = np.asarray(c["rotation"], float).reshape(3, 3)
        fy, h0, w0 = float(c["fy"]), int(c["height"]), int(c["width"])
    except (KeyError, TypeError, ValueError) as e:
        raise SceneError(f"{path}: camera {index} lacks position, rotation (3x3), fy, width or height "
                         f"({e!r})") from None
    if not (np.isfinite(fy) and fy > 0 and w0 >= 1 and h0 >= 1):
        raise SceneError(f"{path}: camera {index}: expected a focal length fy > 0 and a width and height of 1 px or "
                         f"more, got fy {fy:g}, {w0}x{h0}")
    pl = placement or {"R": np.eye(3), "scale": 1.0, "t": np.zeros(3)}
    R, scale, t = np.asarray(pl["R"], float), float(pl["scale"]), np.asarray(pl["t"], float)
    width, height = width or w0, height or h0
    try:
        return Camera.from_pose(scale * R @ pos + t, (R @ c2w).T, fy * height / h0, width, height,
                                near=1e-3 * scale)
    except SceneError as e:   # the camera's own values: name the file and the camera
        raise SceneError(f"{path}: camera {index}: {str(e).removeprefix('camera ')}") from None


def orbit_path(degrees: float, elevation_deg: float = 25.0, azimuth_deg: float = -60.0):
    """A camera circling the sequence's centre about the vertical by ``degrees`` over the video, at the
    distance that frames the whole box (:func:`gasp_core.gs.camera.auto_camera`)."""
    def path(lo, hi, n, width, height, fov_deg):
        turn = np.arange(n) * (degrees / max(n, 1))
        return [auto_camera(lo, hi, width, height, fov_deg, azimuth_deg + a, elevation_deg) for a in turn]
    return path


def keyframe_path(file):
    """Cameras interpolated linearly between keyframes read from a JSON file.

    The file: ``{"keyframes": [{"frame": 0, "position": [x, y, z], "look_at": [x, y, z]}, ...]}``,
    world metres, z up, ``frame`` the index in the rendered video; before the first and after the last
    keyframe the camera holds still. Each frame takes at most one keyframe: the video is sampled at whole frames,
    so a cut is two keyframes on consecutive frames (``4`` and ``5``), and two at one frame would leave the camera
    there to the order of the file (round 101: numpy's interpolation picks one of the two without a word).

    Raises
    ------
    SceneError
        Unreadable file, no keyframes, or a keyframe without ``frame``, ``position`` or ``look_at``, with a
        value that is not finite, a ``frame`` that is not a whole number >= 0, or with ``position == look_at``; two keyframes at the same frame (naming the file,
        both keyframes and the frame).
    """
    file = Path(file)
    try:
        keys = json.loads(file.read_text())["keyframes"]
        frames = np.array([float(k["frame"]) for k in keys])
        pos = np.array([np.asarray(k["position"], float).reshape(3) for k in keys])
        look = np.array([np.asarray(k["look_at"], float).reshape(3) for k in keys])
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as e:
        raise SceneError(f"{file}: expected {{\"keyframes\": [{{\"frame\", \"position\", \"look_at\"}}, ...]}} "
                         f"({e!r})") from None
    if not len(keys):
        raise SceneError(f"{file}: no keyframes")
    for k, key in enumerate(keys):   # true (read as 1), 2.5 or -3 would move the camera where no frame is said
        f = key["frame"]
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not (f >= 0 and float(f).is_integer()):
            raise SceneError(f"{file}: keyframe {k}: frame = {json.dumps(f)}; expected a frame number of the video, "
                             "a whole number >= 0")
    for k, (f, p, q) in enumerate(zip(frames, pos, look)):
        if not (np.isfinite(f) and np.isfinite(p).all() and np.isfinite(q).all()):
            raise SceneError(f"{file}: keyframe {k}: frame, position and look_at must be finite numbers, got "
                             f"frame {float(f)}, position {p.tolist()}, look_at {q.tolist()}")
        if np.array_equal(p, q):
            raise SceneError(f"{file}: keyframe {k}: position and look_at are the same point {p.tolist()}")
    order = np.argsort(frames, kind="stable")
    same = np.flatnonzero(np.diff(frames[order]) == 0)
    if len(same):
        i, j = sorted(order[same[0]:same[0] + 2])
        raise SceneError(f"{file}: keyframes {i} and {j} are both at frame {frames[i]:g}; expected one keyframe per "
                         f"frame (for a cut, put the second at the next frame, {frames[i] + 1:g})")
    frames, pos, look = frames[order], pos[order], look[order]

    def path(lo, hi, n, width, height, fov_deg):
        out = []
        for i in range(n):
            p = [np.interp(i, frames, pos[:, k]) for k in range(3)]
            q = [np.interp(i, frames, look[:, k]) for k in range(3)]
            dist = float(np.linalg.norm(np.subtract(p, q)))
            out.append(Camera(p, q, fov_deg, width, height, near=1e-3 * max(dist, 1e-6)))
        return out
    return path
