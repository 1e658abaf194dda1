"""The engine seam: how the core finds, checks, builds and drives an engine.

An engine is a black box that moves points (GASP paper Sec. 3, ``V_t = phi(V, t)``). A plugin
registers :class:`EngineInfo` records (``gasp_engines`` hook, :mod:`gasp_core.seam.plugins`): a name,
a ``factory``, :class:`Capabilities`, declared :class:`Option` s and
:class:`~gasp_core.seam.limits.Limit` s. The core builds a :class:`~gasp_core.seam.setup.SimSetup`,
checks it against them and builds the engine (:func:`gasp_core.seam.build.build_engine`, one place),
then calls :meth:`PointEngine.step_frame` once per frame and reads :meth:`PointEngine.positions`.
Nothing here imports an engine package, and nothing here is specific to one kind of engine.

The error contract (:mod:`gasp_core.errors`): unsupported input raises ``SceneError``, an engine
that cannot run here ``EngineError``, a blow-up ``EngineDivergence``; anything else an engine
raises is wrapped as ``EngineBug``. The conformance kit (:mod:`gasp_core.testing`) checks it.
"""
from __future__ import annotations

import importlib
import importlib.util
import os
import tempfile
import traceback
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping, NotRequired, Protocol, Required, TypedDict, runtime_checkable

import numpy as np

from gasp_core.errors import EngineBug, GaspError
from gasp_core.seam.install import install_hint
from gasp_core.seam.limits import Limit, split_key
from gasp_core.seam.options import Option
from gasp_core.seam.config import Preset, config_options, config_presets
from gasp_core.seam.setup import SimSetup



