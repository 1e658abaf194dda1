"""The error of a run against a reference run, split into what a user sees: motion, rotation, shape, events.

The position error of :mod:`gasp_studies.measure` (mean distance between the same Gaussians' means) mixes
a body's motion, its turning and its deformation: a bounce that lands one frame later costs as much as a
body that came out misshapen. Here, per object and per frame (world frame, metres, then divided by the
object size: the diagonal of the bounding box of the reference's frame-0 means):

* **centroid**: ``|c_run - c_ref|``, ``c`` the mean of the object's Gaussian means;
* **rotation**: the angle of the best rotation taking the run's centred means onto the reference's
  (Kabsch: W. Kabsch, Acta Cryst. A32 (1976) 922; SVD of the cross-covariance with the reflection fix);
* **shape**: the mean distance left after that best rigid fit, ``mean_i |R (a_i - c_a) - (b_i - c_b)|``.

Events (:func:`events`) come from the centroid and the lowest Gaussians' heights over the ground: the
first impact's time, the restitution, the contact's duration, the rest height, the lateral drift and the
final rotation. Every figure also comes **in units of U**, the reference's own uncertainty: the same
figure between the reference and its twin on the next coarser grid (:func:`in_units`), or that divided by
``r^p - 1`` where an order ``p`` was observed (Richardson, :mod:`gasp_studies.convergence`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Share of an object's Gaussians below its "bottom" height (a few stray Gaussians do not make contact).
BOTTOM_QUANTILE = 0.5
#: Contact when the bottom is within this many grid cells (the reference's dx) of the lowest it gets in the run
#: (a grid engine's ground is a grid-node condition: a body stops a run-dependent fraction of a cell above it).
CONTACT_GAP_DX = 0.5
#: Gravity of the free flights :func:`ballistic_restitution` fits, m/s^2 (the scenes' default ``gravity``).
G_FLIGHT = 9.81


@dataclass
class Track:
    """One run's Gaussian means over time, world frame.

    Attributes
    ----------
    means : ndarray, shape (n_frames + 1, n, 3), float64
        World metres; frame 0 is the input.
    obj_start : ndarray, shape (n_objects + 1,), int
        Row offsets of the objects.
    names : list of str
    frame_dt : float
        Seconds between frames.
    ground_z : float or None
        Height of the ground plane, m (None: no ground; then no contact events).
    dx : float
        Grid spacing of the run, m (NaN when unknown).
    label : str
    splats : callable, optional
        ``splats(frame) -> Splats`` (world frame) for the rendered comparison (:mod:`gasp_studies.images`).
    cameras_json : Path, optional
        The capture's graphdeco ``cameras.json`` and the placement of the object it belongs to.
    """

    means: np.ndarray
    obj_start: np.ndarray
    names: list[str]
    frame_dt: float
    ground_z: float | None
    dx: float = float("nan")
    label: str = ""
    splats: object = None
    cameras_json: Path | None = None
    placement: dict | None = None
    extra: dict = field(default_factory=dict)

    def object_means(self, k: int) -> np.ndarray:
        """Means of object ``k``, shape (n_frames + 1, n_k, 3)."""
        return self.means[:, self.obj_start[k]:self.obj_start[k + 1]]


def track_from_run_dir(path, label: str | None = None) -> Track:
    """A :class:`Track` from a ``gasp simulate`` output folder (``run.json`` and its frames, any layout).

    Raises
    ------
    SceneError
        Not a run folder (no ``run.json``, no placements or frames): the message names the path.
    """
    import json
    from gasp_core.render.paths import find_cameras_json
    from gasp_core.render.run import load_run
    run = load_run(path)
    per_obj, counts = [], []
    for k, o in enumerate(run.objects):
        pl = o["placement"]
        R, s, t = np.asarray(pl["R"], float), float(pl["scale"]), np.asarray(pl["t"], float)
        frames = [s * run.read(f, k).means.astype(np.float64) @ R.T + t for f in range(run.n_frames)]
        per_obj.append(np.stack(frames))
        counts.append(frames[0].shape[0])
    meta = json.loads((Path(path) / "run.json").read_text())
    dx = float((meta.get("domain") or {}).get("dx", float("nan")))
    first = run.objects[0]
    cams = find_cameras_json(first["file"]) if first.get("file") else None
    return Track(np.concatenate(per_obj, axis=1), np.concatenate([[0], np.cumsum(counts)]).astype(int),
                 [o.get("name", f"object{k}") for k, o in enumerate(run.objects)], run.frame_dt, run.ground_z, dx,
                 label or Path(path).name, run.splats, cams, first["placement"])


def kabsch(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rotation ``R`` minimising ``sum_i |R (a_i - c_a) - (b_i - c_b)|^2`` (Kabsch 1976).

    Parameters
    ----------
    a, b : ndarray, shape (n, 3)
        The same points in two states (n >= 3, not all on a line for a unique answer).

    Returns
    -------
    R, c_a, c_b : ndarray, shapes (3, 3), (3,), (3,)
        A proper rotation (det +1) and the two centroids.
    """
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    H = (a - ca).T @ (b - cb)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return R, ca, cb


