"""Row-wise work on the host's cores: ``T^-1``, the control rule and the quaternions of a large object in chunks of
rows, each chunk on a thread of a pool (issue 65 item 3: with the engine on a GPU the host's rebuild is the frame's
time; at 2M Gaussians it took 4.1 s on one core of this 2-core machine, ``benchmarks/bench_rebuild_rows.py``).

Every function run through :func:`by_rows` works row by row (no sum or sort across rows), so the chunks' results,
put back in order, are the whole array's **bit for bit** (``tests/test_rows.py``). NumPy releases the GIL inside its
array loops, so the threads run at once. Objects under :data:`MIN_ROWS` rows run in one call, as before (the README
donut's 66k Gaussians: no thread, no change), so a CPU engine's own threads are not crowded by small rebuilds.
"""
from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Callable

import numpy as np

#: Objects with fewer rows than this are rebuilt in one call.
MIN_ROWS = 262_144
#: Rows a chunk (a few MB of float64 temporaries a chunk).
CHUNK_ROWS = 131_072


def host_threads() -> int:
    """The threads of the pool: the cores this process may use (``os.sched_getaffinity`` where it exists), at
    least 1; ``GASP_REBUILD_THREADS`` sets it."""
    env = os.environ.get("GASP_REBUILD_THREADS")
    if env and env.isdigit() and int(env) > 0:
        return int(env)
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:   # not on Linux
        return max(1, os.cpu_count() or 1)


def by_rows(fn: Callable[..., tuple], n: int, *arrays: np.ndarray) -> tuple:
    """``fn(*(a[lo:hi] for a in arrays))`` over chunks of the ``n`` rows, results concatenated along axis 0 in order.

    Parameters
    ----------
    fn : callable
        Takes the arrays' rows ``lo:hi`` (each array's first axis has ``n`` rows, or the argument is None and passed
        as None) and returns a tuple of arrays with ``hi - lo`` rows each. It must work row by row.
    n : int
        Rows.

    Returns
    -------
    tuple of ndarray
        ``fn``'s outputs for all ``n`` rows; ``fn(*arrays)`` itself when ``n < MIN_ROWS`` or one thread.
    """
    threads = host_threads()
    if n < MIN_ROWS or threads < 2:
        return fn(*arrays)
    edges = list(range(0, n, CHUNK_ROWS)) + [n]

    def part(k: int) -> tuple:
        lo, hi = edges[k], edges[k + 1]
        return fn(*(None if a is None else a[lo:hi] for a in arrays))

    with ThreadPoolExecutor(max_workers=threads) as pool:
        parts = list(pool.map(part, range(len(edges) - 1)))
    return tuple(np.concatenate([p[i] for p in parts]) for i in range(len(parts[0])))
