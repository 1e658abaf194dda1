"""A run folder's ``run.json``, checked as a scene is before anything is read or written from it.

A run folder may come from someone else, edited by hand. Everything ``gasp export``, ``gasp render`` and
``gasp view`` take from its ``run.json`` is checked first, each refusal one line naming the file and the field:
``frame_dt`` a finite number of seconds > 0 (``-0.0333`` gave a USD playing backwards, ``0`` a division by zero),
``objects`` a list of tables, each ``name`` one path component (``../../escape`` would write outside ``-o``),
unique, and an ``up_axis`` one of ``+x -x +y -y +z -z``.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from gasp_core.errors import SceneError
from gasp_core.scene.values import UP_AXES


def check_component(name, where: str) -> str:
    """``name`` when it is one path component a folder may be named by: a non-empty string, not ``.`` or ``..``,
    without ``/``, ``\\`` or a NUL byte.

    Raises
    ------
    SceneError
        ``"<where>: expected one folder name ..., got '../../escape'"``.
    """
    if (not isinstance(name, str) or name in ("", ".", "..") or any(c in name for c in "/\\\0")
            or name != name.strip()):
        raise SceneError(f"{where}: expected one folder name (no '/', '\\', '..', not empty), got {name!r}; "
                         "the run folder is corrupt or not gasp's")
    return name


def load_json(path: Path) -> object:
    """The JSON of ``path``, nested at most as deep as Python's parser goes.

    Raises
    ------
    SceneError
        Unreadable, not JSON, or nested too deep (one line naming the file).
    """
    try:
        return json.loads(Path(path).read_text())
    except (OSError, ValueError, RecursionError) as e:
        raise SceneError(f"{path}: not readable JSON ({type(e).__name__}: {str(e)[:200]})") from None


def check_run_json(folder, *, need_frame_dt: bool = True) -> dict:
    """``folder/run.json`` after checking the fields read from it (module notes).

    Parameters
    ----------
    folder : path-like
        A run folder written by ``gasp simulate``.
    need_frame_dt : bool
        ``frame_dt`` must be there (``gasp export``); otherwise it may be absent (an older run: 1/30 s).

    Returns
    -------
    dict
        The record as read.

    Raises
    ------
    SceneError
        No ``run.json``, or a field that is not what ``gasp simulate`` writes (one line: the file and the field).
    """
    path = Path(folder) / "run.json"
    if not path.is_file():
        raise SceneError(f"{folder}: not a run folder (no run.json; make one with 'gasp simulate')")
    run = load_json(path)
    if not isinstance(run, dict):
        raise SceneError(f"{path}: expected a table (the run.json of a gasp simulate run), got {type(run).__name__}")
    if "frame_dt" in run or need_frame_dt:
        dt = run.get("frame_dt")
        if not (isinstance(dt, (int, float)) and not isinstance(dt, bool) and math.isfinite(dt) and dt > 0):
            raise SceneError(f"{path}: frame_dt: expected a finite number of seconds > 0, got {dt!r}")
    objects = run.get("objects")
    if not isinstance(objects, list) or not objects or not all(isinstance(o, dict) for o in objects):
        raise SceneError(f"{path}: objects: expected a list of object tables, got {objects!r:.80}")
    for k, o in enumerate(objects):
        check_component(o.get("name"), f"{path}: objects[{k}].name")
        if o.get("up_axis", "+z") not in UP_AXES:
            raise SceneError(f"{path}: objects[{k}].up_axis: expected one of {' '.join(UP_AXES)}, "
                             f"got {o.get('up_axis')!r}")
    names = [o["name"] for o in objects]
    if len(set(names)) != len(names):
        raise SceneError(f"{path}: objects: the name '{next(n for n in names if names.count(n) > 1)}' is there "
                         "twice; expected one folder per object")
    return run
