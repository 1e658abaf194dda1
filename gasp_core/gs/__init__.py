"""Gaussian Splatting scenes in memory and on disk: :mod:`.gaussians` (the model), :mod:`.registry` (one record per
file format: sniff, reader, writer, what it keeps and loses; every reader and writer is reached through it),
:mod:`.io` (graphdeco / GaMeS / 2DGS PLY), :mod:`.compressed` (SuperSplat compressed PLY), :mod:`.splatv` (dynamic
splaTV), :mod:`.formats` (``.spz`` / ``.sog`` through gsply, their writers), :mod:`.splat` (``.splat``, ``.ksplat``),
:mod:`.sog` (the SOG writer), :mod:`.gltf` (GLB with ``KHR_gaussian_splatting``), :mod:`.ply` (column checks shared
by the readers) and :mod:`.describe` (``gasp info``)."""
