"""The frames of a run whose stiff brittle bodies break on impact into rigid fragments (issue 66 item 5;
``docs/fracture.md`` "Stiff brittle bodies: fragments"; the physics in :mod:`gasp_core.run.fragments`).

A ``brittle`` body that takes the rigid route (``material.model`` ``"rigid"``, or ``"auto"`` at handbook stiffness,
``gasp_core.prepare.route``) is *breakable*. After each frame the core reads every breakable body's mean velocity
from the engine; a change beyond gravity's over the frame is an impact with impulse ``J`` (per mass ``dV``), whose
direction is the contact's normal and whose approach speed ``v_n`` is the body's speed into it half a frame before
(:func:`impacts`). When the impact breaks the body (:func:`gasp_core.run.fragments.break_check`), that frame is
discarded, the engine closed, and a new engine built at the previous frame's positions and velocities in which the
body is its fragments (:func:`gasp_core.run.fragments.split_body`), each a rigid body of the same material; the
frame is simulated again, the fragments meeting the ground one by one. The points keep their order, so the frames'
rebuild (``T^-1``) is unchanged; the fragments' restitution is capped by the fracture (:func:`broken_restitution`).
From the break on the run's pieces (``gasp_core.run.pieces``) no longer link points of different fragments, so they
are the fragments, and the crack faces (``gasp_core.maps.crack_faces``) show on the points next to the cut.

Limits: a body breaks once (a fragment does not break again); no checkpoint is saved after the break (the fragments'
engine is not the scene's), so a run stopped after it resumes from the last frame before it and breaks again there.
"""
from __future__ import annotations

import dataclasses
import warnings
from typing import Callable, Iterator

import numpy as np

from gasp_core.seam.engine import call_engine
from gasp_core.seam.runner import EngineRun, FrameRecord, RunStats
from gasp_core.run import grady_cells
from gasp_core.run.fragments import break_check, cut_damage, ground_hit, split_body


def breakable(setup) -> list[int]:
    """The bodies that may break into fragments: ``brittle`` and rigid (after ``gasp_core.prepare.route``)."""
    return [b for b, m in enumerate(setup.materials) if m.name == "brittle" and m.model == "rigid"]


def mean_velocities(setup, v: np.ndarray, bodies: list[int]) -> np.ndarray:
    """Mass-weighted mean velocity of each of ``bodies``, shape (len(bodies), 3), m/s."""
    m = setup.p_mass
    return np.array([(m[setup.body_id == b, None] * v[setup.body_id == b]).sum(0) / m[setup.body_id == b].sum()
                     for b in bodies]).reshape(len(bodies), 3)


def impacts(setup, bodies: list[int], x_prev: np.ndarray, v_prev: np.ndarray, v_now: np.ndarray) -> list[dict]:
    """The breaking impacts of ``bodies`` over one frame (module notes), one dict per body that breaks.

    Parameters
    ----------
    setup : SimSetup
    bodies : list of int
    x_prev, v_prev : ndarray, shape (n, 3)
        Positions (m) and velocities (m/s) at the frame's start.
    v_now : ndarray, shape (n, 3)
        Velocities at its end, m/s. A body whose free fall from the frame's start meets a ground within the
        frame (:func:`ground_hit`) takes the ground's normal (+z) and its speed there as the impact's: at 20 m/s the
        cup meets the ground, rebounds and meets the domain's ceiling within one frame, and the frame's mean
        velocity change alone read 10.8 m/s along a tilted normal.

    Returns
    -------
    list of dict
        ``body``, ``normal`` (3,), ``impact_speed`` (m/s), ``impact_point`` (3,), ``mass`` (kg), ``volume`` (m^3),
        ``length`` (m) and :func:`~gasp_core.run.fragments.break_check`'s figures.
    """
    dt, g = setup.frame_dt, setup.gravity
    ground = max((b.height for b in setup.boundaries if b.kind == "ground"), default=-np.inf)
    before, after = mean_velocities(setup, v_prev, bodies), mean_velocities(setup, v_now, bodies)
    out = []
    for k, b in enumerate(bodies):
        dv = after[k] - before[k] - g * dt
        m = setup.materials[b]
        size = float(np.linalg.norm(dv))
        v_break = m.tensile_strength / (m.rho * np.sqrt(m.E / m.rho))
        if size < min(v_break, 1e3):   # no impulse that could break it
            continue
        sel = setup.body_id == b
        n = dv / size
        v_n = max(0.0, -float((before[k] + 0.5 * g * dt) @ n))
        hit = ground_hit(float(x_prev[sel, 2].min()) - ground, float(before[k][2]), -float(g[2]), dt)
        if hit is not None:   # it meets the ground in the frame: the ground's normal, the speed of its free fall there
            n, v_n = np.array([0.0, 0.0, 1.0]), hit
        along = x_prev[sel] @ n
        first = along <= along.min() + setup.dx   # the points that touch first: their centre
        rec = {"body": b, "normal": n, "impact_speed": v_n, "impact_point": x_prev[sel][first].mean(axis=0),
               "mass": float(setup.p_mass[sel].sum()), "volume": float(setup.p_vol[sel].sum()),
               "length": float(np.ptp(along)), "restitution": 1.0 if m.restitution is None else float(m.restitution),
               "tensile_strength": float(m.tensile_strength), "impedance": float(m.rho * np.sqrt(m.E / m.rho))}
        rec.update(break_check(m, rec["mass"], rec["volume"], rec["length"], v_n))
        if rec["breaks"]:
            out.append(rec)
    return out


