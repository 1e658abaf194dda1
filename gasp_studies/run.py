"""Fan scene runs out on Dask, one fresh worker process per run, each with a wall-clock limit.

A run is a :class:`RunSpec` (scene, engine, options, frames). :func:`execute` runs it inside a
Dask worker through the core's own pipeline (:func:`gasp_core.prepare.scene.prepare_scene`,
:func:`gasp_core.run.pipeline.iter_frames`) and returns a :class:`RunOutput`: the Gaussian means of
every frame (file frame, float32) and a JSON-able record of timings and engine statistics.
Results come back through Dask; nothing is handed over through files.

:class:`Runner` owns the cluster. By default it starts a ``distributed.LocalCluster`` of worker
processes (``processes=True``, ``threads_per_worker=1``, at most one worker per core); with
``scheduler`` it connects to an existing cluster instead. It gives each worker one run at a
time and restarts the worker (through its nanny) after every run, so every run starts in a
fresh process: an engine's runtime may be process-global (one per process, reset by its
init), and a fresh process gives an honest peak memory. A run that passes ``timeout_s`` is cancelled and its worker is
restarted (which kills it); a worker that dies mid-run is reported as ``crashed``.
"""
from __future__ import annotations

import os
import sys
import tempfile
import time
import traceback
import uuid
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from gasp_core.errors import GaspError
from gasp_core.scene.spec import Scene

#: Default wall-clock limit of one run, seconds.
RUN_TIMEOUT_S = 3600.0


#: How long ``--scheduler ADDRESS`` is tried before the run gives up (Dask's ``Client(timeout=...)``).
CONNECT_TIMEOUT = "30s"


@dataclass
class RunSpec:
    """One run: ``scene`` on ``engine`` with ``options`` (replacing the scene's) for ``n_frames``.

    ``label`` names the run in tables and file names. The scene's object files must be readable
    by the workers (the same machine, or a shared file system for a remote cluster).
    ``keep_frames``: frames whose rebuilt Gaussians come back as world-frame splats
    (:attr:`RunOutput.keyframes`, for the reports' strips of rendered frames).
    """

    scene: Scene
    engine: str
    options: dict
    n_frames: int
    label: str
    keep_frames: tuple[int, ...] = ()


@dataclass
class RunOutput:
    """What one run gives back.

    Attributes
    ----------
    record : dict
        JSON-able. ``status`` is ``ok``, ``diverged`` (with ``frame``, ``cause``, ``message``),
        ``error`` (``message``), ``timeout`` or ``crashed``; ``build_s``, ``frame_s`` (wall time
        per frame, s), ``frame_cpu_s``, ``engine_stats``, ``peak_rss_mb`` (the worker process's
        ``ru_maxrss``), ``worker_base_rss_mb`` (the same when the run started: the fresh worker's
        own footprint), ``size_m`` (bounding-box diagonal of the frame-0 means, world frame, m),
        ``simulated_points``, ``gaussians``, ``task_s`` (the run inside the worker), ``dispatch_s``
        (submit to result, minus ``task_s``), ``restart_s`` (the worker restart after the run).
    means : ndarray, shape (n_frames + 1, n, 3), float32, or None
        Gaussian means per frame (frame 0 = the input), file frame of each object, objects
        concatenated; fewer frames when the run diverged.
    m_per_unit : ndarray, shape (n,), float32, or None
        Metres per file unit of each row (the object's placement scale).
    obj_start : ndarray, shape (n_objects + 1,), int64, or None
        Row offsets of the objects.
    log : str
        The run's stdout and stderr (file-descriptor level, so native libraries' output too).
    keyframes : dict of int -> Splats
        World-frame splats (float32) of the frames in :attr:`RunSpec.keep_frames` the run reached
        (:func:`gasp_studies.strips.world_splats`).
    """

    record: dict
    means: np.ndarray | None = None
    m_per_unit: np.ndarray | None = None
    obj_start: np.ndarray | None = None
    log: str = ""
    keyframes: dict = field(default_factory=dict)


def _rss_peak_mb() -> float:
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux


