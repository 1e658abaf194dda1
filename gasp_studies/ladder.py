"""The stiffness ladder (issue 40, item 4): one drop, E from 1e4 to 2e11 Pa, each engine's cost, restitution and energy.

The drop: an elastic ball (``material`` jelly, nu 0.3, radius :data:`RADIUS` = 0.1 m, lattice points at ``dx / 2``,
``dx`` = 1/16 m: 136 points) in the unit cube, its lowest point :data:`DROP` = 0.2 m above a ground (friction 0.5)
at ``GROUND_H`` = 3 dx, released at rest (impact at 1.98 m/s after 0.20 s); ``frame_dt`` 0.01 s, :data:`N_FRAMES` =
60 frames (0.60 s: 19 frames of free fall before the impact, and a bounce of restitution 0.4 to 1 flies 16 to 40 frames
before it lands again: both free flights long enough to fit). ``model = "auto"`` is resolved as ``gasp simulate`` resolves it
(:func:`gasp_core.prepare.route.resolve_models` with the engine's features): on an engine with the feature
``rigid_limit`` the ball takes the rigid limit where its estimated deformation is below a quarter of a cell
(here from E 1e6 Pa up), elsewhere its full elastic model.

Densities (:data:`LADDER`): real materials of each stiffness, so that the explicit step (``dx / c``, ``c`` the
P-wave speed ``sqrt(E (1 - nu) / ((1 + nu)(1 - 2 nu) rho))``) and ``auto``'s impact strain ``v / c`` are those a user
meets: 1000 kg/m^3 from 1e4 Pa (a soft gel) to 1e9 Pa (polyethylene: 950 kg/m^3, E 0.8-1.2e9 Pa), 7850 kg/m^3 for
steel (2e11 Pa). Under gravity alone neither the free flights nor the rigid limit depend on rho.

Figures per case (:func:`run_case`): the model taken, substeps per frame (the engine's ``stats()``), CPU and wall
seconds of build and frames (recorded, never asserted), the restitution from the free flights around the first
bounce (:func:`gasp_studies.accuracy.ballistic_restitution` through :func:`gasp_studies.accuracy.events`) and by frame
differences, and the energy: ``K + P``, ``K = sum m |v|^2 / 2`` of the engine's point velocities, ``P = sum m g z``;
no elastic energy (not read from the engines), so ``K + P`` is a lower bound of the total energy, and a ``K + P``
above the start is a gain whatever the elastic energy. Its largest rise over the start, in units of the energy the
fall releases (``M g DROP``), over the frames after the first (``energy_peak``; frame 0 is the start itself) and
over those after the first impact (``energy_peak_after_impact``).
"""
from __future__ import annotations

import math
import time
import warnings

import numpy as np

from gasp_core.errors import EngineDivergence, EngineError, SceneError
from gasp_core.prepare.route import declared_cfl, resolve_models
from gasp_core.seam.setup import Boundary, Material, SimSetup
from gasp_core.testing import GRAVITY, run_trace, sphere_points
from gasp_core.testing.scenes_basic import GROUND_H
from gasp_studies.accuracy import Track, events

#: (E Pa, rho kg/m^3, what it stands for) of the ladder.
LADDER = ((1e4, 1000.0, "soft gel"), (1e5, 1000.0, "jelly"), (1e6, 1000.0, "soft rubber"),
          (1e7, 1000.0, "rubber"), (1e9, 1000.0, "polyethylene"), (2e11, 7850.0, "steel"))
RADIUS = 0.1
DROP = 0.2
N_GRID = 16
FRAME_DT = 0.01
N_FRAMES = 60
#: The contact level over the bottom's lowest height, in dx (:func:`gasp_studies.accuracy.events`' ``gap_m``): a
#: quarter cell, below the rebound of a bounce of restitution 0.4 (3.2 cm).
GAP_DX = 0.25


def case_id(E: float) -> str:
    """``"E_1e4"``, ..., ``"E_2e11"``: the case names of the ladder."""
    mant, exp = f"{E:.0e}".split("e")
    return f"E_{mant}e{int(exp)}"


