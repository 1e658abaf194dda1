"""Prototype check (issue 29, phase A): the implicit grid viscosity on ``bar_viscous_decay``, at the elastic step.

Usage: python benchmarks/viscous_bar_proto.py {coloured|base} [N_SUBSTEPS|elastic|auto] [eta]
"""
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

mode = sys.argv[1]
sub = sys.argv[2] if len(sys.argv) > 2 else "elastic"
if mode == "coloured":
    from coloured_solver import install
    install()
from gasp_core.seam.plugins import get_engine
from gasp_core.testing.kit import run_trace
from gasp_core.testing.scenes_damping import (BAR_ETA, BAR_FRAME_DT, BAR_T, bar_mode_decay, bar_mode_setup,
                                              kelvin_voigt_decrement, BAR_L)
from gasp_core.toolkit.substeps import p_wave_speed

eta = float(sys.argv[3]) if len(sys.argv) > 3 else BAR_ETA
setup = bar_mode_setup(eta=eta)
if sub == "elastic":
    n = math.ceil(BAR_FRAME_DT / (0.4 * setup.dx / p_wave_speed(setup.materials[0])) - 1e-9)
    setup.options["n_substeps"] = n
elif sub != "auto":
    setup.options["n_substeps"] = int(sub)
info = get_engine("taichi_mpm")
import gasp_taichi_mpm.engine as E
import functools
E.substeps_from_options = functools.partial(E.substeps_from_options, implicit_viscosity=True)
built = []
import gasp_taichi_mpm.solver as SM
_orig = SM.MPMSolver
def _make(*a, **k):
    s = _orig(*a, **k)
    built.append(s)
    return s
SM.MPMSolver = _make
tr = run_trace(info, setup, round(BAR_T / BAR_FRAME_DT))
vis = getattr(built[-1], "visc", None)
if vis is not None:
    print("cg iterations per solve", vis.iters / max(vis.solves, 1))
mat = setup.materials[0]
beta, wd, delta = kelvin_voigt_decrement(mat.E, mat.rho, mat.viscosity, BAR_L)
fit = bar_mode_decay(tr)
print(f"{mode} substeps={tr.stats.engine.get('n_substeps')} eta={eta:.1f}: delta {fit['delta']:.4f} vs {delta:.4f} "
      f"({fit['delta'] / delta - 1:+.4f}), rms {fit['rms']:.4f}")
