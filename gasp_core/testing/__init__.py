"""The GASP engine conformance kit, installed with the core so an engine developed anywhere runs it.

- :func:`check_engine` runs every scene an engine has the capabilities for, outside pytest;
  ``gasp conform ENGINE`` does the same from the command line.
- :mod:`gasp_core.testing.pytest_plugin` (loaded automatically through the ``pytest11`` entry point)
  gives :func:`parametrize_conformance` / :func:`assert_conformance` and the result table.
- Scenes: :data:`SCENES` (physics with known answers in :mod:`.scenes_freefall`, :mod:`.scenes_basic` and
  :mod:`.scenes_materials`, the error contract in :mod:`.scenes_contract`).

See ``docs/writing_an_engine.md``.
"""
from __future__ import annotations

from gasp_core.testing.helpers import GRAVITY, Check, box_points, check, make_setup, sphere_points, wall_margin
from gasp_core.testing.kit import (EngineReport, evaluate_scene, record, Requires, resolve_engine, run_trace, Scene,
                                   SceneResult, Trace)
from gasp_core.testing.scenes import check_engine, SCENES, scene_by_name, select_scenes

__all__ = ["GRAVITY", "Check", "EngineReport", "Requires", "SCENES", "Scene", "SceneResult", "Trace",
           "assert_conformance", "box_points", "check", "check_engine", "conformance_params", "evaluate_scene",
           "make_setup", "parametrize_conformance", "record", "resolve_engine", "run_trace", "scene_by_name",
           "select_scenes", "sphere_points", "wall_margin"]


def __getattr__(name):  # the pytest helpers import pytest: only when asked for
    if name in ("assert_conformance", "conformance_params", "parametrize_conformance"):
        from gasp_core.testing import pytest_plugin
        return getattr(pytest_plugin, name)
    raise AttributeError(f"module 'gasp_core.testing' has no attribute {name!r}")
