"""GASP engine plugin ``mujoco_flex``: MuJoCo 4 flex bodies carrying the scene's points.

Each deformable body becomes a coarse conforming tetrahedral lattice (a ``flexcomp`` of type
``direct``, 3D, with MuJoCo's Saint Venant-Kirchhoff flex elasticity); every input point rides
on its lattice tetrahedron through fixed barycentric weights. Rigid bodies become MuJoCo free
bodies made of one box per occupied lattice cell.

Importing this module does not import ``mujoco``; the factory does.
"""
from __future__ import annotations

import itertools

from gasp_core.seam import Capabilities, engine_hook, EngineInfo, Limit, Option, Preset
from gasp_core.mpm.sweep import dedupe_settings

__all__ = ["CAPABILITIES", "ENGINE", "LIMITS", "OPTIONS", "gasp_engines", "sweep"]

ENGINE = "mujoco_flex"

#: What the engine offers. ``metal`` is MuJoCo's flex von Mises plasticity (elasticity ``yield``).
CAPABILITIES = Capabilities(
    materials=frozenset({"jelly", "metal", "rigid"}),
    boundaries=frozenset({"ground", "fixed_region"}),
    devices=frozenset({"cpu"}),
    precisions=frozenset({"f64"}),
    deterministic=frozenset({"cpu"}),
    # mesh colliders as MuJoCo mesh geoms: collisions with their convex hull (gasp_mujoco_flex.colliders);
    # passive points ride on their tet (barycentric), like every point
    features=frozenset({"static_colliders", "passive_points"}),
)

#: Engine options (``[engine] options`` of a scene), declared as data.
OPTIONS = (
    Option("device", "cpu", "where to run: only 'cpu'", kind="str", choices=("cpu",)),
    Option("precision", "f64", "floating-point precision: only 'f64' (MuJoCo is double precision)",
           kind="str", choices=("f64",)),
    Option("dt", None, "MuJoCo timestep, s (default: from the elastic-wave estimate); <= frame_dt",
           lo=0.0, lo_open=True),
    Option("cfl", 0.5, "safety factor of the elastic-wave estimate dt = cfl h / c_p", lo=0.0, lo_open=True),
    Option("dt_max", 2e-3, "upper bound of the automatic dt (contact resolution), s", lo=0.0, lo_open=True),
    Option("cell_size", None, "lattice cell size h, m (default: a body's longest side / cells_across)",
           lo=0.0, lo_open=True),
    Option("cells_across", 8, "lattice cells along a body's longest side when cell_size is not given",
           lo=0.0, lo_open=True),
    Option("damping", 2e-3, "Rayleigh damping coefficient of the flex elasticity, s", lo=0.0),
    Option("integrator", "discrete", "MuJoCo integrator (the implicit ones reject flex elasticity)",
           kind="str", choices=("discrete", "Euler")),
    Option("solver", "Newton", "MuJoCo constraint solver (PGS rejects flex elasticity under discrete)",
           kind="str", choices=("Newton", "CG")),
    Option("iterations", 50, "constraint solver iterations", kind="int", lo=1),
    Option("radius", None, "flex collision radius, m (default: 0.05 h)", lo=0.0, lo_open=True),
    Option("memory", None, "MuJoCo's arena size (its <size memory=...>: bytes, or with a K, M or G suffix, "
           "e.g. '1G'); raise it when MuJoCo reports a full contact or constraint buffer (default: MuJoCo's own)",
           kind="str", pattern=r"[0-9]+[KMGT]?"),
    Option("max_strain", 5.0, "a tet edge stretched beyond (1 + max_strain) x its rest length is a divergence",
           lo=0.0, lo_open=True),
)

#: Ranges narrower than the core's, checked by the core before the factory runs (gasp_core.seam.limits).
#: MuJoCo refuses a negative Poisson ratio ("Poisson ratio must be in [0, 0.5)"); rigid bodies have no
#: elasticity, so their nu is not read.
LIMITS = {
    **{f"{m}.nu": Limit(lo=0.0, why="MuJoCo's flex elasticity") for m in sorted(CAPABILITIES.materials - {"rigid"})},
}

#: ``gasp bench`` sweep: lattice ``cells_across`` x ``cfl``, then the hierarchy share ``core_fraction``.
SWEEP = {"cells_across": (4, 8, 12), "cfl": (0.25, 0.5, 1.0), "reference_cells": 16,
         "core_fraction": (1.0, 0.5, 0.2)}
SWEEP_QUICK = {**SWEEP, "cells_across": (4, 8), "cfl": (0.5,), "reference_cells": 8}


