"""Memory of a grid (MPM) engine: the estimate and the refusal before allocating (in the seam since issue 51:
the core's point assembly checks it before the fill, and ``prepare/`` imports nothing of ``mpm/``).

Two checks use it: the engines' own, once the points are known (:func:`check_memory`), and the point
assembly's, before an object's interior fill allocates its points (:func:`check_fill`), since ``n_grid``
and ``particles_per_cell`` together set the number of fill points (``n_grid = 200``,
``particles_per_cell = 64`` gave the guitar 1.36 million).
"""
from __future__ import annotations

import os

from gasp_core.errors import SceneError

#: Share of this machine's physical memory a run may plan to use.
SHARE = 0.8
#: Bytes one point costs while the points are assembled, besides the engine's own: float64 ``x``, ``v``,
#: ``C`` (9), volume and body id (3 + 3 + 9 + 1 + 1 numbers of 8 bytes), the fill's cell index and point
#: (3 + 3 x 8 bytes) and a copy of ``x`` and ``v`` as they are concatenated (6 x 8 bytes).
ASSEMBLY_BYTES = 17 * 8 + 6 * 8 + 6 * 8


def estimate_bytes(n_points: int, n_grid: int, precision: str, grid_copies: int = 1) -> int:
    """Memory an MLS-MPM engine allocates, bytes: particles (x, v, F, C, Jp, mass, volume, ids) and grid.

    ``grid_copies`` counts private grid copies (one per CPU thread where an engine keeps them).
    """
    b = 4 if precision == "f32" else 8
    particles = n_points * (3 + 3 + 9 + 9 + 1 + 1 + 1) * b + n_points * 3 * 4
    grid = (n_grid + 3) ** 3 * 4 * b * (1 + grid_copies)
    return int(particles + grid)


def machine_bytes() -> int | None:
    """This machine's physical memory, bytes; None where the system does not say."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return None


def check_memory(need: int, engine: str, what: str = "") -> None:
    """Refuse before allocating when ``need`` bytes exceed :data:`SHARE` of this machine's physical memory.

    Raises
    ------
    SceneError
        Naming the estimate, the memory here and the settings that drive it.
    """
    total = machine_bytes()
    if total is not None and need > SHARE * total:
        raise SceneError(f"engine '{engine}': needs about {need / 2**30:.1f} GiB ({what}); this machine has "
                         f"{total / 2**30:.1f} GiB: lower n_grid or the number of points")


def check_fill(where: str, n_points: int, n_grid: int, particles_per_cell: float, precision: str = "f32") -> None:
    """Refuse, before the points are allocated, a point count whose assembly and engine exceed :data:`SHARE`
    of this machine's memory (:func:`estimate_bytes` plus :data:`ASSEMBLY_BYTES` a point).

    Parameters
    ----------
    where : str
        The scene file and the object being filled, for the message.
    n_points : int
        Points so far, the object's fill included (its inside cells, an upper bound).
    n_grid, particles_per_cell : int, float
        The ``[domain]`` settings that set the count, named in the message.
    precision : {"f32", "f64"}
        The engine's (``f32`` when the scene does not say: the smaller estimate).

    Raises
    ------
    SceneError
        One line: the count, the estimate, this machine's memory and the two keys.
    """
    total = machine_bytes()
    need = estimate_bytes(n_points, n_grid, precision) + n_points * ASSEMBLY_BYTES
    if total is not None and need > SHARE * total:
        raise SceneError(f"{where}: [domain] n_grid = {n_grid} with particles_per_cell = {particles_per_cell:g} "
                         f"makes about {n_points:,} points, needing about {need / 2**30:.1f} GiB; this machine "
                         f"has {total / 2**30:.1f} GiB: lower particles_per_cell or n_grid")
