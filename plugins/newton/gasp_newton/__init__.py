"""GASP engine plugin ``newton``: NVIDIA Newton's implicit MPM (``newton.solvers.SolverImplicitMPM``).

An implicit engine: its step is not capped by the elastic wave speed, so stiff and granular bodies run at
one step per frame, at a measured cost in dissipation (docs/newton.md). Importing this module imports
neither Warp nor Newton: the factory imports :mod:`gasp_newton.engine` when a simulation is built, and
``available()`` only looks for the package.
"""
from __future__ import annotations


from gasp_core.seam import Capabilities, engine_hook, EngineInfo, Option, Preset
from gasp_core.mpm.sweep import dedupe_settings

from .materials import MATERIALS

__all__ = ["CAPABILITIES", "ENGINE", "KNOWN_FAILURES", "OPTIONS", "gasp_engines", "sweep"]

ENGINE = "newton"

CAPABILITIES = Capabilities(
    materials=MATERIALS,
    boundaries=frozenset({"ground", "walls", "fixed_region"}),
    devices=frozenset({"cpu", "cuda"}),
    precisions=frozenset({"f32"}),
    deterministic=frozenset({"cpu"}),
    features=frozenset({"grid", "initial_C", "state"}),
)

#: Newton's ``SolverImplicitMPM.Config`` fields GASP exposes, with Newton's defaults (Newton 1.8.0), and the
#: step count. ``threads`` is accepted so that a scene written for another MPM engine runs unchanged.
OPTIONS = (
    Option("device", "cpu", "where to run: 'cpu', 'cuda' (the default GPU) or 'cuda:N' (GPU N)", kind="str",
           pattern=r"cpu|cuda(:\d+)?"),
    Option("precision", "f32", "floating-point precision (Newton's implicit MPM is f32 only)", kind="str",
           choices=("f32",)),
    Option("n_substeps", None, "implicit steps per frame (default: per frame from cfl)", kind="int", lo=1),
    Option("cfl", 1.0, "automatic steps: a point moves at most cfl voxels per step ((v_max + |g| frame_dt) "
                       "dt <= cfl voxel_size; Newton's contact sees the ground only within about a voxel)",
           kind="number", lo=0.0, hi=4.0, lo_open=True),
    Option("max_substeps", 64, "automatic steps: at most this many per frame", kind="int", lo=1),
    Option("voxel_size", None, "grid voxel size, m (default: the scene's dx = domain / n_grid)", kind="number",
           lo=0.0, lo_open=True),
    Option("strain_basis", "P0", "Newton's strain (stress) basis", kind="str",
           choices=("P0", "P1d", "Q1", "Q1d", "pic8", "pic27")),
    Option("velocity_basis", "Q1", "Newton's velocity basis (Q1 trilinear, B2/B3 B-splines)", kind="str",
           choices=("Q1", "B2", "B3")),
    Option("solver", "auto", "rheology solver ('auto': Gauss-Seidel for Q1, batched GS otherwise)", kind="str",
           choices=("auto", "gs", "gs-soa", "gs-batched", "jacobi", "cg", "cr", "gmres")),
    Option("max_iterations", 250, "rheology solver iterations per step, at most (Newton's default; a solve stopped "
                                  "early loses the strain it did not reach: an elastic body creeps flat at 50, e.g. "
                                  "the self-weight sag 3.6x too large at 1 step per 1/30 s; docs/newton.md)",
           kind="int", lo=1),
    Option("tolerance", 1.0e-4, "rheology solver residual tolerance", kind="number", lo=0.0, lo_open=True),
    Option("carry_residual_strain", "none", "strain an unconverged solve leaves: 'none' drops it (soft "
           "bodies then relax, e.g. flatten), 'unconverged' keeps the flow-rule residual, 'sampled' keeps dt grad v "
           "minus the plastic increment (Newton's Config.carry_residual_strain)", kind="str",
           choices=("none", "unconverged", "sampled")),
    Option("transfer_scheme", "apic", "particle-grid transfer", kind="str", choices=("apic", "pic")),
    Option("integration_scheme", "pic", "shape-function support: point samples or GIMP", kind="str",
           choices=("pic", "gimp")),
    Option("grid_type", "sparse", "Newton's grid storage", kind="str", choices=("sparse", "dense", "fixed")),
    Option("damping", 0.0, "elastic damping relaxation time of every material, s (Newton's mpm:damping)",
           kind="number", lo=0.0),
    Option("threads", None, "accepted and ignored: Warp runs CPU kernels on one thread", kind="int", lo=1),
)

#: The ``gasp bench`` sweep: grid, step size, bases, solver and tolerance, one at a time around the
#: defaults at the largest grid, against a reference of cfl 0.25 and tolerance 1e-5 at n_grid 64.
SWEEP = {"n_grid": (32, 48, 64), "cfl": (0.5, 1.0, 2.0), "n_substeps": (1, 4), "strain_basis": ("P0", "Q1"),
         "velocity_basis": ("Q1", "B2"), "solver": ("auto", "cr"), "max_iterations": (50, 250),
         "tolerance": (1.0e-3, 1.0e-4), "transfer_scheme": ("apic", "pic")}