def broken_restitution(hit: dict) -> float:
    """The fragments' coefficient of restitution: the body's ``e`` times ``v_break / v_n`` (at most ``e``), where
    ``v_break = f_t / (rho c)`` is the approach speed whose plane-wave stress reaches the tensile strength. The
    body's ``e`` is its material's ``restitution`` (a ``substance`` sets it from the restitution table: 0.9 for
    porcelain and glass, ``gasp_core.scene.tables``), else 1 (the cap alone: a rebound of at most ``v_break``).

    The elastic rebound of a bar that meets a wall is the particle velocity of the reflected wave, ``sigma / (rho c)``
    (Saint-Venant's impact of a bar; Graff 1975, "Wave Motion in Elastic Solids", 2.4). A brittle body carries no
    stress above ``f_t``: what it gives back is at most that of an impact at ``v_break`` (the body's ``e`` of it),
    the rest of the approach going into the fracture (its cracks, the fragments' relative motion and vibration),
    as a plastic impact's restitution falls above its yield velocity (Johnson 1985, "Contact Mechanics", 11.4)."""
    v_break = hit["tensile_strength"] / hit["impedance"]
    return float(hit["restitution"] * min(1.0, v_break / max(hit["impact_speed"], 1e-12)))


def fragmented(setup, x: np.ndarray, v: np.ndarray, hits: list[dict], seed: int = 0):
    """The setup at ``x``, ``v`` with each hit body made of its fragments, and the cut between them.

    Returns
    -------
    tuple
        ``(SimSetup, damage (n,), records)``: a fragment's body keeps the body's index for its largest fragment
        and appends one per other fragment (the same material); ``records`` per hit, the figures of ``hits`` with
        ``fragments`` (count) and ``fragment_mass`` (kg each, largest first), JSON-ready.
    """
    body_id, mats = setup.body_id.copy(), list(setup.materials)
    damage, records = np.zeros(len(x)), []
    material = setup.p_mass > 0
    for h in hits:
        sel = np.flatnonzero(setup.body_id == h["body"])
        spacing = float(np.percentile(np.cbrt(setup.p_vol[sel][material[sel]]), 90.0))
        frag = split_body(x[sel], material[sel], spacing, h["impact_point"], h["count"], h["size"], seed)
        k = int(frag.max()) + 1
        ids = np.concatenate([[h["body"]], len(mats) + np.arange(k - 1)])
        body_id[sel] = ids[frag]
        m = setup.materials[h["body"]]
        mats[h["body"]] = m = dataclasses.replace(m, restitution=broken_restitution(h))
        mats += [m] * (k - 1)
        damage[sel] = cut_damage(x[sel], frag, material[sel], spacing)
        masses = np.bincount(frag, weights=setup.p_mass[sel])
        records.append({**{key: (val.tolist() if isinstance(val, np.ndarray) else val) for key, val in h.items()},
                        "fragments": k, "fragment_mass": sorted(masses.tolist(), reverse=True),
                        "fragment_restitution": m.restitution})
    new = dataclasses.replace(setup, x=np.array(x), v=np.array(v), body_id=body_id, materials=mats, C=None)
    return new, damage, records


def frames(info, setup, stats: RunStats, n_frames: int, start_frame: int = 0, state: dict | None = None,
           sleep: bool = False, before: Callable[[], None] | None = None, tracker=None,
           settle: bool = False) -> Iterator[FrameRecord]:
    """The run's checked frames (:meth:`gasp_core.seam.runner.EngineRun.frames`), its breakable bodies broken into
    fragments on the impact that breaks them (module notes). ``before`` is called once the engine is built.
    ``stats.fragments`` gains one record per break (``frame``: the last frame before it, and :func:`fragmented`'s).
    ``tracker`` (the run's :class:`gasp_core.run.pieces.PieceTracker`) is told the fragments
    (:meth:`~gasp_core.run.pieces.PieceTracker.split_bodies`): its pieces are then the fragments and the crack faces
    show on both sides of the cut; without one, each frame's damage after the break is the cut
    (:func:`gasp_core.run.fragments.cut_damage`). Errors as :class:`~gasp_core.seam.runner.EngineRun`."""
    bodies = breakable(setup)
    if not bodies and grady_cells.applies(info, setup):   # a soft brittle body: Grady's cells at its landing
        yield from grady_cells.frames(info, setup, stats, n_frames, start_frame, state, sleep, before, tracker, settle)
        return
    with EngineRun(info, setup, stats, start_frame=start_frame, state=state, sleep=sleep, settle=settle) as run:
        if before is not None:
            before()
        if not bodies:
            yield from run.frames(n_frames)
            return
        x_prev, v_prev, hits = setup.x, setup.v, []
        if start_frame:   # resumed (its checkpoint is before any break): the restored state
            x_prev = np.asarray(call_engine(info, "positions", run.engine.positions), np.float64)
            v_prev = np.asarray(call_engine(info, "velocities", run.engine.velocities), np.float64)
        for rec in run.frames(n_frames):
            v_now = np.asarray(call_engine(info, "velocities", run.engine.velocities), np.float64)
            hits = impacts(setup, bodies, x_prev, v_prev, v_now)
            if hits:
                break
            yield rec
            x_prev, v_prev = rec.x, v_now
        if not hits:
            return
    k0 = rec.frame - 1
    new, damage, records = fragmented(setup, x_prev, v_prev, hits)
    stats.fragments = [{"frame": k0, **r} for r in records]
    if tracker is not None:
        tracker.split_bodies(new.body_id)
        damage = None
    with warnings.catch_warnings():   # the fragments of one body share its grid field by design (docs/fracture.md)
        warnings.filterwarnings("ignore", message=".*share one grid velocity field", category=UserWarning)
        run = EngineRun(info, new, stats, sleep=sleep)
    with run:
        for r in run.frames(n_frames - k0):
            stats.damage = damage
            yield FrameRecord(r.frame + k0, r.x, r.wall_s, None)
