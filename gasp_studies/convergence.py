"""A converged reference from a grid sequence, with its own uncertainty stated.

A run's error is only as good as the answer it is measured against. The finest run of a sweep is
not the converged answer: its own discretisation error can be as large as the differences between
the settings being compared (the README donut: the full model at ``n_grid`` 64 is 8 % of its size
from ``n_grid`` 96). This module turns runs of one model on several grids into

* a **Richardson estimate** of the converged means (three or more grids, a consistent observed
  order of convergence), and the finest run's distance to it as the reference's uncertainty; or
* where that cannot be made (two grids, or a sequence that does not converge monotonically), the
  **finest run** with its distance to the next coarser run as the uncertainty.

Notation: grid spacing ``h = 1 / n_grid`` (the domain is the same for every run), means
``x_h = x* + C h^p`` (Roache, *Verification and Validation in Computational Science and
Engineering*, 1998, ch. 5; Celik et al., "Procedure for estimation and reporting of uncertainty due
to discretization in CFD applications", J. Fluids Eng. 130 (2008) 078001). Distances are the mean
over Gaussians of the distance between the same Gaussian's means, per frame, divided by the object
size; the sequence's scalar is the root mean square over frames of these per-frame distances.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Orders outside this range are not trusted (a sequence outside the asymptotic range, or noise).
ORDER_RANGE = (0.5, 4.0)
#: Per-frame distances below this fraction of the size count as "no difference" (float rounding).
FLOOR = 1e-7


@dataclass
class Reference:
    """A reference answer and its uncertainty.

    Attributes
    ----------
    means : ndarray, shape (n_frames, n, 3), float64
        The reference means per frame (world metres, or whatever unit the runs were given in).
    uncertainty : ndarray, shape (n_frames,)
        Estimated distance of the finest run from the converged answer per frame (Richardson), or
        the finest run's distance to the next coarser one (``method = "finest"``); fraction of
        the size.
    method : str
        ``"richardson"`` or ``"finest"``.
    grids : list of int
        The ``n_grid`` values used, coarse to fine.
    order : float or None
        The observed order of convergence (Richardson only).
    note : str
        Why Richardson was not used, or empty.
    """

    means: np.ndarray
    uncertainty: np.ndarray
    method: str
    grids: list[int]
    order: float | None = None
    note: str = ""
    extra: dict = field(default_factory=dict)

    @property
    def bound(self) -> float:
        """The reference's uncertainty on its worst frame, fraction of the size."""
        return float(self.uncertainty.max()) if self.uncertainty.size else 0.0

    def converged(self, tolerance: float) -> bool:
        """True when the reference is known to better than ``tolerance`` (fraction of the size) on every frame."""
        return self.bound < tolerance

    def summary(self) -> dict:
        """JSON-ready description (no arrays but the per-frame uncertainty)."""
        return {"method": self.method, "grids": self.grids, "order": self.order, "bound": self.bound,
                "note": self.note, "uncertainty_per_frame": [round(float(u), 6) for u in self.uncertainty],
                **self.extra}


def frame_distance(a: np.ndarray, b: np.ndarray, size: float) -> np.ndarray:
    """Per-frame mean distance between the same Gaussians' means, / ``size``.

    Parameters
    ----------
    a, b : ndarray, shape (n_frames, n, 3)
        Means; only the frames both have are compared.
    size : float
        Object size, same unit as the means (> 0).

    Returns
    -------
    ndarray, shape (min(len(a), len(b)),), float64
    """
    n = min(len(a), len(b))
    d = np.linalg.norm(np.asarray(a[:n], np.float64) - np.asarray(b[:n], np.float64), axis=2)
    return d.mean(axis=1) / float(size)


def _rms(e: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.square(e)))) if e.size else 0.0


