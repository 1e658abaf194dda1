"""Round 84 (issue 67, ``docs/contact.md`` "Round 84: a settled start"): the scene key ``settle``, a start at rest in
the bodies' own weight.

A captured scene is at rest: a jelly on a table already carries its weight. Started unstressed, a soft body sags into
its weight at ``t = 0`` (``rho g h^2 / 3 E``: 0.33 mm for a 10 cm jelly cube of E 100 kPa) and rings along the
ground's normal; on a slope near its friction limit the ring's swing of the normal force lets the base slip each
period, and an undamped cube walks down a slope it would hold (rounds 78-80: 3-6 mm a second at ``tan / mu`` 0.96,
on MPM and on explicit finite elements alike). ``settle = true`` starts the run from the state the bodies reach at
rest instead: **dynamic relaxation** (Otter 1966; Underwood 1983, "Dynamic relaxation", in Computational Methods for
Transient Analysis; the gravity step of geotechnical codes), on the scene's own engine:

* gravity is ramped up in :data:`STAGES` equal steps (each a fresh engine of the setup with gravity scaled, the
  state carried by ``get_state`` / ``set_state``), :data:`STAGE_FRAMES` settle frames each, then held at full
  gravity for :data:`HOLD_FRAMES` frames: the load rises slowly against the bodies' ring, so the base's friction
  is asked for ``tan theta`` of the normal force throughout (a body that holds at rest never slips on the way);
* **kinetic damping** (Cundall 1976): each settle frame the points' kinetic energy is read; where it fell since
  the last frame (a peak passed) every velocity and affine velocity ``C`` is set to zero (``set_state`` between
  frames), which takes the ring's energy out at its peaks whatever its period;
* a settle frame is :data:`FRAME_PER_PERIOD` of the slowest body's first compression period ``4 L / c_p`` (``L``
  its largest extent, ``c_p`` its P-wave speed), so the peaks are seen;
* the run then starts from the settled state with zero velocities, at frame 0 and time 0; the scene's colliders
  are held at their ``t = 0`` place during the settle, impulses and force fields are left out of it.

Frame 0 of the output stays the captured positions; frame 1 is the first simulated from the settled state (the
sag, where it shows, appears there instead of as a ring). The settle's record goes to ``run.json`` (``settle``:
frames, the settle frame, the largest displacement from the capture, the last frame's largest motion in cells).

Refused (:class:`~gasp_core.errors.SceneError`): an engine without the feature ``state``; a point with an initial
velocity (a settled start is for bodies at rest). Warned (``UserWarning``): a settle that ends with a point still
moving over :data:`RESIDUAL_CELLS` a frame (a body slides, falls or flows), or a point moved over :data:`MOVED_CELLS`
from the scene as given (a body fell, slid or tipped into place). The work is bounded: :data:`STAGES` engine builds
and ``STAGES * STAGE_FRAMES + HOLD_FRAMES`` settle frames of at most ``MAX_SETTLE_S`` in all.
"""
from __future__ import annotations

import warnings

import numpy as np

from gasp_core.errors import SceneError

#: Gravity's ramp: equal steps from ``g / STAGES`` to ``g``.
STAGES = 4
#: Settle frames at each step of the ramp.
STAGE_FRAMES = 20
#: Settle frames at full gravity after the ramp.
HOLD_FRAMES = 60
#: A settle frame, as a fraction of the slowest body's first compression period ``4 L / c_p``.
FRAME_PER_PERIOD = 0.1
#: The settle's simulated time at most, s (a very soft, large body: its frames are shortened to fit, and its record
#: says how far it settled).
MAX_SETTLE_S = 5.0
#: The last settle frame's largest point motion, in cells, above which the record says ``settled`` false and the
#: run warns (a body still sliding or falling: the scene was not at rest).
RESIDUAL_CELLS = 1.0e-3
#: A point displaced more than this many cells from the capture by the settle: the run warns that a body fell,
#: slid or tipped into place (a sag is a few hundredths of a cell: the 10 cm jelly cube's 0.3 mm).
MOVED_CELLS = 0.5
#: 1: kinetic damping (velocities zeroed at each peak of the kinetic energy); 0, a broken variant: none (the ramp
#: alone: the bodies keep ringing).
KINETIC = 1


