"""The memory a splat file's Gaussians will take, refused before the file is decoded.

Every reader knows its Gaussian count before it decodes: from the file's size where records have a fixed size
and no header (``.splat``, ``.splatv``, a ``.glb``'s float32 attributes), from the header otherwise (PLY's
``element vertex``, ``.ksplat``, ``.spz``, ``.sog``'s ``meta.json``). :func:`check_count` refuses a count whose
Gaussians need more than :data:`SHARE` of this machine's physical memory at :data:`READ_BYTES` each, in one line
naming the file, so that a 2 GB ``.splat`` (67 million records) is refused in a second instead of decoding
until the kernel kills the process.
"""
from __future__ import annotations

import os

from gasp_core.errors import SceneError

#: Share of this machine's physical memory a command may plan to use (as a run's points may).
SHARE = 0.8
#: Bytes one Gaussian costs while a command reads and describes it: ``gasp info`` on a ``.splat`` peaked at
#: 327 bytes a Gaussian more (max RSS 426 MB at 182,496 Gaussians, 601 MB at 729,984; the donut tiled); the
#: studio holds a copy for the page beside it.
READ_BYTES = 400


def machine_bytes() -> int | None:
    """This machine's physical memory, bytes; None where the system does not say."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return None


def max_gaussians() -> int | None:
    """The most Gaussians a file may hold on this machine (:data:`SHARE` of its memory at :data:`READ_BYTES`
    each); None where the machine's memory is unknown."""
    total = machine_bytes()
    return None if total is None else int(SHARE * total / READ_BYTES)


def check_count(path, n: int, source: str) -> None:
    """Refuse ``n`` Gaussians (read from ``source``: ``"its size"``, ``"its header"``) before decoding them when
    they need more than :data:`SHARE` of this machine's memory.

    Raises
    ------
    SceneError
        One line: the file, the count and where it came from, the memory it needs and the memory here.
    """
    limit = max_gaussians()
    if limit is not None and n > limit:
        raise SceneError(f"{path}: {source} gives {n:,} Gaussians, needing about {n * READ_BYTES / 2**30:.1f} GiB to "
                    f"read ({READ_BYTES} bytes each); this machine has {machine_bytes() / 2**30:.1f} GiB, room for "
                    f"{limit:,}: split the scene or read it on a larger machine")
