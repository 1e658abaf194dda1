"""Every conformance scene, in the order they run (:data:`SCENES`, :func:`scene_by_name`), and running them
(:func:`select_scenes`, :func:`check_engine`)."""
from __future__ import annotations

from typing import Iterable, Mapping

from gasp_core.errors import SceneError
from gasp_core.seam.engine import EngineInfo
from gasp_core.testing.kit import EngineReport, evaluate_scene, resolve_engine, Scene
from gasp_core.testing.scenes_basic import SCENES_BASIC
from gasp_core.testing.scenes_colliders import SCENES_COLLIDERS
from gasp_core.testing.scenes_contract import contract_scenes
from gasp_core.testing.scenes_wind import SCENES_WIND
from gasp_core.testing.scenes_passive import SCENES_PASSIVE
from gasp_core.testing.scenes_analytic import SCENES_ANALYTIC
from gasp_core.testing.scenes_damping import SCENES_DAMPING
from gasp_core.testing.scenes_rest import SCENES_REST
from gasp_core.testing.scenes_sleep import SCENES_SLEEP
from gasp_core.testing.scenes_contact import SCENES_CONTACT
from gasp_core.testing.scenes_support import SCENES_SUPPORT
from gasp_core.testing.scenes_walls import SCENES_WALLS
from gasp_core.testing.scenes_freefall import SCENES_FREEFALL
from gasp_core.testing.scenes_mass import SCENES_MASS
from gasp_core.testing.scenes_materials import SCENES_MATERIALS
from gasp_core.testing.scenes_granular import SCENES_GRANULAR
from gasp_core.testing.scenes_pairs import SCENES_PAIRS
from gasp_core.testing.scenes_flow_pairs import SCENES_FLOW_PAIRS
from gasp_core.testing.scenes_fracture import SCENES_FRACTURE

#: All scenes: physics with known answers first, then the error contract.
SCENES: list[Scene] = [*SCENES_FREEFALL, *SCENES_BASIC, *SCENES_MATERIALS, *SCENES_GRANULAR, *SCENES_COLLIDERS, *SCENES_REST, *SCENES_CONTACT, *SCENES_PAIRS, *SCENES_FLOW_PAIRS, *SCENES_SUPPORT, *SCENES_WALLS, *SCENES_ANALYTIC, *SCENES_DAMPING, *SCENES_PASSIVE, *SCENES_WIND, *SCENES_MASS,
                     *SCENES_SLEEP, *SCENES_FRACTURE]
SCENES += contract_scenes(lambda: {s.name for s in SCENES})


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


def select_scenes(scenes: Iterable[Scene | str] | None = None, include_slow: bool = False) -> list[Scene]:
    """Scenes by name or object; default every scene of :data:`gasp_core.testing.SCENES` (no slow ones
    unless ``include_slow``).

    Raises
    ------
    SceneError
        An unknown scene name (the message lists the known ones).
    """
    if scenes is None:
        return [s for s in SCENES if include_slow or not s.slow]
    return [scene_by_name(s) if isinstance(s, str) else s for s in scenes]


def check_engine(engine: str | EngineInfo, scenes: Iterable[Scene | str] | None = None,
                 include_slow: bool = False, known_failures: Mapping[str, str] | None = None) -> EngineReport:
    """Run every applicable conformance scene on one engine, outside pytest.

    Parameters
    ----------
    engine : str or EngineInfo
        An installed engine's name, or a registration record (a plugin under development passes its own).
    scenes : iterable of Scene or str, optional
        Default: all of :data:`gasp_core.testing.SCENES` (without slow ones unless ``include_slow``).
    include_slow : bool
    known_failures : mapping, optional
        ``{scene_name: reason}``; default the engine's own ``EngineInfo.known_failures``.

    Returns
    -------
    EngineReport
        One :class:`SceneResult` per scene: pass / fail / skip (with the missing capability) /
        xfail / xpass / error, each with its messages and measured figures.

    Raises
    ------
    EngineError
        If ``engine`` is a name that is not installed.
    SceneError
        An unknown scene name.
    """
    info = resolve_engine(engine)
    chosen = select_scenes(scenes, include_slow)
    return EngineReport(info.name, [evaluate_scene(info, s, known_failures) for s in chosen])


class ScreenPasses(dict):
    """Which of the screen scenes ``screen`` (names, tuple of str) the engine ``info`` (an ``EngineInfo``) passes, as a
    set whose members are evaluated lazily: ``name in passes`` runs :func:`evaluate_scene` on that scene once (its
    status ``"pass"``) and caches it; ``other & passes`` and ``iter(passes)`` give the passed names, in the screen's
    order for the iteration (which evaluates every scene of the screen). Used by the broken-engine checks
    (``conformance_tests/test_checks_catch_broken.py``) so that the default tier runs only the scenes its own tests
    ask for. ``evaluate`` (``(info, scene) -> SceneResult``; default ``evaluate_scene(info, scene, {})``) runs a scene:
    the checks pass the pytest plugin's ``evaluate_once``, which shares the run with the conformance test of the same
    engine and scene. Raises what :func:`scene_by_name` raises for an unknown name (``SceneError``)."""

    def __init__(self, info: EngineInfo, screen: tuple[str, ...], evaluate=None):
        super().__init__()
        self.info, self.screen = info, tuple(screen)
        self.evaluate = evaluate or (lambda info, scene: evaluate_scene(info, scene, {}))

    def __missing__(self, name: str) -> bool:
        self[name] = self.evaluate(self.info, scene_by_name(name)).status == "pass"
        return self[name]

    def __contains__(self, name) -> bool:
        return self[name]

    def __rand__(self, other) -> set:
        return {s for s in other if s in self}

    def __iter__(self):
        return iter([s for s in self.screen if s in self])
