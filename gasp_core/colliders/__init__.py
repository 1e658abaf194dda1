"""Colliders, impulses and force fields as data every engine reads: :mod:`.model` (what they are) and
:mod:`.sdf` (signed distance fields from triangles, splats or a box). See ``docs/colliders.md``."""
