"""Divergence between runs: distances between Gaussian means, Chamfer, errors against a reference.

All distances are in the world frame: a file-frame distance times the object's placement scale
(the file -> world map is a similarity). Relative values are divided by the object size, the
diagonal of the bounding box of the reference's frame-0 Gaussian means (world frame, metres).
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

from gasp_core.errors import GaspError

from .run import RunOutput


def steady_s_per_frame(frame_s: Sequence[float]) -> float:
    """Mean wall time of frames 2..n (frame 1 holds JIT compiles); frame 1 if alone; NaN if none."""
    if len(frame_s) == 0:
        return float("nan")
    return float(np.mean(frame_s[1:])) if len(frame_s) > 1 else float(frame_s[0])


def chamfer(a: np.ndarray, b: np.ndarray) -> float:
    """Symmetric Chamfer distance ``0.5 (mean_a min_b |a-b| + mean_b min_a |a-b|)``.

    Parameters
    ----------
    a, b : ndarray, shapes (n, 3), (m, 3)
        Point clouds, any length unit (the result is in the same unit).

    Returns
    -------
    float
        NaN when either cloud is empty.
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
        Means of the same Gaussians (file frame, objects concatenated).
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


def _same_gaussians(ref: RunOutput, other: RunOutput) -> None:
    if ref.means.shape[1] != other.means.shape[1]:
        raise GaspError(f"cannot compare '{other.record['label']}' with '{ref.record['label']}': "
                        f"{other.means.shape[1]} vs {ref.means.shape[1]} Gaussians")


def divergence_rows(ref: RunOutput, other: RunOutput, frame_dt: float, with_chamfer: bool = True) -> list[dict]:
    """Per-frame distance rows of ``other`` against ``ref``.

    Frames are compared while both runs have them (a diverged run stops early). Columns are
    :data:`gasp_studies.report.DIVERGENCE_COLUMNS`; relative values are divided by
    ``ref.record['size_m']``. No rows when either run has no frames.

    Raises
    ------
    GaspError
        If the two runs hold different numbers of Gaussians.
    """
    if ref.means is None or other.means is None:
        return []
    _same_gaussians(ref, other)
    size = float(ref.record["size_m"])
    rows = []
    for f in range(min(len(ref.means), len(other.means))):
        d = frame_distances(ref.means[f], other.means[f], ref.m_per_unit, ref.obj_start, with_chamfer)
        rows.append({"frame": f, "t_s": f * frame_dt, "engine": other.record["label"],
                     "reference": ref.record["label"], **d, "mean_dist_rel": d["mean_dist_m"] / size,
                     "max_dist_rel": d["max_dist_m"] / size, "chamfer_rel": d["chamfer_m"] / size})
    return rows


NAN_ERRORS = {"err_mean": float("nan"), "err_max": float("nan"), "err_final": float("nan"),
              "err_point_max": float("nan")}


def run_errors(ref: RunOutput | None, run: RunOutput) -> dict[str, float]:
    """Errors of ``run`` against ``ref``, as fractions of the object size.

    ``err_mean``: mean over frames 1..n of the per-frame mean distance between the same
    Gaussian's means; ``err_max``: the worst frame's mean distance; ``err_final``: the last
    frame's; ``err_point_max``: the largest single-Gaussian distance over all frames. All NaN when
    either run failed or the two have different shapes (a different Gaussian count).
    """
    if ref is None or ref.means is None or run.means is None or run.record.get("status") != "ok":
        return dict(NAN_ERRORS)
    ma, mb = ref.means.astype(np.float64), run.means.astype(np.float64)
    if ma.shape != mb.shape:
        return dict(NAN_ERRORS)
    size = float(ref.record["size_m"])
    d = np.linalg.norm(ma[1:] - mb[1:], axis=2) * ref.m_per_unit[None, :]
    per_frame = d.mean(axis=1) / size
    return {"err_mean": float(per_frame.mean()), "err_max": float(per_frame.max()),
            "err_final": float(per_frame[-1]), "err_point_max": float(d.max() / size)}


