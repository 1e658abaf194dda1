"""Each Taichi CPU worker on its own core (``gasp_taichi_mpm.affinity``; issue 39, item 2): the threads pinned are
the ones that do the kernels' work, one per core, and pinning changes no number."""
import os
import sys

import numpy as np
import pytest

from gasp_core.seam import Boundary

pytest.importorskip("taichi")

from gasp_taichi_mpm import affinity  # noqa: E402

from test_taichi_mpm import block_setup, build, run  # noqa: E402

LINUX_2 = pytest.mark.skipif(not sys.platform.startswith("linux") or len(affinity.allowed_cores()) < 2,
                             reason="pinning needs Linux and 2 allowed cores")


def _busy_threads(step) -> dict[int, int]:
    """Nanoseconds each thread of this process ran during ``step()`` (threads that ran at all)."""
    tids = affinity.thread_ids()
    before = affinity._run_ns(tids)
    step()
    after = affinity._run_ns(tids)
    return {t: after[t] - before[t] for t in after if t in before and after[t] > before[t]}


@LINUX_2
def test_the_threads_doing_the_kernels_work_are_pinned_one_per_core():
    """Built with 2 threads, the engine reports the two cores it pinned; the two threads other than Python's that
    run during a frame's kernels are exactly the pinned ones, each on its own single core. An engine that pins
    idle threads (Taichi's compile threads), or none, fails here."""
    cores = affinity.allowed_cores()[:2]
    e = build(block_setup(lo=(0.25, 0.25, 0.2), size=(0.5, 0.5, 0.5), ppc_axis=4, threads=2,
                          boundaries=[Boundary("ground", height=0.1)]))
    assert e.stats()["pinned_cores"] == cores and e.unpinned_why == ""
    e.step_frame()   # compiles (Taichi's compile threads run here)
    busy = _busy_threads(lambda: [e.step_frame() for _ in range(2)])
    busy.pop(os.getpid(), None)
    workers = {t for t in busy if busy[t] > 0.1 * max(busy.values())}
    assert len(workers) == 2, busy
    assert sorted(os.sched_getaffinity(t) for t in workers) == [{c} for c in cores]
    single = {t for t in affinity.thread_ids() if t != os.getpid() and len(os.sched_getaffinity(t)) == 1}
    assert single == workers   # nothing else pinned


def test_pinning_is_declined_with_a_reason_where_it_cannot_help():
    """One thread, or more threads than allowed cores: nothing pinned, the reason said; the kernel is not run."""
    ran = []
    assert affinity.pin_workers(set(), lambda: ran.append(1), 1) == ([], "one thread")
    n = len(affinity.allowed_cores())
    cores, why = affinity.pin_workers(set(), lambda: ran.append(1), n + 1)
    assert cores == [] and f"{n + 1} threads on {n} allowed cores" in why and not ran


@LINUX_2
def test_pinning_is_declined_when_the_busy_threads_are_not_the_pools():
    """Threads that do not run during the calibration kernel are not taken for workers: nothing is pinned."""
    cores, why = affinity.pin_workers({os.getpid()}, lambda: None, 2)
    assert cores == [] and "found 0 busy worker threads, expected 2" in why


def test_pinned_and_unpinned_runs_give_the_same_numbers():
    """Without the contact's balance, whose impulse sums use float64 atomics (engine.py), 2 threads repeat bit for
    bit, pinned or not."""
    kw = dict(lo=(0.25, 0.25, 0.2), size=(0.5, 0.5, 0.5), ppc_axis=4, threads=2, contact_balance=False,
              boundaries=[Boundary("ground", height=0.1)])
    a = run(block_setup(pin_threads=True, **kw), 3)
    b = run(block_setup(pin_threads=False, **kw), 3)
    assert b.stats()["pinned_cores"] == [] and b.unpinned_why.startswith("not asked")
    assert np.array_equal(a.positions(), b.positions()) and np.array_equal(a.velocities(), b.velocities())
