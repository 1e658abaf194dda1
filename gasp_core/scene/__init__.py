"""The TOML scene format: :mod:`.spec` (objects and the scene), :mod:`.tables` (engine, domain, boundaries,
materials), :mod:`.extras` (colliders, forces, impulses), :mod:`.select` (``select``/``static``) and
:mod:`.values` (the checked readers every value goes through)."""