def compression_period(setup) -> float:
    """The slowest non-rigid body's first compression period ``4 L / c_p``, s: ``L`` its points' largest extent (m),
    ``c_p = sqrt((lambda + 2 mu) / rho)`` its P-wave speed (``E``, ``nu``, ``rho`` of its material). 0.0 where every
    body is rigid (``model = "rigid"``) or none has an ``E``."""
    x, body = np.asarray(setup.x, float), np.asarray(setup.body_id)
    T = 0.0
    for b, m in enumerate(setup.materials):
        sel = body == b
        if not sel.any() or getattr(m, "model", "auto") == "rigid" or not getattr(m, "E", 0.0):
            continue
        L = float((x[sel].max(axis=0) - x[sel].min(axis=0)).max())
        nu = float(m.nu)
        c_p = float(np.sqrt(m.E * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu) * m.rho)))
        T = max(T, 4.0 * max(L, setup.dx) / c_p)
    return T


def settle_frame_s(setup) -> float:
    """A settle frame, s: :data:`FRAME_PER_PERIOD` of :func:`compression_period` (the scene's ``frame_dt`` where every
    body is rigid), at most ``MAX_SETTLE_S`` over the settle's frames."""
    T = compression_period(setup)
    return min(FRAME_PER_PERIOD * T if T > 0.0 else setup.frame_dt,
               MAX_SETTLE_S / (STAGES * STAGE_FRAMES + HOLD_FRAMES))


def settle_substeps(info, setup) -> int | None:
    """The substeps the settle asks of the engine ``info`` (its ``STAGES * STAGE_FRAMES + HOLD_FRAMES`` frames of
    :func:`settle_frame_s`, each at the engine's step rule ``info.substeps`` for the settle's setup at full gravity),
    for the run's time estimate; None where the engine has no step rule."""
    if info.substeps is None:
        return None
    return int(info.substeps(_still(setup, 1.0, settle_frame_s(setup)))) * (STAGES * STAGE_FRAMES + HOLD_FRAMES)


def check_settle(info, setup) -> None:
    """Raise :class:`SceneError` where ``settle = true`` cannot be done: the engine lacks the feature ``state``, a
    point has an initial velocity, or there is gravity and nothing to rest on (no ground, walls, ``fixed_region`` or
    collider: the bodies would fall out of the domain while settling, round 100)."""
    if "state" not in info.capabilities.features:
        from gasp_core.seam.plugins import engines
        able = sorted(n for n, i in engines().items() if "state" in i.capabilities.features)
        raise SceneError(f"settle = true needs an engine with the feature 'state' (get_state / set_state); engine "
                         f"'{info.name}' has not: use one that has ({', '.join(able) or 'none installed'}), or "
                         f"leave settle out")
    v = np.asarray(setup.v, float)
    if len(v) and np.abs(v).max() > 0.0:
        bodies = sorted(set(np.asarray(setup.body_id)[np.abs(v).max(axis=1) > 0.0].tolist()))
        raise SceneError(f"settle = true is for bodies at rest, but bodies {bodies} start with a velocity "
                         f"(|v| up to {np.abs(v).max():.3g} m/s); leave settle out or give them no velocity")
    if np.abs(np.asarray(setup.gravity, float)).max() > 0.0 and not setup.colliders and not setup.boundaries:
        raise SceneError("settle = true starts the bodies at rest in their weight, but the scene has gravity and "
                         "nothing to rest on (no [[boundary]] ground, walls or fixed_region, no [[collider]]): they "
                         "would fall out of the domain while settling; add a support or leave settle out")


def _still(setup, g_scale: float, frame_dt: float):
    """The setup of one settle step: gravity scaled, settle frames, colliders held where they are at ``t = 0``, no
    impulses or force fields."""
    import dataclasses

    from gasp_core.colliders.model import Motion
    held = [dataclasses.replace(c, motion=Motion()) for c in setup.colliders]
    return setup.replace(gravity=np.asarray(setup.gravity, float) * g_scale, frame_dt=frame_dt, colliders=held,
                         impulses=[], forces=[])


