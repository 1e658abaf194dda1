"""How a substep's lists and reductions run (engine option ``schedule``, issue 65; ``/work/shared/design/gpu-first.md``
rows 16-22): one MPM, two schedules.

- ``"cpu"``: the loops of :mod:`gasp_warp_mpm.viscosity` and :mod:`gasp_warp_mpm.balance` as they were, serial where
  a fixed order gives the same bits on every run (one thread builds the viscous lists and sums each dot product; the
  balance's sums are f64 atomics, one thread fixes the listed contact nodes). Warp runs CPU kernels on one thread, so
  these are the CPU's own bits, unchanged. Its one-thread kernels and their launches are in the CPU-only module
  :mod:`gasp_warp_mpm.schedule.ordered` (``lists``, ``dot``, ``contact_fix``; issue 65's layout, as taichi_mpm's
  ``schedule/ordered.py``).
- ``"gpu"``: the same algorithm with no ``dim=1`` launch over points, grid nodes or list entries
  (:mod:`gasp_warp_mpm.schedule.gpu`): the viscous node and cell lists by a flag pass over the nodes, an exclusive
  ``wp.utils.array_scan`` and a scatter (node order kept); every dot product, the balance's per-body moments and its
  per-support friction sums by a two-level block reduction of fixed block size :data:`BLOCK` (per-block partial sums
  in item order, then a fixed-order pass over the blocks: no atomics, the same bits on every run); the contact fix
  applied per node in parallel; CG stopped on the device (``wp.capture_while`` inside a CUDA graph where conditional
  nodes are supported, else read on the host every :data:`gasp_warp_mpm.schedule.gpu.CHECK_EVERY` iterations).
  ``dim=1`` is left to scalar bookkeeping (the CG's step lengths, the last fold of at most ``BLOCK`` block partials)
  and ``dim = n_bodies`` / ``n_bodies n_sup`` to per-body work. It runs on CPU too (the tests compare it there).
- ``"auto"`` (default): ``"gpu"`` on CUDA, ``"cpu"`` on CPU.
"""
import os

SCHEDULES = ("auto", "cpu", "gpu")

#: Items per block of the gpu schedule's reductions (fixed: the sums' order, hence their bits, depend on it alone).
BLOCK = 256


def resolve(schedule: str, is_cuda: bool) -> str:
    """``"cpu"`` or ``"gpu"``: the schedule named by option ``schedule`` on a device (``"auto"``: gpu on CUDA)."""
    if schedule not in SCHEDULES:   # the core checks the option; this guards a direct call
        raise ValueError(f"option schedule={schedule!r}; expected one of {', '.join(map(repr, SCHEDULES))}")
    if schedule == "auto":
        forced = os.environ.get("GASP_SCHEDULE")   # the test runs' override of "auto" (docs/performance.md)
        return forced if forced in ("cpu", "gpu") else ("gpu" if is_cuda else "cpu")
    return schedule


def n_blocks(n: int) -> int:
    """Blocks of :data:`BLOCK` items covering ``n`` items (at least one)."""
    return max(1, -(-int(n) // BLOCK))


def viscosity_for(engine, Ft):
    """The implicit viscous step of ``engine``'s schedule: :class:`gasp_warp_mpm.schedule.ordered.CpuViscosity`
    ("cpu") or :class:`gasp_warp_mpm.schedule.gpu.GpuViscosity` ("gpu"), both a
    :class:`gasp_warp_mpm.viscosity.ImplicitViscosity`."""
    if engine.schedule == "gpu":
        from .gpu import GpuViscosity
        return GpuViscosity(engine, Ft)
    from .ordered import CpuViscosity
    return CpuViscosity(engine, Ft)


def balance_for(engine, k, lo_v, dx, dt_f, ex) -> tuple[list, list]:
    """The contact's balance launches of ``engine``'s schedule: (before P2G, after the grid update), each a list of
    recorded launches (:func:`gasp_warp_mpm.schedule.ordered.balance_launches` or
    :func:`gasp_warp_mpm.schedule.gpu_balance.gpu_balance_launches`: the same steps, no atomics on a body's row)."""
    if engine.schedule == "gpu":
        from .gpu_balance import gpu_balance_launches
        return gpu_balance_launches(engine, k, lo_v, dx, dt_f, ex)
    from .ordered import balance_launches
    return balance_launches(engine, k, lo_v, dx, dt_f, ex)
