"""GASP engine plugin ``warp_mpm``: the MLS-MPM solver of ``docs/mpm.md`` written in NVIDIA Warp.

Registers one engine through the ``gasp_engines`` hook. Importing this module does not import
Warp: the factory imports :mod:`gasp_warp_mpm.engine` when a simulation is built, and
``available()`` only checks that ``warp`` can be imported.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
import importlib.util

from gasp_core.seam import engine_hook, EngineInfo, install_hint, option
from gasp_core.seam.config import config_options, from_option
from gasp_core.mpm.roll_contact import ROLL_CONTACT
from gasp_core.mpm.grid_engine import MPM_CAPABILITIES, grid_substeps
from gasp_core.mpm.options import MPMConfigCudaIndex
from gasp_core.mpm.sweep import mpm_sweep
from gasp_core.mpm.failures import MPM_KNOWN_FAILURES
from gasp_core.mpm.ground_check import check_ground_in_grid

__all__ = ["CAPABILITIES", "ENGINE", "OPTIONS", "WarpMPMConfig", "gasp_engines", "sweep"]

ENGINE = "warp_mpm"

#: The MLS-MPM record of the grid-engine base (``gasp_core.mpm.grid_engine``), with the rigid limit (issue 40).
CAPABILITIES = dataclasses.replace(MPM_CAPABILITIES, features=MPM_CAPABILITIES.features | {"rigid_limit", "sleep", "body_friction",
                                                                                      "fracture_cells"})

@dataclass(frozen=True)
class WarpMPMConfig(MPMConfigCudaIndex):
    """The engine's settings (:class:`gasp_core.mpm.options.MPMConfigCudaIndex`: ``device`` "cpu", "cuda" or
    "cuda:N", Warp's device names), with ``threads``, accepted so that a scene written for another MPM engine runs
    unchanged, and ``schedule`` (:mod:`gasp_warp_mpm.schedule`)."""

    threads: int | None = option(None, "accepted and ignored: Warp runs CPU kernels on one thread (runs repeat bit "
                                 "for bit)", kind="int", lo=1)
    schedule: str = option("auto", "how a substep's reductions and lists run: 'cpu' (serial loops, one thread; the "
                           "CPU's bits), 'gpu' (parallel flag-scan-scatter lists and fixed-block reductions, no "
                           "atomics on a body's row, CG stopped on the device; runs on CPU too) or 'auto' (gpu on "
                           "CUDA, cpu on CPU)", kind="str", choices=("auto", "cpu", "gpu"))
    roll_contact: bool = from_option(ROLL_CONTACT)


#: The options, one per field of :class:`WarpMPMConfig`.
OPTIONS = config_options(WarpMPMConfig)


def sweep(quick: bool) -> tuple[list[dict], dict]:
    """``gasp bench`` settings and reference: the grid-engine sweep of ``gasp_core.mpm.sweep.mpm_sweep``."""
    return mpm_sweep(quick, CAPABILITIES.precisions)


def _available() -> str | None:
    if importlib.util.find_spec("warp") is None:
        return f"the 'warp-lang' package is not installed: {install_hint('warp_mpm', distribution='gasp-warp-mpm')}"
    try:
        import warp  # noqa: F401  (imported only when availability is asked for)
    except Exception as e:  # broken install, missing native library
        return f"'warp' cannot be imported: {e}"
    return None


#: Known failures of the shared MLS-MPM algorithm (docs/mpm.md), measured figures in the reasons.
KNOWN_FAILURES = dict(MPM_KNOWN_FAILURES)


#: The engine's registration record (the ``gasp_engines`` hook, :func:`gasp_core.seam.plugins.engine_hook`).
gasp_engines = engine_hook(EngineInfo(
    name=ENGINE,
    factory="gasp_warp_mpm.engine:WarpMPMEngine",
    capabilities=CAPABILITIES,
    config=WarpMPMConfig,
    known_failures=KNOWN_FAILURES,
    sweep=sweep,
    check_scene=check_ground_in_grid,
    substeps=grid_substeps,
    available=_available,
    speed={"cpu": "jelly block of 46,656 points 3.8 M particle-substeps/s on one core (Warp's CPU kernels run "
                  "serially), 6.2 on the donut of 146,471 points (benchmarks/results/bench_engines.md)",
           "cuda": "not measured (Warp's wheel does not fit the lent GPU machine; docs/performance.md)"},
    description=("MLS-MPM (docs/mpm.md) in NVIDIA Warp; CUDA, or CPU on one core (Warp runs CPU kernels "
                 "serially, deterministic): on CPU use taichi_mpm, which uses every core (docs/performance.md); "
                 "viscosity implicit (no step limit); its CUDA speed is not measured yet"),
))
