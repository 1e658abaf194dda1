"""The solids that share one grid velocity field, named (issue 67 item 4, ``docs/contact.md`` "Round 34: the solids
that share one field are named", "Round 61: a field per body by colouring"): :func:`shared_field_bodies`, the engines'
warning at build (:func:`shared_field_warning`) and the record in an engine's stats (``run.json`` ``engine_stats``
``field_colouring``, :func:`fields_record`)."""
from __future__ import annotations

import numpy as np

from gasp_core.mpm.colouring import colour_scene, coloured
from gasp_core.mpm.contact import FLOWING
from gasp_core.mpm.fields import field_bodies


def shared_field_bodies(setup) -> list[int]:
    """The bodies (indices of ``setup.materials``, the scene's objects in order) that do not flow and share one grid
    velocity field with another such body: where they touch they move as one (no slip, no Coulomb law, no separation
    within a cell), as in any single-field MPM. Empty where every solid has a field of its own
    (``fields.field_bodies``: two bodies on the particle contact, flowing bodies against one other body, or, round
    61, soft bodies coloured with no two of a field within reach) or the option ``contact_fields`` is false (the
    scene asked for one field). Coloured scenes name the bodies of the pairs the colouring could not separate (odd
    cycles, :func:`colour`); three or more solids with a rigid one, or two beside a flowing body, share one."""
    if not setup.options.get("contact_fields", True):
        return []
    if coloured(setup):
        return sorted({b for pair in colour_scene(setup)[1] for b in pair})
    in_a = field_bodies(setup)
    solids = [i for i, m in enumerate(setup.materials) if m.name not in FLOWING and (in_a is None or not in_a[i])]
    return solids if len(solids) >= 2 else []


def shared_field_warning(setup, engine: str) -> None:
    """Warn (``UserWarning``) when :func:`shared_field_bodies` is not empty, naming the bodies and what to do."""
    shared = shared_field_bodies(setup)
    if shared:
        import warnings
        names = ", ".join(f"{i} ({setup.materials[i].name})" for i in shared[:6])
        names += f" and {len(shared) - 6} more" if len(shared) > 6 else ""
        why = ("they touch each other in an odd cycle (three bodies mutually within reach), which two fields cannot "
               "separate" if coloured(setup) else "the two-field contact takes two bodies, flowing bodies against one "
               "other, or three or more solids with none flowing")
        warnings.warn(f"engine '{engine}': bodies {names} share one grid velocity field: where they touch they move "
                      f"as one, with no slip and no friction law between them ({why}; docs/contact.md); make the "
                      f"ones that only support the others [[collider]] meshes, or simulate them apart", stacklevel=2)


def fields_record(setup, names=None) -> dict | None:
    """An engine's stats' ``field_colouring`` (``run.json`` ``engine_stats``; round 61): where :func:`coloured`,
    ``{"coloured": True, "field_a": [bodies in field A], "shared_pairs": [[i, j], ...] (odd cycles,
    ``colouring.colour``), "shared_bodies": [names or indices]}``;
    elsewhere where :func:`shared_field_bodies` names bodies, ``{"coloured": False, "shared_bodies": [...]}``; None
    otherwise (the record is absent)."""
    def name(i):
        return names[i] if names is not None and i < len(names) else int(i)
    shared = shared_field_bodies(setup)
    if coloured(setup):
        in_a, pairs, _ = colour_scene(setup)
        return {"coloured": True, "field_a": [name(i) for i in np.flatnonzero(in_a)],
                "shared_pairs": [[name(i), name(j)] for i, j in pairs], "shared_bodies": [name(i) for i in shared]}
    return {"coloured": False, "shared_bodies": [name(i) for i in shared]} if shared else None
