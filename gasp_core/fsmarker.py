"""The list of every file a run wrote (``.gasp-output``), and what a folder holds beyond it.

``--overwrite`` replaces a folder only if everything in it, at every depth, is a file or folder
gasp wrote there and left as it was (docs/reliability.md, "Reliability"). At commit the run writes the marker
:data:`MARKER` into its folder: per file its path relative to the folder, its size (bytes) and
modification time (ns), and the folders. :func:`unexpected_entries` walks a folder (not following
links) and names what the marker does not list: a file a user added (also a dot file, also one
deep in a subfolder), a file edited since (its size or time differ), a link, a folder added. A
folder without a marker holding such a list is never a gasp output, whatever else it holds (a
``run.json`` of the user's is not a reason to replace it).
"""
from __future__ import annotations

import json
import os
import re
import stat
from pathlib import Path

MARKER = ".gasp-output"
#: The claim file (:class:`gasp_core.fsutil.OutputClaim`); not part of a run's results.
CLAIM = ".gasp-claim"
#: Files at a run folder's top level that are the machinery's, not results (a committed folder holds no
#: ``.gasp-pid``: one there is not gasp's).
_SKIP_TOP = (MARKER, CLAIM)
#: What :func:`unexpected_entries` returns for a folder without a marker listing its files.
NO_LIST = f"no {MARKER} list of the files gasp wrote"


def _walk(folder: Path):
    """``(relative posix path, lstat)`` of every entry below ``folder`` (links not followed).

    Raises
    ------
    OSError
        A subfolder that cannot be listed (a file in it could not be checked).
    """
    def fail(e):
        raise e
    for root, dirs, files in os.walk(folder, onerror=fail, followlinks=False):
        for name in sorted(dirs + files):
            p = Path(root) / name
            rel = p.relative_to(folder).as_posix()
            if rel in _SKIP_TOP:
                continue
            yield rel, p.lstat()


def write_marker(folder: Path) -> None:
    """Write :data:`MARKER` into the finished run folder ``folder``: every file (size, mtime) and folder in it."""
    files, dirs = {}, []
    for rel, st in _walk(folder):
        if stat.S_ISDIR(st.st_mode):
            dirs.append(rel)
        else:
            files[rel] = [st.st_size, st.st_mtime_ns]
    entries = sorted({rel.split("/")[0] for rel in [*files, *dirs]})
    (folder / MARKER).write_text(json.dumps({"version": 2, "entries": entries, "dirs": dirs, "files": files}) + "\n")


def unexpected_entries(folder: Path) -> list[str]:
    """What ``folder`` holds that gasp did not write there, or changed since (empty list: a gasp output).

    Returns ``[NO_LIST]`` for a folder without a marker (not a gasp output); an entry that changed is
    named ``"<path> (changed)"``, one that cannot be listed ``"<path> (unreadable)"``. A marker of an older
    gasp (its top-level entries only) covers frame files in the object folders and nothing else.
    """
    try:
        marker = json.loads((folder / MARKER).read_text())
        if "files" not in marker and isinstance(marker.get("entries"), list):
            return _legacy_unexpected(folder, set(marker["entries"]))
        files, dirs = marker["files"], set(marker["dirs"])
        if not isinstance(files, dict):
            raise TypeError("files")
    except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError):
        return [NO_LIST]
    extra = []
    try:
        for rel, st in _walk(folder):
            if stat.S_ISDIR(st.st_mode):
                if rel not in dirs:
                    extra.append(rel)
            elif rel not in files or not stat.S_ISREG(st.st_mode):
                extra.append(rel)
            elif files[rel] != [st.st_size, st.st_mtime_ns]:
                extra.append(f"{rel} (changed)")
    except OSError as e:
        extra.append(f"{e.filename} (unreadable)")
    return extra


