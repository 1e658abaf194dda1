"""The engine seam: how the core finds, checks, builds and drives an engine.

An engine is a black box that moves points (GASP paper Sec. 3, ``V_t = phi(V, t)``). A plugin
registers :class:`EngineInfo` records (``gasp_engines`` hook, :mod:`gasp_core.seam.plugins`): a name,
a ``factory``, :class:`Capabilities` and declared :class:`Option` s. The core builds a
:class:`~gasp_core.seam.setup.SimSetup`, checks it against the capabilities and options
(:func:`check_supported`, one place), builds the engine with :func:`build_engine`, then calls
:meth:`PointEngine.step_frame` once per frame and reads :meth:`PointEngine.positions`.
Nothing here imports an engine package, and nothing here is specific to one kind of engine.

The error contract (:mod:`gasp_core.errors`): unsupported input raises ``SceneError``, an engine
that cannot run here ``EngineError``, a blow-up ``EngineDivergence``; anything else an engine
raises is wrapped as ``EngineBug``. The conformance kit (:mod:`gasp_core.testing`) checks it.
"""
from __future__ import annotations

import math
import os
import re
import tempfile
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping, Protocol, runtime_checkable

import numpy as np

from gasp_core.errors import EngineBug, GaspError, SceneError
from gasp_core.seam.setup import SimSetup



#: Feature names an engine may declare in :attr:`Capabilities.features` (beyond materials and boundaries).
FEATURES = {
    "initial_C": "starts from SimSetup.C, the initial velocity gradient (APIC's affine matrix); "
                 "engines without it ignore C and start from v alone",
    "state": "get_state() -> dict of arrays and set_state(dict) save and restore the whole simulation "
             "state after a frame (gasp simulate --resume); set_state right after the factory",
    "passive_points": "moves the passive rows of SimSetup (SimSetup.passive: rendered points with p_vol = 0) "
                      "itself, carried by the material's motion with no mass, stress or F (a grid engine: "
                      "G2P only); for engines without it the core embeds them in the material points' "
                      "motion (gasp_core.seam.passive)",
    "grid": "simulates on a background grid of SimSetup.n_grid cells; points within a few dx of "
            "a wall are inside the grid's transfer stencil",
    "static_colliders": "SimSetup.colliders without motion: rigid obstacles as signed distance fields "
                        "(gasp_core.colliders.model.Collider), Coulomb friction",
    "moving_colliders": "SimSetup.colliders with a prescribed rigid motion (Collider.pose(t)); "
                        "contact uses the velocity relative to the collider",
    "impulse": "SimSetup.impulses: a velocity change (or imposed velocity) inside a box or sphere over [t0, t1]",
    "wind": "SimSetup.forces of kind 'wind': a uniform acceleration plus divergence-free turbulence",
    "attractors": "SimSetup.forces of kind 'attractor': acceleration towards a point with a falloff",
}


@dataclass(frozen=True)
class Capabilities:
    """What an engine can do, as data (names from :data:`MATERIALS`, :data:`BOUNDARIES`, :data:`FEATURES`).

    Attributes
    ----------
    materials, boundaries : frozenset of str
    devices : frozenset of str
        e.g. ``{"cpu", "cuda"}``.
    precisions : frozenset of str
        ``{"f32"}``, ``{"f32", "f64"}``.
    deterministic : frozenset of str
        Devices on which a run repeats bit for bit; the option that makes it so (e.g. one thread) is
        named by :attr:`EngineInfo.deterministic_options`.
    features : frozenset of str
        Further abilities (keys of :data:`FEATURES`): a scene that needs one is refused up front by
        an engine without it.
    """

    materials: frozenset[str]
    boundaries: frozenset[str]
    devices: frozenset[str] = frozenset({"cpu"})
    precisions: frozenset[str] = frozenset({"f32"})
    deterministic: frozenset[str] = frozenset()
    features: frozenset[str] = frozenset()

    def as_dict(self) -> dict[str, Any]:
        return {k: sorted(getattr(self, k)) for k in
                ("materials", "boundaries", "devices", "precisions", "deterministic", "features")}

    def missing(self, materials: Iterable[str] = (), boundaries: Iterable[str] = (),
                features: Iterable[str] = ()) -> list[tuple[str, str]]:
        """``(kind, name)`` of every requested material, boundary or feature this engine lacks."""
        out = []
        for kind, names, have in (("material", materials, self.materials),
                                  ("boundary", boundaries, self.boundaries),
                                  ("feature", features, self.features)):
            out += [(kind, n) for n in dict.fromkeys(names) if n not in have]
        return out


