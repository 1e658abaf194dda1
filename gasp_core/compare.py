"""``gasp compare``: one scene on several engines, each in its own process, with a divergence report.

Every engine runs in a fresh ``python -m gasp_core.compare`` child process: Taichi's ``ti.init``
and Genesis's ``gs.init`` are process-global, and a fresh process gives an honest peak memory
(``resource.getrusage(RUSAGE_SELF).ru_maxrss`` of the child). The child runs
:func:`gasp_core.pipeline.iter_frames` and saves the Gaussian means of every frame (file frame,
float32) to an ``.npz`` plus a JSON record of its timings and engine statistics; the parent
compares the runs against the first engine (the reference) frame by frame:

* mean and max distance between corresponding Gaussian means (same Gaussian, two engines), metres;
* the symmetric Chamfer distance ``0.5 (mean_a min_b |a - b| + mean_b min_a |a - b|)`` between the
  two clouds of means (per object, :class:`scipy.spatial.cKDTree`), metres;
* each also relative to the object size: the diagonal of the bounding box of the reference's
  frame-0 Gaussian means, world frame (metres).

Distances are taken in the world frame: a file-frame distance times the object's ``scale``
(the file -> world map is a similarity).

The report folder is written to a temporary folder and moved into place (``os.replace``) only
when it is complete; an existing folder is refused unless ``overwrite``.
"""
from __future__ import annotations

import csv
import dataclasses
import json
import math
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Mapping

import numpy as np

from .engine import EngineError, GaspError, SceneError
from .pipeline import commit_dir  # noqa: F401  (also used by bench)
from .scene import Scene, load_scene

#: Default wall-clock limit of one engine run (child process), seconds.
RUN_TIMEOUT_S = 3600.0

TABLE_COLUMNS = ["engine", "version", "status", "device", "precision", "threads", "simulated_points",
                 "gaussians", "n_frames", "substeps_per_frame", "dt_s", "build_s", "first_frame_s",
                 "s_per_frame", "cpu_s_per_frame", "peak_rss_mb", "options"]
DIVERGENCE_COLUMNS = ["frame", "t_s", "engine", "reference", "mean_dist_m", "max_dist_m", "chamfer_m",
                      "mean_dist_rel", "max_dist_rel", "chamfer_rel"]


# --------------------------------------------------------------------------- scene helpers
def subsample_scene(scene: Scene, max_gaussians: int | None, workdir: Path) -> tuple[Scene, list[int]]:
    """Scene whose objects keep every k-th Gaussian so that each has at most ``max_gaussians``.

    The subsets are written as graphdeco PLYs into ``workdir``; objects already small enough are
    left as they are.

    Returns
    -------
    scene : Scene
        A copy (the input is not changed).
    strides : list of int
        ``k`` per object (1 = all Gaussians).

    Raises
    ------
    SceneError
        If ``max_gaussians`` is not a positive integer, or an object file cannot be read.
    """
    from .io import read_gaussians, write_gaussians
    if max_gaussians is None:
        return scene, [1] * len(scene.objects)
    if isinstance(max_gaussians, bool) or not isinstance(max_gaussians, int) or max_gaussians < 1:
        raise SceneError(f"max_gaussians: expected a positive integer, got {max_gaussians!r}")
    objects, strides = [], []
    for i, spec in enumerate(scene.objects):
        g = read_gaussians(spec.file)
        k = max(1, math.ceil(g.n / max_gaussians))
        strides.append(k)
        if k == 1:
            objects.append(spec)
            continue
        path = Path(workdir) / f"{i}_{Path(spec.file).stem}_every{k}.ply"
        write_gaussians(path, g.subset(np.arange(0, g.n, k)), overwrite=True)
        # keep the object's name (output stem) recognisable; placement uses the subset's own bbox
        objects.append(dataclasses.replace(spec, file=path))
    return dataclasses.replace(scene, objects=objects), strides


