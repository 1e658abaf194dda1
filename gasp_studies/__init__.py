"""GASP studies: one scene on several engines or settings, measured against a reference.

Not part of the core: ``pip install -e ".[studies]"`` adds it (Dask and matplotlib). Parts:

* :mod:`gasp_studies.run`: fan runs out on Dask (a ``LocalCluster`` of one-thread worker
  processes by default, or an existing cluster); every run gets a fresh worker process
  (engine runtimes may be process-global: one per process) and a wall-clock limit;
* :mod:`gasp_studies.measure`: divergence between runs (distances, Chamfer, errors against a
  reference, Pareto front);
* :mod:`gasp_studies.report`: tables, CSV, Markdown, plots;
* :mod:`gasp_studies.accuracy`, :mod:`gasp_studies.images`, :mod:`gasp_studies.trade`: the error of a run
  against a reference split into centroid, rotation (Kabsch), shape, events and rendered images (PSNR,
  SSIM), each in units of the reference's own uncertainty U, and the rule that picks the ``default``
  quality level from it (:mod:`gasp_studies.bench_rank`: ``gasp bench``'s ranking in these terms).

:mod:`gasp_studies.compare` (``gasp compare``) and :mod:`gasp_studies.bench` (``gasp bench``)
put them together. Nothing here names an engine: an engine's sweep of settings comes from its
own :attr:`gasp_core.seam.engine.EngineInfo.sweep`.
"""
