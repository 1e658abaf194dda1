"""From a scene to what an engine gets: :mod:`.placement` (world frame, flatten, ``T``), :mod:`.selection`
(what moves), :mod:`.checks` (the Gaussians of an object), :mod:`.colliders` (scene colliders),
:mod:`.assembly` (points, fill, domain: the ``SimSetup``) and :mod:`.scene` (engine chosen and checked)."""
