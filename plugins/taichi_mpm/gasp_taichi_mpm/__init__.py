"""GASP engine plugin ``taichi_mpm``: the MLS-MPM solver of ``docs/mpm.md`` on Taichi.

Importing this module is cheap: it does not import Taichi. The factory imports
:mod:`gasp_taichi_mpm.engine` (and Taichi) when a simulation is built.

Taichi keeps one runtime per process and ``ti.init`` resets it, so **one taichi_mpm engine is
live per process at a time**: building a new engine invalidates the previous one (its methods
then raise :class:`gasp_core.seam.engine.EngineError`).
"""
from __future__ import annotations

import os

# Taichi prints a banner on stdout when imported; GASP's output (``gasp engines --json``) must stay
# clean, so the banner is off unless the user asked for it.
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "False")

import dataclasses
from dataclasses import dataclass

from gasp_core.seam import engine_hook, EngineInfo, option
from gasp_core.seam.config import config_options, from_option
from gasp_core.mpm.roll_contact import ROLL_CONTACT
from gasp_core.mpm.grid_engine import MPM_CAPABILITIES, grid_substeps
from gasp_core.mpm.options import MPMConfig
from gasp_core.mpm.sweep import mpm_sweep
from gasp_core.mpm.failures import MPM_KNOWN_FAILURES
from gasp_core.mpm.ground_check import check_ground_in_grid

__all__ = ["CAPABILITIES", "ENGINE", "OPTIONS", "TaichiMPMConfig", "gasp_engines", "sweep"]

ENGINE = "taichi_mpm"

#: The MLS-MPM record of the grid-engine base (``gasp_core.mpm.grid_engine``), with the rigid limit (issue 40).
CAPABILITIES = dataclasses.replace(MPM_CAPABILITIES, features=MPM_CAPABILITIES.features | {"rigid_limit", "sleep", "body_friction",
                                                                                      "fracture_cells"})

@dataclass(frozen=True)
class TaichiMPMConfig(MPMConfig):
    """The engine's settings (:class:`gasp_core.mpm.options.MPMConfig`: ``device`` "cpu", "cuda" or "auto", Taichi
    runs on the default CUDA device only), with ``threads``, ``schedule``, ``p2g`` and ``pin_threads``."""

    device: str = option("cpu", "where to run: 'cpu', 'cuda' (the default GPU) or 'auto': cuda where Taichi starts "
                         "a CUDA GPU (measured faster there: the README donut 6.2x an H100 machine's 16 CPU cores, "
                         "docs/performance.md), else cpu", kind="str", choices=("cpu", "cuda", "auto"))
    threads: int | None = option(None, "CPU threads (Taichi's cpu_max_num_threads; default: the cores this process "
                                 "may use); the coloured block P2G gives the same numbers on any count (the contact "
                                 "balance's impulse sums may differ in the last bits beyond 1)", kind="int", lo=1)
    schedule: str = option("auto", "how a substep's loops, scans and sums run (gasp_taichi_mpm.schedule): 'cpu' "
                           "ordered for the same bits on any thread count, 'gpu' every loop parallel (atomic P2G, "
                           "fixed-tree sums), 'auto' gpu on cuda and cpu on the CPU", kind="str",
                           choices=("auto", "cpu", "gpu"))
    p2g: str = option("auto", "the GPU schedule's P2G on CUDA: 'tiles' (each 4^3-node block's points summed in shared "
                      "memory, then one global add a node: gasp_taichi_mpm.schedule.tiles; not with wind), 'atomic' "
                      "(every point's 27 nodes added to the global grid), 'auto' tiles from 262,144 points (on an "
                      "H100 atomic was 3.5x faster on the 65k-point donut, tiles 2.3x faster on a 1M-point block); the "
                      "CPU never tiles", kind="str", choices=("auto", "atomic", "tiles"))
    tile_sort_every: int = option(1, "the tiled P2G sorts the points by block every this many substeps (and at each "
                                  "frame's first); between sorts a point that left its block is added atomically",
                                  kind="int", lo=1, hi=64)
    deterministic: bool = option(False, "the GPU schedule's P2G in 64-bit fixed point (integer atomics: the same "
                                 "grid on any run, thread count and device; gasp_taichi_mpm.schedule.fixed; never "
                                 "tiled); the CPU schedule repeats without it (threads = 1); not with wind, colliders, "
                                 "walls' particle contact, the contact chosen per body, two fields or rigid bodies",
                                 kind="bool")
    pin_threads: bool = option(True, "pin each CPU worker thread to its own core (Linux; 2 threads or more, no more "
                               "than the allowed cores): left to the scheduler, the workers often share one core "
                               "(docs/performance.md); the numbers are the same either way", kind="bool")
    roll_contact: bool = from_option(ROLL_CONTACT)


#: The options, one per field of :class:`TaichiMPMConfig`.
OPTIONS = config_options(TaichiMPMConfig)


def sweep(quick: bool) -> tuple[list[dict], dict]:
    """``gasp bench`` settings and reference: the grid-engine sweep of ``gasp_core.mpm.sweep.mpm_sweep``."""
    return mpm_sweep(quick, CAPABILITIES.precisions)


#: Known failures of the shared MLS-MPM algorithm (docs/mpm.md), measured figures in the reasons.
KNOWN_FAILURES = dict(MPM_KNOWN_FAILURES)


#: The engine's registration record (the ``gasp_engines`` hook, :func:`gasp_core.seam.plugins.engine_hook`).
gasp_engines = engine_hook(EngineInfo(
    name=ENGINE,
    factory="gasp_taichi_mpm.engine:TaichiMPMEngine",
    capabilities=CAPABILITIES,
    config=TaichiMPMConfig,
    deterministic_options={"threads": 1},
    known_failures=KNOWN_FAILURES,
    sweep=sweep,
    check_scene=check_ground_in_grid,
    substeps=grid_substeps,
    requires=("taichi",),
    speed={"cpu": "README donut 0.80 s a frame on 2 cores, 0.64 s on an H100 machine's 16 CPU threads "
                  "(docs/performance.md, 2026-11-26)",
           "cuda": "README donut 0.167 s a frame on an H100 (74 substeps), 0.117 s on an H200 (5.9x its host's 16 "
                   "CPU threads, round 39, 2026-11-28); jelly block 295 and 641 M particle-substeps/s at 1M and 16M "
                   "points (docs/performance.md 'On the GPU', round 29, 2026-11-26)"},
    install="gasp-taichi-mpm",
    description=("MLS-MPM with APIC transfers and quadratic B-splines (Hu et al. 2018), "
                 "docs/mpm.md, on Taichi (CPU or CUDA, f32 or f64). The CPU default: its coloured block "
                 "P2G uses every core and gives the same numbers on any thread count (docs/performance.md); "
                 "viscosity implicit (no step limit). On CUDA its GPU schedule runs the README donut at 0.167 s a "
                 "frame on an H100 (0.111 s at 69 substeps, 5.8x that machine's 16 CPU cores), a 16M-point block "
                 "at 641 M particle-substeps/s, and repeats bit for bit with deterministic = true "
                 "(docs/performance.md). One engine per process at a time (ti.init is global)."),
))