def _rest(state: dict) -> dict:
    """``state`` with every velocity and affine velocity zero (and a trapezoid's last ``C``), frame and time 0."""
    out = dict(state)
    for k in ("v", "C", "C_prev"):
        if k in out:
            out[k] = np.zeros_like(out[k])
    for k in ("frame", "sim_time"):
        if k in out:
            out[k] = np.zeros_like(np.asarray(out[k]))
    return out


def settled_state(info, setup) -> tuple[dict, dict]:
    """The state the bodies of ``setup`` reach at rest in their weight (module notes) and its record.

    Returns
    -------
    state : dict
        A ``get_state`` of the engine, velocities zero, frame and time 0: ``set_state`` it on an engine built from
        ``setup``.
    record : dict
        ``frames`` (settle frames run), ``frame_s`` (s), ``period_s`` (:func:`compression_period`), ``moved_mm`` (the
        largest point displacement from ``setup.x``), ``residual_cells`` (the last frame's largest point motion, in
        cells), ``left_domain`` (points outside the domain after it), ``settled`` (under :data:`RESIDUAL_CELLS`, and
        none left).

    Raises
    ------
    SceneError
        :func:`check_settle`'s refusals.
    """
    from gasp_core.seam.build import build_engine
    from gasp_core.seam.engine import call_engine
    from gasp_core.seam.cells import left_grid
    check_settle(info, setup)
    n_frames = STAGES * STAGE_FRAMES + HOLD_FRAMES
    T, tau = compression_period(setup), settle_frame_s(setup)
    m = np.asarray(setup.p_mass, float)
    state, x, moved = None, np.asarray(setup.x, float), 0.0
    for k in range(1, STAGES + 1):
        e = build_engine(info, _still(setup, k / STAGES, tau))
        try:
            if state is not None:
                call_engine(info, "set_state", e.set_state, _rest(state))
            ke_prev = np.inf
            for _ in range(STAGE_FRAMES + (HOLD_FRAMES if k == STAGES else 0)):
                call_engine(info, "settle frame", e.step_frame)
                x_new = np.asarray(e.positions(), float)
                moved = float(np.abs(x_new - x).max())
                x = x_new
                v = np.asarray(e.velocities(), float)
                ke = float(m @ np.einsum("ij,ij->i", v, v))
                if KINETIC and ke < ke_prev:   # a peak passed: kinetic damping
                    call_engine(info, "set_state", e.set_state, _rest(call_engine(info, "get_state", e.get_state)))
                    ke = 0.0
                ke_prev = ke
            state = call_engine(info, "get_state", e.get_state)
        finally:
            e.close()
    residual = moved / setup.dx
    # a point that left the domain stays where it left (residual 0 there): it did not settle (round 100)
    left = int(left_grid(x, setup).sum())
    record = {"frames": n_frames, "frame_s": tau, "period_s": T,
              "moved_mm": 1000.0 * float(np.abs(x - np.asarray(setup.x, float)).max()),
              "residual_cells": residual, "left_domain": left, "settled": bool(residual < RESIDUAL_CELLS and not left)}
    if left:
        warnings.warn(f"settle: {left} point(s) left the domain while settling: a body fell or slid off what holds "
                      f"it, so the scene has no state at rest there; the run starts without them", UserWarning,
                      stacklevel=2)
    if not record["settled"] and not left:
        warnings.warn(f"settle: the scene was not at rest after {n_frames} settle frames ({n_frames * tau:.3g} s): "
                      f"a point still moved {residual:.3g} cells in the last one (over {RESIDUAL_CELLS:g}); a body "
                      f"slides (tan theta over its friction), falls or flows. The run starts where the settle left "
                      f"it, at rest", UserWarning, stacklevel=2)
    if record["moved_mm"] > 1000.0 * MOVED_CELLS * setup.dx:
        warnings.warn(f"settle: a point moved {record['moved_mm']:.3g} mm ({record['moved_mm'] / 1000.0 / setup.dx:.2g} "
                      f"cells) from the scene as given while settling (over {MOVED_CELLS:g}): a body fell, slid or "
                      f"tipped into place, so the scene was not at rest there", UserWarning, stacklevel=2)
    return _rest(state), record
