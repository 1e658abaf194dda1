"""Prototype (issue 29, phase A): the README donut on the coloured P2G with implicit viscosity.

Usage: python benchmarks/donut_proto.py THREADS FRAMES [explicit]
"""
import functools
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import coloured_solver
from coloured_p2g import per_thread_cpu

threads, frames = int(sys.argv[1]), int(sys.argv[2])
if len(sys.argv) > 3:
    coloured_solver.IMPLICIT = False
coloured_solver.install()
import gasp_taichi_mpm.engine as E
E.substeps_from_options = functools.partial(E.substeps_from_options, implicit_viscosity=coloured_solver.IMPLICIT)
from gasp_core.prepare.scene import prepare_scene
from gasp_core.seam.build import build_engine
from gasp_core.scene.spec import load_scene

prep = prepare_scene(load_scene(Path(__file__).resolve().parents[1] / "examples" / "donut_jelly.toml"), "taichi_mpm")
prep.setup.options["threads"] = threads
eng = build_engine(prep.info, prep.setup)
eng.step_frame()
s = eng.solver
s.n_sorts, s.sort_s, s.late_total = 0, 0.0, 0
if s.implicit_viscosity:
    s.visc.iters = s.visc.solves = 0
c0, t0, p0 = per_thread_cpu(), time.perf_counter(), time.process_time()
for _ in range(frames):
    eng.step_frame()
wall, cpu, c1 = time.perf_counter() - t0, time.process_time() - p0, per_thread_cpu()
print({"threads": threads, "frames": frames, "n_points": len(prep.setup.x), "substeps": eng.n_substeps,
       "wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "cores": round(cpu / wall, 2),
       "threads_cpu_s": sorted((round(v - c0.get(k, 0.0), 2) for k, v in c1.items()), reverse=True)[:4],
       **s.sort_stats(), "cg_iters_per_solve": (s.visc.iters / max(s.visc.solves, 1)) if s.implicit_viscosity else None,
       "z_max": float(eng.positions()[:, 2].max()), "z_min": float(eng.positions()[:, 2].min())})
