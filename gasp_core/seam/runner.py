"""Drive an engine frame by frame and stop it cleanly when it blows up.

Every engine goes through :class:`EngineRun` (or :func:`run_engine`, its frames as one generator), so NaN and
points leaving the domain are caught
in one place and reported as :class:`EngineDivergence` with the frame and the likely cause,
before anything is written. Exceptions follow the error contract of :mod:`gasp_core.errors`:
an engine's ``GaspError`` passes through, anything else becomes :class:`EngineBug`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from gasp_core.errors import EngineDivergence, EngineError
from gasp_core.seam.build import build_engine
from gasp_core.seam.cells import left_grid
from gasp_core.seam.engine import call_engine, EngineInfo, PointEngine, StatefulEngine
from gasp_core.seam.setup import SimSetup
from gasp_core.seam.body_sleep import BodySleep
from gasp_core.seam.energy_watch import EnergyWatch
from gasp_core.seam.sleep import SleepWatch


@dataclass
class FrameRecord:
    """One simulated frame.

    Attributes
    ----------
    frame : int
        1-based frame index (frame 0 is the initial state and is not simulated).
    x : ndarray, shape (n, 3), float64
        Positions, metres, world frame.
    wall_s : float
        Wall time of ``step_frame`` plus read-back, seconds.
    get_state : callable or None
        The engine's :meth:`~gasp_core.seam.engine.StatefulEngine.get_state` (engines with the
        feature ``state``; None for the others), for checkpoints.
    """

    frame: int
    x: np.ndarray
    wall_s: float
    get_state: Callable[[], dict] | None = None


@dataclass
class RunStats:
    """Timings and engine statistics of a run."""

    build_s: float = 0.0
    frame_s: list[float] = field(default_factory=list)
    engine: dict = field(default_factory=dict)
    #: The last simulated frame of a scene that fell asleep (:mod:`gasp_core.seam.sleep`); None: awake to the end.
    asleep_after: int | None = None
    #: Per body, when it slept and woke (:meth:`gasp_core.seam.body_sleep.BodySleep.record`; engines with the feature
    #: ``sleep`` and sleep on); empty otherwise.
    bodies: list = field(default_factory=list)
    #: The last frame's per-point damage, shape (n,), float64, setup order (engines with the feature ``damage`` on a
    #: scene with a ``brittle`` body, ``docs/fracture.md``); None otherwise. ``gasp_core.run.pieces`` reads it.
    damage: np.ndarray | None = None
    #: Points whose transfer stencil has left the grid after the last frame (engines with the feature
    #: ``left_domain``: they drop out of the simulation where they are, :func:`left_grid`); None otherwise.
    left_domain: int | None = None
    #: The breaks of stiff brittle bodies into rigid fragments (``gasp_core.run.fragment_run``), one record each.
    fragments: list = field(default_factory=list)
    #: The settled start's record (:func:`gasp_core.seam.settle.settled_state`; the scene key ``settle``); None without.
    settle: dict | None = None
    #: The energy watchdog's record (:meth:`gasp_core.seam.energy_watch.EnergyWatch.record`: the largest gain over
    #: the start's energy seen, as a fraction of the scene's energy scale; run.json ``energy``); None before a frame.
    energy: dict | None = None


#: The likely cause of non-finite values, or of points jumping out of the domain within a step: the one
#: text every engine and the runner give (:func:`check_state`).
CAUSE_UNSTABLE = "time step above the stability limit, or material too stiff for the time step"
#: The likely cause of points drifting out of the domain (:func:`check_state`).
CAUSE_LEFT_DOMAIN = ("points left the domain: no ground or walls to stop them, a domain too small, or an "
                     "unstable time step; add walls/ground or enlarge the domain")


def check_state(x: np.ndarray, setup: SimSetup, frame: int, margin: float | None = None) -> None:
    """Raise :class:`EngineDivergence` if ``x`` is non-finite or outside the domain: the one blow-up check.

    :func:`run_engine` applies it to every frame; an engine that wants to stop inside its own step
    calls this same function (or raises with :data:`CAUSE_UNSTABLE` / :data:`CAUSE_LEFT_DOMAIN`
    from its own counters, e.g. points out of the grid during a substep).

    Parameters
    ----------
    x : ndarray, shape (n, 3)
        Positions, metres.
    setup : SimSetup
    frame : int
    margin : float, optional
        Tolerance outside the domain box, metres (default ``setup.dx``).

    Raises
    ------
    EngineDivergence
        With the count and first index of the offending points and the likely cause.
    """
    if x.shape != setup.x.shape:
        raise EngineDivergence(
            f"engine returned positions of shape {x.shape}, expected {setup.x.shape}", frame,
            "the engine dropped or added points")
    finite = np.isfinite(x).all(axis=1)
    if not finite.all():
        bad = np.flatnonzero(~finite)
        raise EngineDivergence(
            f"{len(bad)} point(s) non-finite (first index {bad[0]})", frame, CAUSE_UNSTABLE)
    m = setup.dx if margin is None else margin
    out = ((x < setup.domain_lo - m) | (x > setup.domain_hi + m)).any(axis=1)
    if out.any():
        bad = np.flatnonzero(out)
        raise EngineDivergence(
            f"{len(bad)} point(s) left the domain [{setup.domain_lo.tolist()}, {setup.domain_hi.tolist()}] "
            f"(first index {bad[0]} at {x[bad[0]].tolist()})", frame, CAUSE_LEFT_DOMAIN)


class EngineRun:
    """An engine built for a setup (and restored after ``start_frame``), then driven frame by frame: the one place
    a run meets its engine. Use it as a context manager: the engine is closed on leaving it.

    Parameters
    ----------
    info : EngineInfo
        From :func:`gasp_core.seam.plugins.get_engine`.
    setup : SimSetup
    stats : RunStats, optional
        Filled with the build time, ``engine.stats()`` (once built: ``n_substeps`` for the work estimate; again after
        the last frame), per-frame wall times, the sleep's record.
    start_frame : int
        Resume after this frame: ``state`` (from the engine's ``get_state``) is restored with ``set_state`` (engines
        with the feature ``state``, a :class:`~gasp_core.seam.engine.StatefulEngine`); :meth:`frames` then
        simulates frames ``start_frame + 1 .. n_frames``.
    state : dict, optional
    sleep : bool
        Let a scene at rest fall asleep (:mod:`gasp_core.seam.sleep`): later frames repeat the last one (``wall_s``
        0, ``stats.asleep_after``); ``get_state`` then carries the sleep's count, so a resumed run sleeps alike. With
        an engine with the feature ``sleep``, each body at rest is frozen on its own and woken by what comes within
        its reach (:mod:`gasp_core.seam.body_sleep`, the engine's ``set_asleep``; ``stats.bodies``).
    settle : bool
        A fresh run (``start_frame`` 0) starts from its bodies at rest in their weight
        (:func:`gasp_core.seam.settle.settled_state`, the scene key ``settle``; its record in ``stats.settle``).

    Raises
    ------
    SceneError, EngineError
        From :func:`gasp_core.seam.build.build_engine` (capabilities, options, limits) or the engine;
        ``EngineError`` too for ``start_frame`` on an engine without the feature ``state``.
    EngineBug
        The engine raised anything outside the error contract.
    """

    def __init__(self, info: EngineInfo, setup: SimSetup, stats: RunStats | None = None, start_frame: int = 0,
                 state: dict | None = None, sleep: bool = False, settle: bool = False):
        if start_frame and "state" not in info.capabilities.features:
            raise EngineError(f"engine '{info.name}' cannot resume after frame {start_frame}: "
                              f"it does not have the feature 'state'")
        self.info, self.setup, self.start_frame = info, setup, start_frame
        self.stats = stats if stats is not None else RunStats()
        t0 = time.perf_counter()
        self.watch = SleepWatch(setup, sleep, BodySleep(setup) if "sleep" in info.capabilities.features else None)
        if settle and not start_frame:
            from gasp_core.seam.settle import settled_state
            state, self.stats.settle = settled_state(info, setup)
        self.engine, self.get_state = _built(info, setup, start_frame, state, self.watch, bool(settle))
        self.stats.build_s = time.perf_counter() - t0
        self._open = True
        try:
            self.stats.engine = dict(call_engine(info, "stats", self.engine.stats))
        except BaseException:
            self.close()
            raise

    def __enter__(self) -> EngineRun:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Close the engine (once)."""
        if self._open:
            self._open = False
            call_engine(self.info, "close", self.engine.close)

    def frames(self, n_frames: int) -> Iterator[FrameRecord]:
        """Simulate up to frame ``n_frames`` (each ``setup.frame_dt`` seconds), yielding each checked frame.

        Raises
        ------
        EngineDivergence
            At the first frame whose state is non-finite or outside the domain (:func:`check_state`), that gained
            energy (:class:`gasp_core.seam.energy_watch.EnergyWatch`), or when the engine itself reports a blow-up.
        EngineBug
            The engine raised anything outside the error contract.
        """
        info, setup, stats, watch, engine = self.info, self.setup, self.stats, self.watch, self.engine
        advance = _advancer(engine, watch)
        x = np.asarray(call_engine(info, "positions", engine.positions), dtype=np.float64)
        damaged = "damage" in info.capabilities.features and any(m.name == "brittle" for m in setup.materials)
        leaves = "left_domain" in info.capabilities.features
        energy = EnergyWatch(setup, left_grid(x, setup) if leaves and self.start_frame else None)
        flow = _flow_reader(info, engine, setup) if watch.enabled else None
        state = None if flow is None else flow()   # the damage and plastic strain now: a creep is no rest
        for frame in range(self.start_frame + 1, n_frames + 1):
            if watch.asleep_after is not None:   # asleep: the frame repeats the last one (gasp_core.seam.sleep)
                if damaged and stats.damage is None:   # resumed asleep: the restored state's damage (the pieces)
                    stats.damage = np.asarray(call_engine(info, "damage", engine.damage), dtype=np.float64)
                stats.asleep_after = watch.asleep_after
                stats.frame_s.append(0.0)
                yield FrameRecord(frame, x + 0.0, 0.0, self.get_state)
                continue
            t0 = time.perf_counter()
            x_prev, x = x, call_engine(info, f"frame {frame}", advance, frame, x)
            dt_wall = time.perf_counter() - t0
            check_state(x, setup, frame)
            out = left_grid(x, setup) if leaves else None
            try:
                energy.check(frame, x_prev, x, out)
            finally:
                stats.energy = _merged(stats.energy, energy.record())
            if leaves:
                stats.left_domain = int(out.sum())
            if damaged:
                stats.damage = np.asarray(call_engine(info, "damage", engine.damage), dtype=np.float64)
            stats.frame_s.append(dt_wall)
            growth = None
            if flow is not None and watch.asleep_after is None:
                state_prev, state = state, flow(stats.damage if damaged else None)   # damage read once
                growth = state - state_prev
            watch.update(frame, x_prev, x, growth)
            stats.bodies = [] if watch.bodies is None else watch.bodies.record()
            yield FrameRecord(frame, x, dt_wall, self.get_state)
        stats.engine = dict(call_engine(info, "stats", engine.stats))


def _merged(old: dict | None, new: dict) -> dict:
    """The energy record of a run made of several engine runs (``gasp_core.run.fragment_run``'s): the largest gain of
    all, the latest run's scale and skip reason."""
    gains = [r["largest_gain"] for r in (old, new) if r is not None and r["largest_gain"] is not None]
    return {**new, "largest_gain": max(gains) if gains else None}


def run_engine(info: EngineInfo, setup: SimSetup, n_frames: int, stats: RunStats | None = None,
               start_frame: int = 0, state: dict | None = None, sleep: bool = False) -> Iterator[FrameRecord]:
    """:class:`EngineRun`'s frames as one generator (the engine built at the first ``next``, closed at the end):
    ``n_frames`` checked frames. Parameters and errors as :class:`EngineRun` and :meth:`EngineRun.frames`.

    Yields
    ------
    FrameRecord
    """
    with EngineRun(info, setup, stats, start_frame, state, sleep) as run:
        yield from run.frames(n_frames)


def _flow_reader(info: EngineInfo, engine: PointEngine, setup: SimSetup) -> Callable[..., np.ndarray] | None:
    """``read(damage=None)``: each point's irreversible state, shape (n,), float64, setup order: its damage (feature
    ``damage``, brittle bodies) plus its plastic strain (feature ``plastic_strain``, plasticine bodies), whose growth
    keeps a body awake (:data:`gasp_core.seam.sleep.FLOW_TOL`); None where the scene has neither."""
    names = {m.name for m in setup.materials}
    features = info.capabilities.features
    parts = [(k, getattr(engine, k)) for k, mat in (("damage", "brittle"), ("plastic_strain", "plasticine"))
             if k in features and mat in names]
    if not parts:
        return None

    def read(damage: np.ndarray | None = None) -> np.ndarray:
        """The sum of the parts; ``damage`` (n,): the frame's damage where the caller read it already."""
        return sum(damage if k == "damage" and damage is not None else
                   np.asarray(call_engine(info, k, f), dtype=np.float64) for k, f in parts)
    return read


def _advancer(engine: PointEngine, watch: SleepWatch) -> Callable[[int, np.ndarray], np.ndarray]:
    """``advance(frame, x)``: the per-body wake test on the last positions ``x`` (engines with the feature
    ``sleep``: ``set_asleep`` when the flags changed, and always before the first frame simulated here), one
    ``step_frame``, the new positions (float64)."""
    told: list = [None]   # the flags the engine was last given

    def advance(frame: int, x: np.ndarray) -> np.ndarray:
        if watch.bodies is not None:
            watch.before_frame(frame, x)
            if told[0] is None or not np.array_equal(told[0], watch.bodies.asleep):
                told[0] = watch.bodies.asleep.copy()
                engine.set_asleep(told[0].copy())
        engine.step_frame()
        return np.asarray(engine.positions(), dtype=np.float64)
    return advance


def _built(info: EngineInfo, setup: SimSetup, start_frame: int, state: dict | None, watch: SleepWatch,
           settled: bool = False):
    """The engine built (and, after ``start_frame``, restored from ``state``; ``settled``: from the settled
    ``state`` at frame 0) and its checkpoint reader (None without the feature ``state``), the sleep's count in and out
    through ``watch``."""
    engine: PointEngine = build_engine(info, setup)
    stateful: StatefulEngine | None = engine if "state" in info.capabilities.features else None
    if start_frame:
        call_engine(info, "set_state", stateful.set_state, watch.take_from(state))
    elif settled:
        call_engine(info, "set_state", stateful.set_state, state)
    return engine, (None if stateful is None else watch.saving(lambda: call_engine(info, "get_state", stateful.get_state)))


def simulate(info: EngineInfo, setup: SimSetup, n_frames: int,
             on_frame: Callable[[FrameRecord], None] | None = None) -> tuple[np.ndarray, RunStats]:
    """Run ``n_frames`` and return all positions, shape (n_frames + 1, n, 3), frame 0 = ``setup.x``.

    Raises
    ------
    EngineDivergence
        See :func:`run_engine`.
    """
    stats = RunStats()
    xs = [setup.x.copy()]
    for rec in run_engine(info, setup, n_frames, stats):
        xs.append(rec.x)
        if on_frame is not None:
            on_frame(rec)
    return np.stack(xs), stats
