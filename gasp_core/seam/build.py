"""Building an engine: check what a setup needs against what the engine declares, then call its factory.

One place (:func:`build_engine`) for every caller, the pipeline, the conformance kit and the studies:
capabilities (:func:`check_supported`), options (:func:`gasp_core.seam.engine.check_options`), the
engine's declared limits (:func:`gasp_core.seam.limits.check_limits`), then the factory under the error
contract (:func:`gasp_core.seam.engine.call_engine`).
"""
from __future__ import annotations

from typing import Iterable, Mapping

from gasp_core.errors import GaspError, SceneError
from gasp_core.seam.engine import call_engine, EngineInfo, PointEngine, StatefulEngine
from gasp_core.seam.options import check_options
from gasp_core.seam.limits import check_limits, check_precision, precision_of
from gasp_core.seam.passive import build_with_fallback
from gasp_core.seam.plugins import engines as installed_engines
from gasp_core.seam.setup import SimSetup


def check_supported(info: EngineInfo, materials: Iterable[str] = (), boundaries: Iterable[str] = (),
                    features: Iterable[str] = (), others: Mapping[str, EngineInfo] | None = None) -> None:
    """The one capability check: refuse what the engine lacks, before any work.

    Parameters
    ----------
    info : EngineInfo
    materials, boundaries, features : iterable of str
        What the scene uses.
    others : mapping, optional
        Installed engines by name, to name those that have what is missing.

    Raises
    ------
    SceneError
        Naming the engine, what it lacks, and the installed engines that have it.
    """
    missing = info.capabilities.missing(materials, boundaries, features)
    if not missing:
        return
    kind, name = missing[0]
    attr = {"material": "materials", "boundary": "boundaries", "feature": "features"}[kind]
    if others is None:
        try:
            others = installed_engines()
        except GaspError:
            others = {}
    able = sorted(n for n, e in others.items() if name in getattr(e.capabilities, attr))
    raise SceneError(f"engine '{info.name}' does not support the {kind} '{name}' "
                     f"(it supports {attr}: {sorted(getattr(info.capabilities, attr)) or 'none'}); "
                     f"engines that do: {able or 'none installed'}")


def needs(materials: Iterable[str] = (), boundaries: Iterable = (), colliders: Iterable = (),
          forces: Iterable = (), impulses: Iterable = ()) -> dict[str, list[str]]:
    """The one rule of what a run asks of an engine: ``materials``, ``boundaries`` and ``features`` names.

    Applied to a parsed scene before any file is read (:func:`gasp_core.prepare.scene.scene_needs`)
    and to a :class:`SimSetup` (:func:`setup_needs`); both give the same names for the same scene.

    Parameters
    ----------
    materials : iterable of str or Material
        Material names of the simulated bodies (static objects take no part), or the
        :class:`~gasp_core.seam.setup.Material` s: one with ``viscosity > 0`` needs ``viscosity``.
    boundaries : iterable
        Anything with a ``kind`` (:class:`~gasp_core.seam.setup.Boundary`).
    colliders : iterable
        Anything with a ``moving`` flag (:class:`~gasp_core.colliders.model.Collider`,
        :class:`~gasp_core.scene.extras.ColliderSpec`): ``moving_colliders`` or ``static_colliders``.
    forces : iterable
        Anything with a ``kind``: ``"wind"`` needs ``wind``, any other ``attractors``.
    impulses : iterable
        Any impulse needs ``impulse``.

    Returns
    -------
    dict
        ``{"materials": [...], "boundaries": [...], "features": [...]}``, each without repeats, in
        first-use order (keys of :func:`check_supported`).
    """
    materials = list(materials)
    features = ["viscosity" for m in materials if getattr(m, "viscosity", 0.0) > 0]
    features += ["rigid_limit" for m in materials if getattr(m, "model", "auto") == "rigid"]
    features += ["moving_colliders" if c.moving else "static_colliders" for c in colliders]
    features += ["wind" if f.kind == "wind" else "attractors" for f in forces]
    if list(impulses):
        features.append("impulse")
    names = [m if isinstance(m, str) else m.name for m in materials]
    return {"materials": list(dict.fromkeys(names)), "boundaries": list(dict.fromkeys(b.kind for b in boundaries)),
            "features": list(dict.fromkeys(features))}


def setup_needs(setup: SimSetup) -> dict[str, list[str]]:
    """:func:`needs` of a setup (its materials, boundaries, colliders, forces and impulses; its Grady's cells:
    ``fracture_cells``)."""
    out = needs(setup.materials, setup.boundaries, setup.colliders, setup.forces, setup.impulses)
    if getattr(setup, "cells", None) is not None:
        out["features"].append("fracture_cells")
    return out


def _factory(info: EngineInfo, setup: SimSetup) -> PointEngine:
    """``info.factory(setup)``, and an engine that declares the feature ``state`` is a :class:`StatefulEngine`.

    Raises
    ------
    TypeError
        It declares ``state`` without ``get_state`` / ``set_state`` (an engine bug: wrapped as
        ``EngineBug`` by the caller).
    """
    engine = info.factory(setup)
    if "state" in info.capabilities.features and not isinstance(engine, StatefulEngine):
        engine.close()
        raise TypeError(f"engine '{info.name}' declares the feature 'state' but its {type(engine).__name__} "
                        f"has no get_state() and set_state()")
    return engine


def build_engine(info: EngineInfo, setup: SimSetup) -> PointEngine:
    """Check ``setup`` against the engine's capabilities, options and limits, then call its factory.

    Parameters
    ----------
    info : EngineInfo
    setup : SimSetup
        ``setup.options`` are checked and completed with the declared defaults (in place).

    Returns
    -------
    PointEngine

    Raises
    ------
    SceneError
        A material, boundary or feature the engine lacks; an unknown or invalid option; a value
        outside the engine's declared limits (:attr:`EngineInfo.limits`); a material value beyond
        the run's precision (:func:`gasp_core.seam.limits.check_precision`).
    EngineError
        The engine cannot run here.
    EngineBug
        The factory raised anything outside the error contract, or returned an engine without
        ``get_state`` / ``set_state`` although it declares the feature ``state``.
    """
    check_supported(info, **setup_needs(setup))
    setup.options = check_options(setup.options, info.options, info.name)
    check_limits(info.name, info.limits, setup)
    check_precision(info.name, precision_of(info.capabilities.precisions, setup.options), setup)
    if setup.passive is not None and "passive_points" not in info.capabilities.features:
        # the core moves the passive rows
        return build_with_fallback(info, setup, lambda i, s: call_engine(i, "build", _factory, i, s))
    return call_engine(info, "build", _factory, info, setup)
