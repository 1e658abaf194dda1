"""The MPM engines' shared half (issue 65 renamed it from ``toolkit``): what every grid engine of GASP shares, and
nothing the seam needs.

Engines opt in by importing it; :mod:`gasp_core.seam` and :mod:`gasp_core.run` never do. So that with
the same scene every MPM engine starts from the same numbers, it holds:

- :mod:`~gasp_core.mpm.options`: the declared options of a grid engine (``mpm_options``,
  ``MPM_OPTIONS``; ``dt`` excludes ``n_substeps`` as declared data, checked by the core);
- :mod:`~gasp_core.mpm.substeps`: the stable time step and substeps (``mpm_stable_dt``,
  ``mpm_substeps``, ``substeps_from_options``; ``docs/mpm.md``, "Time step") and the passive points'
  schedule (``passive_schedule``);
- :mod:`~gasp_core.mpm.materials`: the material codes and the per-body parameter table the
  kernels read (``MaterialKind``, ``Param``, ``MATERIAL_CODES``, ``P_*`` columns, ``material_table``) and
  the initial ``Jp``;
- :mod:`~gasp_core.mpm.points`: the points held by ``fixed_region`` boundaries (``fixed_mask``),
  the order of points by grid cell (``cell_order``, ``material_first_order``), mass statistics and
  stranded passive points;
- :mod:`~gasp_core.mpm.ground_check`: the engines' ``check_scene`` (an explicit domain holds the contact's
  ground layers); the memory estimate lives in :mod:`gasp_core.seam.memory` (the core's assembly checks it too);
- :mod:`~gasp_core.mpm.failures`: the known conformance failures of the shared algorithm;
- :mod:`~gasp_core.mpm.grid_tables`: colliders, forces and impulses packed for the kernels, with the named
  columns both MPM plugins index them by (``CM_*``, ``FR_*``, ``MD_*``, ``IM_*``, ``FT_*``, ``PO_*``);
- :mod:`~gasp_core.mpm.sweep`: the ``gasp bench`` sweep of a grid engine (``mpm_sweep``, ``grid_sweep``).
- :mod:`~gasp_core.mpm.grid_engine`: what a grid engine does outside its kernels (``GridEngineBase``:
  point order, ``get_state`` / ``set_state``, statistics; ``choose_dt``; ``MPM_CAPABILITIES``).
"""