class _CaptureFds:
    """Send file descriptors 1 and 2 to a temporary file while a run lasts (its log)."""

    def __enter__(self):
        sys.stdout.flush()
        sys.stderr.flush()
        self.file = tempfile.TemporaryFile(mode="w+b")
        self.saved = [os.dup(1), os.dup(2)]
        os.dup2(self.file.fileno(), 1)
        os.dup2(self.file.fileno(), 2)
        return self

    def __exit__(self, *exc):
        sys.stdout.flush()
        sys.stderr.flush()
        for fd, saved in zip((1, 2), self.saved):
            os.dup2(saved, fd)
            os.close(saved)
        self.file.seek(0)
        self.text = self.file.read().decode(errors="replace")
        self.file.close()
        return False


def execute(spec: RunSpec, capture: bool = True) -> RunOutput:
    """Run ``spec`` in this process (the task a Dask worker runs) and return its :class:`RunOutput`.

    Errors are caught and reported in the record (``status`` ``diverged`` or ``error``), never
    raised: one engine's failure does not stop a study. A run whose work is beyond ``gasp simulate``'s bound
    (:func:`gasp_core.run.budget.check_before`, without ``--yes``) stops after its first frame as an ``error``.
    """
    from gasp_core.errors import EngineDivergence
    from gasp_core.run.budget import check_before
    from gasp_core.run.frames import iter_frames
    from gasp_core.prepare.scene import prepare_scene
    from gasp_core.seam.runner import RunStats

    from .strips import world_splats

    rec: dict[str, Any] = {"engine": spec.engine, "label": spec.label, "status": "ok",
                           "options": dict(spec.options), "worker_base_rss_mb": _rss_peak_mb(),
                           "pid": os.getpid()}
    means: list[np.ndarray] = []
    keyframes: dict = {}
    m_per_unit = obj_start = None
    t_start = time.perf_counter()
    cap = _CaptureFds() if capture else None
    if cap is not None:
        cap.__enter__()
    try:
        t0 = time.perf_counter()
        prep = prepare_scene(spec.scene, spec.engine, spec.options)
        rec["prepare_s"] = time.perf_counter() - t0
        rec["version"] = prep.info.version
        rec["simulated_points"] = int(len(prep.setup.x))
        rec["render_points"] = int(prep.setup.n_render)
        rec["gaussians"] = int(sum(o.gaussians.n for o in prep.objects))
        rec["n_grid"] = int(prep.setup.n_grid)
        rec["dx_m"] = float(prep.setup.dx)
        counts = [o.gaussians.n for o in prep.objects]
        obj_start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        m_per_unit = np.concatenate([np.full(o.gaussians.n, o.placement.scale, np.float32)
                                     for o in prep.objects])
        world0 = np.concatenate([o.placement.to_world(o.gaussians.means) for o in prep.objects])
        rec["size_m"] = float(np.linalg.norm(world0.max(axis=0) - world0.min(axis=0)))
        stats = RunStats()
        cpu_marks = []
        try:
            kept_cpu = kept_wall = 0.0  # keeping keyframes is the study's work: left out of the timings
            for frame, gs, _row in iter_frames(prep, spec.n_frames, stats):
                if frame == 1:   # the engine is built: gasp simulate's work bound (round 100: 1e10 frames ran on)
                    check_before(stats.engine or {}, rec["simulated_points"], spec.n_frames, spec.n_frames - 1, False,
                                 override="")
                cpu_marks.append(time.process_time() - kept_cpu)
                means.append(np.concatenate([g.means for g in gs]).astype(np.float32))
                if frame in spec.keep_frames:
                    c0, w0 = time.process_time(), time.perf_counter()
                    keyframes[frame] = world_splats(prep.objects, gs)
                    kept_cpu += time.process_time() - c0
                    kept_wall += time.perf_counter() - w0
            # what a user waits for: read, fill, hierarchy, build, every frame and its T^-1 rebuild
            rec["end_to_end_s"] = time.perf_counter() - t0 - kept_wall
        except EngineDivergence as e:
            rec.update(status="diverged", frame=e.frame, cause=e.cause, message=str(e))
        rec["build_s"] = stats.build_s
        rec["frame_s"] = list(stats.frame_s)
        # process CPU time between frames (all threads; includes the T^-1 rebuild; frame 1 the build)
        rec["frame_cpu_s"] = np.diff(cpu_marks).tolist()
        rec["engine_stats"] = stats.engine
    except GaspError as e:
        rec.update(status="error", message=f"{type(e).__name__}: {e}")
    except Exception as e:  # reported, never fatal to the study
        rec.update(status="error", message=f"{type(e).__name__}: {e}", traceback=traceback.format_exc())
    finally:
        if cap is not None:
            cap.__exit__(None, None, None)
    rec["task_s"] = time.perf_counter() - t_start
    rec["peak_rss_mb"] = _rss_peak_mb()
    rec["frames_saved"] = len(means)
    return RunOutput(rec, np.stack(means) if means else None, m_per_unit if means else None,
                     obj_start if means else None, cap.text if cap is not None else "", keyframes)


