"""The conformance kit's machinery: requirements, results, running a scene, :func:`check_engine`.

A :class:`Scene` is a small :class:`~gasp_core.seam.setup.SimSetup` factory (hundreds to a few
thousand points) plus an ``evaluate`` function that turns the simulated frames into named
:class:`Check` s with the measured figures; a contract scene has a ``run`` function instead,
which builds and drives the engine itself. A scene declares what it :class:`Requires`; an engine
that lacks it is skipped with the missing capability as the reason. An engine declares its known
failures in :attr:`EngineInfo.known_failures <gasp_core.seam.engine.EngineInfo>` (scene name ->
reason with measured figures); they run as strict expected failures.

Conventions: world frame, metres, z up; ``x``, ``v`` are (n, 3) float64 arrays; kinetic energy
``0.5 sum p_mass |v|^2`` uses the engine's reported point velocities; gravitational potential is
``-sum p_mass g . x``.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping

import numpy as np

from gasp_core.seam.engine import Capabilities, EngineInfo, call_engine
from gasp_core.errors import EngineBug, EngineDivergence, EngineError, GaspError
from gasp_core.seam.runner import CAUSE_UNSTABLE, RunStats, run_engine
from gasp_core.seam.setup import SimSetup
from gasp_core.testing.helpers import Check


@dataclass(frozen=True)
class Requires:
    """What a scene needs from an engine (names as in :class:`~gasp_core.seam.engine.Capabilities`).

    Attributes
    ----------
    materials, boundaries, features : frozenset of str
        ``features`` are keys of :data:`gasp_core.seam.engine.FEATURES` (e.g. ``"grid"``).
    deterministic : bool
        The engine must promise bit-identical repeats on ``cpu`` (``Capabilities.deterministic``),
        with the option values of ``EngineInfo.deterministic_options``.
    """

    materials: frozenset[str] = frozenset()
    boundaries: frozenset[str] = frozenset()
    features: frozenset[str] = frozenset()
    deterministic: bool = False

    def missing(self, caps: Capabilities) -> list[str]:
        """The capabilities ``caps`` lacks, in words (empty when the scene can run)."""
        out = [f"{kind} '{name}'" for kind, name in caps.missing(sorted(self.materials), sorted(self.boundaries),
                                                                 sorted(self.features))]
        if self.deterministic and "cpu" not in caps.deterministic:
            out.append("deterministic on cpu")
        return out


@dataclass
class Trace:
    """Frames of one run.

    Attributes
    ----------
    setup : SimSetup
    x, v : ndarray, shape (n_frames + 1, n, 3), float64
        Positions (m) and velocities (m/s); frame 0 is ``setup.x`` / ``setup.v``.
    t : ndarray, shape (n_frames + 1,)
        Simulated time of each frame, s.
    stats : RunStats
    """

    setup: SimSetup
    x: np.ndarray
    v: np.ndarray
    t: np.ndarray
    stats: RunStats

    @property
    def p_mass(self) -> np.ndarray:
        return self.setup.p_mass

    def centroid(self) -> np.ndarray:
        """Mass-weighted centroid per frame, shape (n_frames + 1, 3), m."""
        m = self.p_mass
        return np.einsum("i,fij->fj", m, self.x) / m.sum()

    def momentum(self) -> np.ndarray:
        """Total linear momentum per frame, shape (n_frames + 1, 3), kg m/s."""
        return np.einsum("i,fij->fj", self.p_mass, self.v)

    def kinetic(self) -> np.ndarray:
        """Kinetic energy per frame, J."""
        return 0.5 * np.einsum("i,fi->f", self.p_mass, (self.v ** 2).sum(axis=2))

    def potential(self) -> np.ndarray:
        """Gravitational potential energy ``-sum m g . x`` per frame, J."""
        return -np.einsum("i,fij,j->f", self.p_mass, self.x, self.setup.gravity)


@dataclass(frozen=True)
class Scene:
    """A scene with a known answer, or a check of the error contract.

    Attributes
    ----------
    name : str
        Used in pytest ids ``engine-scene`` and in ``EngineInfo.known_failures``.
    description : str
    requires : Requires
    build : callable or None
        ``build(info) -> SimSetup`` (``info`` lets a scene place walls where a grid engine puts
        them, see :func:`wall_margin`, or pass ``C`` to engines with the ``initial_C`` feature).
    n_frames : int
    evaluate : callable or None
        ``evaluate(info, trace) -> list[Check]``; may run more simulations (determinism,
        invariance). ``trace`` is the run of ``build(info)`` for ``n_frames``.
    run : callable or None
        ``run(info) -> list[Check]``: instead of ``build``/``evaluate``, for scenes that must see
        how building or running fails (the error contract).
    slow : bool
        Excluded from the default pytest run and from :func:`check_engine` unless asked for.
    """

    name: str
    description: str
    requires: Requires
    build: Callable[[EngineInfo], SimSetup] | None = None
    n_frames: int = 0
    evaluate: Callable[[EngineInfo, Trace], list[Check]] | None = None
    run: Callable[[EngineInfo], list[Check]] | None = None
    slow: bool = False


@dataclass
class SceneResult:
    """Outcome of one scene on one engine.

    ``status`` is one of ``pass``, ``fail``, ``skip``, ``xfail``, ``xpass`` (a known failure
    that passed: counts as a failure), ``error`` (the engine raised outside the error contract,
    :class:`~gasp_core.errors.EngineBug`: a defect of the engine, also a failure).
    """

    engine: str
    scene: str
    status: str
    message: str
    checks: list[Check] = field(default_factory=list)
    wall_s: float = 0.0

    @property
    def ok(self) -> bool:
        return self.status in ("pass", "skip", "xfail")

    def as_dict(self) -> dict[str, Any]:
        return {"engine": self.engine, "scene": self.scene, "status": self.status, "message": self.message,
                "wall_s": round(self.wall_s, 3),
                "checks": [{"name": c.name, "passed": c.passed, "message": c.message, "figures": c.figures}
                           for c in self.checks]}


@dataclass
class EngineReport:
    """Per-scene results of :func:`check_engine` for one engine."""

    engine: str
    results: list[SceneResult]

    @property
    def ok(self) -> bool:
        """True when no scene failed, errored or passed unexpectedly."""
        return all(r.ok for r in self.results)

    def by_scene(self) -> dict[str, SceneResult]:
        return {r.scene: r for r in self.results}

    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for r in self.results:
            out[r.status] = out.get(r.status, 0) + 1
        return out

    def table(self) -> str:
        """A Markdown table: scene | status | wall s | message."""
        rows = ["| scene | status | wall s | details |", "|---|---|---|---|"]
        for r in self.results:
            msg = r.message.replace("|", "/").replace("\n", " ")
            rows.append(f"| {r.scene} | {r.status} | {r.wall_s:.1f} | {msg} |")
        return "\n".join(rows)


# --------------------------------------------------------------------------------------------
# Running
# --------------------------------------------------------------------------------------------

def resolve_engine(engine: str | EngineInfo) -> EngineInfo:
    """An :class:`EngineInfo` from a name (installed engines) or the record itself.

    Raises
    ------
    EngineError
        If no installed engine has that name.
    """
    if isinstance(engine, EngineInfo):
        return engine
    from gasp_core.seam.plugins import engines, unknown_engine_message
    found = engines()
    if engine not in found:
        raise EngineError(unknown_engine_message(engine, found))
    return found[engine]


def run_trace(info: EngineInfo, setup: SimSetup, n_frames: int) -> Trace:
    """Run ``n_frames`` through :func:`gasp_core.seam.runner.run_engine`, recording velocities too.

    Raises
    ------
    SceneError, EngineError, EngineBug
        As :func:`run_engine`.
    EngineDivergence
        As :func:`run_engine`, and also when ``velocities()`` has the wrong shape or is not finite.
    """
    holder: dict[str, Any] = {}

    def factory(s: SimSetup):
        holder["engine"] = info.factory(s)
        return holder["engine"]

    recording = dataclasses.replace(info, factory=factory)
    stats = RunStats()
    xs = [setup.x.copy()]
    vs = [setup.v.copy()]
    for rec in run_engine(recording, setup, n_frames, stats):
        v = np.asarray(call_engine(info, f"frame {rec.frame}", holder["engine"].velocities), dtype=np.float64)
        if v.shape != setup.x.shape:
            raise EngineDivergence(f"engine returned velocities of shape {v.shape}, expected "
                                   f"{setup.x.shape}", rec.frame, "the engine dropped or added points")
        if not np.isfinite(v).all():
            raise EngineDivergence("non-finite velocities", rec.frame, CAUSE_UNSTABLE)
        xs.append(rec.x)
        vs.append(v)
    t = np.arange(len(xs)) * setup.frame_dt
    return Trace(setup, np.stack(xs), np.stack(vs), t, stats)


def evaluate_scene(info: EngineInfo, scene: Scene, known_failures: Mapping[str, str] | None = None) -> SceneResult:
    """Run one scene on one engine and classify it (see :class:`SceneResult`).

    ``known_failures`` defaults to ``info.known_failures``; pass ``{}`` where the caller (pytest)
    handles expected failures itself.
    """
    kf = info.known_failures if known_failures is None else known_failures
    missing = scene.requires.missing(info.capabilities)
    if missing:
        return SceneResult(info.name, scene.name, "skip", "missing capability: " + ", ".join(missing))
    reason = info.unavailable_reason()
    if reason:
        return SceneResult(info.name, scene.name, "skip", f"engine unavailable: {reason}")
    t0 = time.perf_counter()
    checks: list[Check] = []
    errored = False
    try:
        if scene.run is not None:
            checks = scene.run(info)
        else:
            trace = run_trace(info, scene.build(info), scene.n_frames)
            checks = scene.evaluate(info, trace)
        passed = all(c.passed for c in checks)
        message = "; ".join(str(c) for c in checks)
    except EngineBug as e:  # outside the error contract: a defect of the engine
        passed, errored, message = False, True, f"EngineBug: {e}"
    except GaspError as e:  # divergence, scene or engine error: the scene fails
        passed, message = False, f"{type(e).__name__}: {e}"
    wall = time.perf_counter() - t0
    if scene.name in kf:
        status = "xpass" if passed else "xfail"
        message = (f"known failure ({kf[scene.name]}) " +
                   ("PASSED unexpectedly: " if passed else "observed: ") + message)
    else:
        status = "pass" if passed else ("error" if errored else "fail")
    return SceneResult(info.name, scene.name, status, message, checks, wall)


def record(node, result: SceneResult | str) -> None:
    """Attach a result (or a line of text) to a pytest item for the session's result table."""
    if isinstance(result, SceneResult):
        text = "; ".join(f"{c.name} {'ok' if c.passed else 'FAIL'}: {c.message}" for c in result.checks)
        text = f"{text or result.message} [{result.wall_s:.1f} s]"
        measured, tolerance = measured_and_tolerance(result.checks)
        node.user_properties.append(("conformance_measured", measured))
        node.user_properties.append(("conformance_tolerance", tolerance))
    else:
        text = str(result)
    node.user_properties.append(("conformance_detail", text))


def measured_and_tolerance(checks: Iterable[Check]) -> tuple[str, str]:
    """Two short columns for the result table: each check's measured value (``name value``, with the
    signed error where the scene gives one) and its tolerance (``<= limit`` or ``[lo, hi]``)."""
    meas, tol = [], []
    for c in checks:
        f = c.figures
        if "value" not in f:
            continue
        v = f"{f['signed']:+.3g}" if "signed" in f else f"{f['value']:.3g}"
        meas.append(f"{c.name} {v}")
        if "limit" in f:
            tol.append(f"{c.name} <= {f['limit']:.3g}" if "signed" not in f else f"{c.name} +-{f['limit']:.3g}")
        elif "lo" in f and "hi" in f:
            tol.append(f"{c.name} [{f['lo']:.3g}, {f['hi']:.3g}]")
    return "; ".join(meas), "; ".join(tol)
