"""Every conformance scene, in the order they run: :data:`SCENES` and :func:`scene_by_name`."""
from __future__ import annotations

from ..errors import SceneError
from .kit import Scene
from .scenes_basic import SCENES_BASIC
from .scenes_colliders import SCENES_COLLIDERS
from .scenes_contract import SCENES_CONTRACT
from .scenes_mass import SCENES_MASS
from .scenes_materials import SCENES_MATERIALS
from .scenes_passive import SCENES_PASSIVE
from .scenes_wind import SCENES_WIND

#: All scenes: physics with known answers first, then the error contract.
SCENES: list[Scene] = [*SCENES_BASIC, *SCENES_MATERIALS, *SCENES_COLLIDERS, *SCENES_WIND, *SCENES_PASSIVE, *SCENES_MASS, *SCENES_CONTRACT]


def scene_by_name(name: str) -> Scene:
    """The scene of :data:`SCENES` called ``name``.

    Raises
    ------
    SceneError
        Naming the known scenes.
    """
    for s in SCENES:
        if s.name == name:
            return s
    raise SceneError(f"unknown conformance scene '{name}'; known: {[s.name for s in SCENES]}")
