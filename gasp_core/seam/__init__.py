"""The plugin contract: everything an engine, renderer or soup-writer plugin imports, from one place.

A plugin writes ``from gasp_core.seam import EngineInfo, Capabilities, Option, hookimpl, ...`` and
nothing else from the core (grid engines may add the opt-in helpers of :mod:`gasp_core.mpm`).
``docs/writing_an_engine.md`` walks through it; ``examples/engine_template`` is a working plugin.

What is here, by the module that defines it:

- the input, :mod:`gasp_core.seam.setup`: :class:`SimSetup` (world frame, metres, z up, SI units),
  :class:`Material`, :class:`Boundary`, and the capability names :data:`MATERIALS`, :data:`BOUNDARIES`;
- the declaration, :mod:`gasp_core.seam.engine`: :class:`EngineInfo` (the ``gasp_engines`` record),
  :class:`Capabilities`, :class:`Option`, the feature names :data:`FEATURES`; and
  :class:`~gasp_core.seam.limits.Limit` (:mod:`gasp_core.seam.limits`) for ranges narrower than the core's;
- the protocol an engine implements: :class:`PointEngine` (``step_frame``, ``positions``, ``velocities``,
  ``stats() -> EngineStats``, ``close``) and, with the feature ``state``, :class:`StatefulEngine`
  (``get_state``, ``set_state``) and, with the feature ``sleep``, :class:`SleepingEngine` (``set_asleep``, per-body
  sleep, :mod:`gasp_core.seam.body_sleep`); :class:`EngineStats` names the ``stats()`` keys the core reads
  (``mass`` in kg and ``centre_of_mass`` in metres among them); :func:`mass_properties` computes them;
- the hooks, :mod:`gasp_core.seam.plugins`: :data:`hookimpl`, and the records :class:`RendererInfo`
  (``gasp_renderers``) and :class:`SoupWriterInfo` (``gasp_soup_writers``);
- the error contract, :mod:`gasp_core.errors`: :class:`SceneError` (input the engine does not take),
  :class:`EngineError` (cannot run here), :class:`EngineDivergence` (a blow-up, with the frame and cause);
  anything else an engine raises becomes :class:`EngineBug`;
- driving an engine from a plugin's own tests: :func:`get_engine`, :func:`engines`, :func:`build_engine`
  (the core's capability, option and limit checks, then the factory), :func:`call_engine` (the error
  contract) and :func:`check_state` (the core's blow-up check on positions) with its two likely causes,
  :data:`CAUSE_UNSTABLE` and :data:`CAUSE_LEFT_DOMAIN` (an engine raising :class:`EngineDivergence` itself uses them),
  and :data:`CAUSE_ENERGY`, the runner's energy watchdog's (:mod:`gasp_core.seam.energy_watch`);
- :func:`install_hint` (:mod:`gasp_core.seam.install`): the one line that installs a plugin, which its
  "cannot run here" reason prints, as ``gasp engines`` and an unknown-engine error do.

This module only re-exports. The core's own modules never import it (they import each name from the
module that defines it), so that importing the contract cannot close an import loop.
"""
from gasp_core.errors import EngineBug, EngineDivergence, EngineError, GaspError, SceneError
from gasp_core.seam.build import build_engine
from gasp_core.seam.install import install_hint
from gasp_core.seam.engine import (call_engine, Capabilities, EngineInfo, EngineStats, FEATURES, PointEngine,
                                   SleepingEngine, StatefulEngine)
from gasp_core.seam.options import Option
from gasp_core.seam.config import Preset, from_option, option
from gasp_core.seam.limits import Limit
from gasp_core.seam.passive import mass_properties
from gasp_core.seam.plugins import RendererInfo, SoupWriterInfo, engine_hook, engines, get_engine, hookimpl
from gasp_core.seam.energy_watch import CAUSE_ENERGY
from gasp_core.seam.runner import CAUSE_LEFT_DOMAIN, CAUSE_UNSTABLE, check_state
from gasp_core.seam.setup import BOUNDARIES, MATERIALS, Boundary, Material, SimSetup

__all__ = [
    # input
    "SimSetup", "Material", "Boundary", "MATERIALS", "BOUNDARIES",
    # declaration
    "EngineInfo", "Capabilities", "Option", "Limit", "FEATURES", "option", "from_option", "Preset",
    # protocol
    "PointEngine", "StatefulEngine", "SleepingEngine", "EngineStats", "mass_properties",
    # hooks
    "engine_hook", "hookimpl", "RendererInfo", "SoupWriterInfo",
    # errors
    "GaspError", "SceneError", "EngineError", "EngineDivergence", "EngineBug",
    # driving an engine
    "get_engine", "engines", "install_hint", "build_engine", "call_engine", "check_state", "CAUSE_UNSTABLE", "CAUSE_LEFT_DOMAIN",
    "CAUSE_ENERGY",
]