def ball_setup(E: float, rho: float, model: str = "auto", options: dict | None = None,
               n_grid: int = N_GRID) -> SimSetup:
    """The ladder's drop at ``E`` (Pa) and ``rho`` (kg/m^3), ``material.model`` as given (unresolved); points at
    ``dx / 2`` of ``n_grid`` (:data:`N_GRID`: 136 points; 24: 552)."""
    dx = 1.0 / n_grid
    x, p_vol = sphere_points((0.5, 0.5, GROUND_H + DROP + RADIUS), RADIUS, dx / 2)
    return SimSetup(x=x, v=0.0, p_vol=p_vol, body_id=0,
                    materials=[Material("jelly", E=E, nu=0.3, rho=rho, model=model)],
                    gravity=np.array([0.0, 0.0, -GRAVITY]), domain_lo=np.zeros(3), domain_hi=np.ones(3),
                    n_grid=n_grid, boundaries=[Boundary("ground", height=GROUND_H, friction=0.5)],
                    frame_dt=FRAME_DT, options=dict(options or {}))


def resolve(info, setup: SimSetup) -> dict:
    """Resolve ``model = "auto"`` as ``gasp simulate`` does for ``info``'s features; the choice (``model``, ``why``,
    ``substeps_elastic``, ``substeps_rigid`` estimates)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return resolve_models(setup, ["ball"], frozenset(info.capabilities.features), declared_cfl(info))[0]


def energy(tr) -> np.ndarray:
    """``K + P`` per frame of a :class:`gasp_core.testing.Trace`, J (``P`` over the ground)."""
    return tr.kinetic() + tr.p_mass.sum() * GRAVITY * (tr.centroid()[:, 2] - GROUND_H)


def track(tr, label: str = "") -> Track:
    """The :class:`gasp_studies.accuracy.Track` of a run of the ladder's drop (one object, ``"ball"``)."""
    return Track(means=tr.x, obj_start=np.array([0, tr.x.shape[1]]), names=["ball"], frame_dt=tr.setup.frame_dt,
                 ground_z=GROUND_H, dx=tr.setup.dx, label=label)


def figures(tr) -> dict:
    """Restitution and energy figures of a run of the ladder's drop (see the module)."""
    e = energy(tr)
    fall = float(tr.p_mass.sum() * GRAVITY * DROP)
    ev = events(track(tr), 0, GAP_DX * tr.setup.dx)
    after = int(np.ceil(ev["impact_s"] / tr.setup.frame_dt)) if np.isfinite(ev["impact_s"]) else len(e)
    return {"restitution": ev["restitution_ballistic"], "restitution_frames": ev["restitution"],
            "impact_s": ev["impact_s"], "energy_start_J": float(e[0]), "fall_energy_J": fall,
            "energy_peak": float((e[1:].max() - e[0]) / fall), "energy_end": float((e[-1] - e[0]) / fall),
            "energy_peak_frame": 1 + int(np.argmax(e[1:])), "energy_J": e.tolist(),
            "energy_peak_after_impact": float((e[after:].max() - e[0]) / fall) if after < len(e) else float("nan"),
            "deepest_dx": float((GROUND_H - tr.x[:, :, 2].min()) / tr.setup.dx)}


def run_case(info, E: float, rho: float, model: str = "auto", n_frames: int = N_FRAMES,
             options: dict | None = None) -> dict:
    """Run the ladder's drop at ``E`` on ``info``: ``{"outcome": "ok" | "refused" | "diverged", ...}``.

    ``refused``: :class:`SceneError` / :class:`EngineError` (at build: the engine says it cannot run the case, the
    message in ``error``); ``diverged``: :class:`EngineDivergence` (with its frame); ``ok``: :func:`figures` and
    ``model``, ``why``, ``n_substeps``, ``cpu_s``, ``wall_s``, ``build_s``. Other exceptions propagate.
    """
    setup = ball_setup(E, rho, model, options)
    choice = resolve(info, setup)
    out = {"engine": info.name, "E": E, "rho": rho, "model": choice["model"], "why": choice.get("why", ""),
           "substeps_elastic_estimate": choice.get("substeps_elastic"), "n_points": len(setup.x)}
    cpu0, wall0 = time.process_time(), time.perf_counter()
    try:
        tr = run_trace(info, setup, n_frames)
    except (SceneError, EngineError) as e:
        return {**out, "outcome": "refused", "error": f"{type(e).__name__}: {e}"}
    except EngineDivergence as e:
        return {**out, "outcome": "diverged", "error": f"EngineDivergence: {e}"}
    out.update(cpu_s=time.process_time() - cpu0, wall_s=time.perf_counter() - wall0, build_s=tr.stats.build_s,
               n_substeps=tr.stats.engine.get("n_substeps"), outcome="ok")
    if not math.isfinite(float(np.abs(tr.x).max())):
        return {**out, "outcome": "nan"}
    return {**out, **figures(tr)}
