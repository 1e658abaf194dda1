"""Gaussian Splatting scenes in memory and on disk: :mod:`.gaussians` (the model), :mod:`.io` (graphdeco /
GaMeS / 2DGS PLY), :mod:`.compressed` (SuperSplat compressed PLY), :mod:`.splatv` (dynamic splaTV),
:mod:`.formats` (``.spz`` / ``.sog`` through gsply, the writers), :mod:`.splat` (``.splat``, ``.ksplat``),
:mod:`.sog` (the SOG writer), :mod:`.ply` (column checks shared by the readers) and :mod:`.describe` (``gasp info``)."""
