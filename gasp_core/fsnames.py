"""Names and folders of the files and folders gasp writes (:mod:`gasp_core.fsutil` uses these checks).

A temporary file's or a partial folder's name is built from the name the user gave: the checks here keep that
from refusing a name the filesystem takes, or from failing with an error that names gasp's temporary file
instead of the user's path (round 101b).
"""
from __future__ import annotations

import os
from pathlib import Path

from gasp_core.errors import GaspError

#: The longest temporary-file prefix taken from a file's name: with mkstemp's 8 random characters and a suffix the
#: temporary name stays within the usual 255-byte file name limit, so it never refuses a name the user may give.
PREFIX_BYTES = 200
#: What a partial folder adds to its output folder's name: ``.`` + ``.partial-`` + mkdtemp's 8 characters.
PARTIAL_EXTRA_BYTES = 18


def temp_prefix(name: str) -> str:
    """``.NAME.``, NAME cut to :data:`PREFIX_BYTES` bytes (whole characters) when longer."""
    raw = os.fsencode(name)
    return f".{raw[:PREFIX_BYTES].decode('utf-8', 'ignore') if len(raw) > PREFIX_BYTES else name}."


def check_folder(path: Path) -> None:
    """Refuse a file whose folder does not exist.

    Raises
    ------
    FileNotFoundError
        Naming ``path`` and its folder (not the temporary file a writer would have made there).
    """
    if not path.parent.is_dir():
        raise FileNotFoundError(f"output '{path}': folder '{path.parent}' does not exist")


def name_max(folder: Path) -> int:
    """The longest file name, in bytes, of the filesystem holding ``folder`` (or its nearest existing parent)."""
    for p in [folder.absolute(), *folder.absolute().parents]:
        if p.is_dir():
            try:
                return int(os.pathconf(p, "PC_NAME_MAX"))
            except (OSError, ValueError, AttributeError):
                return 255
    return 255


def check_output_name(outdir: Path) -> None:
    """Refuse an output folder whose partial folder's name (``.NAME.partial-XXXXXXXX``) the filesystem cannot hold.

    Raises
    ------
    GaspError
        Naming the folder, its name's length in bytes and the longest that fits.
    """
    n, limit = len(os.fsencode(outdir.name)), name_max(outdir.parent) - PARTIAL_EXTRA_BYTES
    if n > limit:
        raise GaspError(f"output folder '{outdir}': its name is {n} bytes long; at most {limit} fit (the run writes "
                        f"into a hidden '.NAME.partial-XXXXXXXX' beside it first); choose a shorter name")


def refuse_link(outdir: Path) -> None:
    """Refuse an output folder that is a symbolic link: a run commits by putting its new folder in the output's place,
    which would replace the link by a folder and leave the old run at the link's target (round 102).

    Raises
    ------
    GaspError
        Naming the link and its target.
    """
    if outdir.is_symlink():
        raise GaspError(f"output folder '{outdir}' is a symbolic link (to '{os.readlink(outdir)}'); gasp writes a "
                        f"new folder in the output's place and would replace the link; give the folder it points "
                        f"to, or another name")


def alive(pid: int) -> bool:
    """True if process ``pid`` exists (or exists under another user)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def is_within(a: Path, b: Path) -> bool:
    """True if ``a`` is ``b`` or lies inside it."""
    try:
        a.relative_to(b)
        return True
    except ValueError:
        return False