def surface_kinetic(run: RunOutput) -> np.ndarray | None:
    """Kinetic energy per unit mass of the Gaussian means, per frame interval, J/kg times ``frame_dt^2``.

    ``1/2 mean_i |x_i(f) - x_i(f - 1)|^2`` in metres (world frame: the placement is a similarity, so the
    file-frame distance times ``m_per_unit``); shape (n_frames,). None when the run has no means."""
    if run.means is None or len(run.means) < 2:
        return None
    d = np.diff(run.means.astype(np.float64), axis=0) * run.m_per_unit[None, :, None]
    return 0.5 * (d ** 2).sum(axis=2).mean(axis=1)


def energy_figures(ref: RunOutput | None, run: RunOutput) -> dict[str, float]:
    """What a setting costs in energy (``docs/dissipation.md``), from the Gaussians' frame-to-frame motion.

    ``ke_left``: the surface's mean kinetic energy over the last quarter of the frames over its peak (an
    elastic scene that keeps moving stays near its share; a damped one falls towards 0); ``ke_vs_ref``: the
    run's kinetic energy summed over the frames over the reference run's (< 1: the setting damps more than the
    reference). NaN where a run failed or the Gaussian counts differ.
    """
    nan = {"ke_left": float("nan"), "ke_vs_ref": float("nan")}
    ke = surface_kinetic(run) if run.record.get("status") == "ok" else None
    if ke is None or not ke.max() > 0:
        return nan
    out = {"ke_left": float(ke[-max(1, len(ke) // 4):].mean() / ke.max()), "ke_vs_ref": float("nan")}
    k_ref = surface_kinetic(ref) if ref is not None else None
    if k_ref is not None and k_ref.shape == ke.shape and k_ref.sum() > 0:
        out["ke_vs_ref"] = float(ke.sum() / k_ref.sum())
    return out


def pareto_front(cost: Sequence[float], err: Sequence[float]) -> np.ndarray:
    """Mask of the points no other point beats on both axes (minimising both).

    A point is dominated when another has ``cost <=`` and ``err <=`` with at least one strictly
    smaller. Points with a non-finite value are never on the front.

    Parameters
    ----------
    cost, err : sequences of float, same length

    Returns
    -------
    ndarray of bool, shape (n,)

    Raises
    ------
    ValueError
        If the lengths differ.
    """
    c = np.asarray(cost, dtype=np.float64)
    e = np.asarray(err, dtype=np.float64)
    if c.shape != e.shape:
        raise ValueError(f"pareto_front: cost and err must have the same length, got {c.shape} and {e.shape}")
    ok = np.isfinite(c) & np.isfinite(e)
    front = ok.copy()
    for i in np.flatnonzero(ok):
        dominated = ok & (c <= c[i]) & (e <= e[i]) & ((c < c[i]) | (e < e[i]))
        if dominated.any():
            front[i] = False
    return front


def cheapest_within(rows: list[dict], budget: float, key: str = "err_max", cost: str = "wall_s") -> dict | None:
    """The ``ok`` row with the least ``cost`` whose ``key`` error is at most ``budget`` (a fraction)."""
    ok = [r for r in rows if r["status"] == "ok" and np.isfinite(r.get(key, np.nan)) and r[key] <= budget
          and np.isfinite(r.get(cost, np.nan))]
    return min(ok, key=lambda r: r[cost]) if ok else None


def cheapest_ranked(rows: list[dict], budget: float, cost: str = "end_to_end_s") -> tuple[dict | None, str]:
    """The cheapest row within ``budget`` of the engine's converged reference, or why none is ranked.

    ``rows``: one engine's rows, the reference first, with ``err_conv_max`` (worst frame's mean
    distance to the converged reference, :func:`gasp_studies.convergence.sweep_reference`) and
    ``ref_bound`` (that reference's own uncertainty). Without them (no grid sequence) the errors
    against the reference run (``err_max``) are used, the reference itself left out.

    Returns
    -------
    row, why
        ``row`` None with ``why`` "not ranked: ..." when the reference is not known to better than
        ``budget``, or "none" when no run is within it.
    """
    bound = rows[0].get("ref_bound", float("nan")) if rows else float("nan")
    if not np.isfinite(bound):
        c = cheapest_within(rows[1:], budget, "err_max", cost)
        return c, "" if c else "none"
    if bound >= budget:
        return None, f"not ranked: the converged reference is itself uncertain by {100 * bound:.2g} % of the size"
    c = cheapest_within(rows, budget, "err_conv_max", cost)
    return c, "" if c else "none"