def record_written(path) -> Path | None:
    """Add ``path``, a file or folder a gasp command has just written inside a finished run folder (``gasp render``'s
    ``RUN/render.mp4``, ``gasp view --export RUN/page.html``), to that folder's :data:`MARKER` list with its size and
    time, so that ``gasp simulate --overwrite`` replaces it with the run (issue 68: ``render.mp4`` made the README's
    folder "not a gasp output"), and refuses it again once someone changes it. Nothing is recorded outside a folder
    whose marker holds a file list, nor where the folder already holds anything its marker does not list (the list
    vouches only for what gasp wrote). Returns the run folder whose list took ``path``, or None."""
    path = Path(path)
    for folder in path.resolve().parents:
        if (folder / MARKER).is_file():
            break
    else:
        return None
    try:
        marker = json.loads((folder / MARKER).read_text())
        files, dirs = marker["files"], marker["dirs"]
        if not isinstance(files, dict) or not isinstance(dirs, list):
            return None
    except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError):
        return None
    rel = path.resolve().relative_to(folder).as_posix()
    if [e for e in unexpected_entries(folder) if e != rel and not e.startswith(rel + "/")
            and not e.startswith(rel + " ")]:
        return None
    parts = rel.split("/")
    for k in range(1, len(parts)):                       # the folders above it, inside the run folder
        if "/".join(parts[:k]) not in dirs:
            dirs.append("/".join(parts[:k]))
    st = path.lstat()
    if stat.S_ISDIR(st.st_mode):
        if rel not in dirs:
            dirs.append(rel)
        for sub, sst in _walk(path):
            key = f"{rel}/{sub}"
            if stat.S_ISDIR(sst.st_mode):
                if key not in dirs:
                    dirs.append(key)
            else:
                files[key] = [sst.st_size, sst.st_mtime_ns]
    else:
        files[rel] = [st.st_size, st.st_mtime_ns]
    marker["entries"] = sorted(set(marker.get("entries", [])) | {parts[0]})
    tmp = folder / f".{MARKER}.{os.getpid()}.tmp"       # replaced whole (fsutil imports this module)
    try:
        tmp.write_text(json.dumps(marker) + "\n")
        os.replace(tmp, folder / MARKER)
    finally:
        tmp.unlink(missing_ok=True)
    return folder


#: What a gasp run writes inside an object folder (the only files a marker of before the file list may cover).
_RUN_FILE = re.compile(r"(frame_\d{4,}|static|rest)(\.ply|\.compressed\.ply|\.spz|\.sog)|moving_rows\.npy")


def _legacy_unexpected(folder: Path, entries: set) -> list[str]:
    """:func:`unexpected_entries` for a marker of an older gasp (top-level entries only, no file list): a
    top-level entry it does not list, or anything in an object folder that is not a frame file, is named."""
    extra = []
    try:
        for rel, st in _walk(folder):
            top, _, rest = rel.partition("/")
            if top not in entries:
                extra.append(rel)
            elif rest and ("/" in rest or not stat.S_ISREG(st.st_mode) or not _RUN_FILE.fullmatch(rest)):
                extra.append(rel)
    except OSError as e:
        extra.append(f"{e.filename} (unreadable)")
    return extra


#: What a run writes at the top of its partial folder (besides one folder per object): its pid, its checkpoint,
#: ``run.json`` / ``frames.json`` / ``render.mp4``.
_PARTIAL_TOP = re.compile(r"\.gasp-pid|\.gasp-checkpoint\.npz|run\.json|frames\.json|render\.mp4")
#: :func:`gasp_core.fsutil.atomic_write`'s temporary files, anywhere in a partial folder.
_TEMPORARY = re.compile(r"\..+\.tmp")


def _gasp_file(pattern: re.Pattern, name: str) -> bool:
    return bool(pattern.fullmatch(name) or _TEMPORARY.fullmatch(name))


def foreign_entries(partial: Path) -> list[str]:
    """What a partial folder holds that no gasp run writes there (relative paths; ``[]``: only gasp's), so that
    ``--discard`` and ``--overwrite`` never delete a file the user put in it."""
    extra = []
    try:
        for top in sorted(partial.iterdir()):
            if top.is_dir() and not top.is_symlink():
                extra += [f"{top.name}/{f.name}" for f in sorted(top.iterdir())
                          if f.is_dir() or f.is_symlink() or not _gasp_file(_RUN_FILE, f.name)]
            elif top.is_symlink() or not _gasp_file(_PARTIAL_TOP, top.name):
                extra.append(top.name)
    except OSError as e:
        extra.append(f"{e.filename} (unreadable)")
    return extra