def engine_options(scene: Scene, engine: str, options: Mapping[str, Mapping] | None = None) -> dict:
    """Options for ``engine``: the scene's ``[engine] options`` if it names this engine, else none;
    then ``options[engine]`` on top."""
    out = dict(scene.engine.options) if scene.engine.name == engine else {}
    if options and engine in options:
        out.update(options[engine])
    return out


def select_engines(scene: Scene, requested: Iterable[str] | None,
                   grid_only: bool = False) -> tuple[list[str], dict[str, str]]:
    """Engines that can run ``scene``, and the reason for each that cannot.

    Parameters
    ----------
    scene : Scene
    requested : iterable of str or None
        Engine names in order (duplicates allowed: a repeated run of the same engine); None for
        every installed engine.
    grid_only : bool
        With ``requested=None``, keep grid-based engines only.

    Returns
    -------
    runnable : list of str
    skipped : dict
        ``{engine: reason}`` (not installed, not available here, missing material or boundary).
    """
    from .pipeline import check_capabilities
    from .plugins import engines as all_engines
    found = all_engines()
    names = list(requested) if requested is not None else \
        [n for n, e in found.items() if not grid_only or "grid" in e.capabilities.features]
    runnable, skipped = [], {}
    for name in names:
        if name not in found:
            skipped[name] = f"not installed (installed engines: {sorted(found) or 'none'})"
            continue
        info = found[name]
        reason = info.unavailable_reason()
        if reason:
            skipped[name] = f"not available: {reason}"
            continue
        try:
            check_capabilities(info, scene, found)
        except EngineError as e:
            skipped[name] = str(e)
            continue
        runnable.append(name)
    return runnable, skipped


