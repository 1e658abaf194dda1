"""Which model a body takes, the full elastic one or the rigid limit, chosen from its physics (issue 40, item 2).

A body's ``material.model`` (:data:`gasp_core.seam.schema.BODY_MODELS`) is ``"elastic"``, ``"rigid"`` or ``"auto"``
(the default). For ``"auto"`` the core estimates the strain the body will show (:func:`estimate`):

* under its weight, standing on a ground: ``eps_w = rho g H / E`` (the base of a column of height ``H``);
* at the impact of its drop: ``eps_i = v / c``, ``c = sqrt(E / rho)``, ``v = sqrt(v_n^2 + 2 g gap)`` (``v_n`` its
  starting speed downwards, ``gap`` its lowest point's height over the ground under it, or over the domain's floor
  where the scene has colliders or no ground under it): the strain of a bar hitting a rigid wall at ``v`` (the
  stress ``rho c v`` of a plane wave), an upper bound for a rounded body;
* from its own spin and spread of speeds: ``eps_s = rho max|v - v_mean|^2 / E``;
* from what will land on it (issue 53 item 4, :func:`loads`): the bodies above it whose horizontal extents overlap
  its own, of mass ``M`` landing at ``u`` (their fall from their lowest point to its top): the larger of the strain of
  their weight applied at once over its horizontal section ``A`` (``2 M g / (A E)``, twice the static strain of a
  sudden load) and the strain whose elastic energy over its volume ``V`` takes up their kinetic energy
  (``eps_l = sqrt(M u^2 / (E V))``, from ``E eps^2 V / 2 = M u^2 / 2``),

and the deformation ``max(eps) L`` (``L`` its largest extent). Below :data:`RIGID_SHARE` of a grid cell the grid
cannot show it, and the body takes the rigid limit (on an engine with the feature ``rigid_limit``); ``metal`` also
needs its stress ``E eps`` below its yield stress. The choice, its figures and the substeps per frame each model
would need are one line on stderr and, per object, ``model`` in ``run.json``.
"""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np

from gasp_core.errors import SceneError
from gasp_core.seam.schema import RIGID_KINDS, STIFF_BRITTLE_E

#: ``auto`` takes the rigid limit when the estimated deformation is below this share of a grid cell.
RIGID_SHARE = 0.25


def estimate(m, x: np.ndarray, p_vol: np.ndarray, v: np.ndarray, gravity, floor: float | None, dx: float,
             frame_dt: float, v_max: float, cfl: float | None = None, load: dict | None = None) -> dict:
    """The strain estimates of one body (the module's model).

    Parameters
    ----------
    m : Material
    x, v : ndarray, shape (n, 3)
        The body's points (m) and velocities (m/s).
    p_vol : ndarray, shape (n,)
        m^3 (passive rows 0).
    gravity : array-like, shape (3,)
        m/s^2.
    floor : float or None
        The height the body may fall to, m (z up): the ground under it, or the domain's floor where colliders may
        stop it first or no ground is under it; None: it never hits anything (no weight, no impact).
    dx : float
        Grid spacing, m.
    frame_dt : float
        s.
    v_max : float
        The fastest speed the scene may reach, m/s (the step's velocity bound).
    cfl : float, optional
        The Courant number of the engine's automatic substep (its declared option ``cfl``); None: no substep
        figures.
    load : dict, optional
        What will land on the body (:func:`loads`): ``mass`` (kg) and ``speed`` (m/s); None: nothing.

    Returns
    -------
    dict
        ``strain_weight, strain_impact, strain_spin, strain_load, strain`` (dimensionless), ``impact_speed`` (m/s),
        ``deformation`` (m), ``deformation_cells`` (in ``dx``), ``substeps_elastic`` and ``substeps_rigid`` (about
        how many substeps per frame the body's wave speed and the motion alone need at ``cfl``; None without).
    """
    g = float(np.linalg.norm(gravity))
    w = np.where(p_vol > 0.0, p_vol, 0.0)
    W = float(w.sum()) or 1.0
    size = float(np.ptp(x, axis=0).max()) if len(x) else 0.0
    v_mean = (w[:, None] * v).sum(axis=0) / W
    low = float(x[:, 2].min()) if len(x) else 0.0
    gap = max(low - floor, 0.0) if floor is not None else None
    E, rho = float(m.E), float(m.rho)
    c = math.sqrt(E / rho)
    eps_w = rho * g * float(np.ptp(x[:, 2])) / E if gap is not None and g > 0.0 else 0.0
    v_imp = math.sqrt(max(0.0, -float(v_mean[2])) ** 2 + 2.0 * g * gap) if gap is not None else 0.0
    eps_i = v_imp / c
    spread = float(np.max(np.linalg.norm(v - v_mean, axis=1))) if len(v) else 0.0
    eps_s = rho * spread * spread / E
    eps_l = 0.0
    if load and load["mass"] > 0.0 and len(x):
        area = max(float(np.ptp(x[:, 0]) * np.ptp(x[:, 1])), 1e-12)
        volume = max(float(p_vol.sum()), 1e-12)
        eps_l = max(2.0 * load["mass"] * g / (area * E), math.sqrt(load["mass"] * load["speed"] ** 2 / (E * volume)))
    eps = max(eps_w, eps_i, eps_s, eps_l)
    n_el = None if cfl is None else math.ceil(frame_dt / (cfl * dx / max(m.p_wave_speed, v_max, 1e-12)))
    n_rg = None if cfl is None else math.ceil(frame_dt / (cfl * dx / max(v_max, 1e-12)))
    return {"strain_weight": eps_w, "strain_impact": eps_i, "strain_spin": eps_s, "strain_load": eps_l, "strain": eps,
            "impact_speed": v_imp, "deformation": eps * size, "deformation_cells": eps * size / dx,
            "substeps_elastic": n_el, "substeps_rigid": n_rg}


