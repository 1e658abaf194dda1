"""Memory of a grid (MPM) engine: the estimate and the refusal before allocating."""
from __future__ import annotations

import os

from gasp_core.errors import SceneError


def estimate_bytes(n_points: int, n_grid: int, precision: str, grid_copies: int = 1) -> int:
    """Memory an MLS-MPM engine allocates, bytes: particles (x, v, F, C, Jp, mass, volume, ids) and grid.

    ``grid_copies`` counts private grid copies (one per CPU thread where an engine keeps them).
    """
    b = 4 if precision == "f32" else 8
    particles = n_points * (3 + 3 + 9 + 9 + 1 + 1 + 1) * b + n_points * 3 * 4
    grid = (n_grid + 3) ** 3 * 4 * b * (1 + grid_copies)
    return int(particles + grid)


def check_memory(need: int, engine: str, what: str = "") -> None:
    """Refuse before allocating when ``need`` bytes exceed 80 % of this machine's physical memory.

    Raises
    ------
    SceneError
        Naming the estimate, the memory here and the settings that drive it.
    """
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return
    if need > 0.8 * total:
        raise SceneError(f"engine '{engine}': needs about {need / 2**30:.1f} GiB ({what}); this machine has "
                         f"{total / 2**30:.1f} GiB: lower n_grid or the number of points")
