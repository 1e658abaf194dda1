"""Opt-in helpers for grid (MPM) engines, from one place: ``from gasp_core.toolkit import ...``.

Nothing in the core needs them (:mod:`gasp_core.seam` and :mod:`gasp_core.run` never import this
package); a grid engine takes what fits, so that engines on the same scene agree on the substep,
the material table and the sweeps. The plugin contract itself is :mod:`gasp_core.seam`.

- :mod:`gasp_core.toolkit.mpm`: the substep rule (:func:`mpm_stable_dt`, :func:`mpm_substeps`,
  :func:`substeps_for`, :func:`substeps_from_options`), the common MPM options (:func:`mpm_options`,
  :func:`check_mpm_options`, :data:`PASSIVE_EVERY`, :func:`passive_schedule`), the per-body material
  table (:func:`material_table`, codes ``JELLY`` ... ``LIQUID``, columns ``P_MU`` ... ``P_K``),
  :func:`initial_Jp`, :func:`fixed_mask`, point ordering (:func:`cell_order`,
  :func:`material_first_order`), memory checks (:func:`estimate_bytes`, :func:`check_memory`),
  ``stats()`` helpers (:func:`engine_mass_stats`, :func:`stranded_passive`), blow-up causes
  (:data:`CAUSE_DT`, :data:`CAUSE_DOMAIN`) and the grid engines' :data:`KNOWN_FAILURES`;
- :mod:`gasp_core.toolkit.sweep`: ``gasp bench`` sweeps (:func:`mpm_sweep`, :func:`grid_sweep`,
  :func:`dedupe_settings`);
- :mod:`gasp_core.toolkit.grid_tables`: collider, force and impulse tables for grid kernels
  (:class:`GridTables`, :func:`grid_tables`, :func:`frame_table`). Note that the name ``grid_tables``
  here is the function; the module is ``sys.modules["gasp_core.toolkit.grid_tables"]``.

``from gasp_core.toolkit import mpm`` (the module, for ``mpm.material_table`` style calls) works too.
This package only re-exports; the core never imports it.
"""
from gasp_core.toolkit import mpm, sweep
from gasp_core.toolkit.grid_tables import GridTables, frame_table, grid_tables
from gasp_core.toolkit.mpm import (CAUSE_DOMAIN, CAUSE_DT, JELLY, KNOWN_FAILURES, LIQUID, MATERIAL_CODES,
                                   MAX_SUBSTEPS, METAL, MPM_OPTIONS, N_PARAMS, NEO_HOOKEAN, P_ALPHA,
                                   P_HARDENING, P_K, P_LAM, P_MU, P_SOFTENING, P_THETA_C, P_THETA_S,
                                   P_YIELD, PASSIVE_EVERY, PLASTICINE, SAND, SNOW, VON_MISES_RADIUS, cell_order,
                                   check_memory, check_mpm_options, engine_mass_stats, estimate_bytes,
                                   fixed_mask, ground_top_node, initial_Jp, material_first_order, material_table,
                                   mpm_options, mpm_stable_dt, mpm_substeps, p_wave_speed,
                                   passive_schedule, stranded_passive, substeps_for, substeps_from_options)
from gasp_core.toolkit.sweep import MPM_SWEEP, MPM_SWEEP_QUICK, dedupe_settings, grid_sweep, mpm_sweep

__all__ = [
    "mpm", "sweep",
    "GridTables", "frame_table", "grid_tables",
    "CAUSE_DOMAIN", "CAUSE_DT", "KNOWN_FAILURES", "MAX_SUBSTEPS", "MPM_OPTIONS", "PASSIVE_EVERY",
    "VON_MISES_RADIUS", "ground_top_node", "JELLY", "NEO_HOOKEAN", "METAL", "SAND", "SNOW", "PLASTICINE", "LIQUID", "MATERIAL_CODES",
    "N_PARAMS", "P_MU", "P_LAM", "P_YIELD", "P_SOFTENING", "P_HARDENING", "P_THETA_C", "P_THETA_S",
    "P_ALPHA", "P_K",
    "cell_order", "check_memory", "check_mpm_options", "engine_mass_stats", "estimate_bytes", "fixed_mask",
    "initial_Jp", "material_first_order", "material_table", "mpm_options", "mpm_stable_dt", "mpm_substeps",
    "p_wave_speed", "passive_schedule", "stranded_passive", "substeps_for", "substeps_from_options",
    "MPM_SWEEP", "MPM_SWEEP_QUICK", "dedupe_settings", "grid_sweep", "mpm_sweep",
]