def choose(m, est: dict, rigid_ok: bool) -> tuple[str, str]:
    """``(model, why)`` of one body from its ``material.model`` and :func:`estimate`; ``rigid_ok``: the engine has
    the feature ``rigid_limit``."""
    if m.model != "auto":
        return m.model, f"material.model = {m.model!r}"
    small = est["deformation_cells"] <= RIGID_SHARE
    if m.name == "metal" and float(m.E) * est["strain"] >= float(m.yield_stress):
        return "elastic", (f"auto: its estimated stress {float(m.E) * est['strain']:.3g} Pa reaches its yield "
                           f"stress {float(m.yield_stress):.3g} Pa")
    carried = est.get("load_text") if est.get("strain_load", 0.0) >= est["strain"] > 0.0 else None
    if not small:
        return "elastic", (f"auto: its estimated deformation {1e3 * est['deformation']:.3g} mm is "
                           f"{est['deformation_cells']:.2g} of a cell (the rigid limit below {RIGID_SHARE:g})"
                           + (f" under {carried}" if carried else ""))
    why = (f"auto: its estimated deformation {1e3 * est['deformation']:.3g} mm (strain {est['strain']:.2g}) is "
           f"{est['deformation_cells']:.2g} of a cell (below {RIGID_SHARE:g})" + (f" under {carried}" if carried else ""))
    return ("rigid", why) if rigid_ok else ("elastic", why + ", but the engine has no rigid limit")


def message(name: str, model: str, why: str, est: dict) -> str | None:
    """The one line ``gasp simulate`` prints for a body, or None when its elastic model costs little."""
    n_el, n_rg = est["substeps_elastic"], est["substeps_rigid"]
    if n_el is None:
        return (f"object '{name}': rigid limit ({why}); set material.model = \"elastic\" to simulate its "
                f"deformation") if model == "rigid" else None
    if model == "rigid":
        return (f"object '{name}': rigid limit ({why}): about {n_rg} substeps a frame instead of {n_el}; "
                f"set material.model = \"elastic\" to simulate its deformation")
    if n_el < 4 * n_rg:
        return None
    if "no rigid limit" in why:
        return (f"object '{name}': elastic ({why}): an engine with the feature 'rigid_limit' would take about "
                f"{n_rg} substeps a frame instead of {n_el}")
    return (f"object '{name}': elastic ({why}): material.model = \"rigid\" would take about {n_rg} substeps a "
            f"frame instead of {n_el}, without its deformation")


