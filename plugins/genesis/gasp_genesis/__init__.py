"""GASP engine plugin ``genesis``: the MPM solver of Genesis (``genesis-world``).

Importing this module is cheap and works without Genesis installed: it neither imports Genesis
(whose import alone takes tens of seconds) nor torch. ``available()`` only looks the package up;
the factory imports :mod:`gasp_genesis.engine`, and with it Genesis, when a simulation is built.

Genesis is an optional extra, ``[engine]``, after torch (see ``README.md``; the line is ``gasp engines``'s).

Capabilities are the Genesis MPM materials (``genesis/engine/materials/MPM``, genesis-world 1.4)
whose update matches a GASP material of ``docs/mpm.md``:

========== ============================================ ===========================================
GASP       Genesis                                      difference to docs/mpm.md
========== ============================================ ===========================================
jelly      ``MPM.Elastic(model="corotation")``          none
neo_hookean``MPM.Elastic(model="neohooken")``           no clamp of ``J`` before ``log J``
metal      ``MPM.ElastoPlastic(use_von_mises=True)``    same return mapping; stress is fixed
                                                        corotated on the projected F (Hencky StVK in
                                                        the spec; equal to first order in the
                                                        elastic strain, which the yield bounds)
sand       ``MPM.Sand``                                 Drucker-Prager of Klar et al. 2016 *with*
                                                        volume correction (Tampubolon et al. 2017)
snow       ``MPM.Snow``                                 hardening fixed at 10 (other values refused)
liquid     ``MPM.Liquid(lam=K)``                        none (``lam`` is set to the bulk modulus K)
========== ============================================ ===========================================

Not offered: ``plasticine`` (Genesis has no softening), ``rigid`` (no MPM-rigid body of ours),
``fixed_region`` (Genesis's non-free particles pin whole grid stencils, not the spec's nodes in a
box), per-point volume (one particle volume per MPM solver: the mean of ``p_vol`` is used).
"""
from __future__ import annotations

import importlib.util

from gasp_core.seam import Capabilities, engine_hook, EngineInfo, install_hint, Limit, Preset
from gasp_core.mpm.options import mpm_options
from gasp_core.mpm.sweep import mpm_sweep

__all__ = ["BENCH_EXCLUDED", "CAPABILITIES", "ENGINE", "INSTALL_HINT", "OPTIONS", "gasp_engines",
           "genesis_available", "sweep"]

ENGINE = "genesis"

#: Reason given when Genesis is missing.
INSTALL_HINT = ("genesis-world is not installed: "
                f"{install_hint('genesis', distribution='gasp-genesis[engine]')}")

CAPABILITIES = Capabilities(
    materials=frozenset({"jelly", "neo_hookean", "metal", "sand", "snow", "liquid"}),
    boundaries=frozenset({"ground", "walls"}),
    devices=frozenset({"cpu", "cuda"}),
    precisions=frozenset({"f32", "f64"}),
    deterministic=frozenset(),  # multithreaded atomic P2G on every backend
    # no "initial_C": Genesis starts every particle's C at zero (set_particles_vel sets v only)
    features=frozenset({"grid"}),
)

#: Genesis pads its MPM domain by this many cells (``MPMSolver.setup_boundary``).
PADDING_CELLS = 3
#: Snow hardening coefficient hard-coded in ``genesis/engine/materials/MPM/snow.py``.
GENESIS_SNOW_HARDENING = 10.0

#: Genesis's own parameter ranges, narrower than the core's; the core checks them before the factory
#: runs (``gasp_core.seam.limits``).
LIMITS = {
    "sand.friction_angle": Limit(lo=0.0, hi=90.0, lo_open=True, hi_open=True, why="Genesis MPM.Sand, degrees"),
    "snow.hardening": Limit(lo=GENESIS_SNOW_HARDENING, hi=GENESIS_SNOW_HARDENING,
                            why="Genesis fixes the snow hardening coefficient"),
    "friction": Limit(lo=0.0, why="Genesis coupling friction of the ground and wall planes"),
    "n_grid": Limit(lo=8, why=f"Genesis pads the domain by {PADDING_CELLS} cells on each side"),
}

#: The grid-engine options of ``gasp_core.mpm.options``; ``device`` "cpu" or "cuda" (``gs.init(backend=gs.cuda)``
#: takes the default GPU).
OPTIONS = mpm_options()

#: Why ``gasp bench`` leaves Genesis out unless it is asked for by name (``sweep.excluded_by_default``).
BENCH_EXCLUDED = ("left out of the default sweep: on CPU its build takes ~50 s and a frame ~5x longer "
                  "than taichi_mpm's; pass engines=genesis to bench it")


