"""How a substep's loops, scans and sums run (issue 65): the *schedule*, chosen per run, apart from what the substep
computes.

- ``"cpu"``, the CPU default: ordered for bit-repeatability on any thread count (the coloured block P2G of
  :mod:`gasp_taichi_mpm.transfers`, fixed-slice sums with one thread a slice, node-order lists, host-checked
  convergence). On a GPU its ordered loops are single GPU threads (issue 65: 7.7 s a frame on an H100).
- ``"gpu"``, the CUDA default: every loop over points, nodes or list entries is parallel. Atomic P2G into one grid;
  lists by flag, scan and scatter (:class:`~gasp_taichi_mpm.schedule.primitives.BoxCompaction`, still in node
  order); every body or support sum a fixed-order tree of slice sums
  (:class:`~gasp_taichi_mpm.schedule.primitives.SliceSums`: no atomics, so the sums repeat bit for bit for the
  same inputs); convergence read every :data:`CHECK_EVERY` iterations. It runs on ``ti.cpu`` too (``schedule =
  "gpu"``), where the conformance scenes check it: ``GASP_SCHEDULE=gpu`` in the environment turns every ``"auto"``
  into ``"gpu"`` (``GASP_SCHEDULE=gpu python -m pytest conformance_tests -k taichi_mpm``).

Rule (from the anchors, ``../shared/design/gpu-first.md``): no ``ti.loop_config(serialize=True)`` and no
``block_dim=1`` in a kernel the GPU schedule compiles. Layout: every ordered one-thread loop of the CPU schedule is in
the CPU-only module :mod:`gasp_taichi_mpm.schedule.ordered` (the rigid bodies' and the balance's ordered sums and
fix, the chunked P2G's one-thread chunks, the coloured sort's offsets, the viscous dots' in-order sum); the modules of
both schedules hold none. ``plugins/taichi_mpm/tests/test_taichi_schedule.py`` checks both: no such loop in another module's syntax
tree, none compiled while a GPU-schedule frame runs.
"""
from __future__ import annotations

import os

#: The schedules ``TaichiMPMConfig.schedule`` takes; ``"auto"``: ``"gpu"`` on CUDA, ``"cpu"`` on the CPU.
SCHEDULES = ("auto", "cpu", "gpu")

#: The GPU schedule reads the viscous CG's convergence flag on the host every this many iterations (the iterations
#: after convergence change nothing: :mod:`gasp_taichi_mpm.viscosity`).
CHECK_EVERY = 4


def resolve(schedule: str, device: str) -> str:
    """``"cpu"`` or ``"gpu"`` for ``schedule`` (one of :data:`SCHEDULES`) on ``device`` ("cpu" or "cuda").

    Raises
    ------
    ValueError
        ``schedule`` not one of :data:`SCHEDULES`.
    """
    if schedule not in SCHEDULES:
        raise ValueError(f"engine 'taichi_mpm': option 'schedule' must be one of {', '.join(SCHEDULES)}; "
                         f"got {schedule!r}")
    if schedule == "auto":
        forced = os.environ.get("GASP_SCHEDULE")   # the test runs' override of "auto" (docs/performance.md)
        return forced if forced in ("cpu", "gpu") else ("gpu" if device == "cuda" else "cpu")
    return schedule