#: Feature names an engine may declare in :attr:`Capabilities.features` (beyond materials and boundaries).
FEATURES = {
    "initial_C": "starts from SimSetup.C, the initial velocity gradient (APIC's affine matrix); "
                 "engines without it ignore C and start from v alone",
    "state": "the engine is a StatefulEngine: get_state() -> dict of arrays and set_state(dict) save and "
             "restore the whole simulation state after a frame (gasp simulate --resume); set_state right "
             "after the factory",
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
    "wind": "SimSetup.forces of kind 'wind': quadratic drag 1/2 rho_air C_d A |u - v| (u - v) on the windward "
            "surface, towards a uniform wind plus divergence-free turbulence",
    "attractors": "SimSetup.forces of kind 'attractor': acceleration towards a point with a falloff",
    "viscosity": "Material.viscosity > 0: the Kelvin-Voigt viscous stress sigma_v = 2 eta sym(grad v) added to "
                 "the elastic stress (docs/dissipation.md)",
    "fracture_cells": "SimSetup.cells: Grady's cells on a soft brittle body (gasp_core.run.grady_cells): each node's "
                      "cell of largest weight is one velocity field, the other cells the other; the fields part where "
                      "each has a broken point, and a cell's inside never damages",
    "sleep": "set_asleep(asleep): asleep is an ndarray (n_bodies,) bool, one flag per body (SimSetup.body_id); "
             "from the next step_frame on, the points of a flagged body are left out of every transfer (no P2G, G2P, "
             "stress, contact moments: their x, v, F, C, Jp stay as they are) and a cleared flag resumes them with "
             "the v, F, C they had; called between frames only, by gasp_core.seam.body_sleep's watch, which also "
             "saves the flags in a checkpoint and gives them again after set_state",
    "damage": "damage() -> ndarray (n,) float64 in [0, 1], setup order: each point's damage d after the last frame "
              "(the brittle material, docs/fracture.md; 0 for points of other materials); d never decreases. The "
              "core labels the pieces from it (gasp_core.pieces)",
    "plastic_strain": "plastic_strain() -> ndarray (n,) float64, setup order: each point's accumulated plastic strain "
                      "after the last frame (the plasticine material's Jp, the variable its softening acts on, "
                      "docs/mpm.md; 0 for points of other materials); it never decreases. The sleep watch keeps a "
                      "body whose plastic strain still grows awake (gasp_core.seam.sleep, FLOW_TOL)",
    "body_friction": "bodies slide on each other by Coulomb's law where they touch, whatever their routes: a flowing "
                     "body (sand, snow, liquid) against the others with its friction angle's tan as the coefficient "
                     "(docs/contact.md; the two velocity fields of Bardenhagen et al. 2000)",
    "left_domain": "a point whose transfer stencil leaves the grid (SimSetup.n_grid nodes of SimSetup.dx from "
                   "domain_lo) drops out of the simulation where it is (no P2G or G2P: its x and v stay) and the run "
                   "goes on; the core counts such points every frame (run.json left_domain, with a warning: "
                   "gasp_core.seam.runner.left_grid). A material point that leaves faster than a cell a substep is "
                   "still a divergence (CAUSE_UNSTABLE); a passive point's leaving never is",
    "rigid_limit": "Material.model = 'rigid': the body moves as one rigid body (momentum and angular momentum of "
                   "its points kept), its stress is zero and its stiffness sets no step (docs/rigid.md)",
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


class EngineStats(TypedDict, total=False):
    """What :meth:`PointEngine.stats` returns: the keys the core and the conformance kit read.

    An engine may add any other key (JSON-serialisable values); they go to the run record.

    Keys
    ----
    device : str
        Where it ran (``"cpu"``, ``"cuda:0"``).
    precision : str
        ``"f32"`` or ``"f64"``.
    n_points : int
        Points simulated (``len(setup.x)``).
    mass : float
        Total simulated mass, kg, as the engine holds it (passive points weigh 0). The conformance
        scene ``mass_agreement`` compares it with ``sum rho p_vol`` right after the build.
    centre_of_mass : list of 3 float
        Centre of that mass, metres, world frame (checked by ``mass_agreement`` too).
    dt : float
        Substep, seconds (engines with substeps).
    n_substeps : int
        Substeps per frame (``gasp simulate`` prints it).
    n_grid : int
        Grid cells along the longest domain side (grid engines).
    passive_stranded : int
        Passive points that gathered no velocity in the last grid update (feature ``passive_points``);
        ``gasp simulate`` warns with the count.
    """

    device: Required[str]
    precision: Required[str]
    n_points: Required[int]
    mass: Required[float]
    centre_of_mass: Required[list[float]]
    dt: NotRequired[float]
    n_substeps: NotRequired[int]
    n_grid: NotRequired[int]
    passive_stranded: NotRequired[int]


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
    stats() -> EngineStats
        At least ``device``, ``precision``, ``n_points``, ``mass`` and ``centre_of_mass``
        (:class:`EngineStats`); grid engines add ``dt``, ``n_substeps`` (per frame), ``n_grid``.
        ``n_substeps`` (fixed per run) is the ``N`` of the ``free_fall`` scene's exact semi-implicit Euler answer (:mod:`gasp_core.testing.scenes_freefall`).
    close()
        Free engine resources.

    An engine that declares the feature ``state`` is a :class:`StatefulEngine`: it adds
    ``get_state`` and ``set_state``; the core checks that when it builds the engine.
    """

    def step_frame(self) -> None: ...

    def positions(self) -> np.ndarray: ...

    def velocities(self) -> np.ndarray: ...

    def stats(self) -> EngineStats: ...

    def close(self) -> None: ...


@runtime_checkable
class StatefulEngine(PointEngine, Protocol):
    """A :class:`PointEngine` that saves and restores its whole state (the feature ``state``).

    Methods
    -------
    get_state() -> dict of str -> ndarray
        Everything needed to continue after the current frame bit for bit (``gasp simulate
        --resume`` saves it to ``.gasp-checkpoint.npz`` after every written frame): e.g. ``x``,
        ``v``, ``F``, ``C``, ``Jp``, ``frame``, ``sim_time``. Arrays are copies.
    set_state(state)
        Restore a ``get_state()`` of an engine built from the same setup and options. Called right
        after the factory, before any ``step_frame``; round 84's settle (:mod:`gasp_core.seam.settle`, the scene
        key ``settle``) also calls it between frames, with the velocities zeroed. Raises :class:`SceneError` when a
        key is missing or an array has the wrong shape.
    """

    def get_state(self) -> dict[str, np.ndarray]: ...

    def set_state(self, state: Mapping[str, np.ndarray]) -> None: ...


class SleepingEngine(PointEngine, Protocol):
    """A :class:`PointEngine` that freezes bodies at rest (the feature ``sleep``, :mod:`gasp_core.seam.body_sleep`).

    Methods
    -------
    set_asleep(asleep)
        ``asleep``: ndarray, shape (n_bodies,), bool, one flag per ``SimSetup.body_id`` value. From the next
        ``step_frame`` the flagged bodies' points take no part in any transfer and keep ``x, v, F, C, Jp``; a
        flag cleared resumes them. Called only between frames; every body starts awake. The flags are the
        core's to save (a checkpoint's ``gasp_body_sleep``): ``set_state`` need not restore them.
    """

    def set_asleep(self, asleep: np.ndarray) -> None: ...


@dataclass(frozen=True)
class EngineInfo:
    """Registration record an engine plugin returns from the ``gasp_engines`` hook.

    Attributes
    ----------
    name : str
        Engine name used in scene files (``[engine] name = "my_engine"``).
    factory : callable or str
        ``factory(setup: SimSetup) -> PointEngine``, or where to find it, ``"package.module:Class"`` (the
        declarative record of issue 51: the module is imported when a simulation is built, so that listing engines
        stays cheap). It gets a setup that the core checked against ``capabilities``, ``options`` and ``limits``
        (:func:`gasp_core.seam.build.build_engine`), with ``setup.options`` holding every declared option
        (defaults filled in).
    substeps : callable or None
        ``substeps(setup) -> int``: the substeps a frame the engine's step rule takes for ``setup`` (its options
        completed as the run's), for the line the core prints when it chooses a body's model
        (``gasp_core.prepare.route``); may raise ``SceneError`` where the rule refuses the scene.
    requires : tuple of str
        Modules the engine needs (``("my_solver",)``): without ``available``, the engine is available where each can
        be found (``importlib.util.find_spec``; nothing is imported), else the reason names the first missing one
        and the line that installs ``install``.
    install : str
        The distribution a user installs for the engine (``"gasp-my-engine"``, ``"gasp-my-engine[engine]"``), for
        the install line of a missing requirement (:func:`gasp_core.seam.install.install_hint`).
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
    limits : dict of str -> Limit
        Ranges this engine accepts that are narrower than the core's, as data
        (:mod:`gasp_core.seam.limits`): ``{"nu": Limit(lo=0.0, why="the engine's elasticity model")}``.
        The core refuses a setup outside them before the factory runs, with one error text.
    config : type or None
        The engine's settings as a frozen dataclass whose fields are its options (:mod:`gasp_core.seam.config`):
        ``options`` and ``presets`` are then read from it where not given, and the engine reads
        ``config(**setup.options)``.
    speed : dict of str -> str
        The engine's measured speed on each device it lists (``{"cuda": "README donut 0.111 s a frame on an H100
        (docs/performance.md)"}``); ``gasp engines`` says "not measured" for a device not in it.
    presets : dict of str -> Preset
        What each quality level (``"draft"``, ``"default"``, ``"reference"``) sets among this engine's options
        (:class:`gasp_core.seam.config.Preset`); a level sets no engine option that its engine does not declare here.
    check_scene : callable or None
        ``check_scene(scene, options, setup)``: a check of the scene that the engine owns (its domain against its
        own contact's needs, say), run by the core with the run's options (quality level applied) before any
        file is read (``setup`` None) and again once the setup is built and the bodies' models are chosen.
        Raises ``SceneError`` naming the file, key and the value that works.

    Raises
    ------
    ValueError
        A limit key that names no material, boundary or setup value; a ``speed`` device the engine does not list.
    """

    name: str
    factory: Callable[[SimSetup], PointEngine] | str
    capabilities: Capabilities
    options: tuple[Option, ...] = ()
    deterministic_options: Mapping[str, Any] = field(default_factory=dict)
    known_failures: Mapping[str, str] = field(default_factory=dict)
    sweep: Callable[[bool], tuple[list[dict], dict]] | None = None
    distribution: str = ""
    version: str = ""
    available: Callable[[], str | None] | None = None
    description: str = ""
    limits: Mapping[str, Limit] = field(default_factory=dict)
    check_scene: Callable[[Any, Mapping[str, Any], SimSetup | None], None] | None = None
    substeps: Callable[[SimSetup], int] | None = None
    requires: tuple[str, ...] = ()
    install: str = ""
    config: type | None = None
    presets: Mapping[str, Preset] = field(default_factory=dict)
    speed: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self):
        for key in self.limits:
            split_key(key)
        if set(self.speed) - set(self.capabilities.devices):
            raise ValueError(f"engine '{self.name}': speed given for device(s) "
                             f"{sorted(set(self.speed) - set(self.capabilities.devices))} it does not list")
        if self.config is not None:
            if not self.options:
                object.__setattr__(self, "options", config_options(self.config))
            if not self.presets:
                object.__setattr__(self, "presets", config_presets(self.config))
        for level, preset in self.presets.items():
            unknown = set(preset.options) - {o.name for o in self.options}
            if unknown:
                raise ValueError(f"engine '{self.name}': the preset {level!r} sets undeclared option(s) {sorted(unknown)}")
        if isinstance(self.factory, str):
            object.__setattr__(self, "factory", LazyFactory(self.factory))

    def unavailable_reason(self) -> str | None:
        if self.available is not None:
            return self.available()
        missing = next((m for m in self.requires if importlib.util.find_spec(m) is None), None)
        return None if missing is None else (f"the '{missing}' package is not installed: "
                                             f"{install_hint(self.name, distribution=self.install or None)}")


@dataclass(frozen=True)
class LazyFactory:
    """An engine factory named ``"package.module:Class"``, imported at its first call (:class:`EngineInfo`)."""

    target: str

    def __call__(self, setup: SimSetup) -> PointEngine:
        module, _, name = self.target.partition(":")
        return getattr(importlib.import_module(module), name)(setup)


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