_KINDS = {"int": "an integer", "number": "a number", "str": "a string", "bool": "true or false"}


@dataclass(frozen=True)
class Option:
    """One engine option, declared as data (``gasp engines`` lists them; the core checks them).

    Attributes
    ----------
    name : str
        Key in the scene's ``[engine] options`` table.
    default : Any
        Value when the scene does not give one. ``None`` means "the engine decides" and is
        always accepted.
    doc : str
        Meaning and unit, one line.
    kind : str
        ``"int"``, ``"number"`` (int or float, finite), ``"str"`` or ``"bool"``.
    choices : tuple, optional
        Allowed values (``kind="str"``).
    lo, hi : float, optional
        Inclusive bounds (``kind`` int or number); ``lo_open`` makes ``lo`` exclusive.
    pattern : str, optional
        A regular expression a string value must match in full (e.g. ``cuda(:\\d+)?``); used
        instead of ``choices``.
    excludes : tuple of str
        Options that may not be given together with this one (both not None), e.g. ``dt`` excludes
        ``n_substeps``: a rule across options, declared as data and checked by :func:`check_options`.
    """

    name: str
    default: Any
    doc: str
    kind: str = "number"
    choices: tuple | None = None
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    pattern: str | None = None
    excludes: tuple[str, ...] = ()

    def expected(self) -> str:
        """What a valid value is, in words."""
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        text = _KINDS[self.kind]
        if self.pattern is not None:
            text += f" matching {self.pattern!r}"
        if self.lo is not None and self.hi is not None:
            text += f" in {'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}]"
        elif self.lo is not None:
            text += f" {'>' if self.lo_open else '>='} {self.lo:g}"
        elif self.hi is not None:
            text += f" <= {self.hi:g}"
        return text

    def valid(self, value: Any) -> bool:
        """True when ``value`` is acceptable (``None`` always is)."""
        if value is None:
            return True
        if self.kind == "bool":
            return isinstance(value, bool)
        if self.kind == "str":
            if not isinstance(value, str):
                return False
            if self.pattern is not None:
                return re.fullmatch(self.pattern, value) is not None
            return self.choices is None or value in self.choices
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            return False
        if self.kind == "int" and not isinstance(value, (int, np.integer)):
            return False
        if not math.isfinite(value):
            return False
        if self.choices is not None and value not in self.choices:
            return False
        if self.lo is not None and (value <= self.lo if self.lo_open else value < self.lo):
            return False
        return self.hi is None or value <= self.hi


def check_options(options: Mapping[str, Any], declared: Iterable[Option], engine: str) -> dict[str, Any]:
    """Every declared option's value: the scene's where given, else the default.

    Parameters
    ----------
    options : mapping
        The scene's ``[engine] options``.
    declared : iterable of Option
        :attr:`EngineInfo.options`.
    engine : str
        Engine name, for messages.

    Returns
    -------
    dict
        ``{name: value}`` for every declared option.

    Raises
    ------
    SceneError
        An unknown option (the message lists the declared ones), a value of the wrong type or
        out of range (the message names the option, the value and what is expected), or two options
        given together that one of them excludes (:attr:`Option.excludes`).

    Notes
    -----
    The only check of engine options: :func:`gasp_core.seam.build.build_engine` calls it before the
    factory, and an engine reads ``setup.options`` (every declared option present) without checking
    them again. It is idempotent: completed options pass unchanged.
    """
    by_name = {o.name: o for o in declared}
    if not isinstance(options, Mapping):
        raise SceneError(f"engine '{engine}': options must be a table like {{ name = value }}, "
                         f"got {options!r}")
    unknown = sorted(set(options) - set(by_name))
    if unknown:
        raise SceneError(f"engine '{engine}': unknown option(s) {unknown}; allowed: {sorted(by_name)}")
    merged = {name: o.default for name, o in by_name.items()}
    for name, value in options.items():
        if not by_name[name].valid(value):
            raise SceneError(f"engine '{engine}': option {name}={value!r}; expected {by_name[name].expected()}")
        merged[name] = value
    for name, o in by_name.items():
        for other in o.excludes:
            if merged[name] is not None and merged.get(other) is not None:
                raise SceneError(f"engine '{engine}': give option {name} or option {other}, not both")
    return merged