def sweep(quick: bool) -> tuple[list[dict], dict]:
    """``gasp bench`` settings and reference of this engine.

    ``cells_across`` x ``cfl`` (all Gaussians simulated), then ``core_fraction`` at the middle
    ``cells_across`` and ``cfl``; the reference takes ``reference_cells`` cells across and the
    smallest ``cfl``. ``cells_across`` and ``cfl`` are engine options, ``core_fraction`` a scene key.

    Returns
    -------
    settings : list of dict
        No duplicates, never the reference.
    reference : dict
    """
    v = SWEEP_QUICK if quick else SWEEP
    cf, cores, cells = sorted(v["cfl"]), sorted(v["core_fraction"]), sorted(v["cells_across"])
    ref = {"cells_across": int(v["reference_cells"]), "cfl": cf[0], "core_fraction": cores[-1]}
    out = [{"cells_across": int(n), "cfl": c, "core_fraction": cores[-1]} for n, c in itertools.product(cells, cf)]
    mid = cells[len(cells) // 2]
    out += [{"cells_across": mid, "cfl": cf[len(cf) // 2], "core_fraction": k} for k in cores]
    return dedupe_settings(out, ref), ref


KNOWN_FAILURES = {
    "rest_gap": "the 4 x 4 x 2 dx slab set on the ground rests with its lowest 1 % of points 0.129 dx inside the "
                "plane (limit 0.01 dx): MuJoCo's soft contact's penetration (recorded in conformance_tests/RESULTS.md, "
                "run only in the slow tier; listed here in round 41)",
    "bounce": "EngineDivergence at frame 13 (t = 0.22 s): 6 lattice tetrahedra inverted on impact of "
              "the E = 2e5 Pa ball after a 0.14 m drop (dt 0.794 ms)",
    "bounce_hertz": "EngineDivergence at frame 49 (t = 0.20 s, the impact): 2 lattice tetrahedra inverted when the "
                    "E = 2e5 Pa ball (R 0.12 m) lands at 1.5 m/s (dt 0.833 ms; 4 inverted at dt 0.2 ms), as in 'bounce'",
    "self_weight_sag": "the 0.125 x 0.125 x 0.25 m column shortens 2.589 mm vs 2.395 mm (uniaxial stress, "
                       "+8.1%) with the default lattice (8 cells along its height)",
    "bar_wave": "c = 9.38 m/s vs sqrt(E/rho) = 10 m/s (-6.2%): the default lattice (8 cells along the 0.9 m bar, "
                "h = 0.11 m) is coarser than the bar's 0.0625 m section",
    "cantilever": "tip deflection 5.66 mm vs Euler-Bernoulli 19.99 mm (-72%): the default lattice "
                  "(8 cells along the 0.6 m bar, ~1.3 across its 0.1 m section) is far too stiff in "
                  "bending (linear tetrahedra lock); first frequency 7.21 Hz vs Timoshenko 4.27 Hz (+69%)",
    "cantilever_offgrid": "same lattice as 'cantilever': 5.66 mm vs 19.99 mm (-72%), 7.21 Hz vs 4.27 Hz",
    "incline_stick": "MuJoCo's soft contacts creep: the 8 x 4 x 2 dx slab set on the 25 deg slope moves 2.52 dx "
                     "down it in 0.4 s with mu = 0.8 > tan(25 deg) (frictionless: 11 dx), turning 16.8 deg (limit "
                     "0.004 dx); incline_slide passes (a = 2.358 vs 2.368 m/s^2, -0.41 %)",
    "incline_stick_cube": "the cube topples down the 25 deg slope (mu = 0.8; a rigid cube tips only beyond 45 deg): "
                          "turned 78.5 deg, centroid 4.36 dx down the slope in 0.4 s",
    "spun_ball_bounce": "the symmetric ball spun at 0.02 rad/s gains angular momentum 2.55x per bounce over 4 bounces "
                        "on frictionless ground (limit 1x; issue 28)",
    "jittered_ball_rest": "the ball of jittered points drifts 28.1 mm horizontally in 40 frames on ground with mu = 0.5 "
                          "(limit 1 mm; issue 28)",
    "ball_on_collider": "the ball of jittered points dropped onto a box collider drifts 5.92 mm horizontally (frame "
                        "12) in 40 frames, mu = 0.5 (limit 1 mm; issue 38); it rests +0.107 dx above the box's top",
    "rest_on_tilted_ground": "MuJoCo's soft contacts creep: the 4 x 4 x 2 dx slab under gravity tilted 15 deg on "
                             "a ground with mu = 0.5 > tan(15 deg) moves 2.66 dx down the slope in 2 s (limit "
                             "0.05 dx); on flat ground it stays within 0.0011 dx",
}


#: The quality levels' step, as the core gave it before each engine declared its presets (issue 51): the cfl of
#: the MLS-MPM engines' levels, not measured on this engine (docs/speed_accuracy.md measures the MLS-MPM engines).
PRESETS = {level: Preset({"cfl": cfl}) for level, cfl in (("draft", 0.8), ("default", 0.8), ("reference", 0.2))}


#: The engine's registration record (the ``gasp_engines`` hook, :func:`gasp_core.seam.plugins.engine_hook`).
gasp_engines = engine_hook(EngineInfo(
    name=ENGINE,
    factory="gasp_mujoco_flex.engine:MujocoFlexEngine",
    capabilities=CAPABILITIES,
    options=OPTIONS,
    presets=PRESETS,
    limits=LIMITS,
    known_failures=KNOWN_FAILURES,
    sweep=sweep,
    speed={"cpu": "jelly block of 46,656 points 1.72 s a frame on 2 cores (benchmarks/results/bench_engines.md)"},
    requires=("mujoco",),
    install="gasp-mujoco-flex",
    description="MuJoCo 4 flex: tetrahedral FEM lattice per body (SVK elasticity, von Mises "
                "plasticity), points embedded barycentrically; rigid bodies as free bodies",
))