# --------------------------------------------------------------------------- child process
def _child_main(job_path: str) -> int:
    """Run one engine (``python -m gasp_core.compare JOB.pkl``); writes ``job['npz']``, ``job['json']``."""
    import resource
    import traceback
    with open(job_path, "rb") as f:
        job = pickle.load(f)
    rec: dict[str, Any] = {"engine": job["engine"], "label": job.get("label", job["engine"]),
                           "status": "ok", "options": job["options"]}
    means: list[np.ndarray] = []
    m_per_unit = obj_start = None
    t_start = time.perf_counter()
    try:
        from .pipeline import iter_frames, prepare_scene
        from .runner import RunStats
        from .engine import EngineDivergence
        scene: Scene = job["scene"]
        t0 = time.perf_counter()
        prep = prepare_scene(scene, job["engine"], job["options"])
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
            for frame, gs, row in iter_frames(prep, job["n_frames"], stats):
                cpu_marks.append(time.process_time())
                means.append(np.concatenate([g.means for g in gs]).astype(np.float32))
        except EngineDivergence as e:
            rec.update(status="diverged", frame=e.frame, cause=e.cause, message=str(e))
        rec["build_s"] = stats.build_s
        rec["frame_s"] = list(stats.frame_s)
        # process CPU time between frames (all threads; includes the T^-1 rebuild; frame 1 the build)
        rec["frame_cpu_s"] = np.diff(cpu_marks).tolist()
        rec["engine_stats"] = stats.engine
    except GaspError as e:
        rec.update(status="error", message=f"{type(e).__name__}: {e}")
    except Exception as e:  # reported, never fatal to the comparison
        rec.update(status="error", message=f"{type(e).__name__}: {e}", traceback=traceback.format_exc())
    rec["child_wall_s"] = time.perf_counter() - t_start
    rec["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # KiB on Linux
    rec["frames_saved"] = len(means)
    if means:
        np.savez_compressed(job["npz"], means=np.stack(means), m_per_unit=m_per_unit, obj_start=obj_start)
    tmp = job["json"] + ".tmp"
    with open(tmp, "w") as f:
        json.dump(rec, f, indent=2, default=str)
    os.replace(tmp, job["json"])
    return 0


def run_engine_subprocess(scene: Scene, engine: str, options: dict, n_frames: int, workdir: Path,
                          label: str | None = None, timeout_s: float = RUN_TIMEOUT_S) -> dict:
    """Run ``scene`` on ``engine`` in a fresh Python process and return its record.

    Parameters
    ----------
    scene : Scene
        Already adjusted (settings, subsets); pickled to the child.
    engine : str
    options : dict
        Engine options (replace the scene's).
    n_frames : int
    workdir : Path
        Receives ``<label>.npz`` (means per frame, float32, shape (frames, n, 3), file frame;
        ``m_per_unit`` (n,) metres per file unit; ``obj_start`` object row offsets),
        ``<label>.json`` (the record) and ``<label>.log`` (the child's stdout and stderr).
    label : str, optional
        File stem (default ``engine``).
    timeout_s : float

    Returns
    -------
    dict
        ``status`` is ``ok``, ``diverged`` (with ``frame``, ``cause``, ``message``), ``error``
        (``message``), ``timeout`` or ``crashed`` (exit code); plus ``frame_s`` (per frame, s),
        ``build_s``, ``engine_stats``, ``peak_rss_mb``, ``size_m``, ``simulated_points``,
        ``npz`` (path or None).
    """
    label = label or engine
    workdir = Path(workdir)
    job = {"scene": scene, "engine": engine, "label": label, "options": dict(options),
           "n_frames": int(n_frames), "npz": str(workdir / f"{label}.npz"),
           "json": str(workdir / f"{label}.json")}
    job_path = workdir / f"{label}.job.pkl"
    with open(job_path, "wb") as f:
        pickle.dump(job, f)
    log = workdir / f"{label}.log"
    t0 = time.perf_counter()
    with open(log, "w") as logf:
        try:
            proc = subprocess.run([sys.executable, "-m", "gasp_core.compare", str(job_path)],
                                  stdout=logf, stderr=subprocess.STDOUT, timeout=timeout_s)
            code = proc.returncode
        except subprocess.TimeoutExpired:
            code = None
    job_path.unlink(missing_ok=True)
    wall = time.perf_counter() - t0
    if Path(job["json"]).exists():
        rec = json.loads(Path(job["json"]).read_text())
    elif code is None:
        rec = {"engine": engine, "label": label, "status": "timeout",
               "message": f"no result within {timeout_s:.0f} s; the child process was killed"}
    else:
        tail = log.read_text(errors="replace")[-600:]
        rec = {"engine": engine, "label": label, "status": "crashed",
               "message": f"child process exited with code {code} without a result; log tail: {tail}"}
    rec.setdefault("options", dict(options))
    rec["process_wall_s"] = wall
    rec["npz"] = job["npz"] if Path(job["npz"]).exists() else None
    rec["log"] = str(log)
    return rec


def steady_s_per_frame(frame_s: list[float]) -> float:
    """Mean wall time of frames 2..n (frame 1 holds the JIT compile of Taichi/Genesis); frame 1 if alone."""
    if not frame_s:
        return float("nan")
    return float(np.mean(frame_s[1:])) if len(frame_s) > 1 else float(frame_s[0])


# --------------------------------------------------------------------------- metrics
def chamfer(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Chamfer distance ``0.5 (mean_a min_b |a-b| + mean_b min_a |a-b|)``.

    Parameters
    ----------
    a, b : ndarray, shapes (n, 3), (m, 3)
        Point clouds, any length unit (the result is in the same unit).

    Returns
    -------
    float
    """
    from scipy.spatial import cKDTree
    if len(a) == 0 or len(b) == 0:
        return float("nan")
    da, _ = cKDTree(b).query(a, k=1)
    db, _ = cKDTree(a).query(b, k=1)
    return 0.5 * (float(da.mean()) + float(db.mean()))


def frame_distances(a: np.ndarray, b: np.ndarray, m_per_unit: np.ndarray, obj_start: np.ndarray,
                    with_chamfer: bool = True) -> dict[str, float]:
    """Distances between two frames of Gaussian means, metres.

    Parameters
    ----------
    a, b : ndarray, shape (n, 3)
        Means of the same Gaussians (file frame, concatenated objects).
    m_per_unit : ndarray, shape (n,)
        Metres per file unit of each row (the object's ``scale``).
    obj_start : ndarray, shape (n_objects + 1,)
        Row offsets of the objects.
    with_chamfer : bool

    Returns
    -------
    dict
        ``mean_dist_m``, ``max_dist_m`` (corresponding means) and ``chamfer_m`` (per object,
        weighted by Gaussian count; NaN when ``with_chamfer`` is false).
    """
    a64, b64 = a.astype(np.float64), b.astype(np.float64)
    d = np.linalg.norm(a64 - b64, axis=1) * m_per_unit
    out = {"mean_dist_m": float(d.mean()), "max_dist_m": float(d.max()), "chamfer_m": float("nan")}
    if with_chamfer:
        total = 0.0
        for s, e in zip(obj_start[:-1], obj_start[1:]):
            if e > s:
                total += chamfer(a64[s:e], b64[s:e]) * float(m_per_unit[s]) * (e - s)
        out["chamfer_m"] = total / max(len(a), 1)
    return out


def divergence_rows(ref: dict, other: dict, frame_dt: float, with_chamfer: bool = True) -> list[dict]:
    """Per-frame distance rows of ``other`` against ``ref`` (records from :func:`run_engine_subprocess`).

    Frames are compared while both runs have them (a diverged run stops early). Relative values are
    divided by ``ref['size_m']``.

    Raises
    ------
    GaspError
        If the two runs hold different numbers of Gaussians.
    """
    if not ref.get("npz") or not other.get("npz"):
        return []
    A, B = np.load(ref["npz"]), np.load(other["npz"])
    ma, mb = A["means"], B["means"]
    if ma.shape[1] != mb.shape[1]:
        raise GaspError(f"cannot compare '{other['label']}' with '{ref['label']}': "
                        f"{mb.shape[1]} vs {ma.shape[1]} Gaussians")
    size = float(ref["size_m"])
    rows = []
    for f in range(min(len(ma), len(mb))):
        d = frame_distances(ma[f], mb[f], A["m_per_unit"], A["obj_start"], with_chamfer)
        rows.append({"frame": f, "t_s": f * frame_dt, "engine": other["label"], "reference": ref["label"],
                     **d, "mean_dist_rel": d["mean_dist_m"] / size, "max_dist_rel": d["max_dist_m"] / size,
                     "chamfer_rel": d["chamfer_m"] / size})
    return rows


# --------------------------------------------------------------------------- output helpers
def write_csv(path: Path, rows: list[dict], columns: list[str]) -> None:
    """Write ``rows`` (dicts) with the given column order; floats with 6 significant digits."""
    def fmt(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.6g}"
        if isinstance(v, (dict, list)):
            return json.dumps(v, sort_keys=True)
        return "" if v is None else v
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: fmt(r.get(k)) for k in columns})


def md_table(rows: list[dict], columns: list[str], headers: list[str] | None = None) -> str:
    """A GitHub Markdown table."""
    def fmt(v):
        if isinstance(v, float):
            return "-" if math.isnan(v) else f"{v:.4g}"
        if isinstance(v, dict):
            return ", ".join(f"{k}={val}" for k, val in v.items()) or "-"
        return "-" if v is None or v == "" else str(v)
    headers = headers or columns
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(fmt(r.get(c)) for c in columns) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def _table_row(rec: dict, n_frames: int) -> dict:
    st = rec.get("engine_stats") or {}
    frame_s = rec.get("frame_s") or []
    status = rec["status"] if rec["status"] != "diverged" else \
        f"diverged at frame {rec.get('frame')}: {rec.get('cause', '')}"
    return {"engine": rec["label"], "version": rec.get("version", ""), "status": status,
            "device": st.get("device", rec.get("options", {}).get("device", "")),
            "precision": st.get("precision", ""), "threads": st.get("threads", ""),
            "simulated_points": rec.get("simulated_points"), "gaussians": rec.get("gaussians"),
            "n_frames": len(frame_s), "substeps_per_frame": st.get("n_substeps"),
            "dt_s": st.get("dt"), "build_s": rec.get("build_s"),
            "first_frame_s": frame_s[0] if frame_s else None,
            "s_per_frame": steady_s_per_frame(frame_s) if frame_s else None,
            "cpu_s_per_frame": steady_s_per_frame(rec.get("frame_cpu_s") or []) if frame_s else None,
            "peak_rss_mb": rec.get("peak_rss_mb"), "options": rec.get("options", {})}


def _plots(outdir: Path, table: list[dict], div: list[dict], reference: str | None) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    labels = sorted({r["engine"] for r in div if r["engine"] != reference}, key=lambda e: [t["engine"] for t in table].index(e))
    for lab in labels:
        rs = [r for r in div if r["engine"] == lab]
        t = [r["t_s"] for r in rs]
        axes[0].plot(t, [100 * r["mean_dist_rel"] for r in rs], marker="o", ms=3, label=lab)
        axes[1].plot(t, [100 * r["chamfer_rel"] for r in rs], marker="o", ms=3, label=lab)
    axes[0].set_title(f"mean distance of Gaussian means vs {reference}")
    axes[1].set_title(f"symmetric Chamfer distance vs {reference}")
    for ax in axes:
        ax.set_xlabel("time, s")
        ax.set_ylabel("% of object size (bbox diagonal)")
        ax.grid(alpha=0.3)
        if labels:
            ax.legend()
    fig.tight_layout()
    fig.savefig(outdir / "divergence.png", dpi=110)
    plt.close(fig)

    ran = [r for r in table if r.get("s_per_frame") is not None]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    names = [r["engine"] for r in ran]
    y = np.arange(len(ran))
    axes[0].barh(y, [r["s_per_frame"] for r in ran], color="tab:blue", label="frames 2..n (mean)")
    axes[0].scatter([r["first_frame_s"] for r in ran], y, color="tab:red", zorder=3,
                    label="frame 1 (incl. JIT compile)")
    axes[0].set_xlabel("wall time per frame, s")
    axes[0].legend(fontsize=8)
    axes[1].barh(y, [r["peak_rss_mb"] or 0 for r in ran], color="tab:green")
    axes[1].set_xlabel("peak resident memory of the engine process, MB")
    for ax in axes:
        ax.set_yticks(y, names)
        ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    fig.savefig(outdir / "timing.png", dpi=110)
    plt.close(fig)


@dataclass
class CompareResult:
    """What :func:`compare_scene` did."""

    outdir: Path
    reference: str | None
    table: list[dict]
    divergence: list[dict]
    skipped: dict[str, str] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)


def compare_scene(scene_path: str | Path, engines: list[str] | None, output: str | Path, *,
                  overwrite: bool = False, n_frames: int | None = None,
                  options: Mapping[str, Mapping] | None = None, max_gaussians: int | None = None,
                  timeout_s: float = RUN_TIMEOUT_S, keep_runs: bool = True,
                  progress: bool = True) -> CompareResult:
    """Run one scene on several engines (one process each) and write a comparison report.

    Layout of ``output``: ``table.csv``/``table.md`` (per engine: version, device, simulated
    points, substeps per frame, wall time per frame, peak memory), ``divergence.csv`` (per frame
    and engine against the reference, the first engine that ran), ``divergence.png``,
    ``timing.png``, ``report.md``, and ``runs/`` (per engine: means ``.npz``, record ``.json``, log).

    Parameters
    ----------
    scene_path : str or Path
        Scene TOML.
    engines : list of str or None
        Engine names in order; the first one that runs is the reference. None: every installed
        engine that can run the scene. A name may repeat (a repeated run, labelled ``name#2``).
    output : str or Path
        Report folder; must not exist unless ``overwrite``.
    overwrite : bool
    n_frames : int, optional
        Override the scene's ``n_frames``.
    options : dict, optional
        ``{engine: {option: value}}`` on top of the scene's ``[engine] options`` (which apply only
        to the engine the scene names).
    max_gaussians : int, optional
        Keep every k-th Gaussian so that each object has at most this many (None: all).
    timeout_s : float
        Per-engine wall-clock limit, seconds.
    keep_runs : bool
        Keep ``runs/*.npz`` (the means per frame).
    progress : bool
        One line per engine on stderr.

    Returns
    -------
    CompareResult

    Raises
    ------
    FileExistsError
        ``output`` exists and ``overwrite`` is false (before any work).
    SceneError
        Bad scene file or argument.
    EngineError
        No engine could run the scene at all (the reasons are in the message).
    """
    output = Path(output)
    if output.exists() and not overwrite:
        raise FileExistsError(f"output folder '{output}' exists; pass --overwrite to replace it")
    scene = load_scene(scene_path)
    if n_frames is not None and (isinstance(n_frames, bool) or not isinstance(n_frames, int) or n_frames < 1):
        raise SceneError(f"n_frames: expected a positive integer, got {n_frames!r}")
    n_frames = scene.n_frames if n_frames is None else n_frames
    runnable, skipped = select_engines(scene, engines)
    if not runnable:
        raise EngineError(f"no engine can run {scene_path}: " +
                          "; ".join(f"{k}: {v}" for k, v in skipped.items()))
    output.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=output.parent, prefix=f".{output.name}.partial-"))
    try:
        runs = tmp / "runs"
        runs.mkdir()
        scene_run, strides = subsample_scene(scene, max_gaussians, runs)
        records, seen = [], {}
        for name in runnable:
            seen[name] = seen.get(name, 0) + 1
            label = name if seen[name] == 1 else f"{name}#{seen[name]}"
            if progress:
                print(f"gasp compare: running {label} ({n_frames} frames) ...", file=sys.stderr, flush=True)
            rec = run_engine_subprocess(scene_run, name, engine_options(scene, name, options), n_frames,
                                        runs, label=label.replace("#", "_"), timeout_s=timeout_s)
            rec["label"] = label
            records.append(rec)
            if progress:
                sp = steady_s_per_frame(rec.get("frame_s") or [])
                print(f"gasp compare: {label}: {rec['status']}"
                      + (f", {sp:.3f} s/frame, peak {rec.get('peak_rss_mb', 0):.0f} MB" if rec.get("frame_s") else "")
                      + (f" ({rec.get('message')})" if rec["status"] != "ok" else ""), file=sys.stderr, flush=True)
        failed = {r["label"]: (f"diverged at frame {r['frame']}: {r.get('message', '')}" if r["status"] == "diverged"
                               else f"{r['status']}: {r.get('message', '')}") for r in records if r["status"] != "ok"}
        ref = next((r for r in records if r["status"] == "ok"), None)
        table = [_table_row(r, n_frames) for r in records]
        div: list[dict] = []
        if ref is not None:
            for r in records:
                if r is not ref:
                    div += divergence_rows(ref, r, scene.frame_dt)
        write_csv(tmp / "table.csv", table, TABLE_COLUMNS)
        headers = ["engine", "version", "status", "device", "precision", "threads", "simulated points",
                   "Gaussians", "frames", "substeps/frame", "dt, s", "build, s", "frame 1, s",
                   "s/frame (2..n)", "CPU s/frame (2..n)", "peak memory, MB", "options"]
        (tmp / "table.md").write_text(md_table(table, TABLE_COLUMNS, headers))
        write_csv(tmp / "divergence.csv", div, DIVERGENCE_COLUMNS)
        _plots(tmp, table, div, ref["label"] if ref else None)
        _report(tmp, scene, scene_path, n_frames, table, div, ref, skipped, failed, strides, records)
        if not keep_runs:
            for p in runs.glob("*.npz"):
                p.unlink()
        commit_dir(tmp, output)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if progress:
        print(f"gasp compare: wrote {output}/report.md", file=sys.stderr)
    return CompareResult(output, ref["label"] if ref else None, table, div, skipped, failed)


def _report(tmp: Path, scene: Scene, scene_path, n_frames: int, table: list[dict], div: list[dict],
            ref: dict | None, skipped: dict, failed: dict, strides: list[int], records: list[dict]) -> None:
    import platform
    lines = [f"# Engine comparison: {scene.name}", "",
             f"Scene `{scene_path}`, {n_frames} frames of {scene.frame_dt:.4g} s "
             f"({n_frames * scene.frame_dt:.3g} s simulated). Each engine ran in its own Python process "
             f"(`python -m gasp_core.compare`), one after the other, on {platform.machine()} with "
             f"{os.cpu_count()} logical CPUs (load average at the end: "
             f"{', '.join(f'{x:.1f}' for x in os.getloadavg())}).", ""]
    if any(k > 1 for k in strides):
        lines += [f"Objects were cut to every k-th Gaussian, k = {strides} (max_gaussians).", ""]
    lines += ["## Engines", "", (tmp / "table.md").read_text(), "",
              "`s/frame (2..n)` is the mean wall time of `step_frame` plus read-back over frames 2..n; "
              "frame 1 also holds the JIT compile (Taichi, Genesis) and is shown apart. `CPU s/frame` is the "
              "process CPU time per frame (all threads, T^-1 rebuild included): on a shared machine it "
              "depends less on the load than wall time. Peak memory is "
              "the child process's `ru_maxrss` (Python, the engine runtime and the scene).", ""]
    if skipped:
        lines += ["## Not run", ""] + [f"- `{k}`: {v}" for k, v in skipped.items()] + [""]
    if failed:
        lines += ["## Failed", ""] + [f"- `{k}`: {v}" for k, v in failed.items()] + [""]
    if ref is not None:
        lines += [f"## Divergence against `{ref['label']}`", "",
                  f"Object size (bounding-box diagonal of the frame-0 Gaussian means, world frame): "
                  f"{ref['size_m']:.4g} m. `mean`/`max`: distance between the same Gaussian's means "
                  f"in the two runs; `Chamfer`: symmetric Chamfer distance between the two clouds of "
                  f"means (0.5 (mean_a min_b + mean_b min_a)). Full per-frame values: `divergence.csv`.",
                  ""]
        summ = []
        for r in records:
            if r is ref or not r.get("npz"):
                continue
            rs = [d for d in div if d["engine"] == r["label"]]
            if not rs:
                continue
            last = rs[-1]
            worst = max(rs, key=lambda d: d["mean_dist_rel"])
            summ.append({"engine": r["label"], "frames": len(rs) - 1,
                         "final_mean": 100 * last["mean_dist_rel"], "final_max": 100 * last["max_dist_rel"],
                         "final_chamfer": 100 * last["chamfer_rel"], "worst_mean": 100 * worst["mean_dist_rel"],
                         "worst_frame": worst["frame"], "final_mean_mm": 1000 * last["mean_dist_m"]})
        if summ:
            lines += [md_table(summ, ["engine", "frames", "final_mean_mm", "final_mean", "final_max",
                                      "final_chamfer", "worst_mean", "worst_frame"],
                               ["engine", "frames compared", "final mean, mm", "final mean, % size",
                                "final max, % size", "final Chamfer, % size", "worst mean, % size",
                                "at frame"]), ""]
        lines += ["![divergence](divergence.png)", "", "![timing](timing.png)", ""]
    (tmp / "report.md").write_text("\n".join(lines))


if __name__ == "__main__":
    sys.exit(_child_main(sys.argv[1]))