@runtime_checkable
class PointEngine(Protocol):
    """A running simulation. Built by ``EngineInfo.factory(setup)``.

    Methods
    -------
    step_frame()
        Advance by ``setup.frame_dt`` seconds (the engine picks its substeps).
        Raises :class:`EngineDivergence` if it detects a blow-up itself.
    positions() -> ndarray, shape (n, 3), float32 or float64
        Current point positions, metres, in the order of ``setup.x``.
    velocities() -> ndarray, shape (n, 3)
        Current point velocities, m/s.
    stats() -> dict
        At least ``device``, ``precision``, ``n_points``; grid engines add ``dt``, ``n_substeps``
        (per frame), ``n_grid``.
    close()
        Free engine resources.
    get_state() -> dict of ndarray, set_state(state)
        Only engines with the feature ``state``: everything needed to continue after the current
        frame bit for bit (``gasp simulate --resume``). ``set_state`` is called right after the
        factory, before any ``step_frame``.
    """

    def step_frame(self) -> None: ...

    def positions(self) -> np.ndarray: ...

    def velocities(self) -> np.ndarray: ...

    def stats(self) -> dict[str, Any]: ...

    def close(self) -> None: ...


@dataclass(frozen=True)
class EngineInfo:
    """Registration record an engine plugin returns from the ``gasp_engines`` hook.

    Attributes
    ----------
    name : str
        Engine name used in scene files (``[engine] name = "my_engine"``).
    factory : callable
        ``factory(setup: SimSetup) -> PointEngine``. Imports the engine package lazily, so
        that listing engines stays cheap. It gets a setup that :func:`check_supported` passed,
        with ``setup.options`` holding every declared option (defaults filled in).
    capabilities : Capabilities
    options : tuple of Option
        Every option the engine takes; anything else in a scene is refused before the factory runs.
    deterministic_options : dict
        Option values that make a run repeat bit for bit on the devices of
        ``capabilities.deterministic`` (e.g. ``{"threads": 1}``); the conformance kit uses them.
    known_failures : dict
        ``{conformance scene name: reason with measured figures}``: run as strict expected failures.
    sweep : callable or None
        ``sweep(quick: bool) -> (settings, reference)`` for ``gasp bench``: a list of setting dicts
        and the reference setting. Keys ``n_grid``, ``particles_per_cell``, ``fill`` and
        ``core_fraction`` change the scene; every other key is an engine option.
    distribution, version : str
        The installed distribution that provides it (filled in by the plugin manager).
    available : callable or None
        ``available() -> str | None``: None when the engine can run here, else the reason it
        cannot (package missing, ...).
    description : str
    """

    name: str
    factory: Callable[[SimSetup], PointEngine]
    capabilities: Capabilities
    options: tuple[Option, ...] = ()
    deterministic_options: Mapping[str, Any] = field(default_factory=dict)
    known_failures: Mapping[str, str] = field(default_factory=dict)
    sweep: Callable[[bool], tuple[list[dict], dict]] | None = None
    distribution: str = ""
    version: str = ""
    available: Callable[[], str | None] | None = None
    description: str = ""

    def unavailable_reason(self) -> str | None:
        return self.available() if self.available is not None else None


def _bug(info: EngineInfo, where: str, e: BaseException) -> EngineBug:
    path = ""
    try:
        fd, path = tempfile.mkstemp(prefix=f"gasp-bug-{info.name}-", suffix=".txt")
        with os.fdopen(fd, "w") as f:
            f.write(f"engine {info.name} ({info.distribution} {info.version}) at {where}\n")
            f.write("".join(traceback.format_exception(e)))
    except OSError:
        path = ""
    return EngineBug(info.name, info.distribution, where, e, path)


def call_engine(info: EngineInfo, where: str, fn: Callable, *args):
    """Call into an engine under the error contract.

    ``GaspError`` s pass through; any other exception becomes :class:`EngineBug` (its traceback
    saved to a temporary file). ``KeyboardInterrupt`` and ``SystemExit`` pass through.
    """
    try:
        return fn(*args)
    except GaspError:
        raise
    except Exception as e:  # the contract: anything else is a bug in the engine
        raise _bug(info, where, e) from e