def sweep(quick: bool) -> tuple[list[dict], dict]:
    """``gasp bench`` settings and reference: the grid-engine sweep of ``gasp_core.mpm.sweep.mpm_sweep``.

    ``sweep.excluded_by_default`` (:data:`BENCH_EXCLUDED`) says why a default ``gasp bench`` leaves
    this engine out.
    """
    return mpm_sweep(quick, CAPABILITIES.precisions)


sweep.excluded_by_default = BENCH_EXCLUDED


def genesis_available() -> str | None:
    """None if the ``genesis`` package (and torch) is installed, else why the engine cannot run.

    Only looks the packages up (``importlib.util.find_spec``); importing Genesis takes tens of
    seconds, so a broken install shows up when the engine is built, as an ``EngineError``.
    """
    for module in ("genesis", "torch"):
        try:
            found = importlib.util.find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            return INSTALL_HINT if module == "genesis" else (
                f"torch is not installed (Genesis needs it): {INSTALL_HINT}")
    return None


KNOWN_FAILURES = {"stacked_gap": (
    "two stacked jelly balls (R 5 cm, n_grid 24) rest +0.868 dx apart (mean of the last 0.5 s of 1 s, +0.717 to "
    "+1.071 dx): one MPM velocity field, so bodies whose points share a grid node move together and stay about a "
    "cell apart, as on taichi_mpm and warp_mpm (+0.84 dx; limit 0.25 dx; measured on genesis-world, CPU, 43 s)"),
    "spinning": (
    "the body spins 11.7% slow: rigid-fit angle 79.47 deg after 0.5 s vs 90 deg; L_z(frame 1) / L_z(0) = 0.883, "
    "then constant within 0.2%. The plugin does not start the APIC affine matrix from SimSetup.C (the Genesis "
    "1.4.5 entity API sets only positions, velocities and active flags; its MPM solver state setter also writes "
    "C, but the plugin does not use that internal path yet), so the first P2G loses the points' own spin; "
    "taichi_mpm and warp_mpm, which read SimSetup.C, turn 89.90 deg"),
    # Genesis' MPM ground is a projection of the grid nodes below the plane: the grid contact GASP's own MPM
    # engines leave by default (docs/contact.md); measured on genesis-world 1.4.5, CPU
    "spun_ball_bounce": ("the symmetric soft ball seeded at 0.02 rad/s gains angular momentum 2.19x per bounce over "
                         "4 bounces on frictionless ground (limit 1x): the grid-node ground contact spins it up"),
    "jittered_ball_rest": ("the ball of jittered points drifts up to 30 mm horizontally (frame 25) in 1.33 s on "
                           "ground with friction 0.5 (limit 1 mm): the grid-node ground contact rolls it"),
    "settle_back": ("the block whose mass centre lies 1.5 point spacings inside its edge stays on that edge: its tilt "
                    "over the last third of 1 s is 23.3 deg (start 21.7, limit 10): the grid-node ground holds it"),
    "rest_gap": ("a slab set on the ground floats: its lowest points rest +0.49 dx above the plane after 0.5 s "
                 "(limit 0.01 dx), the grid-node ground holding the body about half a cell up"),
    "ball_off_wall": ("the jittered ball thrown at 0.5 m/s at a frictionless wall, gravity off, has not come back by "
                      "0.30 s (-v_x / v_0 = -0.819, band 0.5-1) and spins at 1.297 rad/s (spin x R / v_0 = 0.13, limit "
                      "0.025): Genesis' own wall (its grid nodes), not the particle contact")}


#: The quality levels' step, as the core gave it before each engine declared its presets (issue 51): the cfl of
#: the MLS-MPM engines' levels, not measured on this engine (docs/speed_accuracy.md measures the MLS-MPM engines).
PRESETS = {level: Preset({"cfl": cfl}) for level, cfl in (("draft", 0.8), ("default", 0.8), ("reference", 0.2))}


#: The engine's registration record (the ``gasp_engines`` hook, :func:`gasp_core.seam.plugins.engine_hook`).
gasp_engines = engine_hook(EngineInfo(
    name=ENGINE,
    factory="gasp_genesis.engine:GenesisMPMEngine",
    capabilities=CAPABILITIES,
    options=OPTIONS,
    presets=PRESETS,
    limits=LIMITS,
    known_failures=KNOWN_FAILURES,
    speed={"cpu": "jelly block of 46,656 points 0.61 M particle-substeps/s on 2 cores "
                  "(benchmarks/results/bench_engines.md)"},
    sweep=sweep,
    available=genesis_available,
    description=("MPM solver of Genesis (genesis-world; MLS-MPM, quadratic B-splines, APIC) "
                 "on CPU or CUDA. Ground and walls via rigid planes with Coulomb coupling "
                 "friction; one particle volume per scene; gs.init once per process (one "
                 "device and precision per process)."),
))