def observed_order(e_coarse: float, e_fine: float, n: tuple[int, int, int]) -> float | None:
    """Order ``p`` of three grids from their two differences, or None if there is none in :data:`ORDER_RANGE`.

    ``e_coarse = |x_1 - x_2|`` and ``e_fine = |x_2 - x_3|`` for grids ``n = (n_1, n_2, n_3)``
    (coarse to fine, spacing ``1 / n``). With ``x_h = x* + C h^p`` their ratio is
    ``(h_1^p - h_2^p) / (h_2^p - h_3^p)``, which grows with ``p``; solved by bisection.
    """
    if not (e_fine > 0 and e_coarse > 0) or not (n[0] < n[1] < n[2]):
        return None
    h = 1.0 / np.asarray(n, np.float64)
    target = e_coarse / e_fine

    def ratio(p: float) -> float:
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p)
    lo, hi = ORDER_RANGE
    if not ratio(lo) <= target <= ratio(hi):
        return None
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ratio(mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def reference(runs: dict[int, np.ndarray], size: float) -> Reference:
    """The converged reference of one model's runs on several grids.

    Parameters
    ----------
    runs : dict
        ``{n_grid: means}``, means shape (n_frames, n, 3), the same Gaussians in every run; the
        frames all runs have are used. At least one run.
    size : float
        Object size (same unit as the means).

    Returns
    -------
    Reference
        Richardson from the three finest grids when their observed order is in :data:`ORDER_RANGE`
        (then ``means = x_3 + (x_3 - x_2) / (r^p - 1)``, ``r = n_3 / n_2``, and the uncertainty is the
        finest run's per-frame distance to it); otherwise the finest run, uncertainty its per-frame
        distance to the next coarser run (infinite with a single run).

    Raises
    ------
    ValueError
        No runs, or runs with different numbers of Gaussians.
    """
    if not runs:
        raise ValueError("reference: no runs")
    grids = sorted(runs)
    arrays = [np.asarray(runs[g], np.float64) for g in grids]
    if len({a.shape[1] for a in arrays}) != 1:
        raise ValueError(f"reference: the runs hold different numbers of Gaussians: {[a.shape[1] for a in arrays]}")
    n_frames = min(len(a) for a in arrays)
    arrays = [a[:n_frames] for a in arrays]
    fine = arrays[-1]
    if len(grids) == 1:
        return Reference(fine, np.full(n_frames, np.inf), "finest", grids,
                         note="a single grid: its distance to the converged answer is unknown")
    d_fine = frame_distance(arrays[-2], fine, size)
    if len(grids) >= 3:
        d_coarse = frame_distance(arrays[-3], arrays[-2], size)
        e1, e2 = _rms(d_coarse), _rms(d_fine)
        p = observed_order(e1, e2, tuple(grids[-3:]))
        if e2 <= FLOOR:
            return Reference(fine, d_fine, "finest", grids[-2:], note="the two finest grids agree to rounding")
        if p is not None:
            r = grids[-1] / grids[-2]
            means = fine + (fine - arrays[-2]) / (r ** p - 1.0)
            return Reference(means, frame_distance(fine, means, size), "richardson", grids[-3:], order=p,
                             extra={"rms_distance_coarse": e1, "rms_distance_fine": e2})
        note = (f"no order of convergence in {ORDER_RANGE} from n_grid {grids[-3:]} (rms distances "
                f"{100 * e1:.3g} % then {100 * e2:.3g} % of the size): not in the asymptotic range")
    else:
        note = "two grids: Richardson needs three"
    return Reference(fine, d_fine, "finest", grids[-2:], note=note)


def verdict(errors: np.ndarray, ref: Reference, tolerance: float, own: np.ndarray | None = None,
            margin: float = 0.005) -> dict:
    """Whether a run stays within ``tolerance`` of the reference on every frame, or says why it cannot be told.

    Parameters
    ----------
    errors : ndarray, shape (n_frames,)
        The run's per-frame distance to ``ref.means``, fraction of the size.
    ref : Reference
    tolerance : float
        Fraction of the size (0.01 for "1 % of the object size").
    own : ndarray, optional
        The full model's own per-frame distance to the reference; the run then also passes when
        it stays within ``own + margin`` on every frame (the issue's second criterion), and is
        ranked where the reference's uncertainty is below that allowance on every frame.
    margin : float

    Returns
    -------
    dict
        ``ranked`` (false when the reference is not known to better than ``tolerance``: the
        run is then neither passed nor failed), ``within`` (bool or None), ``worst`` (largest
        per-frame error), ``worst_frame``, ``reference_bound``.
    """
    e = np.asarray(errors, np.float64)
    n = min(len(e), len(ref.uncertainty))
    e = e[:n]
    allowed = np.full(n, tolerance)
    if own is not None:
        allowed = np.maximum(allowed, np.asarray(own, np.float64)[:n] + margin)
    # ranked where the reference is known better than what is asked on every frame
    ranked = bool(np.all(ref.uncertainty[:n] < allowed)) if n else False
    out = {"worst": float(e.max()) if n else float("nan"), "worst_frame": int(e.argmax()) if n else -1,
           "reference_bound": ref.bound, "tolerance": tolerance, "ranked": ranked,
           "worst_allowed": float(allowed.max()) if n else float("nan")}
    if not ranked:
        out["within"] = None
        out["why"] = (f"the reference ({ref.method}, n_grid {ref.grids}) is itself uncertain by "
                      f"{100 * ref.bound:.2f} % of the size, not better than the {100 * tolerance:g} % asked for")
        return out
    out["within"] = bool(np.all(e <= allowed))
    return out


def sweep_reference(reference_setting: dict, runs: list[tuple[dict, np.ndarray | None]], size: float,
                    ignore: tuple[str, ...] = ("n_grid", "precision")) -> Reference | None:
    """The converged reference of a ``gasp bench`` sweep: the reference setting's model on every grid swept.

    Parameters
    ----------
    reference_setting : dict
        The engine's reference (its finest setting).
    runs : list of (setting, means)
        Every run of the engine, the reference first; ``means`` shape (n_frames, n, 3) in metres, or
        None for a failed run.
    size : float
        Object size, metres.
    ignore : tuple of str
        Keys in which a run may differ from the reference and still count as the same model on
        another grid (``precision``: f32 and f64 agree to 1e-6 of the size, ``docs/speed_accuracy.md``).

    Returns
    -------
    Reference or None
        None when the reference setting has no ``n_grid`` or its run failed. Of runs on the same
        grid, the one whose setting is the reference (or the first) is used.
    """
    if "n_grid" not in reference_setting or not runs or runs[0][1] is None:
        return None
    model = {k: v for k, v in reference_setting.items() if k not in ignore}
    seq: dict[int, np.ndarray] = {}
    for s, m in runs:
        if m is not None and {k: v for k, v in s.items() if k not in ignore} == model:
            if s == reference_setting or s["n_grid"] not in seq:
                seq[int(s["n_grid"])] = m
    return reference(seq, size)


def conv_errors(rows: list[dict], runs: list[tuple[dict, object]]) -> None:
    """Add ``err_conv_max`` (worst frame's mean distance to the converged reference, fraction of the size) and
    ``ref_bound`` / ``ref_method`` (that reference's uncertainty and how it was made) to one engine's rows,
    reference first (:func:`sweep_reference`; ``runs``: (setting, :class:`gasp_studies.run.RunOutput`)); NaN / "" where
    there is none."""
    def metres(out):
        ok = out.means is not None and out.record.get("status") == "ok"
        return out.means.astype(np.float64) * out.m_per_unit[None, :, None] if ok else None
    world = [(s, metres(o)) for s, o in runs]
    size = float(runs[0][1].record.get("size_m") or np.nan) if runs else np.nan
    conv = sweep_reference(runs[0][0], world, size) if runs and np.isfinite(size) else None
    for r, (_, m) in zip(rows, world):
        ok = conv is not None and m is not None and m.shape[1:] == conv.means.shape[1:]
        r["err_conv_max"] = float(frame_distance(m, conv.means, size).max()) if ok else float("nan")
        r["ref_bound"] = conv.bound if conv is not None else float("nan")
        r["ref_method"] = f"{conv.method} {conv.grids}" if conv is not None else ""