def _failed(spec: RunSpec, status: str, message: str) -> RunOutput:
    return RunOutput({"engine": spec.engine, "label": spec.label, "status": status,
                      "options": dict(spec.options), "message": message})


@dataclass
class Runner:
    """A Dask client that runs :class:`RunSpec` s, one fresh worker process per run.

    Use as a context manager: the cluster starts on entry (a ``LocalCluster`` unless
    ``scheduler`` is given) and stops on exit (an external cluster is left running).

    Parameters
    ----------
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``). Its workers must see the
        scene files; they should have one thread each and a nanny (to be restarted between runs;
        without one, runs share worker processes and the report says so).
    workers : int
        Worker processes of the local cluster (clipped to the number of cores). Runs on the same
        machine compete for cores and memory bandwidth, so wall times per frame are only
        comparable between runs made with ``workers=1`` (the default).
    timeout_s : float
        Wall-clock limit of one run, seconds (from its start on a worker).

    Attributes
    ----------
    startup_s : float
        Seconds to start the local cluster (or connect) and see its workers.
    isolated : bool
        False once a worker could not be restarted between runs.

    Raises
    ------
    GaspError
        ``workers`` or ``timeout_s`` out of range; on entry, a ``scheduler`` not an address or not reached.
    """

    scheduler: str | None = None
    workers: int = 1
    timeout_s: float = RUN_TIMEOUT_S
    startup_s: float = 0.0
    isolated: bool = True
    notes: list[str] = field(default_factory=list)

    def __post_init__(self):
        if isinstance(self.workers, bool) or not isinstance(self.workers, int) or self.workers < 1:
            raise GaspError(f"workers: expected a positive integer, got {self.workers!r}")
        if not (self.timeout_s > 0):
            raise GaspError(f"timeout_s: expected a positive number of seconds, got {self.timeout_s!r}")
        self._cluster = self._client = None

    def __enter__(self) -> "Runner":
        import logging

        from distributed import Client, LocalCluster
        t0 = time.perf_counter()
        if self.scheduler:
            try:
                self._client = Client(self.scheduler, timeout=CONNECT_TIMEOUT)
            except (OSError, ValueError, TypeError) as e:   # the last two: an address distributed cannot parse
                what = "cannot connect" if isinstance(e, OSError) else "not an address such as tcp://HOST:8786"
                raise GaspError(f"--scheduler {self.scheduler}: {what} ({e})") from None
            self._client.wait_for_workers(1, timeout=60)
        else:
            n = max(1, min(self.workers, os.cpu_count() or 1))
            if n < self.workers:
                self.notes.append(f"workers: {self.workers} asked, {n} started (one per core)")
            # dashboard_address=None still serves Dask's dashboard on its default port 8787, and warns when another
            # cluster holds it (issue 55); ":0" takes a free port, so nothing is said
            self._cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                         dashboard_address=":0", silence_logs=logging.ERROR)
            self._client = Client(self._cluster)
            self._client.wait_for_workers(n, timeout=120)
        self._n_workers = len(self._client.nthreads())
        self.startup_s = time.perf_counter() - t0
        return self

    def __exit__(self, *exc):
        if self._client is not None:
            self._client.close()
        if self._cluster is not None:
            self._cluster.close()
        self._client = self._cluster = None
        return False

    def _workers_now(self) -> dict[str, int]:
        """``{address: pid}`` of the workers the scheduler knows now (asked, not cached)."""
        return self._client.run_on_scheduler(
            lambda dask_scheduler: {a: ws.pid for a, ws in dask_scheduler.workers.items()})

    def _restart(self, addr: str, pid: int | None) -> float:
        """Restart the worker ``addr`` (process ``pid``) and wait for its replacement; seconds taken."""
        t0 = time.perf_counter()
        if self._workers_now().get(addr) == pid:
            try:
                self._client.restart_workers([addr], timeout=120)
            except Exception as e:  # no nanny (external cluster), or the worker is already gone
                if self._workers_now().get(addr) == pid:
                    if self.isolated:
                        self.notes.append(f"worker {addr} could not be restarted between runs "
                                          f"({type(e).__name__}: {e}); later runs shared worker processes")
                    self.isolated = False
                    return time.perf_counter() - t0
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            now = self._workers_now()
            if now.get(addr) != pid and len(now) >= self._n_workers:
                break
            time.sleep(0.05)
        return time.perf_counter() - t0

    def run(self, specs: Sequence[RunSpec],
            on_result: Callable[[int, RunOutput], None] | None = None) -> list[RunOutput]:
        """Run every spec (one per worker at a time, a worker restart after each).

        Parameters
        ----------
        specs : sequence of RunSpec
        on_result : callable, optional
            ``on_result(index, output)`` as each run finishes (in finishing order).

        Returns
        -------
        list of RunOutput
            In the order of ``specs``.
        """
        from distributed import wait
        if self._client is None:
            raise GaspError("Runner.run: use the Runner as a context manager (with Runner() as r: ...)")
        pending = list(enumerate(specs))
        running: dict[Any, tuple[int, str, float]] = {}
        pids: dict[str, int] = {}
        results: list[RunOutput | None] = [None] * len(specs)
        tag = uuid.uuid4().hex[:8]
        starved = 0.0

        def finish(i: int, out: RunOutput, addr: str, t0: float) -> None:
            out.record.setdefault("task_s", 0.0)
            out.record["run_wall_s"] = time.perf_counter() - t0
            out.record["dispatch_s"] = out.record["run_wall_s"] - out.record["task_s"]
            out.record["restart_s"] = self._restart(addr, pids.pop(addr, None))
            out.record["isolated"] = self.isolated
            results[i] = out
            if on_result is not None:
                on_result(i, out)

        while pending or running:
            busy = {a for _, a, _ in running.values()}
            for addr, pid in sorted(self._workers_now().items()):
                if addr in busy:
                    continue
                if not pending:
                    break
                i, spec = pending.pop(0)
                fut = self._client.submit(execute, spec, key=f"gasp-run-{tag}-{i}", workers=[addr],
                                          allow_other_workers=False, pure=False)
                running[fut] = (i, addr, time.perf_counter())
                pids[addr] = pid
            if not running:
                starved = starved or time.monotonic()
                if time.monotonic() - starved > 120:  # the cluster lost its workers for good
                    for i, spec in pending:
                        results[i] = _failed(spec, "crashed", "no Dask worker was available for 120 s")
                        if on_result is not None:
                            on_result(i, results[i])
                    break
                time.sleep(0.05)
                continue
            starved = 0.0
            now = time.perf_counter()
            first_deadline = min(t0 + self.timeout_s for _, _, t0 in running.values())
            try:
                wait(list(running), timeout=max(0.01, min(1.0, first_deadline - now)), return_when="FIRST_COMPLETED")
            except TimeoutError:  # distributed.wait raises when nothing finished in time
                pass
            alive = self._workers_now()
            for fut in list(running):
                i, addr, t0 = running[fut]
                spec = specs[i]
                if fut.status == "finished":
                    del running[fut]
                    finish(i, fut.result(), addr, t0)
                elif fut.status in ("error", "cancelled", "lost"):
                    del running[fut]
                    why = repr(fut.exception()) if fut.status == "error" else fut.status
                    finish(i, _failed(spec, "crashed", f"the worker process failed: {why}"), addr, t0)
                elif alive.get(addr) != pids.get(addr):
                    del running[fut]
                    fut.cancel()
                    finish(i, _failed(spec, "crashed", "the worker process died during the run (killed, "
                                                       "out of memory, or a crash in native code)"), addr, t0)
                elif time.perf_counter() - t0 > self.timeout_s:
                    del running[fut]
                    fut.cancel()
                    finish(i, _failed(spec, "timeout", f"no result within {self.timeout_s:.0f} s; the run was "
                                                       f"cancelled and its worker process restarted"), addr, t0)
        return results  # type: ignore[return-value]
