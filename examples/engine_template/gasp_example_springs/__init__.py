"""GASP engine plugin ``example_springs``: a template for engine authors (``docs/writing_an_engine.md``).

A NumPy mass-spring network: every point is a mass ``rho * p_vol``, joined by springs to the points
within 1.5 lattice spacings, with ground contact. It is small on purpose; copy the layout, not the
physics. Importing this module is cheap (no NumPy work, no engine import): the factory imports
:mod:`gasp_example_springs.engine` when a simulation is built.
"""
from __future__ import annotations

from gasp_core.seam import Capabilities, engine_hook, EngineInfo, Option

__all__ = ["CAPABILITIES", "OPTIONS", "gasp_engines"]

#: What the engine can do, as data: the core refuses anything else before the factory runs, and the
#: conformance kit skips the scenes that need more.
CAPABILITIES = Capabilities(
    materials=frozenset({"jelly"}),
    boundaries=frozenset({"ground"}),
    devices=frozenset({"cpu"}),
    precisions=frozenset({"f64"}),
    deterministic=frozenset({"cpu"}),  # single-threaded NumPy: a run repeats bit for bit
    features=frozenset(),              # no grid, does not read SimSetup.C
)

#: Every option a scene may give in ``[engine] options``; the core checks names, types and ranges.
OPTIONS = (
    Option("n_substeps", None, "substeps per frame (default: from cfl and the stiffest spring)", kind="int", lo=1),
    Option("cfl", 0.5, "substep as a fraction of the period of the stiffest point: dt = cfl sqrt(m / sum k)",
           kind="number", lo=0.0, hi=1.0, lo_open=True),
    Option("radius", 1.5, "springs join points closer than radius x the lattice spacing p_vol^(1/3)",
           kind="number", lo=1.0, hi=3.0),
    Option("damping", 0.3, "damping ratio of each spring's dashpot (0 = none, 1 = critical)",
           kind="number", lo=0.0, hi=1.0),
)


#: The analytic continuum scenes a mass-spring network does not meet (its springs are a lattice, not
#: an elastic continuum; a real engine would fix these rather than declare them). Measured with
#: ``gasp conform example_springs`` on the template as shipped.
KNOWN_FAILURES = {
    "self_weight_sag": ("springs between neighbours are not calibrated to E: the column shortens 1.07 mm "
                        "under its own weight vs 2.40 mm (-55 %)"),
    "bar_wave": "a spring lattice carries the front at 12.5 m/s vs sqrt(E/rho) = 10 m/s (+25 %)",
    "bounce_hertz": ("ground contact is a position clamp, not elastic: restitution 0.90 passes but the contact "
                     "lasts 43.2 ms vs Hertz 60.1 ms (-28 %)"),
    "rest_on_tilted_ground": ("the ground clamp has no static friction: a slab under gravity tilted 15 deg "
                              "creeps 0.14 dx in 0.13 s where friction 0.5 must hold it"),
    "rest_gap": ("the position clamp holds the lowest point centres on the plane, so the body's surface rests half a "
                 "point spacing (0.25 dx) below it (limit 0.01 dx)"),
    "spun_ball_bounce": ("the position clamp turns the symmetric ball's seeded spin up: angular momentum grows "
                         "2.07x per bounce over 4 bounces (limit 1x)"),
    "jittered_ball_rest": ("the ball of jittered points drifts up to 55.9 mm horizontally (frame 20) in 1.33 s on ground with "
                           "friction 0.5 (limit 1 mm): the clamp has no tangential friction"),
    "stacked_gap": ("two stacked jelly balls overlap -0.333 dx (mean of the last 0.5 s of 1 s, -0.493 to -0.247 dx): "
                    "the springs link neighbours within a body only, no contact between bodies (limit 0.25 dx)"),
}


#: The engine records of this plugin: the ``gasp_engines`` hook (``engine_hook``), the factory named so that it is
#: imported when a simulation is built.
gasp_engines = engine_hook(EngineInfo(
    name="example_springs",
    factory="gasp_example_springs.engine:SpringEngine",
    capabilities=CAPABILITIES,
    options=OPTIONS,
    limits={},                  # ranges narrower than the core's, as gasp_core.seam.Limit: none here
    deterministic_options={},   # nothing to ask for: every run on cpu is deterministic
    known_failures=KNOWN_FAILURES,   # conformance scenes it fails, each with the measured figure
    description="template: NumPy mass-spring network (semi-implicit Euler) with ground contact",
))