SWEEP_QUICK = {"n_grid": (32, 48), "cfl": (1.0, 2.0), "tolerance": (1.0e-3, 1.0e-4)}


def sweep(quick: bool) -> tuple[list[dict], dict]:
    """``gasp bench`` settings and reference: each option of :data:`SWEEP` varied alone around the defaults."""
    table = SWEEP_QUICK if quick else SWEEP
    ref = {"n_grid": 64, "cfl": 0.25, "tolerance": 1.0e-5}
    base = {"n_grid": max(table["n_grid"])}
    out = [{**base, key: v} for key, values in table.items() for v in values]
    return dedupe_settings(out, ref), ref


_CLAMP = ("the clamped bar hangs as if hinged: time-averaged tip deflection {d} mm vs Timoshenko 20.63 mm "
          "(+{p}x), first frequency 2.136 Hz vs 4.272 Hz (-50 %); fixed_region points are Newton's zero-mass "
          "(kinematic) particles (measured with the defaults, 250 iterations, gasp conform newton, Newton 1.8.0)")
#: Conformance scenes Newton's implicit MPM fails with the defaults, each with the measured figures
#: (``gasp conform newton``, Newton 1.8.0, CPU; docs/newton.md).
KNOWN_FAILURES: dict[str, str] = {
    "cantilever": _CLAMP.format(d="234.08", p="10.3"),
    "cantilever_offgrid": _CLAMP.format(d="280.63", p="12.6"),
    "bounce_hertz": ("the ball rebounds too little: it lands again before the run ends (restitution 0.54, v_in "
                     "1.594, v_out 0.854 m/s, band 0.80-1.02, at one implicit step per 1/240 s frame; 0.75 at four "
                     "steps, with the contact time within 5 % of Hertz); the backward-Euler step damps the rebound "
                     "(docs/newton.md)"),
    "spun_ball_bounce": ("the soft ball rebounds too little to bounce 4 times in 1 s (apexes at frames 1 and 6 only), "
                         "so its spin growth per bounce cannot be measured (issue 28)"),
    "jittered_ball_rest": ("the ball of jittered points drifts 7.87 mm horizontally in 40 frames on ground with "
                           "mu = 0.5 (limit 1 mm; issue 28)"),
    "rest_gap": ("a slab set on the ground rests with its lowest points 0.087 dx too low after 0.5 s (limit 0.01 dx; "
                 "warp_mpm and taichi_mpm -0.001; Newton 1.8.0, CPU; issue 38)"),
    "slide_to_rest": ("the slab launched at 0.5 m/s on ground with mu = 0.3 stops after 36.46 mm, 14.2 % short of "
                      "Coulomb's v0^2 / (2 mu g) = 42.47 mm (limit 4 %; issue 38)"),
    "dam_break": ("the front runs slow: worst |Z - Z_Martin-Moyce| / Z_MM = 0.231 (limit 0.15), Z = 1.84 vs 2.33 "
                  "at T = 1.98, 2.14 vs 2.78 at T = 2.32; the liquid is Newton's compressible E-nu fluid with no "
                  "shear stress, and the implicit solve adds numerical viscosity"),
    "ball_off_wall": ("the ball of jittered points thrown at 0.5 m/s at a frictionless wall (no gravity; Newton's walls "
                      "are planes on the domain's faces) turns at 0.484 rad/s (spin x R 4.8 % of the throw, limit "
                      "2.5 %) and comes back at 0.074 of its speed by 0.3 s (band 0.5-1; issue 38 item 2)"),
    "sand_column_collapse": ("the column spreads too little and ends too low: runout (L_inf - L_i)/L_i = 0.736 vs "
                             "Lube et al. 2.400 (-69 %), H_inf/L_i = 0.254 vs 1.320 (-81 %), still moving at "
                             "0.143 m/s at the end (limit 0.05); the Drucker-Prager slope mapped from Klar's alpha "
                             "(gasp_newton.materials.sand_friction) is not yet checked against Newton's yield "
                             "surface coordinates"),
}


#: The quality levels' step, as the core gave it before each engine declared its presets (issue 51): the cfl of
#: the MLS-MPM engines' levels, not measured on this engine (docs/speed_accuracy.md measures the MLS-MPM engines).
PRESETS = {level: Preset({"cfl": cfl}) for level, cfl in (("draft", 0.8), ("default", 0.8), ("reference", 0.2))}


#: The engine's registration record (the ``gasp_engines`` hook, :func:`gasp_core.seam.plugins.engine_hook`).
gasp_engines = engine_hook(EngineInfo(
    name=ENGINE,
    factory="gasp_newton.engine:NewtonEngine",
    capabilities=CAPABILITIES,
    options=OPTIONS,
    presets=PRESETS,
    known_failures=KNOWN_FAILURES,
    sweep=sweep,
    requires=("newton",),
    install="gasp-newton",
    description="NVIDIA Newton's implicit MPM (SolverImplicitMPM): large steps for stiff and granular "
                "bodies, more numerical dissipation; CPU or CUDA, f32 (docs/newton.md)",
))
