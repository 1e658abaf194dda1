"""``quality = "draft" | "default" | "reference"``: one scene key (and ``gasp simulate --quality``) for the trade.

Each level is a set of scene keys and engine options, measured on the README scenes
(``docs/speed_accuracy.md``, "Quality levels"). A level only fills in what the scene file leaves out:
a key the file sets (``[domain] n_grid``, an object's ``surface``, an engine option) always wins,
except ``n_grid``, which a level scales (``grid_factor``) from the file's value.

* ``draft``: passive surface points (``surface = "passive"``), on an elastic body its Gaussians' centres alone
  (``surface_points = "auto"``, :func:`gasp_core.prepare.surface.choose_surface_points`), 2 fill points per cell,
  the grid velocity gathered at them every 16th substep, ``cfl`` 0.8: no more points and no more time a frame than
  ``default`` on every example (issue 55: with three passive vertices per Gaussian it simulated 151,503 points on
  the README donut against ``default``'s 65,036; now 60,255; docs/speed_accuracy.md, "draft against default").
  Its accuracy figures below and in docs/speed_accuracy.md are of the vertex draft (particle contact, passive
  points held by the ground: docs/contact.md).
* ``default``: chosen by the rule of ``docs/speed_accuracy.md`` ("Choosing the default": the cheapest setting
  whose shape residual is within 1.5 U, whose events are in their bands and whose renders are as close to the
  reference's as its twin's). No cheaper model meets it on the elastic donut (passive points: 2.7x at 2.4 U,
  3.6 degrees of rotation), so: ``surface = "auto"`` (:mod:`gasp_core.prepare.surface`: passive on filled,
  dissipative bodies, the full model on elastic ones and shells), 4 fill points per cell, the grid velocity
  gathered at passive points every 8th substep (engine option ``passive_every`` where the engine has it),
  the Gaussians' centres alone on elastic bodies (``surface_points = "auto"``: PhysGaussian's layout where the
  trade picks it; on the README donut's 36 frames 0.76 U of shape, every event in its band, 2.04x less CPU with the
  step below, docs/speed_accuracy.md, "PhysGaussian's layout", measured 2026-11-23; re-measured in round 57 on the
  engines of 2026-11-30: 1.22 U, 1.89x, but its final rotation (1.27 deg, band 1) and renders (0.3 dB under the
  twin's) miss the rule, not through rounds 54 and 56's step and transfer rules, docs/speed_accuracy.md "Round 57:
  the levels under cfl_rule sum and transfer_damping rate"), ``cfl`` 0.8 (the engines' own default is 0.4): on the README donut the longer step moves the full model by
  0.05 U of shape and costs 0.66x the CPU time (94 substeps a frame instead of 121, the contact's stable step
  binding first; docs/speed_accuracy.md, "The time step").
* ``reference``: the full model (every triangle vertex simulated as material, no hierarchy, 8 fill
  points per cell) on a grid 1.5 times finer, ``cfl`` 0.2: the run the others are measured against.

The scene keys of each level are here (:data:`PRESETS`); its engine options (``cfl``, ``passive_every``) are the
engine's to declare (``EngineInfo.presets``, :mod:`gasp_core.seam.config`; the MLS-MPM engines' are
``gasp_core.mpm.options.MPM_PRESETS``), and :func:`engine_options` gives an engine only what it declares.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from gasp_core.scene.tables import DomainSpec
from gasp_core.scene.values import N_GRID_RANGE, as_string

#: the levels, cheapest first
QUALITY_LEVELS = ("draft", "default", "reference")
#: The level of a scene that sets none (``Scene.quality``'s default).
DEFAULT_QUALITY = "default"

#: The level ``gasp studio`` runs (issue 32: the first simulated frame on screen within a minute of the click on
#: run, on a 2-core CPU, for an object of the donut's size), chosen by ``benchmarks/bench_studio_level.py``: the
#: cheapest level answers with margin, and kernel compiles dominate a cold start, so no cheaper level is added.
#: The figures per engine, and what ``draft`` costs in accuracy: docs/speed_accuracy.md, "The studio's level".
STUDIO_LEVEL = "draft"


def studio_engine_rank(info) -> tuple:
    """Sort key of the engines ``gasp studio`` offers, best first: those declaring a measured preset for
    :data:`STUDIO_LEVEL` (``EngineInfo.presets``: the engines the levels were measured on, ``docs/speed_accuracy.md``),
    then those whose CPU
    runs repeat bit for bit with their default options (``"cpu"`` in ``capabilities.deterministic`` and no
    ``deterministic_options``: the studio's saved scene then reproduces its run without an extra key), then by
    name (a tie-break, not a measurement). Which engine that is on the studio's donut, and how fast it answers:
    docs/studio.md, "Time to the first frame"."""
    preset = info.presets.get(STUDIO_LEVEL)
    repeats = "cpu" in info.capabilities.deterministic and not info.deterministic_options
    return (not (preset is not None and preset.measured), not repeats, info.name)


def studio_engine(infos) -> str | None:
    """The engine ``gasp studio`` runs by default of ``infos`` (EngineInfo records of the installed engines that can
    run the scene): the first by :func:`studio_engine_rank`; None when ``infos`` is empty."""
    ranked = sorted(infos, key=studio_engine_rank)
    return ranked[0].name if ranked else None


@dataclass(frozen=True)
class QualityPreset:
    """What a level sets among the scene keys where the scene file is silent (its engine options are the engine's to
    declare: ``EngineInfo.presets``, :func:`engine_options`).

    Attributes
    ----------
    objects : dict
        ``[[object]]`` keys (``surface``, ``core_fraction``).
    domain : dict
        ``[domain]`` keys (``particles_per_cell``).
    grid_factor : float
        The scene's ``n_grid`` is multiplied by this (rounded, at least 8).
    """

    objects: dict[str, Any] = field(default_factory=dict)
    domain: dict[str, Any] = field(default_factory=dict)
    grid_factor: float = 1.0


#: A level's object keys that a static object does not take (the scene reader refuses them beside ``static``).
STATIC_SKIPS = ("surface_points",)

PRESETS: dict[str, QualityPreset] = {
    "draft": QualityPreset({"surface": "passive", "surface_points": "auto"}, {"particles_per_cell": 2}, 1.0),
    "default": QualityPreset({"surface": "auto", "surface_points": "auto"}, {"particles_per_cell": 4}, 1.0),
    "reference": QualityPreset({"surface": "material", "core_fraction": 1.0}, {"particles_per_cell": 8}, 1.5),
}


def read_quality(data: dict, src: Path, override: str | None = None) -> str:
    """The scene's level: ``override`` (``--quality``) if given, else the top-level ``quality``, else ``"default"``.

    Raises
    ------
    SceneError
        Not one of :data:`QUALITY_LEVELS` (the message names the key and the levels).
    """
    if override is not None:
        return as_string(override, "--quality", src, QUALITY_LEVELS)
    return as_string(data.get("quality", DEFAULT_QUALITY), "quality", src, QUALITY_LEVELS)


def apply_quality(data: dict, level: str) -> dict:
    """``data`` (a parsed scene TOML document) with ``level``'s keys filled in where it has none.

    Returns a new document; ``data`` is not changed. Engine options are not added here (they
    depend on the engine: :func:`engine_options`). A malformed table is left as it is, for the
    reader to report.
    """
    preset = PRESETS[level]
    out = dict(data)
    dom = out.get("domain", {})
    if isinstance(dom, dict):
        dom = {**{k: v for k, v in preset.domain.items() if k not in dom}, **dom}
        n = dom.get("n_grid", DomainSpec.n_grid)
        if preset.grid_factor != 1.0 and isinstance(n, int) and not isinstance(n, bool):
            dom["n_grid"] = max(N_GRID_RANGE[0], int(math.floor(n * preset.grid_factor + 0.5)))
        out["domain"] = dom
    objs = out.get("object")
    if isinstance(objs, list):
        out["object"] = [{**{k: v for k, v in preset.objects.items() if not (o.get("static") is True and k in
                                                                              STATIC_SKIPS)}, **o}
                         if isinstance(o, dict) else o for o in objs]
    return out


def engine_options(level: str, given: dict[str, Any], presets: Mapping[str, Any]) -> dict[str, Any]:
    """Engine options of ``level`` under the ``given`` ones.

    Parameters
    ----------
    level : str
        One of :data:`QUALITY_LEVELS`.
    given : dict
        The scene's ``[engine] options``.
    presets : mapping
        The engine's ``EngineInfo.presets`` (``{level: Preset}``, each with ``options``): what the engine declares
        each level sets among its own options.

    Returns
    -------
    dict
        ``given`` with the level's preset options added where the scene does not set them.
    """
    preset = presets.get(level)
    extra = {} if preset is None else {k: v for k, v in preset.options.items() if k not in given}
    return {**given, **extra}
