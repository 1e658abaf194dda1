"""The accuracy report of a run against a reference, in units of the reference's own uncertainty U, and the
rule that picks the ``default`` quality level from it (``docs/speed_accuracy.md``, "Choosing the default").

:func:`accuracy_report` puts :mod:`gasp_studies.accuracy` (centroid, rotation, shape, events) and
:mod:`gasp_studies.images` (PSNR, SSIM) together for one run; with the reference's **twin** (the same model on
the next coarser grid) every figure is also given in units of U = the twin's own figure against the reference
(divided by ``r^p - 1`` where an order ``p`` of convergence was observed: Richardson's estimate of the
reference's distance to the converged answer). :func:`rule_checks` applies the bands of :data:`BANDS`.
"""
from __future__ import annotations

import numpy as np

from .accuracy import CONTACT_GAP_DX, Track, events, split_errors

#: The rule's bands (docs/speed_accuracy.md): shape within ``shape_u`` U; events within their bands.
BANDS = {"shape_u": 1.5, "restitution": 0.03, "contact_rel": 0.10, "rest_height_dx": 0.25, "drift_m": 1e-3,
         "rotation_deg": 1.0}
#: Frame-by-frame figures of the split, and the event differences, reported per object.
SPLIT_KEYS = ("position", "centroid", "rotation_deg", "shape")


def _worst(v) -> float:
    a = np.asarray(v, np.float64)
    return float(np.nanmax(a)) if a.size and np.isfinite(a).any() else float("nan")


def event_differences(run_ev: dict, ref_ev: dict, final_rotation_deg: float) -> dict[str, float]:
    """``|run - ref|`` per event (contact time relative to the reference's), the final xy apart, m, and the
    final relative rotation, degrees. Two NaNs (neither run lifts off, say) differ by 0; one NaN by inf."""
    def d(key, rel=False):
        a, b = run_ev[key], ref_ev[key]
        if np.isnan(a) and np.isnan(b):
            return 0.0
        if np.isnan(a) or np.isnan(b):
            return float("inf")
        return abs(a - b) / (abs(b) if rel and b else 1.0)
    return {"impact_s": d("impact_s"), "restitution": d("restitution"), "contact_rel": d("contact_s", rel=True),
            "rest_height_m": d("rest_height_m"),
            "drift_m": float(np.linalg.norm(np.subtract(run_ev["final_xy"], ref_ev["final_xy"]))),
            "rotation_deg": float(final_rotation_deg)}


def object_figures(run: Track, ref: Track, gap_m: float) -> dict[str, dict]:
    """Per object: the split per frame, its worst frames, the run's and reference's events and their differences."""
    split = split_errors(run, ref)
    out = {}
    for k, name in enumerate(ref.names):
        s = split[name]
        ev_run, ev_ref = events(run, k, gap_m), events(ref, k, gap_m)
        out[name] = {"per_frame": s, "size_m": s["size_m"],
                     "worst": {key: _worst(s[key]) for key in SPLIT_KEYS},
                     "worst_frame": {key: int(np.nanargmax(s[key])) if len(s[key]) else -1 for key in SPLIT_KEYS},
                     "events_run": ev_run, "events_ref": ev_ref,
                     "event_diff": event_differences(ev_run, ev_ref, s["rotation_deg"][-1])}
    return out


def richardson_factor(ratio: float | None, order: float | None) -> float:
    """``1 / (r^p - 1)``: the converged answer's distance from the finest run per unit of its distance to the
    twin (Richardson), or 1 (the twin's distance itself) without an observed order."""
    if ratio is None or order is None or not ratio > 1:
        return 1.0
    return 1.0 / (ratio ** order - 1.0)


def _in_u(value: float, u: float) -> float:
    if not np.isfinite(value):
        return value
    return float(value / u) if u > 0 else (0.0 if value == 0 else float("inf"))