def rotation_angle_deg(R: np.ndarray) -> float:
    """Angle of a rotation matrix, degrees, in [0, 180] (``atan2(sin, cos)``: exact near 0, unlike ``arccos``)."""
    sin = 0.5 * np.linalg.norm([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return float(np.degrees(np.arctan2(sin, (np.trace(R) - 1.0) / 2.0)))


def split_frame(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """One frame of one object split: ``centroid_m``, ``rotation_deg``, ``shape_m`` (``a`` the run, ``b`` the reference).

    ``a``, ``b``: shape (n, 3), metres, the same Gaussians in the same order.
    """
    R, ca, cb = kabsch(a, b)
    resid = (np.asarray(a, np.float64) - ca) @ R.T - (np.asarray(b, np.float64) - cb)
    return {"centroid_m": float(np.linalg.norm(ca - cb)), "rotation_deg": rotation_angle_deg(R),
            "shape_m": float(np.linalg.norm(resid, axis=1).mean())}


def split_errors(run: Track, ref: Track) -> dict[str, dict[str, list[float]]]:
    """Per object, per frame: centroid, rotation and shape of ``run`` against ``ref``, and the size.

    Returns
    -------
    dict
        ``{object name: {"size_m", "centroid", "rotation_deg", "shape", "position"}}``: ``centroid``,
        ``shape`` and ``position`` (the plain mean distance) as fractions of the object size, lists over
        the frames both runs have.

    Raises
    ------
    ValueError
        The two runs hold different numbers of Gaussians.
    """
    if run.means.shape[1:] != ref.means.shape[1:]:
        raise ValueError(f"split_errors: '{run.label}' has {run.means.shape[1]} Gaussians, "
                         f"'{ref.label}' {ref.means.shape[1]}: not the same scene")
    n = min(len(run.means), len(ref.means))
    out = {}
    for k, name in enumerate(ref.names):
        a, b = run.object_means(k)[:n], ref.object_means(k)[:n]
        size = float(np.linalg.norm(np.ptp(b[0], axis=0)))
        rows = [split_frame(a[f], b[f]) for f in range(n)]
        out[name] = {"size_m": size,
                     "centroid": [r["centroid_m"] / size for r in rows],
                     "rotation_deg": [r["rotation_deg"] for r in rows],
                     "shape": [r["shape_m"] / size for r in rows],
                     "position": (np.linalg.norm(a - b, axis=2).mean(axis=1) / size).tolist()}
    return out


def _crossing(t: np.ndarray, y: np.ndarray, level: float, start: int, down: bool) -> float:
    """First time from frame ``start`` on where ``y`` crosses ``level`` (downwards or upwards), linear between frames."""
    for f in range(max(start, 1), len(y)):
        y0, y1 = y[f - 1], y[f]
        if (down and y0 > level >= y1) or (not down and y0 <= level < y1):
            return float(t[f - 1] + (level - y0) / (y1 - y0) * (t[f] - t[f - 1]))
    return float("nan")


def ballistic_restitution(t: np.ndarray, c: np.ndarray, bottom: np.ndarray, level: float, impact: float, lift: float,
                          g: float = G_FLIGHT) -> float:
    """The first bounce's restitution from the free flights around it, as one reads it off a filmed drop.

    ``z + g t^2 / 2 = a + b t`` is fitted (least squares) to the centroid heights ``c`` (m, one per frame at the
    times ``t``, s) of the frames before ``impact`` (s) and of those from ``lift`` (s) until the bottom (``bottom``,
    m) is back within the contact ``level`` (m); the two flights meet at ``t_c = (a_1 - a_0) / (b_0 - b_1)`` and
    ``e = -(b_1 - g t_c) / (b_0 - g t_c)``: the bounce taken as instantaneous where the flights cross. Unlike
    frame differences, it does not depend on where the frames fall within a contact shorter than a frame (an
    undamped rigid bounce back to its height reads 0.52 by frame differences at 30 fps, 1.00 by this; issue 40).
    NaN with fewer than 2 frames on either side or without a downward flight.
    """
    if not (np.isfinite(impact) and np.isfinite(lift)):
        return float("nan")
    pre = np.flatnonzero(t < impact)
    post = []
    for f in np.flatnonzero(t > lift):
        if bottom[f] <= level:
            break
        post.append(f)
    if len(pre) < 2 or len(post) < 2:
        return float("nan")

    def flight(idx):
        A = np.stack([np.ones(len(idx)), t[idx]], axis=1)
        return np.linalg.lstsq(A, c[idx] + 0.5 * g * t[idx] ** 2, rcond=None)[0]
    (a0, b0), (a1, b1) = flight(pre), flight(np.asarray(post))
    if not b1 > b0:   # the flight out is the faster upwards at any one time
        return float("nan")
    tc = (a1 - a0) / (b0 - b1)
    v_in, v_out = b0 - g * tc, b1 - g * tc
    return float(-v_out / v_in) if v_in < 0 else float("nan")


def first_bounce(cz: np.ndarray, bottom: np.ndarray, frame_dt: float, level: float, g: float = G_FLIGHT) -> float:
    """The first bounce's restitution from the free flights around it (:func:`ballistic_restitution`), the flights
    told by the body's lowest point: the frames before the first one whose ``bottom`` (m over the ground, one per
    frame) is within ``level`` (m), and those from the next one above it until the next contact. ``cz``: the
    centroid heights, m. A ``level`` of a cell keeps frames within a contact out (at 6 substeps a frame a 10 cm
    ball moves 11 mm a substep: a frame in its contact may show its bottom 8 mm over the ground; issue 53). NaN
    without a contact or a flight after it."""
    cz, bottom = np.asarray(cz, np.float64), np.asarray(bottom, np.float64)
    t = np.arange(len(cz)) * frame_dt
    hit = np.flatnonzero(bottom <= level)
    if not len(hit):
        return float("nan")
    off = np.flatnonzero((bottom > level) & (np.arange(len(cz)) > hit[0]))
    if not len(off):
        return float("nan")
    # the flight out ends before the next bounce: at the frame before the centroid rises again after its apex (a
    # frame just after a second bounce may show its bottom over the level)
    apex, end = off[0], len(cz)
    for f in range(off[0] + 1, len(cz)):
        if cz[f] < cz[f - 1]:
            apex = f
            break
    for f in range(apex + 1, len(cz)):
        if cz[f] >= cz[f - 1]:
            end = f - 1
            break
    return ballistic_restitution(t[:end], cz[:end], bottom[:end], level, t[hit[0]] - 0.5 * frame_dt,
                                 t[off[0]] - 0.5 * frame_dt, g)


def events(track: Track, k: int, gap_m: float) -> dict[str, float]:
    """Event observables of object ``k``: what a user reads off a drop.

    ``impact_s``: the first time the object's bottom (its :data:`BOTTOM_QUANTILE` % lowest Gaussian
    height) comes within ``gap_m`` of the lowest it gets in the run (linear between frames: the contact
    level, ``contact_level_m`` over the ground, is the run's own, since a grid engine stops a body a
    grid-dependent distance above its ground); ``restitution``: the centroid's
    largest upward speed after it over its largest downward speed before (frame differences);
    ``restitution_ballistic``: the same from the free flights before and after the bounce
    (:func:`ballistic_restitution`, not bound to the frames' phase within a short contact);
    ``contact_s``: from impact to the bottom's first rise above the gap again (NaN when it never lifts off
    within the run); ``rest_height_m``: the centroid's height over the ground on the last frame;
    ``drift_m``: its horizontal travel from frame 0; ``final_rotation_deg``: the object's rotation from
    frame 0 to the last frame (Kabsch). Contact figures are NaN without a ground or an impact.
    """
    m = track.object_means(k)
    t = np.arange(len(m)) * track.frame_dt
    c = m.mean(axis=1)
    R, _, _ = kabsch(m[0], m[-1])
    out = {"impact_s": float("nan"), "restitution": float("nan"), "restitution_ballistic": float("nan"),
           "contact_s": float("nan"),
           "contact_level_m": float("nan"),
           "rest_height_m": float("nan"), "drift_m": float(np.linalg.norm(c[-1, :2] - c[0, :2])),
           "final_rotation_deg": rotation_angle_deg(R), "final_xy": c[-1, :2].tolist()}
    if track.ground_z is None:
        return out
    out["rest_height_m"] = float(c[-1, 2] - track.ground_z)
    bottom = np.percentile(m[:, :, 2], BOTTOM_QUANTILE, axis=1) - track.ground_z
    level = float(bottom.min()) + gap_m
    out["contact_level_m"] = level
    impact = _crossing(t, bottom, level, 1, down=True)
    if not np.isfinite(impact):
        return out
    out["impact_s"] = impact
    f_hit = int(np.ceil(impact / track.frame_dt - 1e-9))
    vz = np.diff(c[:, 2]) / track.frame_dt   # interval f-1..f is vz[f-1]
    v_in = -float(vz[:f_hit].min()) if f_hit > 0 else float("nan")
    lift = _crossing(t, bottom, level, f_hit + 1, down=False)
    out["contact_s"] = float(lift - impact) if np.isfinite(lift) else float("nan")
    stop = int(np.ceil(lift / track.frame_dt)) if np.isfinite(lift) else len(vz)
    after = vz[f_hit:max(stop, f_hit + 1)]
    if v_in > 0 and after.size:
        out["restitution"] = max(float(after.max()), 0.0) / v_in
    out["restitution_ballistic"] = ballistic_restitution(t, c[:, 2], bottom, level, impact, lift)
    return out
