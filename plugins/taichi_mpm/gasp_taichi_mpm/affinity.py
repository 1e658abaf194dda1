"""One CPU core per Taichi worker thread (issue 39, item 2; docs/performance.md, "Where the second core went").

Taichi's CPU backend runs a kernel's outermost loop on a pool of ``cpu_max_num_threads`` worker threads, woken at
every launch (about 14 launches a substep here). Left to Linux's scheduler, the two workers of a 2-core machine
often wake on the same core, and a launch then runs its halves one after the other: measured on the
``bench_mpm`` jelly block (46,656 points, 10 substeps a frame), frames took 61 ms in some stretches of a run and
85-115 ms in others, with the same CPU time (109 ms a frame) and one thread at 114 ms. With each worker pinned to
its own core the frames took 59-66 ms throughout (median 1.87x one thread).

The workers are found, not assumed: the threads that ``ti.init`` started, other than Python's own, and that gain
CPU time while a parallel kernel runs (``/proc/self/task/<tid>/schedstat``, nanoseconds). Linux only; elsewhere, or when the count found is
not the pool's, nothing is pinned and :func:`pin_workers` says why.
"""

import os
import threading
from collections.abc import Callable

TASKS = "/proc/self/task"
#: Iterations of the calibration kernel's parallel loop and of each iteration's serial chain (a few ms in all).
SPIN_ITERS, SPIN_CHAIN = 1024, 400
_spin = None


def allowed_cores() -> list[int]:
    """The cores this process may run on (``taskset``, cgroups), sorted; all of ``os.cpu_count()`` where the
    platform cannot say."""
    if hasattr(os, "sched_getaffinity"):
        return sorted(os.sched_getaffinity(0))
    return list(range(os.cpu_count() or 1))


def spin_all_threads() -> None:
    """Run a parallel Taichi kernel of a few milliseconds, which every worker of the pool takes part in (Taichi
    hands out its loop in chunks of at most 512 iterations; here 1,024 iterations of a 400-step chain).
    Needs ``ti.init`` first."""
    global _spin
    import numpy as np
    import taichi as ti
    if _spin is None:
        @ti.kernel
        def spin(a: ti.types.ndarray(dtype=ti.f32, ndim=1), chain: ti.i32):
            for i in range(a.shape[0]):
                s = ti.cast(i, ti.f32)
                for _k in range(chain):
                    s = ti.sin(s) + 1.0
                a[i] = s
        _spin = spin
    _spin(np.zeros(SPIN_ITERS, np.float32), SPIN_CHAIN)
    ti.sync()


def thread_ids() -> set[int]:
    """The process's thread ids (Linux; empty where ``/proc/self/task`` does not exist)."""
    try:
        return {int(t) for t in os.listdir(TASKS)}
    except OSError:
        return set()


def _run_ns(tids: set[int]) -> dict[int, int]:
    """Nanoseconds each thread has run (the first field of its ``schedstat``); threads gone are left out."""
    out = {}
    for t in tids:
        try:
            with open(f"{TASKS}/{t}/schedstat") as f:
                out[t] = int(f.read().split()[0])
        except (OSError, ValueError, IndexError):
            pass
    return out


def pin_workers(started: set[int], run_parallel: Callable[[], None], threads: int) -> tuple[list[int], str]:
    """Pin each of Taichi's ``threads`` CPU workers to its own allowed core.

    Parameters
    ----------
    started : set of int
        Thread ids that ``ti.init`` started (those after it minus those before it).
    run_parallel : callable
        Runs a parallel Taichi kernel long enough for every worker to take part (a few milliseconds); called once
        before the measurement, since its first call compiles on other threads.
    threads : int
        The pool's size (``cpu_max_num_threads``).

    Returns
    -------
    (cores, why) : list of int, str
        The core each worker was pinned to, in thread-id order, and ``""``; or ``[]`` and why nothing was pinned
        (fewer than 2 threads, more threads than allowed cores, no ``/proc``, or workers not found). Never raises
        for a platform that cannot pin: the run goes on unpinned.
    """
    if threads < 2:
        return [], "one thread"
    if not hasattr(os, "sched_setaffinity"):
        return [], "this platform has no sched_setaffinity"
    cores = allowed_cores()
    if threads > len(cores):
        return [], f"{threads} threads on {len(cores)} allowed cores"
    # Python's own threads are not Taichi's workers (ti.init starts one to look for a newer Taichi)
    candidates = started - {os.getpid()} - {th.native_id for th in threading.enumerate()}
    workers: list[int] = []
    run_parallel()   # its first call compiles (or loads) the kernel, on Taichi's compile threads
    for _attempt in range(3):   # every worker must take a share of the loop; a busy machine may need another go
        before = _run_ns(candidates)
        run_parallel()
        after = _run_ns(candidates)
        workers = sorted(t for t in after if after[t] > before.get(t, after[t]))
        if len(workers) == threads:
            break
    if len(workers) != threads:
        return [], f"found {len(workers)} busy worker threads, expected {threads}"
    pinned = []
    for t, core in zip(workers, cores):
        try:
            os.sched_setaffinity(t, {core})
        except OSError as e:
            for u in workers:   # all or none: a half-pinned pool is worse than none
                try:
                    os.sched_setaffinity(u, set(cores))
                except OSError:
                    pass
            return [], f"sched_setaffinity failed: {e}"
        pinned.append(core)
    return pinned, ""