def resolve_models(setup, names, features, cfl: float | None = None, substeps=None) -> list[dict]:
    """Resolve every body's ``material.model`` in ``setup.materials`` (in place) and say each choice.

    Parameters
    ----------
    setup : SimSetup
    names : list of str
        Object names, one per body.
    features : frozenset of str
        The engine's features (``rigid_limit``).
    cfl : float, optional
        The engine's declared default ``cfl`` (:func:`declared_cfl`), for the estimated substep figures; None: none.
    substeps : callable, optional
        The engine's step rule, ``substeps(setup) -> int`` (``EngineInfo.substeps``): the figures become the run's
        (:func:`run_substeps`); None keeps the estimate's.

    Returns
    -------
    list of dict
        Per body, for ``run.json``: ``model`` (``"elastic"`` or ``"rigid"``; ``"auto"`` for a material that has no
        rigid limit, which keeps its own model), ``why`` and :func:`estimate`'s figures (its substeps the run's,
        :func:`run_substeps`). One ``UserWarning`` line per body whose choice matters (:func:`message`).
    """
    grounds = [float(b.height) for b in setup.boundaries if b.kind == "ground"]
    colliders = bool(getattr(setup, "colliders", None))
    g = float(np.linalg.norm(setup.gravity))
    v0 = float(np.max(np.linalg.norm(setup.v, axis=1))) if len(setup.v) else 0.0
    v_max = v0 + math.sqrt(2.0 * g * float(setup.domain_hi[2] - setup.domain_lo[2]))
    out, mats = [], list(setup.materials)
    carry = loads(setup, names)
    for b, m in enumerate(mats):
        if m.name not in RIGID_KINDS or (m.name == "brittle" and m.model == "auto" and m.E < STIFF_BRITTLE_E):
            out.append({"model": "auto", "why": f"{m.name!r} has no rigid limit: its own model"})
            continue
        sel = setup.body_id == b
        below = [h for h in grounds if h <= float(setup.x[sel, 2].min()) + 1e-9]
        floor = max(below) if below and not colliders else float(setup.domain_lo[2])
        est = estimate(m, setup.x[sel], setup.p_vol[sel], setup.v[sel], setup.gravity, floor, setup.dx,
                       setup.frame_dt, v_max, cfl, carry[b])
        if carry[b]:
            est["load_text"] = carry[b]["text"]
        model, why = choose(m, est, "rigid_limit" in features)
        mats[b] = dataclasses.replace(m, model=model) if m.model == "auto" or model != m.model else m
        out.append({"model": model, "why": why, **est})
    setup.materials = mats
    for b, rec in enumerate(out):
        if "substeps_rigid" in rec:
            # whether the choice is worth a line is the estimate's (its wave speed against the motion); the figures
            # the line gives are the run's where the engine says them
            said = message(names[b], rec["model"], rec["why"], rec) is not None
            rec.update(run_substeps(setup, b, substeps))
            line = message(names[b], rec["model"], rec["why"], rec) if said else None
            if line:
                warnings.warn(line, stacklevel=2)
    return out


def loads(setup, names) -> list[dict | None]:
    """Per body, what will land on it: the other bodies above it (their lowest point above its centre, z up against
    gravity) whose horizontal extents overlap its own.

    Returns
    -------
    list of dict or None
        Per body: ``mass`` (kg, the sum of ``rho p_vol`` of those bodies), ``speed`` (m/s, the fastest landing:
        ``sqrt(v_down^2 + 2 g gap)``, ``gap`` from a body's lowest point to this one's top) and ``text`` (their names
        and figures, for the route's line); None where nothing is above it or gravity is off.
    """
    g = float(np.linalg.norm(setup.gravity))
    n = len(setup.materials)
    if g == 0.0 or n < 2:
        return [None] * n
    sel = [setup.body_id == b for b in range(n)]
    lo = [setup.x[s].min(axis=0) if s.any() else None for s in sel]
    hi = [setup.x[s].max(axis=0) if s.any() else None for s in sel]
    out = []
    for b in range(n):
        if lo[b] is None:
            out.append(None)
            continue
        centre = 0.5 * (lo[b][2] + hi[b][2])
        above = [k for k in range(n) if k != b and lo[k] is not None and lo[k][2] >= centre
                 and np.all(lo[k][:2] <= hi[b][:2]) and np.all(hi[k][:2] >= lo[b][:2])]
        if not above:
            out.append(None)
            continue
        mass = sum(float(setup.materials[k].rho * setup.p_vol[sel[k]].sum()) for k in above)
        speed = max(math.sqrt(max(0.0, -float(setup.v[sel[k], 2].mean())) ** 2
                              + 2.0 * g * max(float(lo[k][2] - hi[b][2]), 0.0)) for k in above)
        who = ", ".join(f"'{names[k]}'" for k in above)
        out.append({"mass": mass, "speed": speed, "text": f"the load of {who} ({mass:.3g} kg landing at "
                                                             f"{speed:.2g} m/s)"})
    return out


def run_substeps(setup, b: int, substeps) -> dict:
    """``substeps_rigid`` and ``substeps_elastic``: the substeps a frame the engine's step rule ``substeps(setup)``
    (``EngineInfo.substeps``, with the scene's engine options) takes with body ``b`` rigid and elastic, the other
    bodies as resolved: the figures the run will show (issue 53: the line said "about 37 substeps a frame" where the
    run took 19). Without a rule, or where it refuses the scene (more than ``max_substeps``), :func:`estimate`'s
    figures stay (the empty dict)."""
    out = {}
    if substeps is None:
        return out
    for key, model in (("substeps_rigid", "rigid"), ("substeps_elastic", "elastic")):
        mats = [dataclasses.replace(m, model=model) if i == b else m for i, m in enumerate(setup.materials)]
        try:
            out[key] = int(substeps(dataclasses.replace(setup, materials=mats)))
        except SceneError:
            pass
    return out


def declared_cfl(info) -> float | None:
    """The default Courant number an engine declares (its option ``cfl``), or None (``info``: EngineInfo)."""
    return next((o.default for o in info.options if o.name == "cfl"), None)
