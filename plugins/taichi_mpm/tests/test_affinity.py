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


# Which threads are pinned, and that they are the ones doing the kernels' work, depends on the machine's load (the
# calibration and the busy-thread count read threads' run time: 2 of 4 runs failed under load, issue 55), so it is
# measured by benchmarks/bench_pinning.py (benchmarks/results/bench_pinning.md), not asserted here.


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