def accuracy_report(run: Track, ref: Track, twin: Track | None = None, *, order: float | None = None,
                    images: dict | None = None) -> dict:
    """The split error of ``run`` against ``ref``, with U from ``twin`` where given.

    Parameters
    ----------
    run, ref : Track
    twin : Track, optional
        The reference's model on the next coarser grid; U of a figure = the twin's figure times
        :func:`richardson_factor` (``r = ref.dx`` ratio ``twin.dx / ref.dx``).
    order : float, optional
        The observed order of convergence of the reference's grid sequence (Richardson).
    images : dict, optional
        ``{"run": scores, "twin": scores, "views": str}`` from :func:`gasp_studies.images.image_scores`.

    Returns
    -------
    dict
        ``objects`` (per object: ``per_frame``, ``worst``, ``events_run``, ``events_ref``, ``event_diff``, and
        with a twin ``u`` and ``in_u`` for the worst split figures and the event differences), ``images``,
        ``gap_m`` (contact gap), ``u_method``.
    """
    dx_ref = ref.dx if np.isfinite(ref.dx) else float("nan")
    gap = CONTACT_GAP_DX * dx_ref if np.isfinite(dx_ref) else 0.01 * float(np.linalg.norm(np.ptp(ref.means[0], 0)))
    figs = object_figures(run, ref, gap)
    out = {"run": run.label, "reference": ref.label, "gap_m": gap, "dx_ref_m": dx_ref, "objects": figs,
           "images": images, "u_method": None}
    if twin is None:
        return out
    r = twin.dx / ref.dx if np.isfinite(twin.dx) and np.isfinite(ref.dx) else None
    fac = richardson_factor(r, order)
    out["u_method"] = (f"Richardson, order {order:.2f}, r = {r:.3g}" if fac != 1.0 else
                       f"distance to the twin ({twin.label}, dx {1e3 * twin.dx:.2f} mm)")
    tw = object_figures(twin, ref, gap)
    for name, f in figs.items():
        u = {**{k: fac * tw[name]["worst"][k] for k in SPLIT_KEYS},
             **{k: fac * v for k, v in tw[name]["event_diff"].items()}}
        mine = {**f["worst"], **f["event_diff"]}
        f["u"], f["in_u"] = u, {k: _in_u(mine[k], u[k]) for k in u}
    return out


def rule_checks(report: dict) -> dict[str, dict]:
    """The ``default`` rule's checks on one report (docs/speed_accuracy.md), worst object first failing.

    Returns ``{check: {"value", "limit", "ok"}}``: ``shape_u`` (worst frame's shape residual in U; needs a
    twin), ``restitution``, ``contact_rel``, ``rest_height_dx``, ``drift_m``, ``rotation_deg`` and, with images,
    ``psnr_db`` (at least the twin's).
    """
    checks: dict[str, dict] = {}

    def put(name, value, limit, ok):
        if name not in checks or not ok:
            checks[name] = {"value": value, "limit": limit, "ok": bool(ok)}
    for f in report["objects"].values():
        d = f["event_diff"]
        if "in_u" in f:
            put("shape_u", f["in_u"]["shape"], BANDS["shape_u"], f["in_u"]["shape"] <= BANDS["shape_u"])
        put("restitution", d["restitution"], BANDS["restitution"], d["restitution"] <= BANDS["restitution"])
        put("contact_rel", d["contact_rel"], BANDS["contact_rel"], d["contact_rel"] <= BANDS["contact_rel"])
        rh = d["rest_height_m"] / report["dx_ref_m"] if np.isfinite(report["dx_ref_m"]) else float("nan")
        put("rest_height_dx", rh, BANDS["rest_height_dx"], rh <= BANDS["rest_height_dx"])
        put("drift_m", d["drift_m"], BANDS["drift_m"], d["drift_m"] <= BANDS["drift_m"])
        put("rotation_deg", d["rotation_deg"], BANDS["rotation_deg"], d["rotation_deg"] <= BANDS["rotation_deg"])
    im = report.get("images")
    if im and im.get("twin"):
        p, pt = im["run"]["psnr_db"], im["twin"]["psnr_db"]
        put("psnr_db", p, pt, p >= pt)
    return checks


def passes(checks: dict[str, dict]) -> bool:
    """Every check of :func:`rule_checks` met."""
    return all(c["ok"] for c in checks.values())


def choose_default(candidates: list[dict]) -> tuple[dict | None, list[str]]:
    """The cheapest candidate meeting every check, and per failing candidate the checks it misses.

    ``candidates``: ``{"name", "cost", "checks"}`` (cost: CPU seconds, say). Returns (the chosen one or None,
    lines "name: check value > limit").
    """
    chosen, why = None, []
    for c in sorted(candidates, key=lambda c: c["cost"]):
        bad = [f"{k} {v['value']:.3g} (limit {v['limit']:.3g})" for k, v in c["checks"].items() if not v["ok"]]
        if not bad and chosen is None:
            chosen = c
        elif bad:
            why.append(f"{c['name']}: " + ", ".join(bad))
    return chosen, why
